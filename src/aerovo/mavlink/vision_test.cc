// The vision messages of a few poses: the axis conversion (docs/autopilot.md), velocities in the
// body frame, covariance growth, reset counter and quality.
#include "aerovo/mavlink/vision.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Core>

namespace aerovo::mavlink::vision_test {
namespace {

VisionPose Pose(double t, double x, double y, double heading, VisionPose::Status s, int inliers) {
  VisionPose p;
  p.time_s = t;
  p.time_usec = static_cast<uint64_t>(t * 1e6);
  p.local_x_m = x;
  p.local_y_m = y;
  p.height_m = 80.0;
  p.heading_rad = heading;
  p.status = s;
  p.n_inliers = inliers;
  p.gsd_m_per_px = 0.1;
  p.sigma_px = 0.75;
  p.half_width_px = 320;
  return p;
}

TEST(MavlinkVision, LocalFrameToFrdAndBodyVelocity) {
  VisionMessageBuilder b;
  const VisionMessages m0 = b.Add(Pose(1.0, 0, 0, 0, VisionPose::Status::kFirst, 0));
  EXPECT_EQ(m0.odometry.frame_id, kMavFrameLocalFrd);
  EXPECT_EQ(m0.odometry.child_frame_id, kMavFrameBodyFrd);
  EXPECT_EQ(m0.odometry.quality, 100);
  // No velocity before a second frame; its covariance unknown (NaN first element).
  EXPECT_TRUE(std::isnan(m0.odometry.vx));
  EXPECT_TRUE(std::isnan(m0.odometry.velocity_covariance[0]));
  for (float v : m0.odometry.pose_covariance) EXPECT_EQ(v, 0.f);  // the origin, exact
  // 2 m to the right of the first image and 10 m up it (forward), turned 90 deg
  // counter-clockwise (to the left): FRD x = 10 (forward), y = 2 (right), yaw = -90 deg.
  VisionPose p1 = Pose(2.0, 2.0, 10.0, M_PI / 2, VisionPose::Status::kOk, 100);
  p1.height_m = 78.0;  // 2 m lower than the first frame: z = +2 (down)
  const VisionMessages m1 = b.Add(p1);
  const Odometry& o = m1.odometry;
  EXPECT_FLOAT_EQ(o.x, 10.f);
  EXPECT_FLOAT_EQ(o.y, 2.f);
  EXPECT_FLOAT_EQ(o.z, 2.f);
  // q = rotation about z by -90 deg: (cos(-45 deg), 0, 0, sin(-45 deg)).
  EXPECT_NEAR(o.q[0], std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(o.q[3], -std::sqrt(0.5), 1e-6);
  // Moved (10, 2, 2) in local FRD over 1 s; the body now faces local -y: body forward =
  // -local y_frd... body x = R^T v: yaw -90 deg -> body x = -v_y, body y = v_x.
  EXPECT_NEAR(o.vx, -2.0, 1e-5);
  EXPECT_NEAR(o.vy, 10.0, 1e-5);
  EXPECT_NEAR(o.vz, 2.0, 1e-5);
  EXPECT_NEAR(o.yawspeed, -M_PI / 2, 1e-5);
  // Step sigma: 0.75 px / sqrt(100) * 0.1 m/px = 7.5 mm; variance 5.625e-5 m^2.
  EXPECT_NEAR(o.pose_covariance[UpperTriangleIndex(0, 0)], 5.625e-5, 1e-9);
  EXPECT_NEAR(o.pose_covariance[UpperTriangleIndex(1, 1)], 5.625e-5, 1e-9);
  // z (not measured) carries the x/y variance, roll and pitch the yaw's: all finite.
  EXPECT_NEAR(o.pose_covariance[UpperTriangleIndex(2, 2)], 5.625e-5, 1e-9);
  // Yaw step sigma: 0.75 px / sqrt(100) / 320 px rad; variance 5.493e-8 rad^2.
  const double var_yaw = std::pow(0.075 / 320.0, 2);
  for (int i = 3; i < 6; ++i)
    EXPECT_NEAR(o.pose_covariance[UpperTriangleIndex(i, i)], var_yaw, 1e-12) << i;
  for (float v : o.pose_covariance) EXPECT_TRUE(std::isfinite(v));
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(o.velocity_covariance[UpperTriangleIndex(i, i)], 2 * 5.625e-5, 1e-9) << i;
  EXPECT_TRUE(std::isnan(o.rollspeed));  // not sent
  EXPECT_TRUE(std::isnan(o.velocity_covariance[UpperTriangleIndex(3, 3)]));
  EXPECT_EQ(m1.position_estimate.covariance, o.pose_covariance);
  EXPECT_EQ(o.quality, 100);
  EXPECT_EQ(o.reset_counter, 0);
  EXPECT_EQ(o.estimator_type, kMavEstimatorTypeVision);
  // The same in VISION_POSITION_ESTIMATE and the delta in the previous body frame (yaw 0).
  EXPECT_FLOAT_EQ(m1.position_estimate.x, 10.f);
  EXPECT_NEAR(m1.position_estimate.yaw, -M_PI / 2, 1e-6);
  EXPECT_FLOAT_EQ(m1.position_delta.position_delta[0], 10.f);
  EXPECT_FLOAT_EQ(m1.position_delta.position_delta[1], 2.f);
  EXPECT_EQ(m1.position_delta.time_delta_usec, 1000000u);
  EXPECT_NEAR(m1.position_delta.angle_delta[2], -M_PI / 2, 1e-6);
  EXPECT_EQ(m1.position_delta.confidence, 100.f);
}

TEST(MavlinkVision, BridgedAndReacquiredFrames) {
  VisionMessageBuilder b;
  b.Add(Pose(0.0, 0, 0, 0, VisionPose::Status::kFirst, 0));
  b.Add(Pose(0.5, 0, 5, 0, VisionPose::Status::kOk, 30));
  const VisionMessages br = b.Add(Pose(1.0, 0, 10, 0, VisionPose::Status::kBridged, 3));
  EXPECT_EQ(br.odometry.quality, -1);
  EXPECT_EQ(br.position_delta.confidence, 0.f);
  // The bridged 5 m step adds its length squared.
  EXPECT_GT(br.odometry.pose_covariance[0], 25.f);
  EXPECT_EQ(br.odometry.reset_counter, 0);
  const VisionMessages re = b.Add(Pose(1.5, 0.5, 14, 0, VisionPose::Status::kReacquired, 40));
  EXPECT_EQ(re.odometry.reset_counter, 1);
  EXPECT_EQ(re.position_estimate.reset_counter, 1);
  EXPECT_EQ(re.odometry.quality, 40);
  const VisionMessages ok = b.Add(Pose(2.0, 0.5, 19, 0, VisionPose::Status::kOk, 5));
  EXPECT_EQ(ok.odometry.reset_counter, 1);  // stays until the next re-anchoring
  EXPECT_EQ(ok.odometry.quality, 5);
  // The caller's quality (aerovo run: PoseQuality) is sent as is, within [-1, 100].
  VisionPose given = Pose(2.5, 0.5, 24, 0, VisionPose::Status::kOk, 5);
  given.quality = 73;
  EXPECT_EQ(b.Add(given).odometry.quality, 73);
  given.quality = 250;
  EXPECT_EQ(b.Add(given).odometry.quality, 100);
  // A measured frame from which the track is made again (aerovo run's lens estimate applied):
  // a reset as well, kept after.
  VisionPose remade = Pose(3.0, 0.6, 29.5, 0, VisionPose::Status::kOk, 50);
  remade.reset = true;
  EXPECT_EQ(b.Add(remade).odometry.reset_counter, 2);
  EXPECT_EQ(b.Add(Pose(3.5, 0.6, 34.5, 0, VisionPose::Status::kOk, 50)).odometry.reset_counter, 2);
}

TEST(MavlinkVision, AttitudeFromTheAutopilotInTheQuaternion) {
  VisionMessageBuilder b;
  VisionPose p = Pose(0.0, 0, 0, 0, VisionPose::Status::kFirst, 0);
  p.roll_rad = 0.2;
  p.pitch_rad = -0.1;
  const Odometry o = b.Add(p).odometry;
  // q of roll 0.2 then pitch -0.1 (yaw 0): w = cos(.1)cos(-.05), x = sin(.1)cos(-.05),
  // y = cos(.1)sin(-.05), z = -sin(.1)sin(-.05).
  EXPECT_NEAR(o.q[0], std::cos(0.1) * std::cos(-0.05), 1e-6);
  EXPECT_NEAR(o.q[1], std::sin(0.1) * std::cos(-0.05), 1e-6);
  EXPECT_NEAR(o.q[2], std::cos(0.1) * std::sin(-0.05), 1e-6);
  EXPECT_NEAR(o.q[3], -std::sin(0.1) * std::sin(-0.05), 1e-6);
}

}  // namespace
}  // namespace aerovo::mavlink::vision_test

namespace aerovo::mavlink::vision_test {
namespace {

// A jump (VisionPose::reset): reset_counter + 1 at that frame only, the accumulated variances
// restarted from it, no velocity or delta across it; the frames after go on as before.
TEST(MavlinkVision, AJumpIsAResetThatRestartsTheVarianceWithoutAVelocity) {
  VisionMessageBuilder b;
  b.Add(Pose(0.0, 0, 0, 0, VisionPose::Status::kFirst, 0));
  std::vector<int> counters;
  double before = 0.0;
  for (int k = 1; k <= 4; ++k) {
    const VisionMessages m = b.Add(Pose(0.5 * k, 0, 5.0 * k, 0, VisionPose::Status::kOk, 100));
    counters.push_back(m.odometry.reset_counter);
    before = m.odometry.pose_covariance[0];
  }
  // Step variance (0.75 px / 10 x 0.1 m/px)^2 = 5.625e-5 m^2 per frame: 4 frames.
  EXPECT_NEAR(before, 4 * 5.625e-5, 1e-9);
  VisionPose jump = Pose(2.5, 3.0, 29.0, 0, VisionPose::Status::kOk, 100);  // 4 m off the line
  jump.reset = true;
  const VisionMessages j = b.Add(jump);
  EXPECT_EQ(j.odometry.reset_counter, 1);
  EXPECT_EQ(j.position_estimate.reset_counter, 1);
  EXPECT_FLOAT_EQ(j.odometry.x, 29.f);  // the new pose is sent as it is
  EXPECT_FLOAT_EQ(j.odometry.y, 3.f);
  EXPECT_EQ(j.odometry.pose_covariance[0], 0.f);  // restarted: the autopilot's new reference
  EXPECT_EQ(j.odometry.pose_covariance[UpperTriangleIndex(5, 5)], 0.f);
  EXPECT_TRUE(std::isnan(j.odometry.vx));
  EXPECT_TRUE(std::isnan(j.odometry.velocity_covariance[0]));
  for (float v : j.position_delta.position_delta) EXPECT_TRUE(std::isnan(v));
  for (float v : j.odometry.pose_covariance) EXPECT_TRUE(std::isfinite(v));
  for (int k = 6; k <= 8; ++k) {
    const VisionMessages m =
        b.Add(Pose(0.5 * k, 3.0, 29.0 + 5.0 * (k - 5), 0, VisionPose::Status::kOk, 100));
    counters.push_back(m.odometry.reset_counter);
    EXPECT_NEAR(m.odometry.pose_covariance[0], (k - 5) * 5.625e-5, 1e-9) << k;
    EXPECT_NEAR(m.odometry.vx, 10.0, 1e-4) << k;  // 5 m forward in 0.5 s
    EXPECT_FLOAT_EQ(m.position_delta.position_delta[0], 5.f);
  }
  EXPECT_EQ(counters, (std::vector<int>{0, 0, 0, 0, 1, 1, 1}));
}

// The window's covariance in the local frame (x = image right, y = image up, heading CCW) in
// FRD (x_frd = y_local, y_frd = x_local, yaw_frd = -heading): J C J' with J the map from local
// (x, y, heading) to FRD (x, y, yaw), added to the accumulated model.
TEST(MavlinkVision, TheWindowsCovarianceTurnedIntoFrd) {
  VisionMessageBuilder b;
  b.Add(Pose(0.0, 0, 0, 0, VisionPose::Status::kFirst, 0));
  VisionPose p = Pose(0.5, 0, 5, 0, VisionPose::Status::kOk, 100);
  VisionPose::LocalCovariance c;
  c.xx = 0.04;  // 0.2 m across the image
  c.xy = 0.01;
  c.yy = 0.09;  // 0.3 m along it
  c.x_heading = 0.002;
  c.y_heading = -0.003;
  c.heading = 0.0004;  // 0.02 rad
  p.covariance = c;
  const VisionMessages m = b.Add(p);
  const auto& pc = m.odometry.pose_covariance;
  const double step = 5.625e-5, step_yaw = std::pow(0.075 / 320.0, 2);
  Eigen::Matrix3d local;
  local << c.xx, c.xy, c.x_heading, c.xy, c.yy, c.y_heading, c.x_heading, c.y_heading, c.heading;
  Eigen::Matrix3d j;
  j << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  const Eigen::Matrix3d frd = j * local * j.transpose();
  const int index[3] = {0, 1, 5};  // x, y, yaw of the 6x6
  for (int r = 0; r < 3; ++r) {
    for (int q = r; q < 3; ++q) {
      const double model = r == q ? (r == 2 ? step_yaw : step) : 0.0;
      EXPECT_NEAR(pc[UpperTriangleIndex(index[r], index[q])], frd(r, q) + model, 1e-7)
          << r << "," << q;
    }
  }
  EXPECT_NEAR(pc[UpperTriangleIndex(0, 0)], 0.09 + step, 1e-7);  // x_frd: the image's up
  EXPECT_NEAR(pc[UpperTriangleIndex(1, 1)], 0.04 + step, 1e-7);
  EXPECT_NEAR(pc[UpperTriangleIndex(0, 5)], 0.003, 1e-7);
  EXPECT_NEAR(pc[UpperTriangleIndex(2, 2)], 0.09 + step, 1e-7);  // z: the larger axis
  for (int i = 3; i < 6; ++i) EXPECT_NEAR(pc[UpperTriangleIndex(i, i)], 0.0004 + step_yaw, 1e-9);
  EXPECT_EQ(m.position_estimate.covariance, pc);
}

TEST(MavlinkVision, TheJumpThresholdIsTheAutopilotsGate) {
  EXPECT_DOUBLE_EQ(PoseJumpResetThresholdM(0.0), 0.5);  // 5 x EKF2_EVP_NOISE's 0.1 m
  EXPECT_DOUBLE_EQ(PoseJumpResetThresholdM(0.05), 0.5);
  EXPECT_DOUBLE_EQ(PoseJumpResetThresholdM(0.4), 2.0);  // 5 sigma of the pose's own
  EXPECT_DOUBLE_EQ(PoseJumpResetThresholdM(std::nan("")), 0.5);
}

}  // namespace
}  // namespace aerovo::mavlink::vision_test
