// libFuzzer target: a run folder read back by `aerovo report` (report/run_reader.h ReadRunDir,
// then RunEnuFrame and CompareWithGps, what the report's figures and summary are drawn from).
// A user may pass any folder, so every file of it is outside data. The input's first byte picks
// the file its other bytes become (frames.csv, transforms.csv, transforms_optimized.csv,
// map_fixes.csv, vo_optimized.tum, summary.json); the others are those of a small valid run
// (kFrames ...; the seeds in fuzz/corpus/run_folder are these files behind their selector byte).
// A read either throws InputError or returns what
// ReadRunDir promises: frame indices in [0, 1e8] in increasing order, counts >= 0, finite numbers,
// positions on the globe; and the comparison with GPS then throws nothing. Anything else (another
// exception, a crash, a sanitizer report, a broken promise) is a bug.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/report/run_reader.h"
#include "fuzz_files.h"

namespace {

using aerovo::RunFileNames;

void Check(bool ok) {
  if (!ok) std::abort();
}

// A 4-frame run with GPS on every frame: what each file holds when the input is not its.
constexpr const char* kFrames =
    "frame,time_s,x_m,y_m,lat_deg,lon_deg,alt_m,n_surf,n_matched,n_inliers,cluster,detect_ms,"
    "describe_ms,correspond_ms,estimate_ms,total_ms,status,gps_lat_deg,gps_lon_deg,gps_alt_m,"
    "gps_flag\n"
    "0,0.000000,0.0000,0.0000,45.000000000,7.000000000,100.0000,500,0,0,-1,10,2,0,0,12,first,"
    "45.000000000,7.000000000,100.0000,\n"
    "1,0.500000,5.0000,0.1000,45.000000900,7.000063500,100.0000,500,400,300,4,10,2,1,1,14,ok,"
    "45.000000900,7.000063600,100.0000,\n"
    "2,1.000000,10.0000,0.2000,45.000001800,7.000127000,100.0000,500,410,320,3,10,2,1,1,14,ok,"
    "45.000001900,7.000127100,100.0000,\n"
    "3,1.500000,15.0000,0.2000,45.000001800,7.000190500,100.0000,500,390,280,5,10,2,1,1,14,ok,"
    "45.000001700,7.000190400,100.0000,\n";
constexpr const char* kTransforms =
    "frame,a11,a12,tx,a21,a22,ty\n0,1,0,0,0,1,0\n1,1,0,-20,0,1,0.5\n2,1,0,-40,0,1,1\n";
constexpr const char* kMapFixes =
    "frame,time_s,status,lat_deg,lon_deg,gps_error_m,applied,map\n2,1.0,ok,45.0000018,7.000127,"
    "0.4,1,0\n";
constexpr const char* kOptimized = "0 0 0 0 0 0 0 1\n0.5 5 0.1 0 0 0 0 1\n1 10 0.2 0 0 0 0 1\n";
constexpr const char* kSummary =
    R"({"enu_origin": {"lat_deg": 45.0, "lon_deg": 7.0, "alt_m": 100.0}, "frames": 4})";

void WriteText(const std::string& path, const char* text) {
  aerovo::fuzz::WriteInput(path, reinterpret_cast<const std::uint8_t*>(text),
                           std::char_traits<char>::length(text));
}

void CheckRun(const aerovo::RunData& run) {
  int previous = -1;
  for (const aerovo::RunFrameRow& f : run.frames) {
    Check(f.frame > previous && f.frame <= 100000000);
    previous = f.frame;
    Check(std::isfinite(f.time_s) && std::isfinite(f.x_m) && std::isfinite(f.y_m));
    Check(f.n_surf >= 0 && f.n_matched >= 0 && f.n_inliers >= 0 && f.cluster >= -1);
    for (const auto& g : {f.geo, f.gps}) {
      Check(!g || (std::fabs(g->lat_deg) <= 90.0 && std::fabs(g->lon_deg) <= 180.0 &&
                   std::isfinite(g->alt_m)));
    }
  }
  for (const auto* rows : {&run.transforms, &run.transforms_optimized}) {
    previous = -1;
    for (const aerovo::FrameTransformRow& t : *rows) {
      Check(t.frame > previous);
      previous = t.frame;
      for (const double a : t.a) Check(std::isfinite(a));
    }
  }
  for (const aerovo::TrajectoryPoint2D& p : run.optimized) {
    Check(std::isfinite(p.t) && std::isfinite(p.x) && std::isfinite(p.y));
  }
  for (const aerovo::MapFixRow& m : run.map_fixes) Check(m.frame >= 0 && (!m.map || *m.map >= 0));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string dir = aerovo::fuzz::MakeFolder("run");
  static const char* const kFiles[] = {RunFileNames::kFramesCsv,
                                       RunFileNames::kTransformsCsv,
                                       RunFileNames::kTransformsOptimizedCsv,
                                       RunFileNames::kMapFixesCsv,
                                       RunFileNames::kVoOptimizedTum,
                                       RunFileNames::kSummaryJson};
  const char* const kValid[] = {kFrames, kTransforms, kTransforms, kMapFixes, kOptimized, kSummary};
  constexpr std::size_t kCount = sizeof(kFiles) / sizeof(kFiles[0]);
  if (size == 0) return 0;
  const std::size_t fuzzed = data[0] % kCount;
  for (std::size_t i = 0; i < kCount; ++i) {
    if (i == fuzzed) {
      aerovo::fuzz::WriteInput(dir + kFiles[i], data + 1, size - 1);
    } else {
      WriteText(dir + kFiles[i], kValid[i]);
    }
  }
  aerovo::RunData run;
  try {
    run = aerovo::ReadRunDir(dir);
  } catch (const aerovo::InputError&) {
    return 0;
  }
  CheckRun(run);
  static_cast<void>(aerovo::RunEnuFrame(run));
  const aerovo::RunComparison c = aerovo::CompareWithGps(run);
  Check(c.vo.size() == c.reference.size() && c.row.size() == c.vo.size());
  return 0;
}
