// The pose stream sink: the frame's capture-to-output latency (FrameRecord::latency_ms), then
// its "pose" line on the pose stream (RunConfig::poses_jsonl; run_steps.h PoseJsonLine) at once,
// even while the run files wait for the heading. The "geo" lines and --print-poses follow the
// run files (RunOutputs, sink_run_files.cc).
#include <memory>

#include "aerovo/core/timer.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class PoseStreamSink : public FrameSink {
 public:
  const char* name() const override { return "pose_stream"; }

  void Write(FrameState& f, const RunContext& run) override {
    f.output.record.latency_ms = (SteadySeconds() - f.frame.received_s) * 1000.0;
    f.latency_ms = static_cast<float>(f.output.record.latency_ms);
    run.outputs->SendPose(f.output, run.state->georef);
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakePoseStreamSink() { return std::make_unique<PoseStreamSink>(); }

}  // namespace aerovo::run_steps
