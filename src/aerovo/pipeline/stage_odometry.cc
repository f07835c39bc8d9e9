// The odometry stage: the visual odometry's step (odometry/visual_odometry.h) on the
// preprocessed pixels, at the frame's height and camera attitude, the telemetry's camera yaw
// given as a hint. A stop request ends the frame inside SURF, matching or RANSAC
// (core/cancel.h): Cancelled, the frame abandoned, not counted as processed.
#include <memory>

#include <fmt/format.h>

#include "aerovo/core/cancel.h"
#include "aerovo/core/error.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class OdometryStage : public FrameStage {
 public:
  const char* name() const override { return "odometry"; }
  // The odometry's errors (a frame of another size, a position that is not finite) do not
  // know the frame: the run's failure is given its name.
  bool ErrorsNameTheFrame() const override { return false; }

  void Process(FrameState& f, const RunContext& run) override {
    const std::optional<double> yaw = f.sample ? f.sample->CameraYawDeg() : std::nullopt;
    const CancelScope cancel(run.stop);
    f.result = run.odometry->Process(f.pixels, f.frame.time_s, f.height_m, yaw, f.attitude.camera);
    if (!f.result.position_m.allFinite()) {
      throw InputError(
          fmt::format("the visual odometry's position is not finite (height {} m, focal {} px)",
                      f.height_m, run.vo_options.focal_px));
    }
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeOdometryStage() { return std::make_unique<OdometryStage>(); }

}  // namespace aerovo::run_steps
