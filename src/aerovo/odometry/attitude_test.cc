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

// A 4:3 frame, 1000 px focal length: corners at atan(sqrt(2000^2 + 1500^2) / 2 / 1000) =
// 51.34 deg from the axis (frame 2000 x 1500 px, principal point at its centre).
TEST(Attitude, LowestCornerDepressionAndTheHorizon) {
  const double f = 1000.0, cx = 999.5, cy = 749.5;
  const double half_fov = std::atan(std::hypot(999.5, 749.5) / f) / kDegToRad;
  EXPECT_NEAR(LowestCornerDepressionDeg({}, f, cx, cy, 2000, 1500), 90.0 - half_fov, 1e-9);
  // Pitched 30 deg forward: the top corners are 30 deg nearer the horizon than at nadir, less
  // than the full 30 (they are off the pitch plane).
  const double pitched = LowestCornerDepressionDeg({0.0, 30.0}, f, cx, cy, 2000, 1500);
  EXPECT_LT(pitched, 90.0 - half_fov);
  EXPECT_GT(pitched, 90.0 - half_fov - 30.0);
  // A camera at the horizon (DJI gimbal pitch 0) has corners above it; rolled 60 deg too.
  EXPECT_LT(LowestCornerDepressionDeg({0.0, 90.0}, f, cx, cy, 2000, 1500), 0.0);
  EXPECT_LT(LowestCornerDepressionDeg({60.0, 0.0}, f, cx, cy, 2000, 1500), 0.0);
  // Only the corners decide: a pitch just below the top edge's limit keeps them all below it.
  EXPECT_GT(LowestCornerDepressionDeg({0.0, 20.0}, f, cx, cy, 2000, 1500), 0.0);
}

}  // namespace
}  // namespace aerovo::attitude_test
