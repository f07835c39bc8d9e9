// Reference (ground-truth) trajectories to compare a run with: the simulator's
// ground_truth.tum / ground_truth.csv, any TUM trajectory, or any telemetry file with positions
// (CSV with named columns, GPX, DJI SRT).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "aerovo/geo/geo_point.h"

namespace aerovo {

/// One reference position. Either geographic (geo set: WGS84, altitude as the file gives it) or
/// local (x_m, y_m: metres East, North of the file's own origin).
struct ReferencePoint {
  double time_s = 0.0;  ///< Seconds, as the file gives them (TUM: first column).
  double x_m = 0.0, y_m = 0.0;
  std::optional<GeoPoint> geo;
  /// 0-based index of the video frame / photo, when the file says (CSV frame column, DJI SRT
  /// FrameCnt): then frames are matched by index rather than by time.
  std::optional<int> frame_index;
};

struct ReferenceTrack {
  std::string path;
  /// "tum", the telemetry format read ("csv", "gpx", "srt"), or "ground_truth_csv"
  /// (ReadGroundTruthCsv).
  std::string format;
  /// True when the points carry WGS84 positions (telemetry formats); false for TUM (local ENU
  /// metres, e.g. the simulator's GT ENU frame whose origin is the ground below frame 0).
  bool geographic = false;
  std::vector<ReferencePoint> points;  ///< Sorted by non-decreasing time.
};

/// The poses of a TUM trajectory file: `t x y z qx qy qz qw` per line (at least t x y; only those
/// are read, into time_s, x_m, y_m), '#' comments and blank lines skipped, times non-decreasing,
/// numbers as ParseDecimal (core/text.h) reads them. `last_line_may_be_cut`: a last line without
/// its newline is dropped unread (a file still being written, or of a run that was killed
/// mid-line: "12.5 3.4 5" may be the start of "12.5 3.4 5.67 ..."). No minimum number of poses.
/// Throws InputError naming the file (and line) for an unreadable file, a malformed line or
/// times that decrease.
std::vector<ReferencePoint> ReadTumPoints(const std::filesystem::path& path,
                                          bool last_line_may_be_cut = false);

/// Reads a reference track. `.tum` and `.txt`: TUM trajectory (`t x y z qx qy qz qw` per line,
/// '#' comments; only t, x, y are used; at least t x y per line). Any other extension: a
/// telemetry file read by ReadTelemetryFile (`.csv` with named columns such as
/// time_s,lat_deg,lon_deg — the simulator's ground_truth.csv —, `.gpx`, `.srt`).
/// Throws InputError naming the file (and line) for an unreadable file, a malformed line, times
/// that decrease, or fewer than 2 points.
ReferenceTrack ReadReferenceTrack(const std::filesystem::path& path);

/// Reads the simulator's ground_truth.csv (`aerovo simulate`, sim/sim_writer.h) in the
/// simulator's own GT ENU frame: a local track (geographic = false, format "ground_truth_csv")
/// whose points carry frame_index (column frame), time_s, x_m = east_m and y_m = north_m. The
/// header must start with the columns frame,time_s,east_m,north_m; further columns are ignored.
/// ReadReferenceTrack reads the same file as geographic positions (lat_deg, lon_deg), which is
/// what a comparison in another ENU frame (a run's: origin at its first GPS fix) needs; this
/// reader keeps the simulator's exact metres, for comparisons paired by frame in that frame.
/// Throws InputError naming the file and line for a missing file, a wrong header, a bad number,
/// a frame index that is not an integer >= 0, times that decrease, or no row at all (one row is
/// enough).
ReferenceTrack ReadGroundTruthCsv(const std::filesystem::path& path);

}  // namespace aerovo
