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
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "aerovo/core/image.h"
#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/io/frame_record.h"
#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/visual_odometry.h"
#include "aerovo/pipeline/preprocess.h"
#include "aerovo/pipeline/run_config.h"

namespace aerovo {

class FrameSource;

/// Mean per-frame stage times, ms.
struct StageTimes {
  double detect_ms = 0.0, describe_ms = 0.0, correspond_ms = 0.0, estimate_ms = 0.0, total_ms = 0.0;
};

/// What a run did, returned by RunFlight and written as summary.json.
struct RunSummary {
  std::string input;
  std::string source_description;
  std::filesystem::path out_dir;
  int frames_processed = 0;
  int frames_expected = -1;  ///< From the source, -1 when unknown (live).
  int frames_ok = 0;         ///< Including the first frame.
  int frames_reacquired = 0;
  int frames_bridged = 0;  ///< Flagged frames (step failed, motion bridged).
  int frames_with_gps = 0;
  bool interrupted = false;  ///< Stopped by the stop flag (SIGINT/SIGTERM) before the end.
  double wall_s = 0.0;
  double fps = 0.0;  ///< frames_processed / wall_s.
  StageTimes mean;
  double focal_px = 0.0;
  std::string focal_source;    ///< "flag", "hfov", "xmp-calibrated", "exif-35mm", ...
  std::string height_source;   ///< "flag" or "telemetry".
  std::string heading_source;  ///< GeoReferencer::heading_source_used(), "" if none.
  /// The simulator's sim.json used to fill in settings ("" when the input is not a simulation).
  std::string sim_manifest;
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
  /// (run_steps::EstimateTelemetryOffset; estimate_valid false: not enough motion or frames).
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
/// The table printed at the end of a run (frames, distance, ATE SE(2)/Sim(2) against GPS and
/// against the ground truth, end-point and relative error, mean stage times, fps); lines end
/// with '\n'.
std::string FormatSummaryTable(const RunSummary& summary);

/// Where RunFlight reports to. `log` gets the configuration and messages (may be null);
/// `progress`, if set, is called after every frame with (frames done, frames expected or -1,
/// frames per second).
struct RunCallbacks {
  std::ostream* log = nullptr;
  std::function<void(int, int, double)> progress;
  /// Streaming: when set, one line per frame as soon as its pose is written
  /// (`frame time_s x_m y_m lat_deg lon_deg status`, space separated, flushed; lat/lon "-" until
  /// the track is geo-referenced). Latency: none, except while the heading waits for the first
  /// GPS segment (GeoRefOptions::min_segment_m).
  std::ostream* poses = nullptr;
  /// When set, called with each frame's record as it is written to frames.csv (same content:
  /// ENU x/y once the track is geo-referenced, counts, stage times, status).
  std::function<void(const FrameRecord&)> frame;
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
/// `source` is an ImageFolderSource and no telemetry file is given). InvalidArgument for a null
/// source.
RunSummary RunFlight(const RunConfig& config, std::unique_ptr<FrameSource> source,
                     const RunCallbacks& callbacks = {}, const std::atomic<bool>* stop = nullptr);

}  // namespace aerovo
