// Lens undistortion of the whole frame (docs/lenses.md, "Points or whole frames";
// frames/camera.h Undistorter::Apply, one cv::remap with maps computed once) against undistorting only
// the interest points (Undistorter::UndistortPoints, OpenCV's iterative inverse of the lens model),
// pinhole and fisheye lenses.
#include <benchmark/benchmark.h>

#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "aerovo/camera/lens.h"
#include "aerovo/frames/camera.h"
#include "aerovo/frames/frame_source.h"

namespace {

aerovo::CameraIntrinsics Lens(int w, int h, bool fisheye) {
  // A 93-degree camera (f = (w / 2) / tan(46.5 deg)).
  aerovo::CameraIntrinsics k = aerovo::IntrinsicsFromFocalPx(0.4745 * w, w, h);
  if (fisheye) {
    k.model = aerovo::LensModel::kFisheye;
    k.distortion = {-0.05, 0.01, -0.002, 0.0005};
  } else {
    k.distortion = {-0.25, 0.07, 0.0005, -0.0003, -0.008};
  }
  return k;
}

// Args: width, height, fisheye (0/1).
void BM_UndistortImage(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const aerovo::Undistorter u(Lens(w, h, state.range(2) != 0));
  cv::Mat m(h, w, CV_8UC1);
  cv::RNG(3).fill(m, cv::RNG::UNIFORM, 0, 256);
  const aerovo::GrayImage in = aerovo::ToGrayImage(m);
  aerovo::GrayImage out;
  for (auto _ : state) benchmark::DoNotOptimize(u.Apply(in.view(), &out).data);
}
BENCHMARK(BM_UndistortImage)
    ->Args({1920, 1080, 0})->Args({1920, 1080, 1})->Args({3840, 2160, 0})->Args({3840, 2160, 1})
    ->Args({4000, 3000, 0})->Args({4000, 3000, 1})
    ->Unit(benchmark::kMillisecond);

// Args: width, height, fisheye (0/1), points (the adaptive SURF target is 1500).
void BM_UndistortPoints(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  aerovo::Undistorter u(Lens(w, h, state.range(2) != 0));
  std::vector<cv::Point2f> base(static_cast<std::size_t>(state.range(3)));
  cv::RNG rng(5);
  // y drawn before x in its own statement (a call's argument order is unspecified; this is the
  // order x86-64 GCC used for cv::Point2f(rng.uniform(..), rng.uniform(..))).
  for (auto& p : base) {
    const float y = rng.uniform(0.0f, h - 1.0f);
    p = cv::Point2f(rng.uniform(0.0f, w - 1.0f), y);
  }
  std::vector<cv::Point2f> pts;
  pts.reserve(base.size());
  for (auto _ : state) {
    pts.assign(base.begin(), base.end());
    u.UndistortPoints(&pts);
    benchmark::DoNotOptimize(pts.data());
  }
}
BENCHMARK(BM_UndistortPoints)
    ->Args({1920, 1080, 0, 1500})->Args({1920, 1080, 1, 1500})->Args({4000, 3000, 0, 1500})
    ->Args({4000, 3000, 1, 1500})
    ->Unit(benchmark::kMillisecond);

// The run's points path (`aerovo run --undistort points`): camera/lens.h LensUndistortion on
// each keypoint, as odometry/visual_odometry.cc does. Args: width, height, fisheye, points.
void BM_UndistortKeypoints(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const aerovo::LensUndistortion lens(Lens(w, h, state.range(2) != 0));
  std::vector<std::pair<double, double>> base(static_cast<std::size_t>(state.range(3)));
  cv::RNG rng(5);
  // A braced list is evaluated left to right ([dcl.init.list]): x then y on every compiler.
  for (auto& p : base) p = {rng.uniform(0.0, w - 1.0), rng.uniform(0.0, h - 1.0)};
  for (auto _ : state) {
    double sum = 0.0;
    for (const auto& p : base) {
      double u = 0.0, v = 0.0;
      if (lens.UndistortPixel(p.first, p.second, &u, &v)) sum += u + v;
    }
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_UndistortKeypoints)
    ->Args({1920, 1080, 0, 1500})->Args({1920, 1080, 1, 1500})->Args({3840, 2160, 0, 1500})
    ->Args({3840, 2160, 1, 1500})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
