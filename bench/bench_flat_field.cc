// The flat-field stage's per-frame work (features/flat_field.h; BENCHMARKS.md, "Sensor
// non-uniformity"): a sample joining the running estimate (RunningFlatField::Add), the estimate
// handed to the corrector (FlatFieldCorrector::Set: interpolated to the frame's pixels), and the
// removal with the contrast stretch (FlatFieldCorrector::Apply), at a thermal detector's 640x512
// (estimated on its own pixels) and at 1920x1080 (on a grid binned by 2).
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

BENCHMARK(BM_RunningAdd)->Args({640, 512})->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CorrectorSet)->Args({640, 512})->Args({1920, 1080})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CorrectorApply)->Args({640, 512})->Args({1920, 1080})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
