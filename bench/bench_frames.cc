// The per-frame input checks and bounds (docs/inputs.md, "Frames that are not what the camera
// saw" and "Frame size: the pixel budget"): the repeated-frame hash every video frame pays
// (frames/frame_source.h PixelHash) and the reduction of frames above the pixel budget
// (pipeline/preprocess.h FrameReducer).
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "aerovo/frames/frame_source.h"
#include "aerovo/pipeline/preprocess.h"

namespace {

aerovo::GrayImage Noise(int w, int h) {
  cv::Mat m(h, w, CV_8UC1);
  cv::RNG rng(3);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return aerovo::ToGrayImage(m);
}

// Args: width, height.
void BM_PixelHash(benchmark::State& state) {
  const aerovo::GrayImage g = Noise(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  for (auto _ : state) benchmark::DoNotOptimize(aerovo::PixelHash(g));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * g.width() * g.height());
}
BENCHMARK(BM_PixelHash)->Args({1920, 1080})->Args({3840, 2160})->Unit(benchmark::kMicrosecond);

// Args: width, height; budget 24 MP (the default max_megapixels).
void BM_FrameReducer(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const aerovo::GrayImage g = Noise(w, h);
  aerovo::FrameReducer r(w, h, 24.0);
  for (auto _ : state) benchmark::DoNotOptimize(r.Apply(g.view()).data);
  state.counters["out_w"] = r.out_width_px();
}
BENCHMARK(BM_FrameReducer)->Args({8000, 6000})->Args({12000, 12000})->Unit(benchmark::kMillisecond);

// Args: width, height; the detection budget of video frames, 2.1 MP (the default
// detect_megapixels): 3840 x 2160 -> 1920 x 1080 by 2 x 2 block means.
void BM_DetectReduction(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const aerovo::GrayImage g = Noise(w, h);
  aerovo::FrameReducer r(w, h, 24.0, 2.1);
  for (auto _ : state) benchmark::DoNotOptimize(r.Apply(g.view()).data);
  state.counters["factor"] = r.factor();
}
BENCHMARK(BM_DetectReduction)->Args({3840, 2160})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
