// Reading back a run folder written by `aerovo run` (report/runner.h, outputs/track_writers.h) for
// the report: frames.csv, transforms.csv, summary.json, config.json; and a simulated flight's
// ground_truth.csv (sim/sim_writer.h). Also the trajectory comparison the report draws.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/telemetry/reference_track.h"

namespace aerovo {

/// One row of frames.csv (columns: outputs/track_writers.h, CsvFrameWriter).
struct RunFrameRow {
  int frame = 0;
  double time_s = 0.0;
  double x_m = 0.0, y_m = 0.0;  ///< ENU metres when geo-referenced, else the local VO frame.
  /// VO position in WGS84 (when geo-referenced); an empty alt_m cell (no altitude known: a track
  /// placed by a map, outputs/track_writers.h GeoTrackPoint) reads as 0, `geo_alt_known` false.
  std::optional<GeoPoint> geo;
  bool geo_alt_known = true;
  int n_surf = 0, n_matched = 0, n_inliers = 0, cluster = -1;
  double detect_ms = 0.0, describe_ms = 0.0, correspond_ms = 0.0, estimate_ms = 0.0, total_ms = 0.0;
  std::string status;
  std::optional<GeoPoint> gps;  ///< GPS fix associated with the frame.
  /// The camera attitude the odometry applied to the frame (frames.csv camera_roll_deg,
  /// camera_pitch_deg: odometry/attitude.h CameraAttitude, degrees); nullopt when none was, or
  /// the run folder does not record it (older builds).
  std::optional<double> camera_roll_deg, camera_pitch_deg;
};

/// One row of transforms.csv: first_px_from_frame as a 2x3 affine [a11 a12 tx; a21 a22 ty]
/// (maps this frame's pixels to the first frame's pixels; see RunFileNames::kTransformsCsv).
struct FrameTransformRow {
  int frame = 0;
  std::array<double, 6> a{1, 0, 0, 0, 1, 0};  ///< a11, a12, tx, a21, a22, ty.
};

/// What a run folder holds. Files that are absent leave their part empty (an interrupted run
/// may lack summary.json).
/// A row of map_fixes.csv (docs/map.md): an attempt against the reference maps.
struct MapFixRow {
  int frame = 0;
  double time_s = 0.0;
  std::string status;            ///< "fix", "gate", "no_map", ...
  std::optional<GeoPoint> geo;   ///< The fitted position (when fitted).
  std::optional<double> gps_error_m;  ///< Its distance from the frame's GPS fix, m.
  bool applied = false;          ///< Fused into the track.
  bool gated_by_graph = false;   ///< A fix the pose graph's gate rejected (older runs: false).
  std::optional<int> map;        ///< The map it came from (index in the order of --map).
};

struct RunData {
  std::filesystem::path dir;
  /// map_fixes.csv (a run with --map); empty when the run has none.
  std::vector<MapFixRow> map_fixes;
  std::vector<RunFrameRow> frames;
  std::vector<FrameTransformRow> transforms;
  /// transforms_optimized.csv (the offline optimisation's placements, docs/backend.md): rows as
  /// `transforms`; empty when the run has none.
  std::vector<FrameTransformRow> transforms_optimized;
  /// vo_optimized.tum: the optimised track (time s, x, y in the frame of frames.csv x_m, y_m);
  /// empty when the run has none.
  std::vector<TrajectoryPoint2D> optimized;
  nlohmann::json summary;  ///< null when summary.json is absent.
  nlohmann::json config;   ///< null when config.json is absent.
  /// frames.csv has the camera_roll_deg and camera_pitch_deg columns: the run records the
  /// attitude the odometry applied to each frame (none on a frame: none applied). False for run
  /// folders of older builds.
  bool records_camera_attitude = false;
};

/// True when `dir` looks like a run folder (frames.csv present).
bool IsRunDir(const std::filesystem::path& dir);

/// Reads frames.csv (required) and, when present, transforms.csv, transforms_optimized.csv,
/// vo_optimized.tum, map_fixes.csv, summary.json, config.json.
/// Throws InputError naming the file, line and column for a missing frames.csv, a bad header or a
/// bad cell: a number that is not a plain decimal (ParseDecimal, core/text.h), a frame index that
/// is not a whole number in [0, 1e8] or does not come after the previous row's (frames.csv,
/// transforms.csv; map_fixes.csv: not before it), a count that is not a whole number >= 0, a
/// latitude outside [-90, 90] or a longitude outside [-180, 180]. A last line cut short (a run
/// killed mid-write) is ignored.
RunData ReadRunDir(const std::filesystem::path& dir);

/// The paired VO and reference trajectories of a run and their comparison.
struct RunComparison {
  std::vector<TrajectoryPoint2D> vo;         ///< VO (frames.csv x_m, y_m) at the paired frames.
  std::vector<TrajectoryPoint2D> reference;  ///< Reference at the same times, same frame (ENU).
  std::vector<int> row;                      ///< Index in RunData::frames of each pair.
  std::optional<TrajectoryComparison> comparison;  ///< When at least 3 pairs align.
  std::string reference_name;                      ///< "GPS" or "ground truth".
};

/// The run's ENU frame (that of frames.csv x_m/y_m, vo.tum, gps.tum): origin summary.json's
/// `enu_origin` (the first fix the run accepted and kept, odometry/georef.h), else (a folder of
/// an older aerovo, or without summary.json) the first fix of frames.csv not flagged rejected;
/// nullopt without a fix.
std::optional<LocalEnu> RunEnuFrame(const RunData& run);

/// The comparison `aerovo run` puts in summary.json: frames with a GPS fix not rejected, GPS
/// converted to the run's ENU frame (RunEnuFrame), SE(2) and Sim(2) alignment
/// (eval/trajectory_eval.h). No comparison (nullopt) when fewer than 3 frames have GPS.
RunComparison CompareWithGps(const RunData& run);

/// The run's VO track against a simulated flight's ground truth in the simulator's frame
/// (ReadGroundTruthCsv in telemetry/reference_track.h: local points with frame indices), paired by
/// frame index as the experiments do, SE(2)/Sim(2). Points without a frame index are not paired.
/// Throws InvalidArgument for a geographic track (its x_m, y_m mean nothing).
RunComparison CompareWithReference(const RunData& run, const ReferenceTrack& ground_truth);

/// Pairs a track with a ground truth, for `aerovo run --truth` (summary.json) and the report
/// alike: geographic truth goes into the ENU frame `enu` (nullopt: one at the truth's first
/// point), local truth (TUM) is taken as metres of the track's frame; points are matched by frame
/// index when every truth point has one (the simulator's CSV, DJI SRT; reference time = the truth
/// point's), else by time (AssociateByTime). `frames[i]` is the frame index of estimate[i].
/// Throws InvalidArgument when the time association fails.
AssociatedTrajectories AssociateWithTruth(const std::vector<TrajectoryPoint2D>& estimate,
                                          const std::vector<int>& frames,
                                          const ReferenceTrack& truth,
                                          const std::optional<LocalEnu>& enu);

/// The run's VO track against a ground-truth file (telemetry/reference_track.h: TUM, or a telemetry
/// file with positions such as the simulator's ground_truth.csv), as `aerovo run --truth` compares
/// them in summary.json (AssociateWithTruth in the run's ENU frame, RunEnuFrame). Throws InputError when the file cannot be read.
RunComparison CompareWithTruthFile(const RunData& run, const std::filesystem::path& truth);

}  // namespace aerovo
