// The source counts sink: the summary's frames per height source (RunSummary::height_sources)
// and per attitude source of the frames whose keypoints were corrected for the attitude
// (attitude_sources, max_tilt_deg).
#include <algorithm>
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class SourceCountsSink : public FrameSink {
 public:
  const char* name() const override { return "source_counts"; }

  void Write(FrameState& f, const RunContext& run) override {
    RunSummary& summary = *run.summary;
    ++summary.height_sources[ToString(f.height_source)];
    if (f.result.attitude_corrected) {
      ++summary.attitude_sources[ToString(f.attitude.source)];
      summary.max_tilt_deg = std::max(summary.max_tilt_deg, f.result.tilt_deg);
    }
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeSourceCountsSink() { return std::make_unique<SourceCountsSink>(); }

}  // namespace aerovo::run_steps
