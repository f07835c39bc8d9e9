#include "aerovo/odometry/attitude.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include "aerovo/core/angles.h"

namespace aerovo {
namespace {

// frd_from_camera: camera (x right, y down, z optical) to camera FRD (x image up, y image right,
// z optical) coordinates.
const Eigen::Matrix3d kFrdFromCamera =
    (Eigen::Matrix3d() << 0, -1, 0, 1, 0, 0, 0, 0, 1).finished();

}  // namespace

Eigen::Matrix3d LevelFromCameraFrd(const CameraAttitude& a) {
  return (Eigen::AngleAxisd(a.pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

CameraAttitude AttitudeOfRotation(const Eigen::Matrix3d& r) {
  // R = Rz(yaw) Ry(pitch) Rx(roll): R(2,0) = -sin(pitch), R(2,1) = cos(pitch) sin(roll),
  // R(2,2) = cos(pitch) cos(roll).
  CameraAttitude a;
  a.pitch_deg = -std::asin(std::clamp(r(2, 0), -1.0, 1.0)) / kDegToRad;
  a.roll_deg = std::atan2(r(2, 1), r(2, 2)) / kDegToRad;
  return a;
}

double TiltFromNadirDeg(const CameraAttitude& a) {
  const Eigen::Vector3d axis = LevelFromCameraFrd(a).col(2);
  return std::acos(std::clamp(axis.z(), -1.0, 1.0)) / kDegToRad;
}

double LowestCornerDepressionDeg(const CameraAttitude& a, double focal_px, double cx_px,
                                 double cy_px, int width_px, int height_px) {
  const Eigen::Matrix3d level_from_frd = LevelFromCameraFrd(a);
  double lowest = 90.0;
  for (const double u : {0.0, static_cast<double>(width_px) - 1.0}) {
    for (const double v : {0.0, static_cast<double>(height_px) - 1.0}) {
      // Camera (x right, y down, z axis) to camera FRD (x up in the image, y right, z axis).
      const Eigen::Vector3d frd(-(v - cy_px), u - cx_px, focal_px);
      const Eigen::Vector3d level = level_from_frd * frd.normalized();
      lowest = std::min(lowest, std::asin(std::clamp(level.z(), -1.0, 1.0)) / kDegToRad);
    }
  }
  return lowest;
}

Eigen::Matrix3d NadirFromCameraHomography(const CameraAttitude& a, double f, double cx,
                                          double cy) {
  Eigen::Matrix3d k;
  k << f, 0, cx, 0, f, cy, 0, 0, 1;
  Eigen::Matrix3d k_inv;
  k_inv << 1.0 / f, 0, -cx / f, 0, 1.0 / f, -cy / f, 0, 0, 1;
  // The virtual camera's FRD frame is the level frame.
  const Eigen::Matrix3d nadir_from_camera =
      kFrdFromCamera.transpose() * LevelFromCameraFrd(a) * kFrdFromCamera;
  return k * nadir_from_camera * k_inv;
}

Eigen::Vector2d ImageCentreGroundOffsetM(const CameraAttitude& a, double height_m) {
  const Eigen::Vector3d ray = LevelFromCameraFrd(a).col(2);  // the optical axis, level frame
  return height_m * ray.head<2>() / ray.z();
}

}  // namespace aerovo
