// Chaining of frame-to-frame image transforms into a camera trajectory (no I/O, no features:
// pure geometry, so that it can be tested on exact transforms).
//
// Frames used throughout the odometry module:
// - pixel frame of frame n: x right (columns), y down (rows), (0, 0) = centre of the top-left
//   pixel; `curr_from_prev` maps pixel positions of frame n-1 to those of frame n.
// - local VO frame ("local"): metric, origin at the first frame's camera centre (the ground
//   point under the image centre), x = the first image's right (+columns), y = the first
//   image's up (-rows), metres. For a nadir camera whose image top points north at the first
//   frame this is East-North.
// - heading_rad: angle (counter-clockwise seen from above, radians) from the local +y axis to
//   the current frame's image-up direction; it is the negative of the change of the camera's
//   compass yaw since the first frame.
#pragma once

#include <Eigen/Core>

namespace aerovo {

/// How per-step image transforms become a metric trajectory.
enum class ScaleMode {
  /// Default. Each step's displacement of the image centre is converted to metres with the
  /// ground sampling distance of the frame it is measured in (height above ground / focal
  /// length in pixels), and the heading is integrated from each step's rotation; the step's
  /// scale is not chained. This is the cure docs/method.md ("Pitfalls on real flights")
  /// prescribes for the tilt-induced scale drift measured on tampa-phantom3 (chained affine
  /// scale swinging 0.6x-2.6x).
  kMetric,
  /// The paper's pure chaining: world_from_frame_n = world_from_frame_{n-1} * prev_from_curr
  /// in the first frame's pixels, converted to metres once with the first frame's ground
  /// sampling distance.
  kAffineChain,
};

/// "metric" / "affine-chain".
const char* ToString(ScaleMode mode);
/// Parses "metric" / "affine-chain"; throws InvalidArgument otherwise.
ScaleMode ParseScaleMode(const char* text);

/// Streaming integrator of frame-to-frame transforms. O(1) state.
class PoseChain {
 public:
  /// `width_px`, `height_px`: frame size; the camera centre is the image centre
  /// ((width - 1) / 2, (height - 1) / 2). Throws InvalidArgument if not positive.
  PoseChain(ScaleMode mode, int width_px, int height_px);

  /// Starts the trajectory at the first frame: position (0, 0), heading 0.
  /// `gsd_m_per_px` = height above ground / focal length in pixels (> 0).
  void Start(double gsd_m_per_px);

  /// Appends one step. `curr_from_prev` (3x3, last row (0, 0, 1) for affine models; a
  /// homography is accepted as well) maps frame n-1 pixels to frame n pixels and must be
  /// invertible. `gsd_prev_m_per_px` / `gsd_curr_m_per_px`: ground sampling distances of the two
  /// frames. `heading_override_rad`: when set (metric mode only), the heading of frame n is
  /// taken from it (e.g. from telemetry yaw) instead of integrated from the step's rotation.
  /// Throws InvalidArgument when Start() was not called or the transform is singular.
  void Step(const Eigen::Matrix3d& curr_from_prev, double gsd_prev_m_per_px,
            double gsd_curr_m_per_px, const double* heading_override_rad = nullptr);

  bool started() const { return started_; }
  ScaleMode mode() const { return mode_; }

  /// Camera centre of the current frame in the local VO frame, metres.
  Eigen::Vector2d position_m() const;
  /// Heading of the current frame (see the file comment), radians in (-pi, pi].
  double heading_rad() const;
  /// Metric mode: local_from_frame, maps current-frame pixels to the local VO frame (metres).
  /// Affine-chain mode: world_from_frame, maps current-frame pixels to first-frame pixels.
  const Eigen::Matrix3d& world_from_frame() const { return world_from_frame_; }
  /// Affine-chain mode: the accumulated scale (sqrt |det| of the linear part, first-frame pixels
  /// per current-frame pixel); 1 in metric mode.
  double chained_scale() const;

 private:
  ScaleMode mode_;
  Eigen::Vector2d centre_px_;
  bool started_ = false;
  double gsd0_ = 1.0;
  double gsd_curr_ = 1.0;
  // Metric mode: rotation+reflection taking a current-frame pixel vector to a local direction.
  Eigen::Matrix2d local_from_pixel_dir_ = Eigen::Matrix2d::Identity();
  Eigen::Vector2d position_m_ = Eigen::Vector2d::Zero();
  Eigen::Matrix3d world_from_frame_ = Eigen::Matrix3d::Identity();
};

/// The rotation angle (radians, pixel frame, positive = clockwise on screen, i.e. from +x
/// towards +y) of the rotation closest to the linear part of `transform` (2x2 top-left block).
double RotationAngleRad(const Eigen::Matrix3d& transform);

/// Isotropic scale of the linear part: sqrt(|det|).
double LinearScale(const Eigen::Matrix3d& transform);

}  // namespace aerovo
