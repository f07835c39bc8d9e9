// The transforms sink: the frame's row of transforms.csv (run_steps.h
// RunOutputs::AppendTransform), in full-frame pixels whatever the reduction.
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class TransformsSink : public FrameSink {
 public:
  const char* name() const override { return "transforms"; }

  void Write(FrameState& f, const RunContext& run) override {
    const Eigen::Matrix3d& world_from_frame = f.result.world_from_frame;
    run.outputs->AppendTransform(
        f.frame.index,
        run.reducer ? Eigen::Matrix3d(world_from_frame * run.reduced_from_full) : world_from_frame);
  }
};

}  // namespace

std::unique_ptr<FrameSink> MakeTransformsSink() { return std::make_unique<TransformsSink>(); }

}  // namespace aerovo::run_steps
