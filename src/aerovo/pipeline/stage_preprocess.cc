// The preprocessing stage: the pixels the odometry gets (pipeline/preprocess.h): the frame
// reduced to the pixel budget, its lens distortion undone (whole frames), its brightness
// scaled by RunConfig::illumination_k (!= 1).
#include <memory>

#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps {
namespace {

class PreprocessStage : public FrameStage {
 public:
  const char* name() const override { return "preprocess"; }

  void Process(FrameState& f, const RunContext& run) override {
    // The frame as read, or as the flat-field stage corrected it.
    GrayImageView view = f.pixels.empty() ? f.frame.gray.view() : f.pixels;
    if (run.reducer) view = run.reducer->Apply(view);
    if (run.undistorter) view = run.undistorter->Apply(view);
    if (run.config->illumination_k != 1.0) {
      view = ScaleBrightness(view, run.config->illumination_k, &dimmed_);
    }
    f.pixels = view;
  }

 private:
  GrayImage dimmed_;  // the frame at illumination_k < 1
};

}  // namespace

std::unique_ptr<FrameStage> MakePreprocessStage() { return std::make_unique<PreprocessStage>(); }

}  // namespace aerovo::run_steps
