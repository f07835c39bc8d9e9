// The flat-field stage's per-frame work (features/flat_field.h; BENCHMARKS.md, "Sensor
// non-uniformity"): a sample joining the running estimate (RunningFlatField::Add), the estimate
// handed to the corrector (FlatFieldCorrector::Set: interpolated to the frame's pixels), and the
// removal with the contrast stretch (FlatFieldCorrector::Apply), at a thermal detector's 640x512
// (estimated on its own pixels) and at 1920x1080 (on a grid binned by 2); the motion test's shift
// search and a photo folder's whole estimate of 21 frames.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/features/flat_field.h"

namespace {

// Eight frames of uniform random pixels (seed 1), cycled.
std::vector<aerovo::GrayImage> Frames(int w, int h) {
  std::mt19937 rng(1);
  std::vector<aerovo::GrayImage> frames;
  for (int i = 0; i < 8; ++i) {
    aerovo::GrayImage f(w, h);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) f.at(x, y) = static_cast<std::uint8_t>(rng() % 256);
    }
    frames.push_back(std::move(f));
  }
  return frames;
}

// Args: width, height.
void BM_RunningAdd(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const std::vector<aerovo::GrayImage> frames = Frames(w, h);
  aerovo::RunningFlatField running(w, h, 120);
  std::size_t i = 0;
  for (auto _ : state) running.Add(frames[i++ % frames.size()].view());
  benchmark::DoNotOptimize(running.estimate().significance);
}

void BM_CorrectorSet(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const std::vector<aerovo::GrayImage> frames = Frames(w, h);
  const aerovo::FlatFieldEstimate e = aerovo::EstimateFlatField(
      {frames[0].view(), frames[1].view(), frames[2].view(), frames[3].view()});
  aerovo::FlatFieldCorrector corrector;
  for (auto _ : state) corrector.Set(e, aerovo::FlatFieldOptions{});
  benchmark::DoNotOptimize(corrector.gain());
}

void BM_CorrectorApply(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const std::vector<aerovo::GrayImage> frames = Frames(w, h);
  const aerovo::FlatFieldEstimate e = aerovo::EstimateFlatField(
      {frames[0].view(), frames[1].view(), frames[2].view(), frames[3].view()});
  aerovo::FlatFieldCorrector corrector;
  corrector.Set(e, aerovo::FlatFieldOptions{});
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(corrector.Apply(frames[i++ % frames.size()].view()).data);
  }
}

// The motion test's shift search (GroundMotion::Best) of two coarse images of a grid of
// width x height (64 x 51 for 640x512, 64 x 36 for a 1920x1080 frame's 960x540 grid).
void BM_GroundMotionBest(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const std::vector<aerovo::GrayImage> frames = Frames(w, h);
  aerovo::GroundMotion motion(w, h);
  std::vector<float> grid(static_cast<std::size_t>(w) * h), a(motion.size()), b(motion.size());
  for (int k = 0; k < 2; ++k) {
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) grid[static_cast<std::size_t>(y) * w + x] = frames[k].at(x, y);
    }
    motion.Coarse(grid.data(), k == 0 ? a.data() : b.data());
  }
  for (auto _ : state) benchmark::DoNotOptimize(motion.Best(a.data(), b.data()).ncc);
}

// A photo folder's estimate (MedianFlatField::Estimate: the medians and the motion test) of 21
// frames of width x height.
void BM_MedianEstimate(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const std::vector<aerovo::GrayImage> frames = Frames(w, h);
  aerovo::MedianFlatField median(w, h, 21);
  for (int i = 0; i < 21; ++i) median.Add(frames[i % frames.size()].view());
  for (auto _ : state) benchmark::DoNotOptimize(median.Estimate().significance);
}

BENCHMARK(BM_GroundMotionBest)->Args({640, 512})->Args({960, 540})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MedianEstimate)->Args({640, 512})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RunningAdd)->Args({640, 512})->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CorrectorSet)->Args({640, 512})->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CorrectorApply)->Args({640, 512})->Args({1920, 1080})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
