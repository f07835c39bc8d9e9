// The height stage: the frame's height above ground (run_steps.h HeightProvider), its
// telemetry relative altitude first checked for a vertical jump by the GPS plausibility check
// (odometry/gps_check.h GpsFixChecker::PlausibleRelAlt).
#include <memory>
#include <string>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class HeightStage : public FrameStage {
 public:
  explicit HeightStage(const RunContext& run)
      : height_(run.config->altitude_m, run.link_reads_autopilot ? run.link : nullptr,
                run.config->mavlink_match_s) {
    // A photo folder's frames are named by their files; a telemetry file names itself.
    const RunConfig& config = *run.config;
    height_.set_ground(config.ground_elevation_m, config.takeoff_height_agl_m,
                       !config.telemetry.empty() && config.telemetry != kNoTelemetry
                           ? config.telemetry
                       : run.photo_folder ? std::string("the photo's EXIF")
                                          : std::string());
  }
  const char* name() const override { return "height"; }

  void Process(FrameState& f, const RunContext& run) override {
    if (!f.sample && !run.telemetry->empty() && !height_.last_m()) {
      height_.set_no_fix_reason(run.telemetry->WhyNoFix(f.frame));
      height_.set_first_record_ahead(run.telemetry->FirstRecordAhead(f.frame));
    }
    // (Once the first record's height stands in, it does for the frames up to that record.)
    // A relative altitude that jumps beyond the vertical speed limit would scale the step: the
    // last plausible height is used instead (the fix itself is judged by the GPS check stage).
    std::optional<TelemetrySample> sample = f.sample;
    if (sample && sample->rel_alt_m) {
      sample->rel_alt_m = run.state->gps_check.PlausibleRelAlt(f.frame.time_s, *sample->rel_alt_m,
                                                               height_.last_m());
    }
    f.height_m = height_.HeightOf(f.frame.name, sample, &run.summary->warnings, f.capture_mono_s);
    f.height_source = height_.last_kind();
  }

 private:
  HeightProvider height_;
};

}  // namespace

std::unique_ptr<FrameStage> MakeHeightStage(const RunContext& run) {
  return std::make_unique<HeightStage>(run);
}

}  // namespace aerovo::run_steps
