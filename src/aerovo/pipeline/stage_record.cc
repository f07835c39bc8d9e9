// The record stage: the frame as the outputs write it (run_steps.h PendingFrame: frames.csv's
// record, the pose stream's fields), from what the stages before found: the odometry's result,
// the fix and its check, the height and its source, the autopilot's attitude.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "aerovo/core/angles.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class RecordStage : public FrameStage {
 public:
  const char* name() const override { return "record"; }

  void Process(FrameState& f, const RunContext& run) override {
    (void)run;
    f.output = PendingFrameOf(f.frame, f.result, f.gps ? f.gps : f.withheld_gps, f.height_m);
    FrameRecord& rec = f.output.record;
    if (f.fix == FixCheck::kRejected) rec.gps_flag = "rejected:" + f.fix_rejection;
    if (f.withheld_gps) rec.gps_flag = kGpsFlagWithheld;
    if (f.window && f.window->has_covariance) {
      f.output.sigma_xy_m = WindowSigmaXyM(*f.window);
      f.output.sigma_heading_deg = WindowSigmaHeadingRad(*f.window) * kRadToDeg;
    }
    if (f.lens_switched) rec.status += "+lens";  // the lens estimate applied (lens_switch.h)
    // A map fix taken at this frame (stage_map_fix.cc): fused into the pose graph, or gated.
    if (f.map_fix == FrameState::MapFixTaken::kFused) rec.status += "+map_fix";
    if (f.map_fix == FrameState::MapFixTaken::kGated) rec.status += "+map_gated";
    rec.height_m = f.height_m;
    rec.height_source = ToString(f.height_source);
    if (f.autopilot_attitude) {
      rec.roll_deg = f.autopilot_attitude->roll_rad * kRadToDeg;
      rec.pitch_deg = f.autopilot_attitude->pitch_rad * kRadToDeg;
    }
    if (f.attitude.camera) {  // the virtual nadir camera of the odometry (stage_attitude.cc)
      rec.camera_roll_deg = f.attitude.camera->roll_deg;
      rec.camera_pitch_deg = f.attitude.camera->pitch_deg;
    }
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeRecordStage() { return std::make_unique<RecordStage>(); }

}  // namespace aerovo::run_steps
