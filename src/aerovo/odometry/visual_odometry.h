// Streaming visual odometry for a downward-looking camera (Ivanov & Muzychuk 2023, docs/method.md):
// per frame, SURF -> matching -> (clustered) RANSAC against the previous frame -> chaining into
// a trajectory (pose_chain.h documents the frames), with failure handling: a step that fails
// (dark or textureless frame, no overlap, too few inliers, implausible motion) is flagged and
// bridged with the previous step's motion (constant velocity), and the tracker re-acquires on
// the next frames by matching them against the last good frame with the predicted motion.
// No I/O: frames arrive decoded (aerovo/io reads files, video and cameras).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "aerovo/camera/pinhole.h"
#include "aerovo/core/image.h"
#include "aerovo/core/options.h"
#include "aerovo/correspondence/correspondence.h"
#include "aerovo/features/surf.h"
#include "aerovo/odometry/attitude.h"
#include "aerovo/odometry/pose_chain.h"

namespace aerovo {

/// The largest height above ground a frame may be given, m: the range of the run's altitude_m
/// (pipeline/run_config.h), 100 km.
inline constexpr double kMaxHeightAboveGroundM = 1e5;

/// Options of the odometry pipeline. Plain aggregate; check with Validate().
struct OdometryOptions {
  /// SURF options. Defaults = MATLAB's (surf.h) except:
  /// - num_threads = 0 (all cores): the odometry is the one consumer that owns the whole machine;
  /// - adaptive = true: every frame keeps about surf.target_points points spread over the image
  ///   whatever its contrast (dim, hazy, thermal, low-texture frames still give a step;
  ///   BENCHMARKS.md "Adaptive interest points"). surf.adaptive = false (or `--paper`) is the
  ///   paper's fixed MATLAB threshold.
  SurfOptions surf = [] {
    SurfOptions s;
    s.num_threads = 0;
    s.adaptive = true;
    return s;
  }();
  /// Correspondence stage (matching + RANSAC, correspondence.h). Defaults are that module's
  /// (clustered RANSAC, affine, MATLAB matching/MSAC defaults, the guided refinement with its
  /// final pass of 6 px) except:
  /// - guided_matching = true: each frame is first matched with the predicted motion (constant
  ///   velocity) as a prior, only candidates within match.guided_radius_px of the prediction
  ///   being compared; if that fails the same method is run unguided, so guidance never loses a
  ///   step it would otherwise find (much faster on smooth flights);
  /// - min_inliers = 12: a step is accepted only with 12 consistent points (the paper's minimum
  ///   cell size; an affine fit on 12 ratio-tested matches at 1.5 px is very unlikely to be
  ///   chance);
  /// - match.num_threads = 0 (all cores);
  /// - clustered.refine_final_min_shift_px = 0 and clustered.refine_final_max_points = 0: the
  ///   final pass runs on every step and every point (a track adds up every step's error, and
  ///   SURF, not this pass, sets the frame rate);
  /// - clustered.refine_fallback = true: a fall-back's fit, and in a clustered run a
  ///   relocalisation's, is refit on all points too (the same evidence as a cell step's).
  /// Why the refinement: a cell's affine fit is exact near the cell and extrapolates poorly to
  /// the rest of the frame (synthetic flights of visual_odometry_test.cc, BENCHMARKS.md
  /// "Correspondence"). clustered.refine = false turns all of it off (the paper's method).
  CorrespondenceOptions correspondence = [] {
    CorrespondenceOptions c;
    c.guided_matching = true;
    c.min_inliers = 12;
    c.match.num_threads = 0;
    c.clustered.refine_final_min_shift_px = 0.f;
    c.clustered.refine_final_max_points = 0;
    c.clustered.refine_fallback = true;
    return c;
  }();
  /// How the steps become metric positions. Default kMetric (docs/method.md, "Pitfalls on real
  /// flights": tilt).
  ScaleMode scale_mode = ScaleMode::kMetric;
  /// Camera focal length in pixels (of the frames given to Process). 0 = unknown: positions are
  /// then in pixels of the first frame (ground sampling distance taken as 1 m/px).
  double focal_px = 0.0;
  /// Height above ground (m) used when Process() is given none. 0 = none (then every frame must
  /// come with a height, unless focal_px is 0).
  double default_height_m = 0.0;
  /// Metric mode: take each frame's heading from the telemetry yaw given to Process (relative
  /// to the first frame's) instead of integrating each step's rotation. Default false (pure VO).
  bool heading_from_yaw = false;
  /// A frame with fewer SURF points than this cannot be matched (dark or textureless); it is
  /// bridged and not used as a reference. Default 20.
  int min_features = 20;
  /// Plausibility of an estimated step: |scale - 1| <= max_scale_change (scale = sqrt|det| of
  /// the linear part). Default 0.3: a nadir camera does not change height by 30 % between
  /// consecutive frames; a larger value means a wrong fit.
  double max_scale_change = 0.3;
  /// Plausibility: ratio of the linear part's singular values <= max_anisotropy. Default 1.5:
  /// perspective from tilt gives a few percent; more is a degenerate fit.
  double max_anisotropy = 1.5;
  /// Plausibility: the image centre may move at most this fraction of the frame's larger side
  /// in one step. Default 0.9: beyond it the frames cannot overlap enough to be matched.
  double max_shift_fraction = 0.9;
  /// Relocalisation: when a frame matches neither the previous nor the last good frame, it is
  /// matched (unguided, rotation-invariant SURF) against stored keyframes, newest first; a match
  /// re-anchors the pose on that keyframe's. This is what recovers from a jump with no overlap
  /// with the previous frame when the flight comes back over earlier ground, including a change
  /// of heading that no motion model predicts. Default true.
  bool relocalize = true;
  /// A keyframe is stored every keyframe_interval measured frames. Default 5.
  int keyframe_interval = 5;
  /// Keyframes kept (oldest dropped): bounds memory (~250 kB per 1000 SURF points) and the
  /// cost of a failed frame (one unguided match per keyframe). Default 64.
  int max_keyframes = 64;
  /// Inliers needed to accept a relocalisation. Default 12 (the paper's minimum cell size):
  /// with the plausibility checks (scale, anisotropy, shift) a chance affine fit with 12 inliers
  /// at 1.5 px is very unlikely, and true relocalisations reach it (BENCHMARKS.md, "Odometry on
  /// real flights").
  int relocalize_min_inliers = 12;
  /// Sampler of the RANSAC of keyframe attempts (which always match all points, unguided).
  /// Default kProsac (our choice): a relocalisation has few true matches among many, which
  /// uniform sampling with 1000 trials finds by luck; PROSAC draws from the lowest-SSD matches
  /// first and relocalises for every seed (BENCHMARKS.md, "Odometry on real flights").
  SamplerKind relocalize_sampler = SamplerKind::kProsac;
  /// Re-acquisition: after a failure, the last good frame stays a candidate reference for this
  /// many frames. Default 5.
  int max_reacquire_gap = 5;
};

/// Throws InvalidArgument naming the offending field (including those of the nested stage
/// options) when out of range.
void Validate(const OdometryOptions& options);
/// The option schema (core/options.h; own keys odometry.* in a run configuration, the stages'
/// surf.*, correspondence.*, ...). focal_px and default_height_m are not in it: the run sets them
/// from its camera and height (RunConfig focal_px, hfov_deg, altitude_m).
// clang-format off
template <class V>
void VisitFields(OdometryOptions& o, V& v) {
  using namespace options;
  v.Group("surf", o.surf);
  v.Group("correspondence", o.correspondence);
  v.Field(o.scale_mode, "scale_mode", "metric (height/focal per step) or affine-chain (the paper's pure chaining)", Any().Alias("scale"));
  v.Field(o.heading_from_yaw, "heading_from_yaw", "Metric mode: heading from the telemetry yaw instead of the steps' rotation", Any());
  v.Field(o.min_features, "min_features", "A frame with fewer SURF points is bridged", Interval(0, 1000000));
  v.Field(o.max_scale_change, "max_scale_change", "Plausibility: largest |scale - 1| of a step", Interval(0, 1, true, true));
  v.Field(o.max_anisotropy, "max_anisotropy", "Plausibility: largest ratio of the step's singular values", AtLeast(1));
  v.Field(o.max_shift_fraction, "max_shift_fraction", "Plausibility: largest move of the image centre, fraction of the larger side", GreaterThan(0));
  v.Field(o.relocalize, "relocalize", "Match a lost frame against stored keyframes", Any());
  v.Field(o.keyframe_interval, "keyframe_interval", "A keyframe every N measured frames", Interval(1, 1000000));
  v.Field(o.max_keyframes, "max_keyframes", "Keyframes kept (oldest dropped)", Interval(1, 1000));
  v.Field(o.relocalize_min_inliers, "relocalize_min_inliers", "Inliers needed to accept a relocalisation", Interval(1, 1000000));
  v.Field(o.relocalize_sampler, "relocalize_sampler", "RANSAC sampler of keyframe attempts", Any());
  v.Field(o.max_reacquire_gap, "max_reacquire_gap", "After a failure the last good frame stays a reference for N frames", Interval(1, 1000000));
}
// clang-format on
template <>
struct options::EnumTraits<ScaleMode>
    : options::EnumList<ScaleMode, ToString, ScaleMode::kMetric, ScaleMode::kAffineChain> {};

/// What happened to a frame.
enum class FrameStatus {
  kFirst,       ///< First frame, or first usable frame after unusable ones only: the origin.
  kOk,          ///< Step estimated against the previous frame.
  kReacquired,  ///< Step estimated against the last good frame or a keyframe (relocalised).
  kBridged,     ///< Step failed: pose predicted with the previous step's motion.
};
/// "first", "ok", "reacquired", "bridged".
const char* ToString(FrameStatus status);

/// Why a step failed (kNone unless status == kBridged).
enum class StepFailure {
  kNone,
  kTooFewFeatures,     ///< Dark, blank or textureless frame (n_surf < min_features).
  kNoTransform,        ///< The correspondence stage found no transform.
  kTooFewInliers,      ///< Fewer than correspondence.min_inliers inliers.
  kImplausibleMotion,  ///< Scale, anisotropy or shift out of the plausible range.
};
/// "", "too-few-features", "no-transform", "too-few-inliers", "implausible-motion".
const char* ToString(StepFailure failure);

/// Result of Process() for one frame. Frames: see pose_chain.h.
struct FrameResult {
  int index = 0;        ///< 0-based count of frames given to Process().
  double time_s = 0.0;  ///< As given.
  FrameStatus status = FrameStatus::kFirst;
  StepFailure failure = StepFailure::kNone;
  int reference_index = -1;  ///< Frame matched against (-1: none).
  int n_surf = 0;            ///< SURF points on this frame.
  int n_matched = 0;         ///< Putative matches of the successful (or last) attempt.
  int n_inliers = 0;         ///< RANSAC inliers of the successful (or last) attempt.
  int cluster = -1;          ///< Cell used by clustered RANSAC, row-major (-1: whole frame).
  int attempts = 0;          ///< Match + RANSAC runs (cells tried, fall-backs, guided/unguided).
  bool fell_back = false;    ///< Clustered RANSAC fell back to standard.
  bool guided = false;       ///< The accepted step came from guided matching.
  bool relocalized = false;  ///< Re-anchored on a keyframe (see OdometryOptions::relocalize).
  double detect_ms = 0.0, describe_ms = 0.0, correspond_ms = 0.0, estimate_ms = 0.0, total_ms = 0.0;
  /// The step applied to the trajectory, curr_from_ref: maps pixels of frame reference_index
  /// (index-1 for kOk; the last good frame or a keyframe for kReacquired) to this frame's
  /// pixels; when bridged, the predicted one-frame step (previous step's motion) from index-1.
  Eigen::Matrix3d curr_from_prev = Eigen::Matrix3d::Identity();
  /// See PoseChain::world_from_frame (metric: local_from_frame in metres; affine-chain: first
  /// frame's pixels from this frame's pixels).
  Eigen::Matrix3d world_from_frame = Eigen::Matrix3d::Identity();
  /// Camera centre in the local VO frame (x = first image right, y = first image up), metres
  /// (pixels of the first frame if the focal length is unknown).
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();
  double heading_rad = 0.0;   ///< See pose_chain.h.
  double gsd_m_per_px = 1.0;  ///< Ground sampling distance used for this frame.
  double step_scale = 1.0;    ///< sqrt|det| of the step's linear part.
  /// The frame's keypoints were mapped to the virtual nadir camera of its attitude (attitude.h):
  /// an attitude was given, focal_px > 0 and the tilt is not exactly 0.
  bool attitude_corrected = false;
  double tilt_deg = 0.0;  ///< Tilt from nadir of the attitude given (0: none).
  /// The frame's features as they were matched (keypoints undistorted and mapped to the virtual
  /// nadir camera when those apply; pixels of this frame), shared with the odometry's own
  /// references (no copy); null when the frame had too few to be used (min_features), or
  /// without VisualOdometry::SetShareFeatures. For the offline optimisation
  /// (odometry/flight_graph.h), which keeps those of its keyframes.
  std::shared_ptr<const FeatureSet> features;
  /// The accepted step's RANSAC inliers in this frame's pixels (one column each; empty when
  /// bridged or first, or without VisualOdometry::SetShareFeatures): the evidence of the step's
  /// information matrix
  /// (backend/pixel_step.h SimilarityFitInformation).
  Eigen::Matrix2Xd step_inliers_curr_px;
};

/// Counts over the frames processed so far.
struct OdometryStats {
  int frames = 0;
  int ok = 0;
  int reacquired = 0;
  int bridged = 0;
};

/// The streaming odometry. Keeps only the previous frame's and the last good frame's features
/// (bounded memory). Not thread-safe; parallel inside (options.surf/match num_threads).
class VisualOdometry {
 public:
  /// Throws InvalidArgument when options are invalid.
  explicit VisualOdometry(const OdometryOptions& options = {});
  ~VisualOdometry();
  VisualOdometry(VisualOdometry&&) noexcept;
  VisualOdometry& operator=(VisualOdometry&&) noexcept;

  const OdometryOptions& options() const { return options_; }

  /// The frames given to Process are distorted by `lens` (camera/pinhole.h; pinhole or fisheye
  /// model): SURF runs on them as they are and every keypoint's position is then mapped to the
  /// ideal pinhole of focal lens.fx_px centred in the frame (camera/lens.h LensUndistortion,
  /// iterative inverse, no allocation), before the attitude correction, matching and RANSAC, so
  /// the steps are those of undistorted frames (the points path of `aerovo run --undistort`,
  /// docs/lenses.md). A keypoint whose ray has no pinhole position is dropped.
  /// Preconditions: called before the first frame; options.focal_px is lens.fx_px (or 0).
  /// Frames of another size than the lens's: InputError naming the frame. Throws
  /// InvalidArgument as Validate(CameraIntrinsics) does.
  void SetLensUndistortion(const CameraIntrinsics& lens);

  /// With `share` (default false), each FrameResult carries the frame's features
  /// (FrameResult::features, shared with the odometry: no copy) and the accepted step's inliers
  /// (step_inliers_curr_px), for the offline optimisation (odometry/flight_graph.h). Off, results
  /// hold neither, so a caller that keeps its results keeps no features.
  void SetShareFeatures(bool share);

  /// Processes the next frame. `height_m`: height above ground (else options.default_height_m);
  /// `yaw_deg`: camera compass yaw (used only with options.heading_from_yaw).
  /// `attitude`: the camera's roll and pitch at this frame (attitude.h: camera FRD frame, 0, 0 =
  /// nadir). When given (and focal_px > 0, tilt not 0) every keypoint is mapped to the virtual
  /// nadir camera (NadirFromCameraHomography, principal point at the frame centre) before
  /// matching, so the step is measured between nadir-equivalent images and position_m is the
  /// point under the camera, not the ground point of the image centre. Without one the frame is
  /// processed as a nadir frame (the behaviour before attitudes existed).
  /// Throws InvalidArgument for an empty frame or a time, yaw or attitude that is not finite,
  /// InputError when the frame size differs from the first frame's or no height above ground is
  /// known for a metric run (none, not > 0, or above kMaxHeightAboveGroundM; message names the
  /// frame).
  FrameResult Process(const GrayImageView& frame, double time_s,
                      std::optional<double> height_m = std::nullopt,
                      std::optional<double> yaw_deg = std::nullopt,
                      std::optional<CameraAttitude> attitude = std::nullopt);

  const OdometryStats& stats() const { return stats_; }

 private:
  struct Impl;
  OdometryOptions options_;
  OdometryStats stats_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace aerovo
