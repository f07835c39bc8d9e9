// The geo-referencing stage: the frame's VO position and accepted fix (none when rejected or
// missing) and the telemetry's camera yaw to the run's GeoReferencer (odometry/georef.h), which
// fixes the heading and the ENU frame. At the first frame of a GPS denial (RunConfig::
// gps_denied_after_s) a geo-reference still open is fixed from the fixes before
// (GeoReferencer::FixWithAvailable), so that the track goes on geo-referenced without GPS; when
// it cannot be (no fix before, or no spread), the summary says so; with a map, the map's fixes
// may seed it (stage_map_fix.cc).
#include <memory>

#include <fmt/format.h>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

// The first denied frame: fix the geo-reference with what was observed, or say why not.
void OnDenial(const FrameState& f, const RunContext& run) {
  GeoReferencer& georef = run.state->georef;
  if (georef.ready()) return;
  if (georef.has_enu() && georef.FixWithAvailable()) {
    if (run.log != nullptr) {
      *run.log << fmt::format(
          "gps denied from frame {}: the heading fixed from the fixes before ({})\n",
          f.frame.index, georef.heading_source_used());
    }
    return;
  }
  if (run.map_fixer) {
    // The map may seed it (stage_map_fix.cc): the frames wait for it (RunOutputs), and if none
    // comes, summary.json map_fixes.georef says why.
    if (run.log != nullptr) {
      *run.log << fmt::format(
          "gps denied from frame {} before the track was geo-referenced: searching the map\n",
          f.frame.index);
    }
    return;
  }
  run.outputs->StopWaitingForHeading();
  run.summary->warnings.push_back(fmt::format(
      "GPS denied from frame {} (time {:.3f} s) before the track could be geo-referenced ({}): "
      "the track stays in the local frame and has no error against the withheld GPS",
      f.frame.index, f.frame.time_s,
      georef.has_enu() ? "the fixes before do not give the heading" : "no fix before"));
}

class GeoreferenceStage : public FrameStage {
 public:
  const char* name() const override { return "georeference"; }

  void Process(FrameState& f, const RunContext& run) override {
    const std::optional<double> yaw = f.sample ? f.sample->CameraYawDeg() : std::nullopt;
    run.state->georef.Observe(f.result.position_m,
                              f.fix == FixCheck::kAccepted ? f.gps : std::nullopt, yaw);
    if (f.gps_denied && !run.state->denial_seen) {
      run.state->denial_seen = true;
      OnDenial(f, run);
    }
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeGeoreferenceStage() {
  return std::make_unique<GeoreferenceStage>();
}

}  // namespace aerovo::run_steps
