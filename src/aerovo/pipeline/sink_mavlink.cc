// The MAVLink sink (--mavlink): each frame's vision message (RunConfig::mavlink_message) as
// soon as its pose is known, stamped with the frame's own capture time (FrameState::
// frame_mono_s, on the clock of RunConfig::mavlink_time), with the pose stream's quality and
// the autopilot's attitude when the link gives one; with RunConfig::mavlink_gps_input also the
// frame's absolute position as GPS_INPUT (mavlink/gps_input.h): the frame's absolute fix when a
// stage found one (FrameState::absolute_fix), else its geo-referenced odometry pose.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>

#include <Eigen/Core>

#include "aerovo/core/angles.h"
#include "aerovo/mavlink/gps_input.h"
#include "aerovo/mavlink/vision.h"
#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/pose_quality.h"

namespace aerovo::run_steps {
namespace {

mavlink::VisionPose::Status StatusOf(FrameStatus s) {
  switch (s) {
    case FrameStatus::kFirst:
      return mavlink::VisionPose::Status::kFirst;
    case FrameStatus::kOk:
      return mavlink::VisionPose::Status::kOk;
    case FrameStatus::kReacquired:
      return mavlink::VisionPose::Status::kReacquired;
    case FrameStatus::kBridged:
      return mavlink::VisionPose::Status::kBridged;
  }
  return mavlink::VisionPose::Status::kBridged;
}

// The larger variance of the position's x/y block of an ODOMETRY pose_covariance, m^2 (its
// largest eigenvalue: the variance along the worst direction).
double LargerPositionVariance(const std::array<float, 21>& pc) {
  const double a = pc[mavlink::UpperTriangleIndex(0, 0)], b = pc[mavlink::UpperTriangleIndex(0, 1)],
               d = pc[mavlink::UpperTriangleIndex(1, 1)];
  if (!std::isfinite(a + b + d)) return 0.0;
  return std::max(0.0, 0.5 * (a + d) + std::sqrt(0.25 * (a - d) * (a - d) + b * b));
}

// GPS_INPUT of the odometry poses: each frame's geo-referenced position (the one frames.csv
// gets: GeoReferencer::Wgs84FromLocal), its velocity from the previous frame's over the frames'
// own time difference, its accuracy from the vision messages' covariance model plus the drift.
class GpsInputOfPoses {
 public:
  /// The GeoFix of frame `f` whose vision messages are `m`; nullopt until the track is
  /// geo-referenced (the heading still unknown).
  std::optional<mavlink::GeoFix> Of(const FrameState& f, const RunContext& run,
                                    const mavlink::VisionMessages& m) {
    const GeoReferencer& georef = run.state->georef;
    const Eigen::Vector2d local = f.result.position_m;
    std::optional<Eigen::Vector2d> previous = previous_local_;
    const double previous_time_s = previous_time_s_;
    previous_local_ = local;
    previous_time_s_ = f.frame_mono_s;
    // Not across the lens switch or a jump of the pose (a loop closure, a fused fix): the track
    // was re-made or corrected there, the step is no motion.
    const bool jumped = f.lens_switched || f.pose_reset;
    // The distance flown from the first frame, whose track the geo-reference anchors (metres:
    // the local frame is metric, the geo-reference only turns and moves it), from the frame
    // whose map fix seeded the geo-reference (no GPS: the track is placed by that fix, whose
    // variance then adds to the odometry's until the next fused fix), or from the last fix
    // against a reference map fused into the track (map_fix.apply): an absolute position, from
    // which the odometry drifts again.
    if (previous && !jumped) distance_m_ += (local - *previous).norm();
    if (f.map_fix == FrameState::MapFixTaken::kFused) {
      distance_m_ = 0.0;
      seed_var_m2_ = 0.0;
    }
    if (f.map_seed_var_m2) {
      distance_m_ = 0.0;
      seed_var_m2_ = *f.map_seed_var_m2;
    }
    if (!georef.ready()) return std::nullopt;
    const RunConfig& config = *run.config;
    mavlink::GeoFix fix;
    fix.unix_time_s = f.frame_unix_s;
    fix.time_usec = static_cast<uint64_t>(std::llround(
        (config.mavlink_time == mavlink::TimestampClock::kUnix ? f.frame_unix_s : f.frame_mono_s) *
        1e6));
    const GeoPoint g = georef.Wgs84FromLocal(local);
    fix.lat_deg = g.lat_deg;
    fix.lon_deg = g.lon_deg;
    // The ENU origin's altitude (the first accepted fix's) plus the height gained since the
    // first geo-referenced frame: the height aerovo was given, not measured (vert fields ignored).
    // A track placed by a map has no altitude (GeoReferencer::altitude_known): alt is marked
    // ignored, never sent as 0 (docs/autopilot.md "No altitude after a map's seed").
    if (!first_height_m_) first_height_m_ = f.height_m;
    if (georef.altitude_known()) fix.alt_msl_m = g.alt_m + (f.height_m - *first_height_m_);
    const double dt = f.frame_mono_s - previous_time_s;
    if (previous && dt > 0.0 && !jumped) {
      const Eigen::Vector2d v = (georef.EnuFromLocal(local) - georef.EnuFromLocal(*previous)) / dt;
      fix.vel_east_mps = v.x();
      fix.vel_north_mps = v.y();
      // ODOMETRY's velocity variance (vx, the same for every axis; NaN at the first frame).
      fix.sigma_velocity_mps = std::sqrt(std::max(0.0, double(m.odometry.velocity_covariance[0])));
    }
    // ODOMETRY's position variance (the step model, plus the online window's covariance when the
    // frame has one: the larger axis of its x/y block), the seed's until the first fused fix,
    // and the drift over the distance flown from the first frame, the seed or the last fused
    // map fix.
    double var = LargerPositionVariance(m.odometry.pose_covariance) + seed_var_m2_;
    var += std::pow(config.mavlink_gps_input_drift * distance_m_, 2);
    fix.sigma_horizontal_m = std::sqrt(var);
    // The image's up (the nose, camera mounted nose-up as for ODOMETRY) clockwise from north:
    // minus the image x axis' angle counter-clockwise from east (the pose stream's yaw_enu_deg).
    fix.yaw_deg = -(f.result.heading_rad + georef.rotation_rad()) * kRadToDeg;
    return fix;
  }

 private:
  std::optional<Eigen::Vector2d> previous_local_;
  double previous_time_s_ = 0.0;
  std::optional<double> first_height_m_;
  double distance_m_ = 0.0;
  double seed_var_m2_ = 0.0;  // the map seed's variance, m², until the first fused fix
};

class MavlinkSink : public FrameSink {
 public:
  const char* name() const override { return "mavlink"; }

  void Write(FrameState& f, const RunContext& run) override {
    const mavlink::VisionMessages m = vision_.Add(PoseOf(f, run));
    switch (run.config->mavlink_message) {
      case mavlink::VisionMessageKind::kOdometry:
        run.link->Send(m.odometry);
        break;
      case mavlink::VisionMessageKind::kVisionPositionEstimate:
        run.link->Send(m.position_estimate);
        break;
      case mavlink::VisionMessageKind::kVisionPositionDelta:
        run.link->Send(m.position_delta);
        break;
    }
    if (!run.config->mavlink_gps_input) return;
    const std::optional<mavlink::GeoFix> pose_fix = gps_.Of(f, run, m);
    const std::optional<mavlink::GeoFix>& fix = f.absolute_fix ? f.absolute_fix : pose_fix;
    if (fix) SendGpsInput(*fix, run);
  }

  void End(const LoopEnd& end, const RunContext* run) override {
    (void)end;
    if (run == nullptr || !run->config->mavlink_gps_input) return;
    run->summary->mavlink["gps_input"] = {{"sent", sent_},
                                          {"with_fix", with_fix_},
                                          {"without_fix", sent_ - with_fix_},
                                          {"send_failed", send_failed_},
                                          {"max_sigma_m", run->config->mavlink_gps_input_max_sigma_m},
                                          {"largest_sigma_m", largest_sigma_m_}};
  }

 private:
  // The frame as the vision messages need it.
  static mavlink::VisionPose PoseOf(const FrameState& f, const RunContext& run) {
    const RunConfig& config = *run.config;
    const FrameResult& r = f.result;
    mavlink::VisionPose p;
    const double t =
        config.mavlink_time == mavlink::TimestampClock::kUnix ? f.frame_unix_s : f.frame_mono_s;
    p.time_usec = static_cast<uint64_t>(std::llround(t * 1e6));
    p.time_s = f.frame.time_s;  // the frame's own time: velocities from its differences
    p.local_x_m = r.position_m.x();
    p.local_y_m = r.position_m.y();
    p.height_m = f.height_m;
    p.heading_rad = r.heading_rad;
    if (f.autopilot_attitude) {
      p.roll_rad = f.autopilot_attitude->roll_rad;
      p.pitch_rad = f.autopilot_attitude->pitch_rad;
    }
    p.status = StatusOf(r.status);
    // The track re-made under the estimated lens (lens_switch.h), or the live pose jumped (a
    // loop closure's whole-graph solve, stage_window.cc; a fused fix).
    p.reset = f.lens_switched || f.pose_reset;
    if (f.window && f.window->has_covariance) {
      const Eigen::Matrix4d& c = f.window->covariance;  // x, y, heading, log-scale
      p.covariance = mavlink::VisionPose::LocalCovariance{c(0, 0), c(0, 1), c(1, 1),
                                                          c(0, 2), c(1, 2), c(2, 2)};
    }
    p.n_inliers = r.n_inliers;
    p.quality = PoseQuality(r);  // the pose stream's number
    p.gsd_m_per_px = r.gsd_m_per_px;
    p.sigma_px = 0.5 * run.vo_options.correspondence.ransac.max_distance_px;
    p.half_width_px = 0.5 * f.frame.gray.width();
    return p;
  }

  void SendGpsInput(const mavlink::GeoFix& fix, const RunContext& run) {
    mavlink::GpsInputOptions o;
    o.max_horizontal_sigma_m = run.config->mavlink_gps_input_max_sigma_m;
    o.gps_id = static_cast<uint8_t>(run.config->mavlink_gps_input_id);
    const mavlink::GpsInput g = mavlink::MakeGpsInput(fix, o);
    if (!run.link->Send(g)) ++send_failed_;
    ++sent_;
    if (g.fix_type == mavlink::kGpsFixType3d) ++with_fix_;
    if (std::isfinite(fix.sigma_horizontal_m))
      largest_sigma_m_ = std::max(largest_sigma_m_, fix.sigma_horizontal_m);
  }

  mavlink::VisionMessageBuilder vision_;
  GpsInputOfPoses gps_;
  int sent_ = 0, with_fix_ = 0, send_failed_ = 0;
  double largest_sigma_m_ = 0.0;
};

}  // namespace

std::unique_ptr<FrameSink> MakeMavlinkSink() { return std::make_unique<MavlinkSink>(); }

}  // namespace aerovo::run_steps
