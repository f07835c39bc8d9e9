#include "aerovo/sim/camera.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "aerovo/core/error.h"

namespace aerovo::sim {

namespace {
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
}

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
}

double FocalPx(const CameraModel& c) {
  if (c.focal_px > 0.0) return c.focal_px;
  return FocalPxFromHorizontalFov(c.hfov_deg, c.width_px);
}

double HorizontalFovDeg(const CameraModel& c) {
  return aerovo::HorizontalFovDeg(FocalPx(c), c.width_px);
}

CameraIntrinsics Intrinsics(const CameraModel& c) {
  return IntrinsicsFromFocalPx(FocalPx(c), c.width_px, c.height_px);
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
  const Eigen::Vector3d p = IntrinsicMatrix(camera) * x_cam;
  return p.head<2>() / p.z();
}

Eigen::Vector2d BackProjectPixel(const CameraModel& camera, const CameraPose& pose,
                                 const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d ray_cam =
      IntrinsicMatrix(camera).inverse() * Eigen::Vector3d(pixel.x(), pixel.y(), 1.0);
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
