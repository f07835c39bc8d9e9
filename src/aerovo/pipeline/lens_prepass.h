// The lens self-calibration pre-pass of `aerovo run` (wide lenses without a
// calibration file; RunConfig::lens_estimation, docs/lenses.md "Self-calibration"). On its own
// thread (LensPrepassTask), started at the first frame and running beside the odometry, a SECOND
// frame source on the same input (a photo folder: random access to its photos; a video file:
// one decoder reading forward from pair to pair, seeking only to a pair more than
// kLensPrepassSeekS ahead) reads a few pairs of
// consecutive frames (consecutive as the run delivers them: `step` apart) spread evenly over the
// flight's window; each frame is reduced to at most kLensPrepassMegapixels, SURF points are
// detected and matched (the run's surf and match options), and correspondence/lens_estimation.h
// EstimateRadialDistortion decides whether a one-parameter radial lens (OpenCV fisheye k1 or
// Brown k1) is significant. The main stream is not touched. A significant estimate becomes the
// run's lens at a fixed frame (pipeline/lens_switch.h) as a calibration file would be
// (run_steps.h RunCamera::calibrated, so undistort auto|points|frames applies) and is written as
// lens_estimate.yaml (OpenCV YAML).
//
// The same pairs give the camera's tilt (RunConfig::attitude_estimation, odometry/
// attitude_estimation.h EstimateCameraAttitude, docs/attitude.md "Estimated from the flight"):
// their points undistorted with the run's lens (given, or the significant estimate), one roll
// and pitch for the flight; a significant estimate is every frame's camera attitude. The attitude
// is estimated for photo folders only (AttitudePrepassSkipReason), and then the pre-pass runs
// before the first frame is processed (RunLensPrepass with PrepassRequest::attitude), lens and
// attitude applied from the first frame.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <future>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/camera/pinhole.h"
#include "aerovo/correspondence/lens_estimation.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/odometry/attitude_estimation.h"
#include "aerovo/telemetry/telemetry.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/pipeline/run_config.h"
#include "aerovo/pipeline/run_types.h"

namespace aerovo::run_steps {

/// Frame pairs the pre-pass reads (the estimator needs at least LensEstimationOptions::min_pairs
/// = 3; 5 leaves two to lose to water or blur). Our choice.
inline constexpr int kLensPrepassPairs = 5;
/// A video's next pair further ahead than this, seconds of stream: the pre-pass seeks to the key
/// frame before it instead of decoding the frames between (lens_prepass.cc ReadVideoPairsFfmpeg).
/// Below it, reading forward decodes no more frames than a seek would with key frames up to this
/// far apart. Our choice (drone cameras put key frames 0.5-2 s apart; a 12 s clip's pairs, 2.4 s
/// apart, are read forward).
inline constexpr double kLensPrepassSeekS = 5.0;
/// Pixel budget of the pre-pass's frames, megapixels (FrameReducer, area reduction): the
/// estimate's coefficients are on normalised coordinates, so the reduction only costs precision
/// (RecoversAFisheyeK1: 960x720 gives k within 0.002). Our choice: keeps the pre-pass's SURF and
/// matching at about 2x the cost of one frame of a 1080p run per pair.
inline constexpr double kLensPrepassMegapixels = 1.0;
/// Matches of a pair given to the estimator, at most: a larger set is thinned by an even stride
/// over the matcher's order (deterministic). The estimator's cost grows with the points (every
/// candidate k refits each pair's homography); 400 points per pair fix k to about 1e-3
/// (LensEstimation.RecoversAFisheyeK1: 500 points, 0.5 px noise). Our choice.
inline constexpr int kLensPrepassMaxMatches = 400;
/// The file a significant estimate is written to in the run folder (OpenCV YAML,
/// camera_files/calibration.h WriteCalibration; `aerovo run --calibration` reads it back).
inline constexpr const char* kLensEstimateYaml = RunFileNames::kLensEstimateYaml;

/// The frame source options of a run (step, window, photo flights): the main source's and the
/// pre-pass's.
FrameSourceOptions SourceOptionsOf(const RunConfig& config);

/// Why the pre-pass does not run for `config` ("" = it runs): lens_estimation off, a calibration
/// file or distortion coefficients given, or (not `live`) an input that is not a file or folder
/// that can be opened again. A live source's pairs come from its frames as delivered
/// (LivePairFeed).
std::string LensPrepassSkipReason(const RunConfig& config, bool live);

/// Why the pre-pass does not estimate the camera's attitude ("" = it does): attitude_estimation
/// or attitude off, a camera_mount_pitch_deg given, an autopilot link that gives ATTITUDE
/// (`autopilot_attitude`), the first frame's telemetry `first_sample` with gimbal or aircraft
/// angles, a live source (`live`), an input that is not a photo folder (`photo_folder` false: a
/// video's first pose does not wait for the pre-pass, pipeline/lens_switch.h, and the tilt must
/// hold from the first frame), or an input that cannot be read again.
std::string AttitudePrepassSkipReason(const RunConfig& config, bool live, bool autopilot_attitude,
                                      const std::optional<TelemetrySample>& first_sample,
                                      bool photo_folder = true);

/// What the pre-pass is asked to estimate.
struct PrepassRequest {
  bool lens = true;       ///< The lens (LensPrepassSkipReason is "").
  bool attitude = false;  ///< The camera's attitude (AttitudePrepassSkipReason is "").
  /// The run's calibrated camera of the frames as delivered (RunCamera::calibrated; unset
  /// without a calibration file): the attitude estimate's points are undistorted with it, with
  /// config.k1..k3, p1, p2, or with a significant lens estimate.
  std::optional<CameraIntrinsics> calibrated;
};

/// What the pre-pass found about the camera's attitude: summary.json "attitude_estimate".
struct AttitudePrepass {
  /// As LensPrepass::status, for the attitude.
  LensPrepassStatus status = LensPrepassStatus::kSkipped;
  bool applied = false;
  std::string why;
  std::optional<AttitudeEstimate> estimate;
  double estimate_ms = 0.0;  ///< Undistortion of the points and EstimateCameraAttitude.
};

/// First frames of the pre-pass's pairs, as ranks among the `frames` frames the run delivers:
/// `pairs` ranks spread evenly ((i + 0.5) / pairs of the way), each followed by the next rank;
/// fewer when the flight is short (distinct ranks only), none below 2 frames.
std::vector<int> LensPrepassPairStarts(int frames, int pairs);

/// What the pre-pass did: summary.json "lens_estimate".
struct LensPrepass {
  /// kApplied, kNotSignificant, kNoEstimate (too few usable pairs or points), kSkipped
  /// (LensPrepassSkipReason) or kFailed (an input error while reading the pairs; the run goes
  /// on without an estimate).
  LensPrepassStatus status = LensPrepassStatus::kSkipped;
  bool applied = false;
  std::string why;  ///< The decision (or the skip, the failure) in one sentence.
  std::optional<LensEstimate> estimate;
  /// The estimated camera of the frames as delivered (full size, focal of the run, centred
  /// principal point, the family's one coefficient); set when applied.
  std::optional<CameraIntrinsics> lens;
  int pairs_read = 0;                ///< Pairs read and matched.
  std::vector<int> pair_frames;      ///< Frame::index of each pair's first frame, as read.
  int width_px = 0, height_px = 0;   ///< The pre-pass's (reduced) frame size.
  double read_ms = 0.0;    ///< Opening the second source and decoding the frames.
  double match_ms = 0.0;   ///< Reduction, SURF and matching.
  double estimate_ms = 0.0;  ///< EstimateRadialDistortion.
  double total_ms = 0.0;
  AttitudePrepass attitude;  ///< The camera's attitude from the same pairs.
};

/// The pre-pass on `config.input` (what `request` asks for; LensPrepassSkipReason must be "" for
/// the lens, AttitudePrepassSkipReason for the attitude) for frames of width_px x height_px as
/// delivered with focal length focal_px (the run's resolved focal, full frames). Input errors
/// while reading are caught (status "failed"); InvalidArgument for a bad size or focal.
/// Deterministic: the RANSAC seed is config.odometry.correspondence.ransac.seed.
LensPrepass RunLensPrepass(const RunConfig& config, int width_px, int height_px, double focal_px,
                           const PrepassRequest& request = {});

/// The frame pairs of a live source, which cannot be read twice: the run hands over copies of
/// pairs of consecutive frames as it delivers them (LensSwitch), the pre-pass's thread matches
/// each as it comes and estimates once the feed is closed. Thread-safe.
class LivePairFeed {
 public:
  /// Adds a pair (ignored once closed).
  void Push(Frame prev, Frame curr);
  /// No more pairs: the pre-pass estimates from those it has.
  void Close();
  /// The next pair, waiting for it; false once closed and empty. Cancelled when `stop` (may be
  /// null) is set while waiting.
  bool Pop(std::pair<Frame, Frame>* pair, const std::atomic<bool>* stop);

 private:
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::pair<Frame, Frame>> pairs_;
  bool closed_ = false;
};

/// RunLensPrepass on its own thread, started by the constructor: the first frames do not wait
/// for it. With a `live_feed`, the pairs are the feed's instead of read from config.input
/// (LensPrepassSkipReason's file check does not apply), the lens alone is estimated, and
/// LensPrepass::read_ms is the time spent waiting for pairs. Get() waits for the result (once). `stop` (the run's stop flag; may be null) ends
/// the reading and matching early (checked per frame and pair; status kFailed, "stopped"). The
/// destructor waits for the thread. `config` and `stop` must outlive the task.
class LensPrepassTask {
 public:
  LensPrepassTask(const RunConfig& config, int width_px, int height_px, double focal_px,
                  const std::atomic<bool>* stop = nullptr,
                  std::shared_ptr<LivePairFeed> live_feed = nullptr);
  ~LensPrepassTask();
  LensPrepassTask(const LensPrepassTask&) = delete;
  LensPrepassTask& operator=(const LensPrepassTask&) = delete;
  /// The pre-pass's result, waiting for it (its errors rethrown: InvalidArgument); Cancelled
  /// when `stop` (may be null) is set while waiting (it may be called again then).
  /// `waited_ms` (may be null) receives the time waited. Once it returned or rethrew, a second
  /// call is InvalidArgument.
  LensPrepass Get(const std::atomic<bool>* stop, double* waited_ms = nullptr);
  /// Get() was called.
  bool taken() const { return taken_; }
  /// The result is there and not taken yet: Get() would not wait.
  bool Ready() const;

 private:
  std::future<LensPrepass> result_;
  bool taken_ = false;
};

/// summary.json's "lens_estimate": status, applied, why, and with an estimate family ("fisheye"
/// or "pinhole": the OpenCV model of k), k, sigma_k, cost_drop, cost, cost_pinhole (px^2),
/// median residuals (px), pairs_used, pairs_improved, points_used, pair_k; pairs_read,
/// pair_frames, frame size, stage times (ms), file (when applied).
nlohmann::json ToJson(const LensPrepass& prepass);

/// summary.json's "attitude_estimate": status, applied, why; when the estimator ran pairs_used,
/// points_used, time_ms; with a valid estimate also roll_deg, pitch_deg, tilt_deg,
/// sigma_roll_deg, sigma_pitch_deg, cost_drop, cost, cost_nadir, median residuals (px),
/// pairs_improved, pair_roll_deg, pair_pitch_deg.
nlohmann::json ToJson(const AttitudePrepass& attitude);

}  // namespace aerovo::run_steps
