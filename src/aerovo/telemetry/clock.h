// The telemetry's clock against the frames': a check that the two time spans can belong together
// (CheckTelemetryClock) and the offset between them estimated from the motion
// (EstimateTelemetryOffset). Used by a run (pipeline/runner.cc) after its frames, for the
// summary's warnings and telemetry_offset_* fields.
#pragma once

#include <string>
#include <vector>

#include "aerovo/telemetry/telemetry.h"

namespace aerovo {

/// The telemetry's clock against the frames': "" when they agree, else a warning naming the
/// telemetry `source`, e.g. when the telemetry's time span is ~1000x the frames' (times in
/// milliseconds read as seconds) or every frame falls in a small part of it. `frames_start_s`,
/// `frames_end_s`: the processed frames' first and last time (seconds), `offset_s` the offset
/// applied (telemetry time = frame time + offset_s). Only for a telemetry matched by time (with
/// frame indices the clock does not matter). Spans that do not overlap at all (another flight,
/// GPS-week or absolute seconds against the frames' from 0) are said first, with both spans.
std::string CheckTelemetryClock(const Telemetry& telemetry, const std::string& source,
                                double frames_start_s, double frames_end_s, double offset_s = 0.0);

/// One position of a planar track: time in seconds (the track's clock) and horizontal position
/// in metres in any fixed frame (only speeds are used).
struct PlanarTrackPoint {
  double time_s = 0.0;
  double x_m = 0.0;
  double y_m = 0.0;
};

/// The time offset between the telemetry and the frames estimated from the motion: the offset
/// d (seconds, telemetry time = frame time + d, the meaning of RunConfig::telemetry_offset_s)
/// that maximises the correlation of the visual odometry's speed at frame time t with the GPS
/// speed at telemetry time t + d, over d in [-max_offset_s, max_offset_s] by 0.05 s. Speeds over
/// a 1 s window. Needs speed changes in the flight (a constant speed says nothing).
struct OffsetEstimate {
  bool valid = false;        ///< Enough overlapping frames (>= 20) and speed variation.
  double offset_s = 0.0;     ///< The estimate, s.
  double correlation = 0.0;  ///< Pearson correlation at the estimate, [-1, 1].
  /// The estimate is clear: correlation >= 0.8 at the peak, and at least 0.1 above the best
  /// correlation 2 s or more away from it (no periodic ambiguity).
  bool clear = false;
  int frames = 0;  ///< Frames compared at the estimate.
};
/// `vo_track_m`: the visual odometry's positions at the frames' times, sorted by time.
OffsetEstimate EstimateTelemetryOffset(const std::vector<PlanarTrackPoint>& vo_track_m,
                                       const Telemetry& telemetry, double max_offset_s = 30.0);

}  // namespace aerovo
