// libFuzzer target: reference (ground-truth) tracks and a run's own TUM tracks
// (telemetry/reference_track.h): a TUM trajectory read as `--truth track.tum` (ReadReferenceTrack),
// the same bytes as a run's vo_optimized.tum whose last line may be cut (ReadTumPoints, what
// `aerovo report` reads), and as the simulator's ground_truth.csv (ReadGroundTruthCsv). The
// readers take a path, so each input is written to files of a private temporary folder. A read
// either throws InputError or returns points that keep the readers' promises: finite numbers,
// times in non-decreasing order, frame indices >= 0, at least 2 points from ReadReferenceTrack
// and 1 from ReadGroundTruthCsv. Anything else (another exception, a crash, a sanitizer report,
// a broken promise) is a bug.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/reference_track.h"
#include "fuzz_files.h"

namespace {

void Check(bool ok) {
  if (!ok) std::abort();
}

void CheckPoints(const std::vector<aerovo::ReferencePoint>& points, bool local) {
  double last = -INFINITY;
  for (const aerovo::ReferencePoint& p : points) {
    Check(std::isfinite(p.time_s) && p.time_s >= last);
    last = p.time_s;
    Check(std::isfinite(p.x_m) && std::isfinite(p.y_m));
    Check(local != p.geo.has_value());
    Check(!p.frame_index || *p.frame_index >= 0);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string folder = aerovo::fuzz::MakeFolder("reference");
  static const std::string tum = folder + "track.tum", csv = folder + "ground_truth.csv";
  aerovo::fuzz::WriteInput(tum, data, size);
  aerovo::fuzz::WriteInput(csv, data, size);
  try {
    const aerovo::ReferenceTrack t = aerovo::ReadReferenceTrack(tum);
    Check(t.format == "tum" && !t.geographic && t.points.size() >= 2);
    CheckPoints(t.points, /*local=*/true);
  } catch (const aerovo::InputError&) {
  }
  try {
    CheckPoints(aerovo::ReadTumPoints(tum, /*last_line_may_be_cut=*/true), /*local=*/true);
  } catch (const aerovo::InputError&) {
  }
  try {
    const aerovo::ReferenceTrack t = aerovo::ReadGroundTruthCsv(csv);
    Check(t.format == "ground_truth_csv" && !t.geographic && !t.points.empty());
    CheckPoints(t.points, /*local=*/true);
    for (const aerovo::ReferencePoint& p : t.points) Check(p.frame_index.has_value());
  } catch (const aerovo::InputError&) {
  }
  return 0;
}
