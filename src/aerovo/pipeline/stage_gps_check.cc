// The GPS check stage: the plausibility of the frame's fix (odometry/gps_check.h GpsFixChecker,
// against the last accepted fix and the VO's motion). A rejected fix is recorded
// (RunState::rejected) and flagged in frames.csv; when later fixes outvote the earlier ones,
// those are rejected (also in the frames still queued for the heading, and in the totals) and
// the challengers accepted, the geo-referencing restarted with them if not fixed yet.
#include <memory>
#include <string>

#include <fmt/format.h>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

// "<telemetry>: the GPS fix of frame N (time t s, <origin>) rejected", naming the photo or
// the record the fix was read from when the sample says (RunTelemetry::OriginOf).
std::string Rejected(const RunContext& run, int frame_index, double time_s) {
  const std::string origin = run.telemetry->OriginOf(frame_index, time_s);
  const std::string from = origin.empty() ? "" : ", " + origin;
  return fmt::format("{}: the GPS fix of frame {} (time {:.3f} s{}) rejected",
                     run.telemetry->origin(), frame_index, time_s, from);
}

// The fixes of `v.superseded` rejected, those of `v.reinstated` accepted (the challenger chain
// replaced the anchor chain at `frame_index`).
void Switch(const GpsFixVerdict& v, int frame_index, const RunContext& run) {
  RunState& state = *run.state;
  // The later fixes outvote the earlier ones: those were wrong (a bad first fix).
  const std::string first_new =
      v.reinstated.empty() ? std::to_string(frame_index) : std::to_string(v.reinstated[0].frame);
  for (const int f : v.superseded) {
    double t = 0.0;
    for (std::size_t i = 0; i < state.totals.gps_frames.size(); ++i) {
      if (state.totals.gps_frames[i] == f) t = state.totals.gps_track[i].t;
    }
    state.rejected[f] = {f, t, "superseded",
                         Rejected(run, f, t) + ": inconsistent with the fixes from frame " +
                             first_new + " on, which outnumber it"};
    state.totals.SetRejected(f, true);
    run.outputs->Reflag(f, "rejected:superseded");
  }
  if (!state.georef.ready()) {
    state.georef.Restart();
    for (const auto& q : v.reinstated) state.georef.Observe(q.local_m, q.gps, std::nullopt);
  } else {
    run.summary->warnings.push_back(fmt::format(
        "{}: the GPS fixes from frame {} on outvote the earlier ones, but the track was "
        "already geo-referenced with those: check the geo-referenced positions",
        run.telemetry->origin(), first_new));
  }
  for (const auto& q : v.reinstated) {
    state.rejected.erase(q.frame);
    state.totals.SetRejected(q.frame, false);
    run.outputs->Reflag(q.frame, "");
  }
}

class GpsCheckStage : public FrameStage {
 public:
  const char* name() const override { return "gps_check"; }

  void Process(FrameState& f, const RunContext& run) override {
    if (!f.gps) {
      f.fix = FixCheck::kNoFix;
      return;
    }
    const Frame& frame = f.frame;
    const int unmeasured = run.odometry->stats().bridged;
    const GpsFixVerdict v = run.state->gps_check.Check(
        frame.index, frame.time_s, *f.gps, f.sample ? f.sample->rel_alt_m : std::nullopt,
        f.result.position_m, unmeasured);
    if (v.switched) Switch(v, frame.index, run);
    if (v.switched || v.accepted) {
      f.fix = FixCheck::kAccepted;
      return;
    }
    f.fix = FixCheck::kRejected;
    f.fix_rejection = v.kind;
    run.state->rejected[frame.index] = {frame.index, frame.time_s, v.kind,
                                        Rejected(run, frame.index, frame.time_s) + ": " + v.reason};
  }
};

}  // namespace

std::unique_ptr<FrameStage> MakeGpsCheckStage() { return std::make_unique<GpsCheckStage>(); }

}  // namespace aerovo::run_steps
