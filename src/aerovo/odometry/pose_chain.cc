#include "aerovo/odometry/pose_chain.h"

#include <cmath>
#include <cstring>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"

namespace aerovo {
namespace {

const Eigen::Matrix2d kFlipY = (Eigen::Matrix2d() << 1.0, 0.0, 0.0, -1.0).finished();

Eigen::Vector2d Apply(const Eigen::Matrix3d& m, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = m * p.homogeneous();
  return q.head<2>() / q.z();
}

// Jacobian of the (possibly projective) map m at p: the local linear part. For an affine map it
// is the top-left 2x2 block; for a homography it differs across the image, and the image centre
// is where the camera's own motion is measured.
Eigen::Matrix2d JacobianAt(const Eigen::Matrix3d& m, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = m * p.homogeneous();
  const Eigen::Vector2d mapped = q.head<2>() / q.z();
  return (m.topLeftCorner<2, 2>() - mapped * m.block<1, 2>(2, 0)) / q.z();
}

double AngleOf(const Eigen::Matrix2d& l) {
  return std::atan2(l(1, 0) - l(0, 1), l(0, 0) + l(1, 1));
}

// Heading (CCW from local +y) of the image-up direction given the local direction of pixel
// vectors.
double HeadingOf(const Eigen::Matrix2d& local_from_pixel_dir) {
  const Eigen::Vector2d up = local_from_pixel_dir * Eigen::Vector2d(0.0, -1.0);
  return std::atan2(-up.x(), up.y());
}

}  // namespace

const char* ToString(ScaleMode mode) {
  return mode == ScaleMode::kMetric ? "metric" : "affine-chain";
}

ScaleMode ParseScaleMode(const char* text) {
  if (std::strcmp(text, "metric") == 0) return ScaleMode::kMetric;
  if (std::strcmp(text, "affine-chain") == 0) return ScaleMode::kAffineChain;
  throw InvalidArgument(std::string("scale mode must be 'metric' or 'affine-chain', got '") + text +
                        "'");
}

double RotationAngleRad(const Eigen::Matrix3d& transform) {
  return AngleOf(transform.topLeftCorner<2, 2>());
}

double LinearScale(const Eigen::Matrix3d& transform) {
  return std::sqrt(std::abs(transform.topLeftCorner<2, 2>().determinant()));
}

PoseChain::PoseChain(ScaleMode mode, int width_px, int height_px) : mode_(mode) {
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument("PoseChain: frame size must be positive, got " +
                          std::to_string(width_px) + "x" + std::to_string(height_px));
  }
  centre_px_ = Eigen::Vector2d(0.5 * (width_px - 1), 0.5 * (height_px - 1));
}

void PoseChain::Start(double gsd_m_per_px) {
  if (!(gsd_m_per_px > 0.0) || !std::isfinite(gsd_m_per_px)) {
    throw InvalidArgument("PoseChain::Start: ground sampling distance must be > 0 m/px, got " +
                          std::to_string(gsd_m_per_px));
  }
  started_ = true;
  gsd0_ = gsd_curr_ = gsd_m_per_px;
  local_from_pixel_dir_ = kFlipY;
  position_m_.setZero();
  if (mode_ == ScaleMode::kMetric) {
    world_from_frame_.setIdentity();
    world_from_frame_.topLeftCorner<2, 2>() = gsd_m_per_px * kFlipY;
    world_from_frame_.topRightCorner<2, 1>() = -gsd_m_per_px * kFlipY * centre_px_;
  } else {
    world_from_frame_.setIdentity();
  }
}

void PoseChain::Step(const Eigen::Matrix3d& curr_from_prev, double gsd_prev_m_per_px,
                     double gsd_curr_m_per_px, const double* heading_override_rad) {
  if (!started_) throw InvalidArgument("PoseChain::Step called before Start");
  if (!(gsd_prev_m_per_px > 0.0) || !(gsd_curr_m_per_px > 0.0)) {
    throw InvalidArgument("PoseChain::Step: ground sampling distances must be > 0 m/px");
  }
  const double det = curr_from_prev.determinant();
  if (!std::isfinite(det) || std::abs(det) < 1e-12 || !curr_from_prev.allFinite()) {
    throw InvalidArgument("PoseChain::Step: curr_from_prev is singular or not finite");
  }
  const Eigen::Matrix3d prev_from_curr = curr_from_prev.inverse();
  if (mode_ == ScaleMode::kMetric) {
    // Where the current camera centre lies in the previous frame's pixels: the displacement
    // is measured in frame n-1, so frame n-1's ground sampling distance converts it.
    const Eigen::Vector2d centre_in_prev = Apply(prev_from_curr, centre_px_);
    position_m_ += gsd_prev_m_per_px * (local_from_pixel_dir_ * (centre_in_prev - centre_px_));
    if (heading_override_rad != nullptr) {
      local_from_pixel_dir_ = RotationMatrix2d(*heading_override_rad) * kFlipY;
    } else {
      // Only the rotation of the step is chained; its scale (tilt, height change, parallax)
      // is discarded and replaced by the known ground sampling distance.
      local_from_pixel_dir_ =
          local_from_pixel_dir_ * RotationMatrix2d(AngleOf(JacobianAt(prev_from_curr, centre_px_)));
    }
    gsd_curr_ = gsd_curr_m_per_px;
    world_from_frame_.setIdentity();
    world_from_frame_.topLeftCorner<2, 2>() = gsd_curr_ * local_from_pixel_dir_;
    world_from_frame_.topRightCorner<2, 1>() =
        position_m_ - gsd_curr_ * local_from_pixel_dir_ * centre_px_;
  } else {
    world_from_frame_ = world_from_frame_ * prev_from_curr;
    world_from_frame_ /= world_from_frame_(2, 2);
    position_m_ = gsd0_ * (kFlipY * (Apply(world_from_frame_, centre_px_) - centre_px_));
    local_from_pixel_dir_ = kFlipY * JacobianAt(world_from_frame_, centre_px_);
    gsd_curr_ = gsd_curr_m_per_px;
  }
}

Eigen::Vector2d PoseChain::position_m() const { return position_m_; }

double PoseChain::heading_rad() const {
  if (mode_ == ScaleMode::kMetric) return HeadingOf(local_from_pixel_dir_);
  return HeadingOf(kFlipY * JacobianAt(world_from_frame_, centre_px_));
}

double PoseChain::chained_scale() const {
  if (mode_ == ScaleMode::kMetric) return 1.0;
  return std::sqrt(std::abs(JacobianAt(world_from_frame_, centre_px_).determinant()));
}

}  // namespace aerovo
