// Descriptor matching speed: aerovo's exhaustive (blocked SIMD, Laplacian-split, threads of
// core/parallel.h) and guided matcher against OpenCV's cv::BFMatcher knnMatch(k = 2) on the same
// descriptors.
//
// Data: N prev points with random 64-d unit descriptors, random Laplacian sign, random positions
// in a 4000 x 3000 frame (12 MP, DJI stills); curr = the prev points moved by a small rotation
// + shift with noised descriptors (SSD ~0.02), in shuffled order. Every query has a true match,
// as in consecutive video frames; the cost of exhaustive matching does not depend on that.
//
// Run: build-x/bench/bench_matching --benchmark_filter=... (see BENCHMARKS.md, "## Matching").
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "aerovo/features/surf.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/matching/matcher.h"

namespace {

using aerovo::FeatureSet;
using aerovo::Keypoint;

struct Pair {
  FeatureSet prev, curr;
  Eigen::Matrix<double, 2, 3> curr_from_prev;
};

void Normalize(float* d, int dim) {
  double n = 0.0;
  for (int k = 0; k < dim; ++k) n += static_cast<double>(d[k]) * d[k];
  const float inv = static_cast<float>(1.0 / std::sqrt(n));
  for (int k = 0; k < dim; ++k) d[k] *= inv;
}

const Pair& GetPair(int n) {
  static std::vector<std::pair<int, Pair>> cache;
  for (const auto& [size, pair] : cache) {
    if (size == n) return pair;
  }
  const int dim = 64;
  std::mt19937 rng(12345u + n);
  std::normal_distribution<float> g(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.018f);
  std::uniform_real_distribution<float> ux(0.f, 4000.f), uy(0.f, 3000.f);
  std::bernoulli_distribution sign(0.5);
  Pair p;
  const double a = 0.02;
  p.curr_from_prev << std::cos(a), -std::sin(a), 30.0, std::sin(a), std::cos(a), -12.0;
  p.prev.descriptor_size = p.curr.descriptor_size = dim;
  p.prev.keypoints.resize(n);
  p.prev.descriptors.resize(static_cast<std::size_t>(n) * dim);
  for (int i = 0; i < n; ++i) {
    Keypoint& k = p.prev.keypoints[i];
    k.x = ux(rng);
    k.y = uy(rng);
    k.laplacian = sign(rng) ? 1 : -1;
    float* d = p.prev.descriptor(i);
    for (int j = 0; j < dim; ++j) d[j] = g(rng);
    Normalize(d, dim);
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  p.curr.keypoints.resize(n);
  p.curr.descriptors.resize(static_cast<std::size_t>(n) * dim);
  for (int slot = 0; slot < n; ++slot) {
    const int src = order[slot];
    Keypoint k = p.prev.keypoints[src];
    const Eigen::Vector2d q = p.curr_from_prev * Eigen::Vector3d(k.x, k.y, 1.0);
    k.x = static_cast<float>(q.x());
    k.y = static_cast<float>(q.y());
    p.curr.keypoints[slot] = k;
    float* d = p.curr.descriptor(slot);
    for (int j = 0; j < dim; ++j) d[j] = p.prev.descriptor(src)[j] + noise(rng);
    Normalize(d, dim);
  }
  cache.emplace_back(n, std::move(p));
  return cache.back().second;
}

// Args: N, threads (0 = all), check_laplacian, use_avx2.
void BM_AerovoExhaustive(benchmark::State& state) {
  const Pair& p = GetPair(static_cast<int>(state.range(0)));
  aerovo::MatchOptions o;
  o.num_threads = static_cast<int>(state.range(1));
  o.check_laplacian = state.range(2) != 0;
  o.use_avx2 = state.range(3) != 0;
  aerovo::Matcher matcher(o);
  aerovo::MatchResult r;
  for (auto _ : state) {
    r = matcher.Match(p.prev, p.curr);
    benchmark::DoNotOptimize(r.matches.data());
  }
  state.counters["matches"] = static_cast<double>(r.matches.size());
  state.counters["pairs/s"] = benchmark::Counter(static_cast<double>(r.num_comparisons),
                                                 benchmark::Counter::kIsIterationInvariantRate);
}

// Args: N, threads, radius px.
void BM_AerovoGuided(benchmark::State& state) {
  const Pair& p = GetPair(static_cast<int>(state.range(0)));
  aerovo::MatchOptions o;
  o.num_threads = static_cast<int>(state.range(1));
  o.guided_radius_px = static_cast<float>(state.range(2));
  aerovo::Matcher matcher(o);
  aerovo::MatchResult r;
  for (auto _ : state) {
    r = matcher.Match(p.prev, p.curr, {}, p.curr_from_prev);
    benchmark::DoNotOptimize(r.matches.data());
  }
  state.counters["matches"] = static_cast<double>(r.matches.size());
  state.counters["pairs/s"] = benchmark::Counter(static_cast<double>(r.num_comparisons),
                                                 benchmark::Counter::kIsIterationInvariantRate);
}

// The refinement's calls (correspondence stage): curr prepared once per frame pair
// (MatchCandidates, outside the timed loop as the stage amortises it over its calls), every
// prev point matched within a tight radius (the final pass, 6 px) or a wide one (40 px).
// Args: N, radius px.
void BM_AerovoGuidedPrepared(benchmark::State& state) {
  const Pair& p = GetPair(static_cast<int>(state.range(0)));
  aerovo::MatchOptions o;
  o.guided_radius_px = static_cast<float>(state.range(1));
  aerovo::Matcher matcher(o);
  const aerovo::MatchCandidates prepared(p.curr);
  aerovo::MatchResult r;
  for (auto _ : state) {
    r = matcher.Match(p.prev, prepared, {}, p.curr_from_prev);
    benchmark::DoNotOptimize(r.matches.data());
  }
  state.counters["matches"] = static_cast<double>(r.matches.size());
  state.counters["queries/s"] = benchmark::Counter(static_cast<double>(p.prev.size()),
                                                   benchmark::Counter::kIsIterationInvariantRate);
}

// Clustered RANSAC's call: a cell's points (prev_subset) against all curr points.
// Args: N, subset size (the first `size` prev indices; positions are random, so any set works).
void BM_AerovoSubset(benchmark::State& state) {
  const Pair& p = GetPair(static_cast<int>(state.range(0)));
  std::vector<int> subset(static_cast<std::size_t>(state.range(1)));
  std::iota(subset.begin(), subset.end(), 0);
  aerovo::Matcher matcher;
  aerovo::MatchResult r;
  for (auto _ : state) {
    r = matcher.Match(p.prev, p.curr, subset);
    benchmark::DoNotOptimize(r.matches.data());
  }
  state.counters["matches"] = static_cast<double>(r.matches.size());
  state.counters["pairs/s"] = benchmark::Counter(static_cast<double>(r.num_comparisons),
                                                 benchmark::Counter::kIsIterationInvariantRate);
}

// Share of the exhaustive matches (same prev and curr index) that `got` also has.
double RecallVs(const std::vector<aerovo::Match>& got, const std::vector<aerovo::Match>& want) {
  std::size_t found = 0, k = 0;
  for (const aerovo::Match& w : want) {
    while (k < got.size() && got[k].prev_index < w.prev_index) ++k;
    found +=
        k < got.size() && got[k].prev_index == w.prev_index && got[k].curr_index == w.curr_index;
  }
  return want.empty() ? 1.0 : static_cast<double>(found) / static_cast<double>(want.size());
}

// Randomized k-d forest (MatchAlgorithm::kKdForest) against exhaustive, one thread.
// Args: N, kd_max_checks (0 = exhaustive: the reference row), kd_trees, prepared (1: curr
// prepared once outside the timed loop, so the forest is built once as for repeated calls
// against one frame; 0: built in every call, as for a single call), unique (1:
// MatchOptions::unique, also for the exhaustive reference). Counters: recall = share of the
// exhaustive matches found; build_ms = one forest build (prepared rows).
void BM_KdForest(benchmark::State& state) {
  const Pair& p = GetPair(static_cast<int>(state.range(0)));
  aerovo::MatchOptions o;
  o.algorithm = aerovo::MatchAlgorithm::kKdForest;
  o.kd_max_checks = static_cast<int>(state.range(1));
  o.kd_trees = static_cast<int>(state.range(2));
  const bool prepared = state.range(3) != 0;
  o.unique = state.range(4) != 0;
  aerovo::MatchOptions reference;
  reference.unique = o.unique;
  aerovo::Matcher matcher(o);
  const aerovo::MatchResult want = aerovo::Matcher(reference).Match(p.prev, p.curr);
  aerovo::MatchCandidates candidates(p.curr);
  if (prepared) {
    const auto t0 = std::chrono::steady_clock::now();
    matcher.Match(p.prev, candidates, {0});  // builds the forest
    state.counters["build_ms"] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  aerovo::MatchResult r;
  for (auto _ : state) {
    if (!prepared) candidates.Reset(p.curr);
    r = matcher.Match(p.prev, candidates);
    benchmark::DoNotOptimize(r.matches.data());
  }
  state.counters["matches"] = static_cast<double>(r.matches.size());
  state.counters["recall"] = RecallVs(r.matches, want.matches);
  state.counters["pairs"] = static_cast<double>(r.num_comparisons);
}

// OpenCV baseline: BFMatcher(NORM_L2) knnMatch k = 2 (no Laplacian split), plus the same
// ratio test and threshold on squared distances so that the match count is comparable.
// Args: N, threads (cv::setNumThreads; 0 = OpenCV's default).
void BM_OpenCvBfKnn(benchmark::State& state) {
  const Pair& p = GetPair(static_cast<int>(state.range(0)));
  const int n = static_cast<int>(p.prev.size());
  const cv::Mat q(n, 64, CV_32F, const_cast<float*>(p.prev.descriptors.data()));
  const cv::Mat t(n, 64, CV_32F, const_cast<float*>(p.curr.descriptors.data()));
  const int old_threads = cv::getNumThreads();
  cv::setNumThreads(static_cast<int>(state.range(1)) == 0 ? -1 : static_cast<int>(state.range(1)));
  cv::BFMatcher bf(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  int matches = 0;
  for (auto _ : state) {
    knn.clear();  // knnMatch appends
    bf.knnMatch(q, t, knn, 2);
    matches = 0;
    for (const auto& m : knn) {
      if (m.size() == 2) {
        const float s1 = m[0].distance * m[0].distance, s2 = m[1].distance * m[1].distance;
        matches += s1 <= 0.04f && s1 <= 0.6f * s2;
      }
    }
    benchmark::DoNotOptimize(matches);
  }
  cv::setNumThreads(old_threads);
  state.counters["matches"] = matches;
  state.counters["pairs/s"] =
      benchmark::Counter(static_cast<double>(n) * n, benchmark::Counter::kIsIterationInvariantRate);
}

// --- Real descriptors: SURF on two 1920 x 1080 crops of the Callas quarry orthophoto, the
// second shifted by (+60, -35) px (the guided prior is that exact shift). Hessian threshold
// 1000 (MATLAB's default) and 200 (dense: tens of thousands of points, as on real flights).

std::filesystem::path SharedDir() {
  if (const char* env = std::getenv("AEROVO_SHARED"); env != nullptr && *env != '\0') return env;
  return AEROVO_SHARED_DIR_DEFAULT;
}

struct RealPair {
  Pair pair;
  bool ok = false;
};

const RealPair& GetRealPair(int threshold) {
  static std::vector<std::pair<int, RealPair>> cache;
  for (const auto& [t, rp] : cache) {
    if (t == threshold) return rp;
  }
  RealPair rp;
  // The decoder's grey (IMREAD_GRAYSCALE), as these figures were measured; empty if absent.
  const std::filesystem::path file = SharedDir() / "data/ortho/callas-quarry.jpg";
  const cv::Mat full = std::filesystem::exists(file)
                           ? aerovo::ReadGrayImage(file, aerovo::GrayFrom::kDecoder)
                           : cv::Mat();
  if (!full.empty()) {
    const int x0 = 3000, y0 = 1600, dx = 60, dy = -35;
    const cv::Mat a = full(cv::Rect(x0, y0, 1920, 1080)).clone();
    const cv::Mat b = full(cv::Rect(x0 + dx, y0 + dy, 1920, 1080)).clone();
    aerovo::SurfOptions so;
    so.hessian_threshold = threshold;
    so.num_threads = 0;
    aerovo::Surf surf(so);
    const auto view = [](const cv::Mat& m) {
      return aerovo::GrayImageView{m.data, m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step)};
    };
    rp.pair.prev = surf.DetectAndDescribe(view(a)).features;
    rp.pair.curr = surf.DetectAndDescribe(view(b)).features;
    rp.pair.curr_from_prev << 1, 0, -dx, 0, 1, -dy;
    rp.ok = true;
  }
  cache.emplace_back(threshold, std::move(rp));
  return cache.back().second;
}

// Args: threshold, mode (0 exhaustive, 1 guided 40 px, 2 cv::BFMatcher, 3 k-d forest with the
// default budget, 4 k-d forest with kd_max_checks 32), threads. Counter recall: share of the
// exhaustive matches found (aerovo modes).
void BM_RealOrtho(benchmark::State& state) {
  const RealPair& rp = GetRealPair(static_cast<int>(state.range(0)));
  if (!rp.ok) {
    state.SkipWithError("shared data not found: data/ortho/callas-quarry.jpg (set AEROVO_SHARED)");
    return;
  }
  const Pair& p = rp.pair;
  const int mode = static_cast<int>(state.range(1));
  const int threads = static_cast<int>(state.range(2));
  double matches = 0, pairs = 0;
  if (mode == 2) {
    const cv::Mat q(static_cast<int>(p.prev.size()), 64, CV_32F,
                    const_cast<float*>(p.prev.descriptors.data()));
    const cv::Mat t(static_cast<int>(p.curr.size()), 64, CV_32F,
                    const_cast<float*>(p.curr.descriptors.data()));
    const int old_threads = cv::getNumThreads();
    cv::setNumThreads(threads);
    cv::BFMatcher bf(cv::NORM_L2);
    std::vector<std::vector<cv::DMatch>> knn;
    for (auto _ : state) {
      knn.clear();
      bf.knnMatch(q, t, knn, 2);
      int m = 0;
      for (const auto& k : knn) {
        if (k.size() == 2) {
          const float s1 = k[0].distance * k[0].distance, s2 = k[1].distance * k[1].distance;
          m += s1 <= 0.04f && s1 <= 0.6f * s2;
        }
      }
      matches = m;
    }
    cv::setNumThreads(old_threads);
    pairs = static_cast<double>(p.prev.size()) * p.curr.size();
  } else {
    aerovo::MatchOptions o;
    o.num_threads = threads;
    if (mode >= 3) o.algorithm = aerovo::MatchAlgorithm::kKdForest;
    if (mode == 4) o.kd_max_checks = 32;
    aerovo::Matcher matcher(o);
    aerovo::MatchResult r;
    for (auto _ : state) {
      r = mode == 1 ? matcher.Match(p.prev, p.curr, {}, p.curr_from_prev)
                    : matcher.Match(p.prev, p.curr);
      benchmark::DoNotOptimize(r.matches.data());
    }
    const aerovo::MatchResult want = aerovo::Matcher().Match(p.prev, p.curr);
    if (mode != 1) state.counters["recall"] = RecallVs(r.matches, want.matches);
    matches = static_cast<double>(r.matches.size());
    pairs = static_cast<double>(r.num_comparisons);
  }
  state.counters["points"] = static_cast<double>(p.prev.size());
  state.counters["matches"] = matches;
  state.counters["pairs/s"] =
      benchmark::Counter(pairs, benchmark::Counter::kIsIterationInvariantRate);
}

void ExhaustiveArgs(benchmark::internal::Benchmark* b) {
  for (int n : {1000, 5000, 20000}) {
    for (int threads : {1, 2}) {
      b->Args({n, threads, 1, 1});
      b->Args({n, threads, 0, 1});
    }
    b->Args({n, 1, 1, 0});  // SSE4.2 kernel
  }
}

}  // namespace

BENCHMARK(BM_AerovoExhaustive)->Apply(ExhaustiveArgs)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_AerovoGuided)
    ->ArgsProduct({{1000, 5000, 20000}, {1, 2}, {40}})
    ->Args({20000, 1, 100})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_AerovoGuidedPrepared)
    ->ArgsProduct({{1000, 5000, 20000}, {6, 40}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
BENCHMARK(BM_AerovoSubset)
    ->ArgsProduct({{5000, 20000}, {12, 50, 200, 1000}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
BENCHMARK(BM_KdForest)
    ->ArgsProduct({{2000, 5000, 20000}, {0, 16, 32, 64, 128}, {4}, {0}, {0}})
    ->ArgsProduct({{2000, 5000, 20000}, {32, 64}, {4}, {1}, {0}})
    ->ArgsProduct({{20000}, {32, 64}, {1, 2, 8}, {1}, {0}})
    ->ArgsProduct({{50000}, {0, 64}, {4}, {0}, {0}})
    ->ArgsProduct({{20000}, {0, 64}, {4}, {0}, {1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_OpenCvBfKnn)
    ->ArgsProduct({{1000, 5000, 20000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK(BM_RealOrtho)
    ->ArgsProduct({{1000, 200}, {0, 1, 2, 3, 4}, {1}})
    ->Args({1000, 0, 2})
    ->Args({200, 0, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
