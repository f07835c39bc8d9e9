// The configuration of one `aerovo run`: every option a run can be told, as flags (cli/run_cli.cc)
// or as a JSON/YAML config file with the same keys; validation, JSON conversion and parsing.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace aerovo {

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
  /// (CorrespondenceOptions::clustered.refine, which turns off every refine_* option).
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

}  // namespace aerovo
