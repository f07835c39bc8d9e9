// A 2D similarity on the ground plane: the pose of one frame in the pose graph (pose_graph.h).
//
// Frames:
// - local: the run's metric ground frame (odometry/pose_chain.h: origin at the first frame's
//   camera centre, x = the first image's right, y = the first image's up, metres; East-North for
//   a nadir camera whose first image top points north; the local ENU frame once geo-referenced).
// - frame n: the frame's own ground coordinates, x = image right, y = image up, in the frame's
//   nominal metres (pixels x the frame's ground sampling distance, height / focal length), origin
//   at the camera centre's ground point.
// `local_from_frame` maps a point of frame n to the local frame:
//   p_local = exp(log_scale) R(heading_rad) p_frame + translation_m,
// R(a) = [cos a, -sin a; sin a, cos a]. heading_rad is the angle (counter-clockwise seen from
// above) from the local +y axis to the frame's image-up direction, the same angle as
// FrameResult::heading_rad (odometry/visual_odometry.h); log_scale is the natural log of the
// frame's true metres per nominal metre (0 when the height above ground is exact).
#pragma once

#include "aerovo/core/angles.h"

#include <cmath>

#include <Eigen/Core>

namespace aerovo::backend {

/// Wraps an angle to (-pi, pi], radians.
inline double WrapAngleRad(double a) {
  a = std::remainder(a, 2.0 * kPi);  // [-pi, pi]
  return a <= -kPi ? a + 2.0 * kPi : a;
}

/// A 2D similarity transform (see the file comment for its frames and units).
struct Similarity2 {
  Eigen::Vector2d translation_m = Eigen::Vector2d::Zero();
  double heading_rad = 0.0;
  double log_scale = 0.0;

  double scale() const { return std::exp(log_scale); }
  /// exp(log_scale) R(heading_rad), the linear part.
  Eigen::Matrix2d Linear() const {
    const double s = scale(), c = std::cos(heading_rad), n = std::sin(heading_rad);
    Eigen::Matrix2d m;
    m << s * c, -s * n, s * n, s * c;
    return m;
  }
  Eigen::Vector2d Apply(const Eigen::Vector2d& p) const { return Linear() * p + translation_m; }
  /// The homogeneous 3x3 matrix.
  Eigen::Matrix3d Matrix() const {
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    m.topLeftCorner<2, 2>() = Linear();
    m.topRightCorner<2, 1>() = translation_m;
    return m;
  }
  /// this * other: a_from_c = a_from_b * b_from_c.
  Similarity2 operator*(const Similarity2& other) const {
    Similarity2 r;
    r.translation_m = Apply(other.translation_m);
    r.heading_rad = WrapAngleRad(heading_rad + other.heading_rad);
    r.log_scale = log_scale + other.log_scale;
    return r;
  }
  /// b_from_a for this = a_from_b.
  Similarity2 Inverse() const {
    Similarity2 r;
    r.heading_rad = WrapAngleRad(-heading_rad);
    r.log_scale = -log_scale;
    r.translation_m = -(r.Linear() * translation_m);
    return r;
  }
  bool AllFinite() const {
    return translation_m.allFinite() && std::isfinite(heading_rad) && std::isfinite(log_scale);
  }
};

/// prev_from_curr = local_from_prev^-1 * local_from_curr: the relative pose a relative factor
/// measures (pose_graph.h).
inline Similarity2 Between(const Similarity2& local_from_prev, const Similarity2& local_from_curr) {
  return local_from_prev.Inverse() * local_from_curr;
}

}  // namespace aerovo::backend
