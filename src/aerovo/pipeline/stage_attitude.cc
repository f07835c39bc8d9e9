// The attitude stage: the camera attitude of the frame (run_steps.h CameraAttitudeOf: the
// telemetry's gimbal, the autopilot's ATTITUDE near the capture time, the aircraft's angles or
// the mount), and once per run a warning when attitude is off and the camera is tilted beyond
// RunConfig::attitude_warn_deg.
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "aerovo/odometry/attitude.h"
#include "aerovo/pipeline/autopilot_attitude.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class AttitudeStage : public FrameStage {
 public:
  const char* name() const override { return "attitude"; }

  void Process(FrameState& f, const RunContext& run) override {
    const RunConfig& config = *run.config;
    if (run.link_reads_autopilot) {
      if (!matcher_) matcher_.emplace(run.link, config.mavlink_match_s);
      f.autopilot_attitude = matcher_->AttitudeOf(f.capture_mono_s);
    }
    f.attitude = CameraAttitudeOf(config, f.sample, f.autopilot_attitude, run.estimated_attitude);
    const FrameAttitude& a = f.attitude;
    if (a.reported && !a.camera && !warned_ &&
        TiltFromNadirDeg(*a.reported) > config.attitude_warn_deg) {
      run.summary->warnings.push_back(fmt::format(
          "{}: the camera is {:.1f} deg from nadir (pitch {:.1f}, roll {:.1f}, from the {}) and "
          "attitude is off: positions are those of the image centre's ground point and the "
          "steps' scale is that of a nadir camera (--attitude auto corrects it)",
          f.frame.name, TiltFromNadirDeg(*a.reported), a.reported->pitch_deg, a.reported->roll_deg,
          Describe(a.source)));
      warned_ = true;
    }
  }

 private:
  bool warned_ = false;                              // the attitude_warn_deg warning was given
  std::optional<AutopilotAttitudeMatcher> matcher_;  // with an autopilot link
};

}  // namespace

std::unique_ptr<FrameStage> MakeAttitudeStage() { return std::make_unique<AttitudeStage>(); }

}  // namespace aerovo::run_steps
