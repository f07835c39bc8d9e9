// The `aerovo run` job as a library: read a flight (video, photo folder or live source) and its
// telemetry, run the visual odometry, geo-reference the trajectory, write every output
// progressively (frames.csv, TUM, GeoJSON, KML, GPX, summary.json, config.json) and compare the
// trajectory with GPS and, when given, with a ground truth (SE(2) and Sim(2) ATE, end-point
// error, relative error).
//
// A flight written by `aerovo simulate` (input = its video or frames folder, sim.json beside it)
// needs nothing else: missing settings come from sim.json (telemetry = its SRT, focal length =
// the simulator's exact focal_px, truth = its ground_truth.csv). Explicit settings win.
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

namespace aerovo {

class FrameSource;

/// Everything a run can be told, as flags (cmd_run.cc) or as a JSON config file with the same
/// keys (ToJson / RunConfigFromJson). Plain aggregate; Validate() checks it.
struct RunConfig {
  /// Video file, image folder, camera index, device path or stream URL (io/frame_source.h).
  std::string input;
  /// Telemetry file (.srt, .gpx, .csv); empty: none, or the photos' EXIF/XMP for a folder.
  std::string telemetry;
  /// Malformed telemetry records (garbage line, missing latitude, out-of-range value, timestamp
  /// out of order): false (default) = the run stops with an error naming the file and line;
  /// true = they are skipped, counted and reported in the summary's warnings (their frames then
  /// have no GPS). Default false: a damaged file is worth a look before trusting it.
  bool lenient_telemetry = false;
  /// Ground-truth track to compare with, beside GPS (io/reference_track.h: the simulator's
  /// ground_truth.csv / .tum, any TUM file, or a telemetry file with positions); matched to the
  /// frames by frame index when the file gives one for every point (CSV frame column, SRT), else
  /// by time. Empty: none, or the simulator's ground_truth.csv when sim.json is found.
  std::string truth;
  /// Output folder (created). Default "aerovo-run".
  std::string out = "aerovo-run";
  /// Process every k-th frame (video; photos: every k-th photo). Default 1.
  int step = 1;
  /// Time window of the source, seconds (end < 0: to the end).
  double start_s = 0.0;
  double end_s = -1.0;
  /// Stop after this many processed frames (0 = all).
  int max_frames = 0;
  /// "clustered" (default, the paper) or "standard".
  std::string mode = "clustered";
  /// "affine" (default), "similarity", "homography", "translation".
  std::string model = "affine";
  /// "metric" (default) or "affine-chain" (see odometry/pose_chain.h).
  std::string scale = "metric";
  /// Heading of the VO track in ENU: "auto" (default: telemetry yaw, else first GPS segment),
  /// "yaw", "gps".
  std::string heading = "auto";
  /// Height above ground, metres; when > 0 it overrides telemetry (tampa-phantom3 has none).
  double altitude_m = 0.0;
  /// Focal length in pixels of the processed frames; when 0, from hfov_deg, else from the
  /// telemetry/EXIF (XMP calibrated focal, else 35 mm equivalent).
  double focal_px = 0.0;
  /// Horizontal field of view, degrees (used when focal_px is 0).
  double hfov_deg = 0.0;
  /// Lens distortion (OpenCV / Brown-Conrady model, coefficients on coordinates normalised by
  /// the focal length, principal point at the image centre): when any is non-zero every frame is
  /// undistorted (cv::remap with maps computed once) before SURF. Default 0 (none; DJI nadir
  /// photos and videos are usually already corrected in camera).
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
  /// Illumination factor k in (0, 1] (the paper's f_k = k f, Fig. 4-6): every frame's brightness
  /// is multiplied by k (ScaleBrightness) after undistortion and before SURF, to study how the
  /// odometry holds in dim light. Default 1 (frames as read).
  double illumination_k = 1.0;
  /// Guided matching with the constant-velocity prior (then unguided on failure). Default on.
  bool guided = true;
  /// Matching without a motion prior (MatchOptions::algorithm): "exhaustive" (default, exact)
  /// or "kdtree" (randomized k-d forest, approximate; pays off from a few thousand points per
  /// frame, see BENCHMARKS.md "Matching"). Guided matching is unaffected.
  std::string matcher = "exhaustive";
  /// Refinement of cell fits on spread points and then on all points
  /// (CorrespondenceOptions::clustered.refine and OdometryOptions::refine_on_all_points).
  /// Default on; off is the paper's clustered RANSAC exactly (the cell's own fit).
  bool refine = true;
  /// RANSAC inliers needed for a step (OdometryOptions::correspondence.min_inliers). Default 12.
  int min_inliers = 12;
  /// SURF Hessian threshold (MATLAB MetricThreshold). Default 1000.
  double surf_threshold = 1000.0;
  /// Keep at most this many SURF points per frame, strongest first (0 = all). Default 0.
  int max_keypoints = 0;
  /// RANSAC seed.
  std::uint64_t seed = 1;
  /// Robust polish of every RANSAC fit (RansacOptions::polish_iterations): IRLS rounds with a
  /// smooth loss over all matches, making the track independent of the seed. Default 0 (off,
  /// MATLAB's estimator as in the paper).
  int polish = 0;
  /// Threads for SURF and matching (0 = all cores).
  int threads = 0;
  /// No progress bar, no configuration dump, only errors and the final table.
  bool quiet = false;
};

/// Throws InvalidArgument naming the bad key.
void Validate(const RunConfig& config);
/// The configuration as JSON (the keys of RunConfig).
nlohmann::json ToJson(const RunConfig& config);
/// `base` with the keys present in `json` replaced. Unknown keys and wrong types throw
/// InvalidArgument naming the key (and `source`, e.g. the config file path).
RunConfig RunConfigFromJson(const nlohmann::json& json, RunConfig base,
                            const std::string& source = "config");
/// Syntax of a run configuration file.
enum class RunConfigFormat { kJson, kYaml };
/// Parses the text of a config file (`source` names it in messages): JSON, or YAML (a flat
/// mapping `key: value` with the same keys; parsed with libyaml), then RunConfigFromJson.
/// InputError names the source and the parse error (with its line for YAML); InvalidArgument
/// names an unknown key or a value of the wrong type or out of the field's range. This is the
/// entry point the config fuzz targets drive (fuzz/).
RunConfig ParseRunConfig(std::string_view text, RunConfigFormat format, RunConfig base,
                         const std::string& source = "config");
/// Reads a config file: YAML for a .yaml/.yml extension, else JSON (ParseRunConfig).
RunConfig LoadRunConfig(const std::filesystem::path& path, RunConfig base);

/// Undistorts frames of one size with a pinhole camera (focal_px, principal point at the image
/// centre ((w-1)/2, (h-1)/2)) and OpenCV distortion coefficients (k1, k2, p1, p2, k3); the output
/// keeps the same camera matrix, so focal_px still converts pixels to angles.
class FrameUndistorter {
 public:
  /// Throws InvalidArgument for a non-positive size or focal length.
  FrameUndistorter(int width_px, int height_px, double focal_px, double k1, double k2, double p1,
                   double p2, double k3);
  ~FrameUndistorter();
  FrameUndistorter(FrameUndistorter&&) noexcept;
  FrameUndistorter& operator=(FrameUndistorter&&) noexcept;
  /// The undistorted copy of `frame` (same size; InvalidArgument for another size). The view
  /// stays valid until the next call.
  GrayImageView Apply(const GrayImageView& frame);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The paper's illumination change f_k = k f on one frame: out(x, y) = min(255, floor(k in(x, y)
/// + 0.5)) (round half up, saturated to 0..255), written into `*buffer` (resized as needed).
/// Returns a view of `*buffer`. Throws InvalidArgument unless k is finite and >= 0.
GrayImageView ScaleBrightness(const GrayImageView& frame, double k, GrayImage* buffer);

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
  /// The ground-truth file compared with ("" = none) and the SE(2) / Sim(2) comparison with it
  /// (processed frames matched as RunConfig::truth says; in the run's ENU frame when the truth is
  /// geographic).
  std::string truth;
  int frames_with_truth = 0;
  std::optional<TrajectoryComparison> truth_evaluation;
  std::vector<std::string> warnings;
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
