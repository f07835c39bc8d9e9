// The geo-referencing stage: the frame's VO position and accepted fix (none when rejected or
// missing) and the telemetry's camera yaw to the run's GeoReferencer (odometry/georef.h), which
// fixes the heading and the ENU frame.
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class GeoreferenceStage : public FrameStage {
 public:
  const char* name() const override { return "georeference"; }

  void Process(FrameState& f, const RunContext& run) override {
    const std::optional<double> yaw = f.sample ? f.sample->CameraYawDeg() : std::nullopt;
    run.state->georef.Observe(f.result.position_m,
                              f.fix == FixCheck::kAccepted ? f.gps : std::nullopt, yaw);
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeGeoreferenceStage() {
  return std::make_unique<GeoreferenceStage>();
}

}  // namespace aerovo::run_steps
