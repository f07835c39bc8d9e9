// SURF speed (aerovo) against OpenCV's detectors on the same images, MATLAB defaults
// (threshold 1000, 3 octaves, 4 scale levels, 64-value descriptor, not upright).
//
// Images (from $AEROVO_SHARED, default ../shared beside the source tree):
//   0: 640x480   tampa-phantom3/DJI_0100.JPG resized (INTER_AREA)
//   1: 800x600   tampa-phantom3/DJI_0100.JPG
//   2: 1920x1080 crop of ortho/callas-quarry.jpg at (4000, 2500): quarry, forest, field.
// Each benchmark reports `keypoints`. Benchmarks whose image is missing skip with a message.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "aerovo/features/surf.h"
#include "aerovo/frames/image_file.h"

namespace {

std::filesystem::path SharedDir() {
  if (const char* env = std::getenv("AEROVO_SHARED"); env != nullptr && *env != '\0') {
    return env;
  }
  return AEROVO_SHARED_DIR_DEFAULT;
}

struct BenchImage {
  std::string name;
  cv::Mat mat;  // CV_8UC1, empty when the source is missing
};

const std::vector<BenchImage>& Images() {
  static const std::vector<BenchImage> images = [] {
    std::vector<BenchImage> v(3);
    v[0].name = "640x480 tampa DJI_0100 resized";
    v[1].name = "800x600 tampa DJI_0100";
    v[2].name = "1920x1080 callas-quarry crop (4000,2500)";
    // The decoder's grey (IMREAD_GRAYSCALE), as these figures were measured; empty if absent.
    const auto read = [](const std::filesystem::path& p) {
      return std::filesystem::exists(p) ? aerovo::ReadGrayImage(p, aerovo::GrayFrom::kDecoder)
                                        : cv::Mat();
    };
    const cv::Mat tampa = read(SharedDir() / "data/flights/tampa-phantom3/DJI_0100.JPG");
    if (!tampa.empty()) {
      cv::resize(tampa, v[0].mat, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
      v[1].mat = tampa;
    }
    const cv::Mat ortho = read(SharedDir() / "data/ortho/callas-quarry.jpg");
    if (!ortho.empty()) v[2].mat = ortho(cv::Rect(4000, 2500, 1920, 1080)).clone();
    return v;
  }();
  return images;
}

const cv::Mat* GetImage(benchmark::State& state) {
  const BenchImage& im = Images().at(state.range(0));
  if (im.mat.empty()) {
    state.SkipWithError(("shared data not found for " + im.name +
                         " (set AEROVO_SHARED or place ../shared beside the source tree)")
                            .c_str());
    return nullptr;
  }
  state.SetLabel(im.name);
  return &im.mat;
}

aerovo::GrayImageView View(const cv::Mat& m) {
  return aerovo::GrayImageView{m.data, m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step)};
}

aerovo::SurfOptions Options(benchmark::State& state) {
  aerovo::SurfOptions o;  // MATLAB defaults
  o.num_threads = static_cast<int>(state.range(1));
  return o;
}

void BM_SurfDetect(benchmark::State& state) {
  const cv::Mat* m = GetImage(state);
  if (m == nullptr) return;
  aerovo::Surf surf(Options(state));
  std::size_t n = 0;
  for (auto _ : state) {
    std::vector<aerovo::Keypoint> kps = surf.Detect(View(*m));
    n = kps.size();
    benchmark::DoNotOptimize(kps.data());
  }
  state.counters["keypoints"] = static_cast<double>(n);
}

void BM_SurfDescribe(benchmark::State& state) {
  const cv::Mat* m = GetImage(state);
  if (m == nullptr) return;
  aerovo::Surf surf(Options(state));
  const std::vector<aerovo::Keypoint> kps = surf.Detect(View(*m));
  for (auto _ : state) {
    aerovo::FeatureSet fs = surf.Describe(View(*m), kps);
    benchmark::DoNotOptimize(fs.descriptors.data());
  }
  state.counters["keypoints"] = static_cast<double>(kps.size());
}

// The timed loop of a fixed-threshold SURF with `options` on `m`; counter: points kept.
void TimeDetectAndDescribe(benchmark::State& state, const cv::Mat& m,
                           const aerovo::SurfOptions& options) {
  aerovo::Surf surf(options);
  std::size_t n = 0;
  for (auto _ : state) {
    aerovo::SurfResult r = surf.DetectAndDescribe(View(m));
    n = r.features.size();
    benchmark::DoNotOptimize(r.features.descriptors.data());
  }
  state.counters["keypoints"] = static_cast<double>(n);
}

void BM_SurfDetectAndDescribe(benchmark::State& state) {
  const cv::Mat* m = GetImage(state);
  if (m == nullptr) return;
  TimeDetectAndDescribe(state, *m, Options(state));
}

// The default of `aerovo run` (SurfOptions::adaptive with its defaults: a contrast-normalised
// floor, per-cell selection of target_points, only the kept points described). Counters: points
// kept, candidates that reached the selection (SurfResult::candidates), the steered floor and
// the cells searched again below their floor per call (SurfResult::cells_redone, mean).
void BM_SurfAdaptiveDetectAndDescribe(benchmark::State& state) {
  const cv::Mat* m = GetImage(state);
  if (m == nullptr) return;
  aerovo::SurfOptions o = Options(state);
  o.adaptive = true;
  if (state.range(2) > 0) o.min_response = static_cast<double>(state.range(2));
  aerovo::Surf surf(o);
  std::size_t n = 0;
  int candidates = 0;
  // Steered as in a stream of this image (the odometry passes each frame's next_min_response
  // and next_cell_min_response to the next call): the steady state of a flight over similar
  // ground.
  aerovo::SurfResult first = surf.DetectAndDescribe(View(*m));
  double steered = first.next_min_response;
  std::vector<float> steered_cells = std::move(first.next_cell_min_response);
  long redone = 0, calls = 0;
  for (auto _ : state) {
    aerovo::SurfResult r = surf.DetectAndDescribe(View(*m), steered, steered_cells);
    steered = r.next_min_response;
    steered_cells.swap(r.next_cell_min_response);
    redone += r.cells_redone;
    ++calls;
    n = r.features.size();
    candidates = r.candidates;
    benchmark::DoNotOptimize(r.features.descriptors.data());
  }
  state.counters["keypoints"] = static_cast<double>(n);
  state.counters["candidates"] = static_cast<double>(candidates);
  state.counters["floor"] = steered;
  state.counters["cells_redone"] = calls > 0 ? static_cast<double>(redone) / calls : 0.0;
}

// The fixed threshold at the adaptive default's number of points: hessian_threshold found by
// bisection (outside the timing) so that the fixed detector keeps about SurfOptions::
// target_points (1500) on the image, the cost the adaptive selection is compared with at equal
// output (BM_SurfAdaptiveDetectAndDescribe). Counters: points kept, the threshold found.
void BM_SurfFixedAtTargetPoints(benchmark::State& state) {
  const cv::Mat* m = GetImage(state);
  if (m == nullptr) return;
  aerovo::SurfOptions o = Options(state);
  const int target = aerovo::SurfOptions{}.target_points;
  double lo = 1.0, hi = 20000.0;  // Hessian thresholds (MATLAB units): many points .. few
  for (int i = 0; i < 30 && hi / lo > 1.01; ++i) {
    o.hessian_threshold = std::sqrt(lo * hi);
    const std::size_t n = aerovo::Surf(o).Detect(View(*m)).size();
    (static_cast<int>(n) > target ? lo : hi) = o.hessian_threshold;
  }
  o.hessian_threshold = hi;  // at most target points
  TimeDetectAndDescribe(state, *m, o);
  state.counters["threshold"] = o.hessian_threshold;
}

template <typename Make>
void OpenCvDetectAndCompute(benchmark::State& state, Make make) {
  const cv::Mat* m = GetImage(state);
  if (m == nullptr) return;
  cv::setNumThreads(static_cast<int>(state.range(1)) == 1 ? 1 : -1);
  cv::Ptr<cv::Feature2D> f = make();
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  for (auto _ : state) {
    f->detectAndCompute(*m, cv::noArray(), kps, desc);
    benchmark::DoNotOptimize(desc.data);
  }
  state.counters["keypoints"] = static_cast<double>(kps.size());
  cv::setNumThreads(-1);
}

void BM_OpenCvSift(benchmark::State& state) {
  OpenCvDetectAndCompute(state, [] { return cv::SIFT::create(); });
}
void BM_OpenCvOrb(benchmark::State& state) {
  OpenCvDetectAndCompute(state, [] { return cv::ORB::create(5000); });
}
void BM_OpenCvAkaze(benchmark::State& state) {
  OpenCvDetectAndCompute(state, [] { return cv::AKAZE::create(); });
}

// Args: {image index, threads (1 = single-threaded, 0 = all cores)}.
void SurfArgs(benchmark::internal::Benchmark* b) {
  for (int threads : {1, 0}) {
    for (int image : {0, 1, 2}) b->Args({image, threads});
  }
  b->ArgNames({"image", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(BM_SurfDetect)->Apply(SurfArgs);
BENCHMARK(BM_SurfDescribe)->Apply(SurfArgs);
BENCHMARK(BM_SurfDetectAndDescribe)->Apply(SurfArgs);
BENCHMARK(BM_SurfFixedAtTargetPoints)->Apply(SurfArgs);
// Args: {image, threads, surf.min_response (0 = the default)}: the cost of the floor.
BENCHMARK(BM_SurfAdaptiveDetectAndDescribe)
    ->ArgNames({"image", "threads", "min_response"})
    ->ArgsProduct({{0, 1, 2}, {1, 0}, {0}})
    ->ArgsProduct({{2}, {1}, {50, 100, 200, 400}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
// OpenCV baselines on the 1080p crop, single-threaded (cv::setNumThreads(1)).
BENCHMARK(BM_OpenCvSift)
    ->Args({2, 1})
    ->ArgNames({"image", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_OpenCvOrb)
    ->Args({2, 1})
    ->ArgNames({"image", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_OpenCvAkaze)
    ->Args({2, 1})
    ->ArgNames({"image", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
