// Shared body of the telemetry fuzz targets: parse the bytes strictly and leniently, and check
// the invariants every successful read promises (telemetry_readers.h). Any other exception than
// InputError, a crash, a sanitizer report or a broken invariant is a bug.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::fuzz {

// Aborts (libFuzzer reports a crash with the input) when `ok` is false.
inline void Check(bool ok) {
  if (!ok) std::abort();
}

inline void CheckResult(const TelemetryReadResult& r, const TelemetryReadOptions& options) {
  Check(r.records > 0);
  Check(static_cast<std::size_t>(r.records) == r.telemetry.size());
  Check(r.skipped_records >= 0 && r.no_fix_records >= 0);
  Check(options.lenient || r.skipped_records == 0);
  Check(static_cast<int>(r.warnings.size()) <= options.max_warnings + kMaxReadNotes);
  double last = -INFINITY;
  int without_fix = 0;
  for (const TelemetrySample& s : r.telemetry.samples()) {
    Check(std::isfinite(s.time_s) && s.time_s >= last);
    last = s.time_s;
    Check(s.lat_deg >= -90.0 && s.lat_deg <= 90.0);
    Check(s.lon_deg >= -180.0 && s.lon_deg <= 180.0);
    // A sample has a position other than 0, 0, or says it has none (TelemetrySample::has_fix).
    Check(s.has_fix ? !(s.lat_deg == 0.0 && s.lon_deg == 0.0)
                    : s.lat_deg == 0.0 && s.lon_deg == 0.0);
    without_fix += s.has_fix ? 0 : 1;
    Check(!s.frame_index || *s.frame_index >= 0);
    Check(!s.origin.empty());
  }
  Check(without_fix <= r.no_fix_records);
  // The camera triggers (TelemetryReadResult::camera_triggers): valid samples that name their
  // message, without a frame index.
  for (const TelemetrySample& s : r.camera_triggers) {
    Check(std::isfinite(s.time_s));
    Check(s.has_fix ? s.lat_deg >= -90.0 && s.lat_deg <= 90.0 && s.lon_deg >= -180.0 &&
                          s.lon_deg <= 180.0 && !(s.lat_deg == 0.0 && s.lon_deg == 0.0)
                    : s.lat_deg == 0.0 && s.lon_deg == 0.0);
    for (const std::optional<double>& v : {s.abs_alt_m, s.rel_alt_m}) {
      Check(!v || (std::isfinite(*v) && std::abs(*v) <= 1e5));
    }
    for (const std::optional<double>& v : {s.roll_deg, s.pitch_deg, s.yaw_deg}) {
      Check(!v || (std::isfinite(*v) && std::abs(*v) <= 360.0));
    }
    Check(!s.unix_time_s || std::isfinite(*s.unix_time_s));
    Check(!s.frame_index);
    Check(!s.origin.empty());
  }
}

template <typename ParseFn>
void FuzzTelemetryReader(const std::uint8_t* data, std::size_t size, ParseFn parse) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (const bool lenient : {false, true}) {
    TelemetryReadOptions options;
    options.lenient = lenient;
    options.max_warnings = 3;
    std::istringstream in(text);
    try {
      CheckResult(parse(in, "fuzz", options), options);
    } catch (const InputError&) {
      // Rejected input: the expected outcome for most mutations.
    }
  }
}

}  // namespace aerovo::fuzz
