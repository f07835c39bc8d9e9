// The run files sink: the frame to the track writers (frames.csv, TUM, GeoJSON, KML, GPX), the
// frame callback and --print-poses, queued until the track is geo-referenced when the run waits
// for a heading (run_steps.h RunOutputs::Enqueue). Takes the frame's output record.
#include <memory>
#include <utility>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class RunFilesSink : public FrameSink {
 public:
  const char* name() const override { return "run_files"; }

  void Write(FrameState& f, const RunContext& run) override {
    run.outputs->Enqueue(std::move(f.output), run.state->georef);
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeRunFilesSink() { return std::make_unique<RunFilesSink>(); }

}  // namespace aerovo::run_steps
