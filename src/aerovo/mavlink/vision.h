// The vision messages of one processed frame, from aerovo's pose (docs/autopilot.md has the
// diagram). aerovo's local frame: origin at the first frame's camera centre, x = first image's
// right, y = first image's up, z up (a right-handed, East-North-Up-like frame turned to the
// first frame; heading counter-clockwise from +y). With the camera looking down and the top of
// the image towards the nose, the image's up is the vehicle's forward, so the local frame is
// the vehicle's start pose as (right, forward, up). Sent as MAV_FRAME_LOCAL_FRD (x forward at
// the start, y right, z down; the autopilot aligns it with its own heading):
//   x_frd = y_local, y_frd = x_local, z_frd = -(height - first height), yaw_frd = -heading.
// Velocities are in MAV_FRAME_BODY_FRD (the vehicle's axes now), from consecutive positions.
#pragma once

#include <cstdint>
#include <optional>

#include "aerovo/mavlink/messages.h"

namespace aerovo::mavlink {

/// The message aerovo sends per frame (RunConfig::mavlink_message).
enum class VisionMessageKind { kOdometry, kVisionPositionEstimate, kVisionPositionDelta };
/// "odometry", "vision_position_estimate", "vision_position_delta".
const char* ToString(VisionMessageKind kind);
/// The clock of the messages' timestamps (RunConfig::mavlink_time).
enum class TimestampClock { kBoot, kUnix };
/// "boot" (CLOCK_MONOTONIC: time since the companion computer booted), "unix".
const char* ToString(TimestampClock clock);

/// One processed frame as the vision messages need it.
struct VisionPose {
  uint64_t time_usec = 0;  ///< Capture time to send (boot or Unix clock, us).
  /// The same instant in seconds (any clock; differences are used: velocities, deltas).
  double time_s = 0.0;
  double local_x_m = 0.0, local_y_m = 0.0;  ///< Position in aerovo's local frame.
  double height_m = 0.0;                    ///< Height above ground used for the frame.
  double heading_rad = 0.0;  ///< Counter-clockwise from the local +y axis.
  std::optional<double> roll_rad, pitch_rad;  ///< From the autopilot, when known.
  enum class Status { kFirst, kOk, kReacquired, kBridged };
  Status status = Status::kOk;
  /// The position jumped at this frame: the track made again (`aerovo run`'s lens estimate
  /// applied, pipeline/lens_switch.h) or the live pose moved by more than the autopilots'
  /// innovation gate (PoseJumpResetThresholdM: a loop closure's whole-graph solve, a fused fix).
  /// reset_counter + 1 as for kReacquired; no velocity across the jump (NaN, as at the first
  /// frame: both autopilots drop it).
  bool reset = false;
  /// The pose's own covariance when the caller has one (`aerovo run --backend-online`: the
  /// window's marginal covariance, odometry/flight_graph.h WindowedPose), in aerovo's local frame:
  /// x, y [m^2], heading [rad^2] and their cross terms. Sent added to the accumulated step model.
  struct LocalCovariance {
    double xx = 0.0, xy = 0.0, yy = 0.0;  ///< Position, m^2.
    double x_heading = 0.0, y_heading = 0.0;  ///< m rad.
    double heading = 0.0;  ///< rad^2.
  };
  std::optional<LocalCovariance> covariance;
  int n_inliers = 0;
  /// ODOMETRY quality (0-100, -1 for a bridged frame) when the caller has one: `aerovo run`
  /// gives pipeline/pose_quality.h PoseQuality, the number its pose stream carries too. Unset:
  /// -1 bridged, 100 first frame, else the inlier count capped at 100.
  std::optional<int> quality;
  double gsd_m_per_px = 1.0;     ///< Ground sampling distance of the frame.
  double sigma_px = 0.75;        ///< 1-sigma residual of one inlier, px (half the threshold).
  double half_width_px = 320.0;  ///< Half the frame's width: the lever arm of a rotation.
};

/// The messages of one frame.
struct VisionMessages {
  Odometry odometry;
  VisionPositionEstimate position_estimate;
  VisionPositionDelta position_delta;
};

/// Turns the frames' poses into messages, keeping what spans frames: the previous pose
/// (velocities, deltas), the accumulated variances and the reset counter.
///
/// Covariance model (the odometry does not expose its residuals, so from the inlier count):
/// a measured step moves the image by a fit on n inliers of residual sigma_px each, so its
/// translation has a per-axis standard deviation of sigma_px / sqrt(n) px, times the ground
/// sampling distance in metres, and its rotation sigma_px / sqrt(n) / half_width_px rad. A
/// bridged step (predicted, not measured) adds its own length squared. Position and yaw
/// variances add up from the first frame (odometry drifts); velocity variance is twice the
/// step's over dt squared (vx, vy, vz; yawspeed likewise). z, roll and pitch are not measured
/// by the vision (z echoes the height aerovo was given, roll and pitch the autopilot's): z
/// carries the x/y variance and roll and pitch the yaw variance, so that every variance
/// ArduPilot and PX4 read is finite and their combined errors are the measured axes'
/// (docs/autopilot.md "Quality, covariance, reset counter"); the autopilot should not fuse them.
/// Before a second frame the velocities and the whole velocity covariance are NaN (unknown);
/// roll and pitch rates are never sent (NaN, and their variances).
/// With VisionPose::covariance (the online window's), its position block turned into FRD
/// (x_frd = y_local, y_frd = x_local: the x/y variances swap, the x-y term stays; yaw_frd =
/// -heading flips the position-yaw terms) and its heading variance are added to the accumulated
/// x/y and yaw variances; z carries the larger of x and y.
/// At a reset (kReacquired, VisionPose::reset) the accumulated variances restart at 0: the new
/// pose is what the autopilot re-aligns its vision offset to (ArduPilot VISO_TYPE 3) or resets
/// its position to (PX4, ArduPilot VISO_TYPE 2), so the drift it sees counts from there
/// (docs/autopilot.md "A pose that jumps").
/// Quality: -1 for a bridged frame, 100 for the first (the origin, exact by definition), else
/// the inlier count capped at 100 (12, the acceptance minimum, gives 12).
class VisionMessageBuilder {
 public:
  VisionMessages Add(const VisionPose& pose);
  uint8_t reset_counter() const { return reset_counter_; }

 private:
  bool have_previous_ = false;
  VisionPose previous_;
  double first_height_m_ = 0.0;
  double var_xy_m2_ = 0.0, var_yaw_rad2_ = 0.0;
  uint8_t reset_counter_ = 0;
};

/// A jump of the live pose (the distance, m, between the pose sent and the previous pose sent
/// moved by the frame's causal step) is sent as a reset (VisionPose::reset, reset_counter + 1)
/// only when the autopilot's innovation gate would reject it as a normal update: 5 standard
/// deviations (PX4 EKF2_EVP_GATE default 5 SD per axis; ArduPilot EK3_POS_I_GATE default 500 %
/// of the horizontal position's) of the position noise, taken as the pose's own standard
/// deviation `sigma_xy_m` but at least PX4's default floor EKF2_EVP_NOISE 0.1 m, the smaller of
/// the two autopilots' (ArduPilot VISO_POS_M_NSE 0.2 m). Smaller jumps are fused by the EKF as
/// any measurement. docs/autopilot.md "A pose that jumps" has the sources.
constexpr double kPoseJumpGateSigmas = 5.0;
constexpr double kPoseJumpNoiseFloorM = 0.1;
constexpr double PoseJumpResetThresholdM(double sigma_xy_m) {
  return kPoseJumpGateSigmas *
         (sigma_xy_m > kPoseJumpNoiseFloorM ? sigma_xy_m : kPoseJumpNoiseFloorM);
}

/// The same for a jump of the heading alone (rad, the wrapped difference between the heading
/// sent and the previous one turned by the frame's causal step): the smaller of the two
/// autopilots' yaw innovation gates (PX4 EKF2_HDG_GATE default 2.6 SD, used for vision yaw in
/// src/modules/ekf2/EKF/aid_sources/external_vision/ev_yaw_control.cpp; ArduPilot
/// EK3_YAW_I_GATE default 300 % = 3 SD) of the yaw noise, taken as the pose's own heading
/// standard deviation `sigma_heading_rad` but at least the smaller of their floors (ArduPilot
/// VISO_YAW_M_NSE 0.2 rad; PX4 max(the message's variance, EKF2_EVA_NOISE 0.1, 0.01^2) as a
/// variance, about 0.32 rad): 0.52 rad (30 degrees) by default. docs/autopilot.md "A pose that
/// jumps".
constexpr double kHeadingJumpGateSigmas = 2.6;
constexpr double kHeadingJumpNoiseFloorRad = 0.2;
constexpr double HeadingJumpResetThresholdRad(double sigma_heading_rad) {
  return kHeadingJumpGateSigmas * (sigma_heading_rad > kHeadingJumpNoiseFloorRad
                                       ? sigma_heading_rad
                                       : kHeadingJumpNoiseFloorRad);
}

/// Index of (row, col), row <= col, in the row-major upper-right triangle of a 6x6 matrix.
constexpr int UpperTriangleIndex(int row, int col) { return row * 6 - row * (row - 1) / 2 + (col - row); }

}  // namespace aerovo::mavlink
