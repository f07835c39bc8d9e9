// The MAVLink sink (--mavlink): each frame's vision message (RunConfig::mavlink_message) as
// soon as its pose is known, stamped with the frame's own capture time (FrameState::
// frame_mono_s, on the clock of RunConfig::mavlink_time), with the pose stream's quality and
// the autopilot's attitude when the link gives one.
#include <cmath>
#include <cstdint>
#include <memory>

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

class MavlinkSink : public FrameSink {
 public:
  const char* name() const override { return "mavlink"; }

  void Write(FrameState& f, const RunContext& run) override {
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
    p.reset = f.lens_switched;  // the track re-made under the estimated lens (lens_switch.h)
    p.n_inliers = r.n_inliers;
    p.quality = PoseQuality(r);  // the pose stream's number
    p.gsd_m_per_px = r.gsd_m_per_px;
    p.sigma_px = 0.5 * run.vo_options.correspondence.ransac.max_distance_px;
    p.half_width_px = 0.5 * f.frame.gray.width();
    const mavlink::VisionMessages m = vision_.Add(p);
    switch (config.mavlink_message) {
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
  }

 private:
  mavlink::VisionMessageBuilder vision_;
};

}  // namespace

std::unique_ptr<FrameSink> MakeMavlinkSink() { return std::make_unique<MavlinkSink>(); }

}  // namespace aerovo::run_steps
