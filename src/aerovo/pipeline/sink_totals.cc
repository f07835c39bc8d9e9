// The totals sink: the frame counted as processed (RunSummary::frames_processed) and in what the
// summary needs (run_steps.h RunTotals: track, fixes, latency; a rejected fix left out of the
// comparison with GPS), and each of its flags (RunSummary::frames_flagged, the first frame with
// each for the warning), and the resets of the live pose by cause (RunSummary::PoseResets).
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class TotalsSink : public FrameSink {
 public:
  const char* name() const override { return "totals"; }

  void Write(FrameState& f, const RunContext& run) override {
    RunState& state = *run.state;
    RunSummary& summary = *run.summary;
    // A fix withheld by GPS denial joins the comparison with GPS (and nothing else).
    state.totals.Add(f.frame.index, f.frame.time_s, f.result, f.gps ? f.gps : f.withheld_gps,
                     f.withheld_gps.has_value());
    state.totals.latency_ms.push_back(f.latency_ms);
    if (f.fix == FixCheck::kRejected) state.totals.SetRejected(f.frame.index, true);
    ++summary.frames_processed;
    for (const std::string& flag : f.flags.Names()) {
      if (summary.frames_flagged[flag]++ == 0) state.first_flagged[flag] = f.frame.name;
    }
    CountReset(f, &summary.pose_resets);
  }

 private:
  // The frame's reset of the live pose, as the MAVLink sink sends it (sink_mavlink.cc), by cause.
  static void CountReset(const FrameState& f, RunSummary::PoseResets* r) {
    const bool reacquired = f.result.status == FrameStatus::kReacquired;
    if (!(reacquired || f.lens_switched || f.pose_reset)) return;
    ++r->frames;
    r->reacquired += reacquired ? 1 : 0;
    r->lens_switch += f.lens_switched ? 1 : 0;
    r->loop_closure += f.pose_reset.cause == PoseReset::Cause::kLoopClosure ? 1 : 0;
    r->map_fix += f.pose_reset.cause == PoseReset::Cause::kMapFix ? 1 : 0;
    r->heading_only += f.pose_reset && f.pose_reset.heading_only ? 1 : 0;
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeTotalsSink() { return std::make_unique<TotalsSink>(); }

}  // namespace aerovo::run_steps
