// The attitude stage: the camera attitude of the frame (run_steps.h CameraAttitudeOf: the
// telemetry's gimbal, the autopilot's ATTITUDE near the capture time, the aircraft's angles or
// the mount), and once per run a warning when attitude is off and the camera is tilted beyond
// RunConfig::attitude_warn_deg.
#include <cmath>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "aerovo/odometry/attitude.h"
#include "aerovo/pipeline/autopilot_attitude.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

// The least depression of a frame corner's ray below the horizon for which the nadir view is
// made, degrees: rays closer to the horizon meet flat ground beyond 1 / tan(5 deg) = 11.4 heights
// away, where a nadir image's pixels stretch more than a hundredfold. Our choice.
constexpr double kMinCornerDepressionDeg = 5.0;

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
    FrameAttitude& a = f.attitude;
    // An attitude that puts part of the frame at or above the horizon has no nadir view (the
    // correction's homography sends those rays to infinity): the frame is processed as it is,
    // said once. Either the attitude is wrong (a DJI gimbal pitch of 0 for a nadir camera) or
    // the camera does not look at the ground, which no nadir odometry tracks.
    if (a.camera && run.camera.focal_px > 0.0 && run.width_px > 0) {
      const double depression =
          LowestCornerDepressionDeg(*a.camera, run.camera.focal_px, 0.5 * (run.width_px - 1),
                                    0.5 * (run.height_px - 1), run.width_px, run.height_px);
      if (depression < kMinCornerDepressionDeg) {
        a.camera.reset();
        a.beyond_nadir_view = true;
        ++beyond_;
        if (beyond_ == 1) {
          run.summary->warnings.push_back(fmt::format(
              "{}: the {} put the camera {:.1f} deg from nadir (pitch {:.1f}, roll {:.1f}): a "
              "frame corner would look {:.1f} deg {} the horizon, where no nadir view of the "
              "frame exists; such frames are processed without attitude correction (a wrong "
              "attitude, e.g. a gimbal pitch of 0 for a nadir camera, or a camera that does not "
              "look at the ground)",
              f.frame.name, Describe(a.source), TiltFromNadirDeg(*a.reported),
              a.reported->pitch_deg, a.reported->roll_deg, std::abs(depression),
              depression < 0.0 ? "above" : "below"));
        }
      }
    }
    if (a.reported && !a.camera && !a.beyond_nadir_view && !warned_ &&
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
  int beyond_ = 0;  // frames whose attitude had no nadir view (beyond_nadir_view)
  std::optional<AutopilotAttitudeMatcher> matcher_;  // with an autopilot link
};

}  // namespace

std::unique_ptr<FrameStage> MakeAttitudeStage() { return std::make_unique<AttitudeStage>(); }

}  // namespace aerovo::run_steps
