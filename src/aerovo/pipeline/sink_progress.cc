// The progress sink: RunCallbacks::progress after every frame (frames done, frames expected or
// -1, frames per second since the run started).
#include <algorithm>
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class ProgressSink : public FrameSink {
 public:
  const char* name() const override { return "progress"; }

  void Write(FrameState& f, const RunContext& run) override {
    (void)f;
    if (!run.callbacks->progress) return;
    const RunSummary& s = *run.summary;
    run.callbacks->progress(s.frames_processed, s.frames_expected,
                            s.frames_processed / std::max(1e-9, run.wall->elapsed_ms() / 1000.0));
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeProgressSink() { return std::make_unique<ProgressSink>(); }

}  // namespace aerovo::run_steps
