#include "aerovo/sim/camera.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"

namespace aerovo::sim {

namespace {}

void Validate(const CameraModel& c) {
  if (c.width_px < 16 || c.height_px < 16 || c.width_px > 16384 || c.height_px > 16384) {
    throw InvalidArgument(
        fmt::format("CameraModel: image size {}x{} px must be within 16..16384 per side",
                    c.width_px, c.height_px));
  }
  if (c.focal_px != 0.0 && !(c.focal_px > 1.0 && std::isfinite(c.focal_px))) {
    throw InvalidArgument(
        fmt::format("CameraModel: focal_px = {} must be > 1 (or 0 to use hfov_deg)", c.focal_px));
  }
  if (c.focal_px == 0.0 && !(c.hfov_deg > 1.0 && c.hfov_deg < 170.0)) {
    throw InvalidArgument(
        fmt::format("CameraModel: hfov_deg = {} must be in (1, 170)", c.hfov_deg));
  }
  try {
    aerovo::Validate(Intrinsics(c));
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(std::string("CameraModel: ") + e.what());
  }
}

bool HasDistortion(const CameraModel& c) {
  for (double d : c.distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

namespace {

// Normalised pinhole coordinates (x/z, y/z) to where the lens puts them (normalised), OpenCV's
// models (camera/pinhole.h LensModel).
Eigen::Vector2d Distort(const CameraModel& c, const Eigen::Vector2d& n) {
  std::vector<double> d = c.distortion;
  const double x = n.x(), y = n.y(), r2 = x * x + y * y;
  if (c.lens == LensModel::kFisheye) {
    d.resize(4, 0.0);
    const double r = std::sqrt(r2);
    if (r < 1e-12) return n;
    const double t = std::atan(r), t2 = t * t;
    const double td = t * (1 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))));
    return n * (td / r);
  }
  d.resize(8, 0.0);
  const double radial = (1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]))) /
                        (1 + r2 * (d[5] + r2 * (d[6] + r2 * d[7])));
  return {x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x),
          y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y};
}

// The inverse of Distort by Gauss-Newton with a numeric Jacobian (converges in a few steps for
// the monotonic part of any real lens).
Eigen::Vector2d Undistort(const CameraModel& c, const Eigen::Vector2d& nd) {
  Eigen::Vector2d n = nd;
  for (int it = 0; it < 30; ++it) {
    const Eigen::Vector2d e = Distort(c, n) - nd;
    if (e.norm() < 1e-13) break;
    constexpr double h = 1e-7;
    Eigen::Matrix2d j;
    j.col(0) = (Distort(c, n + Eigen::Vector2d(h, 0)) - Distort(c, n)) / h;
    j.col(1) = (Distort(c, n + Eigen::Vector2d(0, h)) - Distort(c, n)) / h;
    n -= j.inverse() * e;
  }
  return n;
}

}  // namespace

double FocalPx(const CameraModel& c) {
  if (c.focal_px > 0.0) return c.focal_px;
  return FocalPxFromHorizontalFov(c.hfov_deg, c.width_px);
}

double HorizontalFovDeg(const CameraModel& c) {
  return aerovo::HorizontalFovDeg(FocalPx(c), c.width_px);
}

Eigen::Vector2d UndistortNormalised(const CameraModel& camera, const Eigen::Vector2d& distorted) {
  return HasDistortion(camera) ? Undistort(camera, distorted) : distorted;
}

CameraIntrinsics Intrinsics(const CameraModel& c) {
  CameraIntrinsics k = IntrinsicsFromFocalPx(FocalPx(c), c.width_px, c.height_px);
  k.model = c.lens;
  k.distortion = c.distortion;
  return k;
}

Eigen::Matrix3d IntrinsicMatrix(const CameraModel& c) { return Intrinsics(c).K(); }

Eigen::Matrix3d MapFromCameraRotation(const CameraPose& pose) {
  const double psi = pose.yaw_deg * kDegToRad;
  // Nadir camera whose image top points along compass heading psi: camera y (image down) is
  // the backward direction, camera z looks down, x = y cross z.
  const Eigen::Vector3d forward(std::sin(psi), std::cos(psi), 0.0);
  Eigen::Matrix3d nadir;
  nadir.col(1) = -forward;
  nadir.col(2) = Eigen::Vector3d(0, 0, -1);
  nadir.col(0) = nadir.col(1).cross(nadir.col(2));
  const Eigen::Matrix3d rx =
      Eigen::AngleAxisd(pose.pitch_deg * kDegToRad, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d ry =
      Eigen::AngleAxisd(pose.roll_deg * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return nadir * rx * ry;
}

Eigen::Matrix3d ImageFromGroundHomography(const CameraModel& camera, const CameraPose& pose) {
  // x_cam = R^T (X - C) with X = (e, n, 0): columns of R^T for e and n, and -R^T C.
  const Eigen::Matrix3d rt = MapFromCameraRotation(pose).transpose();
  Eigen::Matrix3d m;
  m.col(0) = rt.col(0);
  m.col(1) = rt.col(1);
  m.col(2) = -rt * pose.position_m;
  return IntrinsicMatrix(camera) * m;
}

Eigen::Vector2d ProjectGroundPoint(const CameraModel& camera, const CameraPose& pose,
                                   const Eigen::Vector2d& ground_en_m) {
  const Eigen::Vector3d x_cam =
      MapFromCameraRotation(pose).transpose() *
      (Eigen::Vector3d(ground_en_m.x(), ground_en_m.y(), 0.0) - pose.position_m);
  if (x_cam.z() <= 0.0) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  const Eigen::Matrix3d k = IntrinsicMatrix(camera);
  if (HasDistortion(camera)) {
    const Eigen::Vector2d d = Distort(camera, x_cam.head<2>() / x_cam.z());
    return {k(0, 0) * d.x() + k(0, 2), k(1, 1) * d.y() + k(1, 2)};
  }
  const Eigen::Vector3d p = k * x_cam;
  return p.head<2>() / p.z();
}

Eigen::Vector2d BackProjectPixel(const CameraModel& camera, const CameraPose& pose,
                                 const Eigen::Vector2d& pixel) {
  Eigen::Vector3d ray_cam =
      IntrinsicMatrix(camera).inverse() * Eigen::Vector3d(pixel.x(), pixel.y(), 1.0);
  if (HasDistortion(camera)) {
    ray_cam.head<2>() = Undistort(camera, ray_cam.head<2>());
  }
  const Eigen::Vector3d ray = MapFromCameraRotation(pose) * ray_cam;
  if (ray.z() >= 0.0 || pose.position_m.z() <= 0.0) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  const double t = -pose.position_m.z() / ray.z();
  return (pose.position_m + t * ray).head<2>();
}

double NadirGsdMetresPerPx(const CameraModel& camera, double height_m) {
  return height_m / FocalPx(camera);
}

}  // namespace aerovo::sim
