// The `aerovo run` job as a library: read a flight (video, photo folder or live source) and its
// telemetry, run the visual odometry, geo-reference the trajectory, write every output
// progressively (frames.csv, TUM, GeoJSON, KML, GPX, summary.json, config.json) and compare the
// trajectory with GPS and, when given, with a ground truth (SE(2) and Sim(2) ATE, end-point
// error, relative error).
//
// A flight written by `aerovo simulate` (input = its video or frames folder, sim.json beside it)
// needs nothing else: missing settings come from sim.json (telemetry = its SRT, focal length =
// the simulator's exact focal_px, truth = its ground_truth.csv). Explicit settings win.
//
// RunFlight chains the steps of run_steps.h (inputs, camera, height, outputs, frame loop,
// summary), each tested on its own.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <map>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/core/image.h"
#include "aerovo/eval/denied_error.h"
#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/visual_odometry.h"
#include "aerovo/outputs/frame_record.h"
#include "aerovo/pipeline/preprocess.h"
#include "aerovo/pipeline/run_config.h"

namespace aerovo {

class FrameSource;
namespace run_steps {
class FrameStage;
class FrameSink;
}  // namespace run_steps

/// What the flat-field stage did (RunConfig::flat_field, pipeline/stage_flat_field.cc):
/// summary.json "flat_field".
struct FlatFieldReport {
  std::string mode = "auto";  ///< FlatFieldOptions::mode.
  /// "photo median" (a photo folder's pre-pass), "running" (video and live), "none" (mode off,
  /// or no estimate: why says).
  std::string estimate = "none";
  bool applied = false;  ///< Removed from at least one frame.
  int frames_corrected = 0;
  int samples = 0;              ///< Frames the (last) estimate is made of.
  double significance = 0.0;    ///< FlatFieldEstimate::significance of the (last) estimate.
  double pattern_std_dn = 0.0;  ///< FlatFieldEstimate::pattern_std_dn.
  double varying_std_dn = 0.0;  ///< FlatFieldEstimate::varying_std_dn.
  bool ground_seen = false;     ///< FlatFieldEstimate::ground_seen (the motion test).
  double ground_overlap = 1.0;  ///< FlatFieldEstimate::ground_overlap (the motion test).
  double gain = 1.0;            ///< The contrast stretch (FlatFieldCorrector::gain), 1 if none.
  double prepass_ms = 0.0;      ///< Photo folders: reading the samples and the median.
  double mean_frame_ms = 0.0;   ///< The stage's mean cost per frame (sampling, removal), without the pre-pass.
  std::string why;              ///< The decision in one sentence.
};

/// Mean per-frame stage times, ms.
struct StageTimes {
  double detect_ms = 0.0, describe_ms = 0.0, correspond_ms = 0.0, estimate_ms = 0.0, total_ms = 0.0;
};

/// Capture-to-send latency over the frames (FrameRecord::latency_ms), ms; NaN when none.
struct LatencyStats {
  int frames = 0;  ///< Frames measured.
  double median_ms = std::numeric_limits<double>::quiet_NaN();
  double p95_ms = std::numeric_limits<double>::quiet_NaN();  ///< Nearest-rank 95th percentile.
  double max_ms = std::numeric_limits<double>::quiet_NaN();
};

/// What a run did, returned by RunFlight and written as summary.json.
struct RunSummary {
  std::string input;
  std::string source_description;
  std::filesystem::path out_dir;
  /// Frames processed and written: always the number of rows of frames.csv, whatever ended the
  /// run (frames processed but not written, e.g. queued for the heading when the disk filled
  /// up, are frames_not_written).
  int frames_processed = 0;
  int frames_not_written = 0;
  int frames_expected = -1;  ///< From the source, -1 when unknown (live).
  int frames_ok = 0;         ///< Including the first frame.
  int frames_reacquired = 0;
  int frames_bridged = 0;  ///< Flagged frames (step failed, motion bridged).
  int frames_with_gps = 0;
  /// Frames the source flagged (frames/frame_source.h Frame::flags), by flag: "duplicate" (pixels
  /// identical to the frame before), "truncated" (a photo cut short). Each such frame is
  /// processed and its status in frames.csv ends with "+flag"; empty when none.
  std::map<std::string, int> frames_flagged;
  /// Size of the frames given to SURF: the source's, or smaller when the frames exceed
  /// RunConfig::max_megapixels (then reduced by frame_scale, the camera's focal length with
  /// them; positions in metres and transforms.csv stay in full-frame terms). 0 before a frame.
  int processed_width_px = 0, processed_height_px = 0;
  /// How the lens distortion was undone (RunConfig::undistort): "none" (no distortion),
  /// "frames" or "points"; lens_scale_change its camera/lens.h MaxLensScaleChange (0: none).
  std::string undistortion = "none";
  double lens_scale_change = 0.0;
  /// The lens self-calibration pre-pass (RunConfig::lens_estimation; pipeline/lens_prepass.h
  /// ToJson): status ("applied", "not significant", "no estimate", "skipped", "failed", "not
  /// applied"), applied, why, and with an estimate its family, k, sigma_k, cost_drop, pairs and
  /// times; where it was taken (pipeline/lens_switch.h): switch_frame, wait_ms,
  /// caught_up_frame, frames_replayed.
  nlohmann::json lens_estimate;
  /// The camera tilt self-calibration (pipeline/lens_prepass.h ToJson(AttitudePrepass)).
  nlohmann::json attitude_estimate;
  FlatFieldReport flat_field;
  double frame_scale = 1.0;  ///< processed width / source width (1 = frames as read).
  /// Frames of a live source read but never processed: they came while the newest one waited
  /// (RunConfig::frame_queue; always 0 for files).
  int frames_dropped = 0;
  LatencyStats latency;
  bool interrupted = false;  ///< Stopped by the stop flag (SIGINT/SIGTERM) before the end.
  double wall_s = 0.0;
  double fps = 0.0;  ///< frames_processed / wall_s.
  /// CPU time of the process during RunFlight (all threads, user + system; core/timer.h
  /// CpuStopwatch), seconds, and per processed frame, milliseconds; the offline optimisation's
  /// is left out (Optimized::cpu_s).
  double cpu_s = 0.0;
  double cpu_ms_per_frame = 0.0;
  StageTimes mean;
  double focal_px = 0.0;
  std::string focal_source;    ///< "flag", "hfov", "xmp-calibrated", "exif-35mm", ...
  std::string height_source;   ///< "flag", "mavlink" or "telemetry".
  /// Frames per FrameRecord::height_source ("altitude_flag", "mavlink_distance_sensor", ...).
  std::map<std::string, int> height_sources;
  /// Frames whose keypoints were mapped to a virtual nadir camera (RunConfig::attitude), by
  /// FrameAttitude::source ("gimbal", "mavlink", "flight", "mount"), and the largest tilt from
  /// nadir corrected, degrees (0: none).
  std::map<std::string, int> attitude_sources;
  double max_tilt_deg = 0.0;
  /// --mavlink: the link's counts (url, sent, send_failed, heartbeats, timesync_answers,
  /// distance_samples, relative_alt_samples, attitude_samples, autopilot_heartbeats,
  /// crc_errors, and of --mavlink-key: signing, signed_accepted, rejected_unsigned,
  /// rejected_bad_signature, rejected_replayed), and with --mavlink-gps-input "gps_input": sent,
  /// with_fix, without_fix, send_failed, max_sigma_m, largest_sigma_m (sink_mavlink.cc); null
  /// without.
  nlohmann::json mavlink;
  std::string heading_source;  ///< GeoReferencer::heading_source_used(), "" if none.
  /// Origin of the run's ENU frame (x_m/y_m of frames.csv once geo-referenced, vo.tum, gps.tum,
  /// the comparisons with GPS and the truth): the first GPS fix the plausibility check accepted
  /// and kept (never a rejected one); nullopt without GPS. summary.json `enu_origin`.
  std::optional<GeoPoint> enu_origin;
  /// The simulator's sim.json used to fill in settings ("" when the input is not a simulation).
  std::string sim_manifest;
  /// The telemetry file used ("" = none given or found; a photo folder's EXIF/XMP is not a file)
  /// and whether it was found beside the video (the same name, .SRT) or is the video's own
  /// subtitle track (telemetry = the video) rather than given.
  std::string telemetry;
  bool telemetry_beside = false;
  bool telemetry_in_video = false;
  /// The photos took the fixes of the telemetry log's camera triggers, one per photo
  /// (run_steps::RunTelemetry::Load; docs/inputs.md "Photos and the autopilot's camera
  /// triggers").
  bool telemetry_camera_triggers = false;
  double vo_path_length_m = 0.0;
  /// SE(2) and Sim(2) comparison with GPS, when at least 3 frames have a GPS fix.
  std::optional<TrajectoryComparison> evaluation;
  /// Why there is no `evaluation` ("" when there is one), e.g. "no frame has a GPS fix".
  std::string gps_comparison_note;
  /// The ground-truth file compared with ("" = none) and the SE(2) / Sim(2) comparison with it
  /// (processed frames matched as RunConfig::truth says; in the run's ENU frame when the truth is
  /// geographic).
  std::string truth;
  int frames_with_truth = 0;
  std::optional<TrajectoryComparison> truth_evaluation;
  /// The offline whole-flight optimisation (RunConfig::backend, odometry/flight_graph.h;
  /// summary.json "optimized"): what it did and the optimised track (vo_optimized.*) against GPS
  /// and the truth as `evaluation` and `truth_evaluation` compare the causal one.
  struct Optimized {
    int keyframes = 0;
    int pairs_tried = 0, pairs_verified = 0, pairs_rejected = 0, pairs_gated = 0, outliers = 0;
    /// Of the pairs, the loop-closure candidates found by appearance (backend.closures): tried,
    /// verified, rejected by the gate.
    int closures_tried = 0, closures_verified = 0, closures_gated = 0;
    /// GPS fixes added as absolute position factors (backend.gps_sigma_m), and of those the
    /// ones the robust cost down-weighted.
    int gps_factors = 0, gps_outliers = 0;
    double match_s = 0.0;  ///< Matching and fitting the pairs, wall s.
    double solve_s = 0.0;  ///< The graph solve, wall s.
    /// CPU time of the whole offline step (pairs, solve, vo_optimized.*, comparisons), s of all
    /// threads; RunSummary::cpu_s leaves it out.
    double cpu_s = 0.0;
    int iterations = 0;
    /// Every candidate pair tried (odometry/flight_graph.h TriedPair): {"a", "b" (source frame
    /// indices), "verdict" (ToString(PairVerdict)), "inliers", "spread", "fit" and "predicted"
    /// ([x m, y m, heading deg, log-scale] of prev_from_curr in frame a's metres: the pair's fit,
    /// the causal track's), "down_weighted", "by_appearance" (a loop-closure candidate found by
    /// appearance, backend.closures)}.
    nlohmann::json pairs = nlohmann::json::array();
    std::optional<TrajectoryComparison> evaluation;        ///< Against GPS.
    std::optional<TrajectoryComparison> truth_evaluation;  ///< Against the truth.
    std::optional<DeniedError> gps_denied_error;  ///< As GpsDenied::error, for this track.
  };
  std::optional<Optimized> optimized;  ///< nullopt: backend.enable off, or no frame.
  /// The online window (backend.online, pipeline/stage_window.cc; summary.json "online"): the
  /// frame-to-keyframe pairs it matched over the run (FlightGraph::AddOnline) and its wall time.
  struct Online {
    int window = 0;  ///< backend.window.
    int pairs_tried = 0, pairs_verified = 0, pairs_gated = 0;
    /// Loop closures by appearance (backend.closures): candidates tried, verified (added),
    /// rejected by the gate; whole-graph solves they caused and their wall time, ms.
    int closures_tried = 0, closures_verified = 0, closures_gated = 0, full_solves = 0;
    double full_solve_ms = 0.0;
    double total_ms = 0.0;  ///< Wall time of the window stage over all frames, ms.
  };
  std::optional<Online> online;  ///< nullopt: backend.online off, or no frame.
  /// GPS denial (RunConfig::gps_denied_after_s >= 0; summary.json "gps_denied", null without):
  /// when it began and the geo-referenced track's error against the withheld fixes, unaligned
  /// (eval/denied_error.h: 1, 5 and 10 minutes after, per km flown without GPS).
  struct GpsDenied {
    double after_s = -1.0;  ///< RunConfig::gps_denied_after_s.
    int from_frame = -1;    ///< The first denied frame (-1: the flight ended before).
    double from_time_s = 0.0;   ///< Its Frame::time_s.
    int fixes_withheld = 0;     ///< Frames whose fix was withheld.
    std::optional<DeniedError> error;  ///< nullopt: see `note`.
    std::string note;  ///< Why there is no `error` ("" when there is one).
  };
  std::optional<GpsDenied> gps_denied;
  /// RunConfig::map (summary.json "map", null without): the map and its cover of the
  /// geo-referenced track (frames whose position falls on the map's data; `note` when the track
  /// is not geo-referenced).
  struct MapCover {
    std::string path;                ///< The first (preferred) map.
    std::vector<std::string> paths;  ///< Every map, in the order of preference.
    int track_points = 0, covered = 0;
    std::string note;
  };
  std::optional<MapCover> map;
  /// Absolute fixes against the map (RunConfig::map, pipeline/map_fixer.h; summary.json
  /// "map_fixes", null without a map): the attempts and what became of them, and, where the
  /// frames have GPS (withheld or not), the fixes' errors against it beside the track's.
  struct MapFixes {
    int every_n_frames = 0;
    int attempted = 0;      ///< Frames matched against the map.
    int fixes = 0;          ///< Of them, fixes (status "fix").
    int applied = 0;        ///< Fixes that moved the track (map_fix.apply): = fused.
    /// map_fix.apply: fixes fused into the pose graph, and rejected by its gate
    /// (FlightGraph::AddFix).
    int fused = 0, gated_by_graph = 0;
    std::vector<std::pair<std::string, int>> by_status;  ///< Every status (ToString), count.
    int no_prediction = 0;  ///< Due frames before the track was geo-referenced.
    int skipped_busy = 0;   ///< Live source: due frames skipped while the worker was busy.
    double mean_ms = 0.0;   ///< Mean time of an attempt (window read and match), ms.
    int searches = 0;       ///< Attempts that were searches, coarse to fine (map_fixes.csv).
    double search_ms = 0.0;  ///< Mean time of a search (windows read, coarse and fine), ms.
    int found = 0;           ///< Searches that gave a fix.
    /// Flight time from the first attempt to the first fix, s (nullopt: no fix).
    std::optional<double> time_to_first_fix_s;
    /// The fixes against GPS (n = fixes with GPS; the rest 0 when n = 0), m, and the track's
    /// error at the same frames.
    int with_gps = 0;
    double median_m = 0.0, rmse_m = 0.0, max_m = 0.0;
    double track_median_m = 0.0, track_rmse_m = 0.0, track_max_m = 0.0;
    /// Per map, in the order of preference: the attempts whose frame (the fit's position, else
    /// the prediction) lay on its data and it was the first map there, their fixes, and those
    /// fused (MapFixRecord::map).
    struct ByMap {
      std::string path;
      int attempted = 0, fixes = 0, fused = 0;
    };
    std::vector<ByMap> by_map;
    /// Without a geo-reference from GPS (pipeline/map_fixer.h, unanchored attempts): the
    /// whole-map searches, their tiles (searched, and the maps' data area in all), the
    /// candidates they found and the fix that confirmed one and seeded the geo-reference
    /// (frame, time s; nullopt: none, `georef_note` says why).
    int whole_map_searches = 0, whole_map_tiles = 0, whole_map_tiles_total = 0, candidates = 0;
    struct Seed {
      int frame = 0;
      double time_s = 0.0;
      int candidate_frame = 0;
      double candidate_time_s = 0.0;
    };
    std::optional<Seed> georef_seed;
    std::string georef_note;
  };
  std::optional<MapFixes> map_fixes;
  /// Frames at which the live pose was reset (summary.json "pose_resets"; MAVLink reset_counter
  /// + 1 at each, docs/autopilot.md "A pose that jumps"), and by cause (a frame may have more
  /// than one): re-anchored after bridged frames (status reacquired), the lens estimate applied
  /// (pipeline/lens_switch.h), a jump past the autopilots' gates from a loop closure's
  /// whole-graph solve or a fused map fix (FrameState::pose_reset), and of those jumps the ones
  /// whose heading alone was past its gate.
  struct PoseResets {
    int frames = 0;
    int reacquired = 0, lens_switch = 0, loop_closure = 0, map_fix = 0, heading_only = 0;
  };
  PoseResets pose_resets;
  std::vector<std::string> warnings;
  /// GPS fixes rejected by the plausibility check (odometry/gps_check.h; frames.csv gps_flag):
  /// their count and, for the first 100, frame, time (s), kind and message. They are not in
  /// `evaluation` (frames_with_gps counts every frame with a fix, rejected or not).
  int gps_rejected = 0;
  struct RejectedGpsFix {
    int frame = 0;
    double time_s = 0.0;
    std::string kind, message;
  };
  std::vector<RejectedGpsFix> gps_rejected_fixes;
  /// The telemetry offset applied (RunConfig::telemetry_offset_s, plus the estimate when
  /// telemetry_auto_offset re-ran the flight) and the offset estimated from the motion
  /// (telemetry/clock.h EstimateTelemetryOffset; estimate_valid false: not enough motion or
  /// frames).
  double telemetry_offset_s = 0.0;
  bool telemetry_offset_estimate_valid = false;
  double telemetry_offset_estimate_s = 0.0;  ///< Telemetry time at video time 0, s.
  double telemetry_offset_correlation = 0.0;
  bool telemetry_offset_clear = false;
  /// The input error that stopped the run after its first frame ("" if none): RunFlight writes
  /// the outputs and summary.json of the frames before it, then throws it (InputError).
  std::string error;
};

nlohmann::json ToJson(const RunSummary& summary);
/// summary.json's "optimized" block (docs/backend.md).
nlohmann::json ToJson(const RunSummary::Optimized& optimized);
/// The headline of a run's end: "Tracked 170 of 172 frames over 1558 m; the track ends 24.6 m
/// (1.58 %) from GPS." The end error is the unaligned one (the track as geo-referenced during the
/// flight, at the last frame with a fix); the distance is GPS's path length, else the VO's. No
/// newline.
std::string RunHeadline(const RunSummary& summary);
/// The text printed at the end of a run, every line within 80 columns and ending with '\n': the
/// headline, a blank line, then the details (frames and their flags, GPS fixes and rejections,
/// VO distance, camera, the SE(2)/Sim(2) comparison tables against GPS and the ground truth,
/// mean stage times, fps, latency, dropped frames). The CLI adds the list of files written.
std::string FormatRunSummary(const RunSummary& summary);

/// Where RunFlight reports to. `log` gets the configuration and messages (may be null);
/// `progress`, if set, is called after every frame with (frames done, frames expected or -1,
/// frames per second).
struct RunCallbacks {
  std::ostream* log = nullptr;
  /// Also print the effective configuration (config.json, ~35 lines) to `log` at the start;
  /// otherwise `log` gets one line naming config.json (`aerovo run --verbose` sets it).
  bool log_config = false;
  std::function<void(int, int, double)> progress;
  /// Streaming: when set, one line per frame as soon as its pose is written
  /// (`frame time_s x_m y_m lat_deg lon_deg status`, space separated, flushed; lat/lon "-" until
  /// the track is geo-referenced). Latency: none, except while the heading waits for the first
  /// GPS segment (GeoRefOptions::min_segment_m).
  std::ostream* poses = nullptr;
  /// When set, called with each frame's record as it is written to frames.csv (same content:
  /// ENU x/y once the track is geo-referenced, counts, stage times, status).
  std::function<void(const FrameRecord&)> frame;
  /// Steps and consumers of every frame added to the run's own (pipeline/frame_state.h): each
  /// stage runs after the built-in ones (it sees the odometry's result, the GPS check, the
  /// output record), each sink after the built-in ones (the frame is written), in this order;
  /// an exception from one ends the run at that frame like any other. A run that re-runs itself
  /// (telemetry_auto_offset) calls them again for the second pass.
  std::vector<std::shared_ptr<run_steps::FrameStage>> stages;
  std::vector<std::shared_ptr<run_steps::FrameSink>> sinks;
};

/// Runs a whole flight. Writes config.json at the start, the per-frame outputs as frames are
/// processed (each file valid at all times), summary.json at the end. Stops early, cleanly,
/// when `stop` becomes true (the files stay valid and the summary says interrupted).
/// Throws InputError / InvalidArgument naming the file, frame or key for bad input; an input
/// error met after the first frame (an undecodable photo, a frame of another size) is thrown
/// after the frames before it are written and summary.json records it (`error`).
RunSummary RunFlight(const RunConfig& config, const RunCallbacks& callbacks = {},
                     const std::atomic<bool>* stop = nullptr);

/// The same run on frames from `source` (any FrameSource: a custom camera driver, frames
/// generated in memory, ...) instead of opening `config.input`, which then only names the run in
/// the outputs. Telemetry comes from `config.telemetry` (the EXIF/XMP of the photos when
/// `source` is an ImageFolderSource and no telemetry file is given). With config.frame_queue > 0
/// (default) `source` is read through a PrefetchSource (frames/prefetch_source.h): its Next() runs
/// on a reader thread, ahead of the processing; a source whose IsLive() is true keeps only the
/// newest frame (RunSummary::frames_dropped). InvalidArgument for a null source.
RunSummary RunFlight(const RunConfig& config, std::unique_ptr<FrameSource> source,
                     const RunCallbacks& callbacks = {}, const std::atomic<bool>* stop = nullptr);

}  // namespace aerovo
