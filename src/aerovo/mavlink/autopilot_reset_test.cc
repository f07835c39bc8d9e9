// What the autopilots do with a jump of aerovo's pose sent as a reset (reset_counter + 1), their
// arithmetic written again here from their sources (docs/autopilot.md "A pose that jumps"):
//   ArduPilot, libraries/AP_VisualOdom/AP_VisualOdom_IntelT265.cpp handle_pose_estimate (the
//   backend of VISO_TYPE 2 "IntelT265" and 3 "VOXL"): type 3 re-aligns its position correction
//   so that the new pose maps onto the last position it had (handle_voxl_camera_reset_jump,
//   align_position) and consumes every message; type 2 ignores every message for 1000 ms after a
//   reset_counter change (should_consume_sensor_data), then the first one it consumes carries a
//   new reset time (AP_VisualOdom_Backend.cpp get_reset_timestamp_ms) and EKF3 resets its
//   position to it (AP_NavEKF3_Measurements.cpp writeExtNavData posReset,
//   AP_NavEKF3_PosVelFusion.cpp SelectVelPosFusion -> ResetPositionNE).
//   PX4, src/modules/ekf2/EKF/aid_sources/external_vision/ev_control.cpp (ev_reset: the
//   sample's reset_counter differs from the previous sample's) and ev_pos_control.cpp
//   updateEvPosFusion (without GNSS: resetHorizontalPositionTo the measurement).
// The EKFs' own fusion between resets is not modelled: each takes the position it is given
// (a consistent track), which is exact at a reset. A straight flight at 10 frames/s, 1 m per
// frame forward; at frame 20 a loop closure moves the pose 3 m right and 4 m back (5 m).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "aerovo/mavlink/vision.h"

namespace aerovo::mavlink::autopilot_reset_test {
namespace {

constexpr int kJumpFrame = 20, kFrames = 45;
const Eigen::Vector2d kJumpLocal(3.0, -4.0);  // local x (right), y (forward), m

// Frame k's ODOMETRY: k m forward, plus the jump from kJumpFrame on (flagged there unless
// `flag_jump` is false).
std::vector<Odometry> Flight(bool flag_jump = true) {
  VisionMessageBuilder b;
  std::vector<Odometry> out;
  for (int k = 0; k < kFrames; ++k) {
    VisionPose p;
    p.time_s = 10.0 + 0.1 * k;
    p.time_usec = static_cast<uint64_t>(std::llround(p.time_s * 1e6));
    const Eigen::Vector2d local =
        Eigen::Vector2d(0.0, 1.0 * k) + (k >= kJumpFrame ? kJumpLocal : Eigen::Vector2d::Zero());
    p.local_x_m = local.x();
    p.local_y_m = local.y();
    p.height_m = 50.0;
    p.status = k == 0 ? VisionPose::Status::kFirst : VisionPose::Status::kOk;
    p.n_inliers = 100;
    p.reset = flag_jump && k == kJumpFrame;
    out.push_back(b.Add(p).odometry);
  }
  return out;
}

uint32_t ArrivalMs(const Odometry& o) { return static_cast<uint32_t>(o.time_usec / 1000); }

// ArduPilot's AP_VisualOdom_IntelT265 with the vision frame aligned to the EKF's at the start
// (no yaw trim), and EKF3's handling of its reset time.
struct ArduPilotVisualOdom {
  explicit ArduPilotVisualOdom(bool voxl) : voxl(voxl) {}
  bool voxl;
  Eigen::Vector2d correction = Eigen::Vector2d::Zero();     // _pos_correction (x, y)
  Eigen::Vector2d last_position = Eigen::Vector2d::Zero();  // _voxl_position_last
  uint8_t voxl_counter = 0, ignore_counter = 0, timestamp_counter = 0;
  uint32_t ignore_start_ms = 0, reset_time_ms = 0, ekf_reset_time_ms = 0;
  std::optional<Eigen::Vector2d> ekf;  // EKF3's position
  int ignored = 0, ekf_resets = 0;

  void Handle(const Odometry& o) {
    const uint32_t now = ArrivalMs(o);
    const Eigen::Vector2d sensor(o.x, o.y);
    if (voxl && o.reset_counter != voxl_counter) {  // handle_voxl_camera_reset_jump
      correction += last_position - (sensor + correction);
      voxl_counter = o.reset_counter;
    }
    const Eigen::Vector2d pos = sensor + correction;  // rotate_and_correct_position
    if (voxl) last_position = pos;                    // record_voxl_position_and_reset_count
    if (!Consume(o.reset_counter, now)) {
      ++ignored;
      return;
    }
    if (o.reset_counter != timestamp_counter) {  // get_reset_timestamp_ms
      timestamp_counter = o.reset_counter;
      reset_time_ms = now;
    }
    if (reset_time_ms != ekf_reset_time_ms) {  // writeExtNavData: posReset -> ResetPositionNE
      ekf_reset_time_ms = reset_time_ms;
      ++ekf_resets;
    }
    ekf = pos;
  }
  bool Consume(uint8_t counter, uint32_t now) {  // should_consume_sensor_data
    if (voxl) return true;
    if (counter != ignore_counter) {
      ignore_counter = counter;
      ignore_start_ms = now;
    }
    if (now - ignore_start_ms > 1000) ignore_start_ms = 0;
    return ignore_start_ms == 0;
  }
};

TEST(AutopilotReset, TheCounterChangesOnceAtTheJump) {
  const std::vector<Odometry> m = Flight();
  for (int k = 0; k < kFrames; ++k) EXPECT_EQ(m[k].reset_counter, k >= kJumpFrame ? 1 : 0) << k;
  // No velocity across the jump: PX4 would reset its velocity to 50 m/s (5 m in 0.1 s).
  EXPECT_TRUE(std::isnan(m[kJumpFrame].vx));
  EXPECT_NEAR(m[kJumpFrame + 1].vx, 10.0, 1e-4);
}

// VISO_TYPE 2: every message for 1 s after the jump is ignored, then EKF3's position is reset
// to aerovo's pose: from there the autopilot's position is aerovo's new pose, no offset kept.
TEST(AutopilotReset, ArduPilotType2IgnoresASecondThenTakesTheNewPose) {
  ArduPilotVisualOdom ap(false);
  const std::vector<Odometry> m = Flight();
  for (int k = 0; k < kFrames; ++k) {
    ap.Handle(m[k]);
    SCOPED_TRACE("frame " + std::to_string(k));
    // Ignored: the jump frame and the next 1000 ms (frames 20 to 30 at 100 ms apart).
    EXPECT_EQ(ap.ignored, std::clamp(k - kJumpFrame + 1, 0, 11));
    ASSERT_TRUE(ap.ekf.has_value());
    if (k < kJumpFrame || k > kJumpFrame + 10) {
      EXPECT_EQ(ap.ekf_resets, k < kJumpFrame ? 0 : 1);
      EXPECT_EQ(*ap.ekf, Eigen::Vector2d(m[k].x, m[k].y));  // aerovo's pose, FRD
    } else {
      EXPECT_EQ(*ap.ekf, Eigen::Vector2d(m[kJumpFrame - 1].x, m[kJumpFrame - 1].y));  // held
    }
  }
  EXPECT_EQ(ap.correction, Eigen::Vector2d::Zero());
  // FRD: x = local y (forward), y = local x (right): the jump arrived whole.
  EXPECT_NEAR(ap.ekf->x(), kFrames - 1 + kJumpLocal.y(), 1e-5);
  EXPECT_NEAR(ap.ekf->y(), kJumpLocal.x(), 1e-5);
}

// VISO_TYPE 3 (what docs/autopilot.md recommends for ODOMETRY): nothing is ignored, but the
// reset re-aligns the position correction so that the new pose lands on the last position: the
// autopilot keeps the track from before the jump, offset by minus the jump and the jump frame's
// own 1 m step, for the rest of the flight.
TEST(AutopilotReset, ArduPilotType3KeepsItsTrackAndAnOffset) {
  ArduPilotVisualOdom ap(true);
  const std::vector<Odometry> m = Flight();
  for (int k = 0; k < kFrames; ++k) ap.Handle(m[k]);
  EXPECT_EQ(ap.ignored, 0);
  EXPECT_EQ(ap.ekf_resets, 1);
  const Eigen::Vector2d jump_frd(kJumpLocal.y(), kJumpLocal.x());
  const Eigen::Vector2d step_frd(1.0, 0.0);
  EXPECT_NEAR((ap.correction - (-jump_frd - step_frd)).norm(), 0.0, 1e-5);
  EXPECT_NEAR((*ap.ekf - Eigen::Vector2d(kFrames - 2, 0.0)).norm(), 0.0, 1e-5);
  // Without the reset flag the autopilot is given the jump as a measurement: its EKF gate
  // decides (5 m against PoseJumpResetThresholdM's 0.5 m here: rejected, then a timeout reset).
  EXPECT_GT(kJumpLocal.norm(), PoseJumpResetThresholdM(0.0));
}

// PX4 EKF2 without GNSS (EKF2_EV_CTRL horizontal position, EKF2_EV_QMIN 0, EKF2_EVP_NOISE
// 0.1 m, EKF2_EVP_GATE 5): the IMU's prediction is taken as the true motion (1 m forward per
// frame), the EKF's own position variance as the floor's. A sample with a new reset_counter
// resets the horizontal position to it (ev_control.cpp ev_reset, ev_pos_control.cpp
// updateEvPosFusion); a sample outside the gate (|innovation| > 5 sqrt(P + R) on an axis) is
// rejected, and after 1 s without fusing (EKF2's no_aid_timeout_max) the position is reset to it.
struct Px4EvPosition {
  std::optional<uint8_t> previous_counter;
  Eigen::Vector2d ekf = Eigen::Vector2d::Zero();
  double last_fuse_s = 0.0;
  int resets = 0, rejected = 0;
  void Handle(const Odometry& o, bool first) {
    const double t = o.time_usec * 1e-6;
    const Eigen::Vector2d measurement(o.x, o.y);
    const bool ev_reset = previous_counter && o.reset_counter != *previous_counter;
    previous_counter = o.reset_counter;  // quality sufficient (EKF2_EV_QMIN 0)
    if (first) {
      ekf = measurement;
      last_fuse_s = t;
      return;
    }
    ekf.x() += 1.0;  // the IMU's prediction
    const double r = std::max(double(o.pose_covariance[0]), 0.01), p = 0.01;
    const double gate = 5.0 * std::sqrt(p + r);
    if (ev_reset || t - last_fuse_s > 1.0 + 1e-6) {
      ekf = measurement;
      ++resets;
      last_fuse_s = t;
    } else if (((measurement - ekf).array().abs() <= gate).all()) {
      ekf += p / (p + r) * (measurement - ekf);  // a Kalman update on each axis
      last_fuse_s = t;
    } else {
      ++rejected;
    }
  }
};

TEST(AutopilotReset, Px4TakesAFlaggedJumpAtOnceAndAnUnflaggedOneASecondLater) {
  for (const bool flag : {true, false}) {
    SCOPED_TRACE(flag ? "flagged" : "not flagged");
    const std::vector<Odometry> m = Flight(flag);
    Px4EvPosition px4;
    for (int k = 0; k < kFrames; ++k) {
      px4.Handle(m[k], k == 0);
      if (k == kJumpFrame) {
        // Flagged: the new pose at once. Not: rejected by the gate, the old track kept.
        EXPECT_NEAR((px4.ekf - Eigen::Vector2d(m[k].x, m[k].y)).norm(), flag ? 0.0 : 5.0, 1e-4);
      }
    }
    EXPECT_EQ(px4.resets, 1);
    // Not flagged: 1 s of rejected samples (frames 20 to 29) before the timeout's reset.
    EXPECT_EQ(px4.rejected, flag ? 0 : 10);
    EXPECT_NEAR(px4.ekf.x(), kFrames - 1 + kJumpLocal.y(), 1e-4);  // aerovo's pose at the end
    EXPECT_NEAR(px4.ekf.y(), kJumpLocal.x(), 1e-4);
  }
}

}  // namespace
}  // namespace aerovo::mavlink::autopilot_reset_test
