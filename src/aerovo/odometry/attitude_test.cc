#include "aerovo/odometry/attitude.h"

#include "aerovo/core/angles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Geometry>

namespace aerovo::attitude_test {
namespace {

constexpr double kF = 800.0, kCx = 639.5, kCy = 359.5, kH = 100.0;

// A camera at the origin of the level frame (x forward, y right, z down) over the ground plane
// z = kH, its FRD axes rotated by level_from_frd: the pixel of a ground point, built from the
// frames' definitions (not from attitude.cc's matrices).
Eigen::Vector2d Project(const Eigen::Matrix3d& level_from_frd, const Eigen::Vector3d& ground) {
  const Eigen::Vector3d frd = level_from_frd.transpose() * ground;
  const double x_cam = frd.y(), y_cam = -frd.x(), z_cam = frd.z();  // right, down, optical
  return {kCx + kF * x_cam / z_cam, kCy + kF * y_cam / z_cam};
}

Eigen::Matrix3d Tilted(double roll_deg, double pitch_deg) {
  return (Eigen::AngleAxisd(pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

TEST(Attitude, MappedPointsEqualTheNadirCamerasOverAPlane) {
  for (const auto& [roll, pitch] : std::vector<std::pair<double, double>>{
           {0.0, 15.0}, {15.0, 0.0}, {-12.0, 9.0}, {15.0, -15.0}, {3.0, 0.5}}) {
    const CameraAttitude a{roll, pitch};
    const Eigen::Matrix3d h = NadirFromCameraHomography(a, kF, kCx, kCy);
    const Eigen::Matrix3d r = Tilted(roll, pitch);
    int seen = 0;
    for (double fwd = -60.0; fwd <= 60.0; fwd += 7.5) {
      for (double right = -80.0; right <= 80.0; right += 9.5) {
        const Eigen::Vector3d g(fwd, right, kH);
        const Eigen::Vector2d tilted = Project(r, g);
        const Eigen::Vector2d nadir = Project(Eigen::Matrix3d::Identity(), g);
        const Eigen::Vector3d q = h * tilted.homogeneous();
        EXPECT_NEAR(q.x() / q.z(), nadir.x(), 1e-6) << roll << " " << pitch;
        EXPECT_NEAR(q.y() / q.z(), nadir.y(), 1e-6) << roll << " " << pitch;
        ++seen;
      }
    }
    EXPECT_EQ(seen, 17 * 17);
  }
}

TEST(Attitude, ImageCentreOffsetIsHeightTimesTanTilt) {
  // Pitch: the centre's ground point lies forward by h tan(pitch); roll > 0 tilts the axis to
  // the image left (the aircraft's right wing down).
  const Eigen::Vector2d p = ImageCentreGroundOffsetM({0.0, 15.0}, kH);
  EXPECT_NEAR(p.x(), kH * std::tan(15.0 * kDegToRad), 1e-6);
  EXPECT_NEAR(p.y(), 0.0, 1e-6);
  const Eigen::Vector2d r = ImageCentreGroundOffsetM({10.0, 0.0}, kH);
  EXPECT_NEAR(r.x(), 0.0, 1e-6);
  EXPECT_NEAR(r.y(), -kH * std::tan(10.0 * kDegToRad), 1e-6);
  // Both: the offset's length is h tan(tilt), the tilt being the optical axis' angle from the
  // vertical.
  const CameraAttitude both{12.0, -9.0};
  const double tilt = TiltFromNadirDeg(both);
  EXPECT_NEAR(ImageCentreGroundOffsetM(both, kH).norm(), kH * std::tan(tilt * kDegToRad), 1e-6);
  // The ground point under the image centre is where the homography puts the image centre in
  // the nadir camera: (offset right, -offset forward) * f / h from the principal point.
  const Eigen::Vector3d c =
      NadirFromCameraHomography(both, kF, kCx, kCy) * Eigen::Vector3d(kCx, kCy, 1.0);
  const Eigen::Vector2d off = ImageCentreGroundOffsetM(both, kH);
  EXPECT_NEAR((c.x() / c.z() - kCx) * kH / kF, off.y(), 1e-6);
  EXPECT_NEAR(-(c.y() / c.z() - kCy) * kH / kF, off.x(), 1e-6);
}

TEST(Attitude, RotationRoundTripAndTilt) {
  const CameraAttitude a{-7.5, 13.0};
  const CameraAttitude b = AttitudeOfRotation(LevelFromCameraFrd(a));
  EXPECT_NEAR(b.roll_deg, a.roll_deg, 1e-9);
  EXPECT_NEAR(b.pitch_deg, a.pitch_deg, 1e-9);
  // A yaw in front does not change roll and pitch.
  const Eigen::Matrix3d yawed =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix() * LevelFromCameraFrd(a);
  EXPECT_NEAR(AttitudeOfRotation(yawed).pitch_deg, a.pitch_deg, 1e-9);
  EXPECT_NEAR(AttitudeOfRotation(yawed).roll_deg, a.roll_deg, 1e-9);
  EXPECT_NEAR(TiltFromNadirDeg({0.0, 15.0}), 15.0, 1e-9);
  EXPECT_NEAR(TiltFromNadirDeg({0.0, 0.0}), 0.0, 1e-9);
  // Nadir: the identity homography.
  EXPECT_TRUE(NadirFromCameraHomography({}, kF, kCx, kCy).isApprox(Eigen::Matrix3d::Identity()));
}

}  // namespace
}  // namespace aerovo::attitude_test
