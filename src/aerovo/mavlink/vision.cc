#include "aerovo/mavlink/vision.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace aerovo::mavlink {
namespace {

// Rotation local FRD from body FRD (ZYX: yaw, then pitch, then roll), row-major.
struct Rot {
  double m[3][3];
  static Rot FromEuler(double roll, double pitch, double yaw) {
    const double cr = std::cos(roll), sr = std::sin(roll), cp = std::cos(pitch),
                 sp = std::sin(pitch), cy = std::cos(yaw), sy = std::sin(yaw);
    Rot r{};
    r.m[0][0] = cy * cp;
    r.m[0][1] = cy * sp * sr - sy * cr;
    r.m[0][2] = cy * sp * cr + sy * sr;
    r.m[1][0] = sy * cp;
    r.m[1][1] = sy * sp * sr + cy * cr;
    r.m[1][2] = sy * sp * cr - cy * sr;
    r.m[2][0] = -sp;
    r.m[2][1] = cp * sr;
    r.m[2][2] = cp * cr;
    return r;
  }
  // body = R^T * local
  void ToBody(const double in[3], double out[3]) const {
    for (int i = 0; i < 3; ++i) out[i] = m[0][i] * in[0] + m[1][i] * in[1] + m[2][i] * in[2];
  }
};

std::array<float, 4> QuaternionOf(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2), cp = std::cos(pitch / 2),
               sp = std::sin(pitch / 2), cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  return {static_cast<float>(cr * cp * cy + sr * sp * sy),
          static_cast<float>(sr * cp * cy - cr * sp * sy),
          static_cast<float>(cr * sp * cy + sr * cp * sy),
          static_cast<float>(cr * cp * sy - sr * sp * cy)};
}

double Wrap(double a) { return std::remainder(a, 2.0 * M_PI); }

// ODOMETRY's pose_covariance: the accumulated x/y and yaw variances on the diagonal, plus the
// pose's own covariance (local frame) turned into FRD; z carries the larger x/y variance and
// roll and pitch the yaw's (docs/autopilot.md "Quality, covariance, reset counter").
void FillPoseCovariance(double var_xy_m2, double var_yaw_rad2,
                        const std::optional<VisionPose::LocalCovariance>& local,
                        std::array<float, 21>& pc) {
  pc.fill(0.f);
  double var_x = var_xy_m2, var_y = var_xy_m2, var_yaw = var_yaw_rad2;
  if (local) {
    // x_frd = y_local, y_frd = x_local, yaw_frd = -heading.
    var_x += local->yy;
    var_y += local->xx;
    var_yaw += local->heading;
    pc[UpperTriangleIndex(0, 1)] = static_cast<float>(local->xy);
    pc[UpperTriangleIndex(0, 5)] = static_cast<float>(-local->y_heading);
    pc[UpperTriangleIndex(1, 5)] = static_cast<float>(-local->x_heading);
  }
  pc[UpperTriangleIndex(0, 0)] = static_cast<float>(var_x);
  pc[UpperTriangleIndex(1, 1)] = static_cast<float>(var_y);
  pc[UpperTriangleIndex(2, 2)] = static_cast<float>(std::max(var_x, var_y));
  for (int i = 3; i < 6; ++i) pc[UpperTriangleIndex(i, i)] = static_cast<float>(var_yaw);
}

// ODOMETRY's velocities in the body frame of `r` (local FRD from body FRD) from the step
// `local_d` (local FRD, m) over dt, and their covariance from the step's variances;
// unknown (NaN, with the whole covariance) when not `known`.
void FillVelocity(bool known, const double local_d[3], double dyaw, double dt, double step_var_xy,
                  double step_var_yaw, const Rot& r, Odometry& o) {
  auto& vc = o.velocity_covariance;
  vc.fill(0.f);
  if (!known) {
    // No velocity before a second frame or across a jump: the velocities and their whole
    // covariance unknown (NaN in the first element, as the ODOMETRY definition marks an unknown
    // covariance).
    o.vx = o.vy = o.vz = o.yawspeed = kNaN;
    vc.fill(kNaN);
    return;
  }
  const double local_v[3] = {local_d[0] / dt, local_d[1] / dt, local_d[2] / dt};
  double body_v[3];
  r.ToBody(local_v, body_v);
  o.vx = static_cast<float>(body_v[0]);
  o.vy = static_cast<float>(body_v[1]);
  o.vz = static_cast<float>(body_v[2]);
  o.yawspeed = static_cast<float>(dyaw / dt);
  const double v_var = 2.0 * step_var_xy / (dt * dt);
  for (int i = 0; i < 3; ++i) vc[UpperTriangleIndex(i, i)] = static_cast<float>(v_var);
  vc[UpperTriangleIndex(5, 5)] = static_cast<float>(2.0 * step_var_yaw / (dt * dt));
  // Roll and pitch rates are not sent (NaN): their variances are unknown too.
  vc[UpperTriangleIndex(3, 3)] = kNaN;
  vc[UpperTriangleIndex(4, 4)] = kNaN;
}

// ODOMETRY's quality: the caller's within [-1, 100], else -1 bridged, 100 the first frame, the
// inlier count capped at 100.
int8_t QualityOf(const VisionPose& p) {
  if (p.quality) return static_cast<int8_t>(std::clamp(*p.quality, -1, 100));
  switch (p.status) {
    case VisionPose::Status::kBridged: return -1;
    case VisionPose::Status::kFirst: return 100;
    default: return static_cast<int8_t>(std::clamp(p.n_inliers, 1, 100));
  }
}

// VISION_POSITION_ESTIMATE: ODOMETRY's position, covariance and reset counter, Euler angles.
VisionPositionEstimate EstimateOf(const Odometry& o, double roll, double pitch, double yaw,
                                  uint64_t time_usec) {
  VisionPositionEstimate e;
  e.usec = time_usec;
  e.x = o.x;
  e.y = o.y;
  e.z = o.z;
  e.roll = static_cast<float>(roll);
  e.pitch = static_cast<float>(pitch);
  e.yaw = static_cast<float>(yaw);
  e.covariance = o.pose_covariance;
  e.reset_counter = o.reset_counter;
  return e;
}

// VISION_POSITION_DELTA's move `local_d` (local FRD) in the previous body frame and the angles
// from the previous body frame.
void FillDelta(const double local_d[3], double roll, double pitch, double dyaw,
               const VisionPose& previous, VisionPositionDelta& d) {
  const double prev_yaw = Wrap(-previous.heading_rad);
  double body_d[3];
  Rot::FromEuler(previous.roll_rad.value_or(0.0), previous.pitch_rad.value_or(0.0), prev_yaw)
      .ToBody(local_d, body_d);
  d.position_delta = {static_cast<float>(body_d[0]), static_cast<float>(body_d[1]),
                      static_cast<float>(body_d[2])};
  d.angle_delta = {static_cast<float>(roll - previous.roll_rad.value_or(0.0)),
                   static_cast<float>(pitch - previous.pitch_rad.value_or(0.0)),
                   static_cast<float>(dyaw)};
}

}  // namespace

const char* ToString(VisionMessageKind kind) {
  switch (kind) {
    case VisionMessageKind::kOdometry: return "odometry";
    case VisionMessageKind::kVisionPositionEstimate: return "vision_position_estimate";
    case VisionMessageKind::kVisionPositionDelta: return "vision_position_delta";
  }
  return "?";
}

const char* ToString(TimestampClock clock) {
  return clock == TimestampClock::kUnix ? "unix" : "boot";
}

VisionMessages VisionMessageBuilder::Add(const VisionPose& p) {
  if (!have_previous_) first_height_m_ = p.height_m;
  // Local FRD position and attitude.
  const double x = p.local_y_m, y = p.local_x_m, z = -(p.height_m - first_height_m_);
  const double yaw = Wrap(-p.heading_rad);
  const double roll = p.roll_rad.value_or(0.0), pitch = p.pitch_rad.value_or(0.0);
  const bool measured = p.status == VisionPose::Status::kOk ||
                        p.status == VisionPose::Status::kReacquired;
  // Re-anchored, the track re-made or the pose jumped (wraps): the accumulated variances
  // restart from this pose, the autopilot's new reference.
  const bool reset = p.status == VisionPose::Status::kReacquired || p.reset;
  if (reset) {
    ++reset_counter_;
    var_xy_m2_ = var_yaw_rad2_ = 0.0;
  }

  // Variances of this step, added to the accumulated ones.
  double step_var_xy = 0.0, step_var_yaw = 0.0;
  double dt = 0.0, dx = 0.0, dy = 0.0, dz = 0.0, dyaw = 0.0;
  if (have_previous_) {
    dt = p.time_s - previous_.time_s;
    dx = x - previous_.local_y_m;
    dy = y - previous_.local_x_m;
    dz = z + (previous_.height_m - first_height_m_);
    dyaw = Wrap(yaw - Wrap(-previous_.heading_rad));
    if (measured) {
      const double s_px = p.sigma_px / std::sqrt(std::max(1, p.n_inliers));
      step_var_xy = std::pow(s_px * p.gsd_m_per_px, 2);
      step_var_yaw = std::pow(s_px / std::max(1.0, p.half_width_px), 2);
    } else {
      step_var_xy = dx * dx + dy * dy;
      step_var_yaw = dyaw * dyaw;
    }
    if (!reset) {
      var_xy_m2_ += step_var_xy;
      var_yaw_rad2_ += step_var_yaw;
    }
  }

  VisionMessages out;
  Odometry& o = out.odometry;
  o.time_usec = p.time_usec;
  o.frame_id = kMavFrameLocalFrd;
  o.child_frame_id = kMavFrameBodyFrd;
  o.x = static_cast<float>(x);
  o.y = static_cast<float>(y);
  o.z = static_cast<float>(z);
  o.q = QuaternionOf(roll, pitch, yaw);
  // Every variance either consumer reads is finite (docs/autopilot.md "Quality, covariance,
  // reset counter"): z, roll and pitch are not measured by the vision, and carry the
  // horizontal and yaw variances, so that ArduPilot's single position and angle errors (which
  // combine [0], [6], [11] and [15], [18], [20]) are the measured axes' and PX4's all-finite
  // checks pass.
  FillPoseCovariance(var_xy_m2_, var_yaw_rad2_, p.covariance, o.pose_covariance);
  // No velocity across a jump (p.reset): PX4 would reset its velocity to it (ev_reset).
  const double local_d[3] = {dx, dy, dz};
  FillVelocity(have_previous_ && dt > 0.0 && !p.reset, local_d, dyaw, dt, step_var_xy,
               step_var_yaw, Rot::FromEuler(roll, pitch, yaw), o);
  o.rollspeed = o.pitchspeed = kNaN;
  o.reset_counter = reset_counter_;
  o.estimator_type = kMavEstimatorTypeVision;
  o.quality = QualityOf(p);

  out.position_estimate = EstimateOf(o, roll, pitch, yaw, p.time_usec);

  VisionPositionDelta& d = out.position_delta;
  d.time_usec = p.time_usec;
  if (have_previous_) {
    d.time_delta_usec = p.time_usec > previous_.time_usec ? p.time_usec - previous_.time_usec : 0;
    FillDelta(local_d, roll, pitch, dyaw, previous_, d);
    // A jump is no motion: NaN, which ArduPilot's writeBodyFrameOdom drops.
    if (p.reset) d.position_delta = d.angle_delta = {kNaN, kNaN, kNaN};
  }
  d.confidence = o.quality < 0 ? 0.f : static_cast<float>(o.quality);

  previous_ = p;
  have_previous_ = true;
  return out;
}

}  // namespace aerovo::mavlink
