// Adaptive interest points (SurfOptions::adaptive): the per-cell selection keeps each cell's
// strongest points, reaches the target on low-contrast frames, is contrast invariant, and gives
// identical output for identical input and any thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#if AEROVO_TESTS_HAVE_OPENCV  // the bench's 1080p crop is a JPEG: read with OpenCV
#include <opencv2/imgcodecs.hpp>
#endif

#include "aerovo/core/error.h"
#include "aerovo/core/simd.h"
#include "aerovo/core/testing.h"
#include "aerovo/features/surf.h"

namespace aerovo::surf_adaptive_test {
namespace {

// Value noise: random levels on grids of 6 and 17 px, bilinearly interpolated and summed, mapped
// to mean + amplitude * [-1, 1]. `amplitude_right` (when >= 0) replaces the amplitude on the right
// half (a half-textured frame).
GrayImage MakeTexture(int w, int h, std::uint32_t seed, double mean, double amplitude,
                      double amplitude_right = -1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto grid = [&](int step) {
    const int gw = w / step + 2, gh = h / step + 2;
    std::vector<double> g(static_cast<std::size_t>(gw) * gh);
    for (double& v : g) v = u(rng);
    return [g, gw, step](double x, double y) {
      const int x0 = static_cast<int>(x / step), y0 = static_cast<int>(y / step);
      const double fx = x / step - x0, fy = y / step - y0;
      const auto at = [&](int i, int j) { return g[static_cast<std::size_t>(j) * gw + i]; };
      return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
             fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
    };
  };
  const auto fine = grid(6), coarse = grid(17);
  GrayImage image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double a = (amplitude_right >= 0.0 && x >= w / 2) ? amplitude_right : amplitude;
      const double v = 0.6 * fine(x, y) + 0.4 * coarse(x, y);
      image.at(x, y) = static_cast<std::uint8_t>(std::clamp(std::lround(mean + a * v), 0L, 255L));
    }
  }
  return image;
}

SurfOptions Adaptive(int target, int grid) {
  SurfOptions o;
  o.adaptive = true;
  o.target_points = target;
  o.grid = grid;
  return o;
}

int CellOf(const Keypoint& kp, int w, int h, int g) {
  const int cx = std::clamp(static_cast<int>(kp.x * g / w), 0, g - 1);
  const int cy = std::clamp(static_cast<int>(kp.y * g / h), 0, g - 1);
  return cy * g + cx;
}

TEST(SurfAdaptive, EachCellKeepsItsStrongestAndTheTargetIsReached) {
  const int w = 480, h = 360, g = 3, target = 360;
  const GrayImage img = MakeTexture(w, h, 7, 128, 100);
  Surf adaptive(Adaptive(target, g));
  const SurfResult r = adaptive.DetectAndDescribe(img.view());
  ASSERT_GT(r.floor_response, 0.0);
  ASSERT_EQ(static_cast<int>(r.features.size()), target);
  // Every candidate: the fixed-threshold detector at the adaptive floor.
  SurfOptions all;
  all.hessian_threshold = r.floor_response;
  const std::vector<Keypoint> cand = Surf(all).Detect(img.view());
  ASSERT_GT(static_cast<int>(cand.size()), 2 * target)
      << "the floor should leave more candidates than the target";
  // `candidates` counts those that reached the selection: the others were rejected early,
  // already beaten by enough stronger points (surf.h).
  ASSERT_LE(r.candidates, static_cast<int>(cand.size()));
  ASSERT_GT(r.candidates, target);
  const int quota = target / (g * g);
  for (int c = 0; c < g * g; ++c) {
    std::vector<float> cand_resp, kept_resp;
    for (const Keypoint& kp : cand) {
      if (CellOf(kp, w, h, g) == c) cand_resp.push_back(kp.response);
    }
    for (const Keypoint& kp : r.features.keypoints) {
      if (CellOf(kp, w, h, g) == c) kept_resp.push_back(kp.response);
    }
    std::sort(cand_resp.rbegin(), cand_resp.rend());
    std::sort(kept_resp.rbegin(), kept_resp.rend());
    const int want = std::min<int>(quota, static_cast<int>(cand_resp.size()));
    ASSERT_GE(static_cast<int>(kept_resp.size()), want) << "cell " << c;
    // The cell's `want` strongest candidates are all kept.
    for (int k = 0; k < want; ++k) EXPECT_EQ(kept_resp[k], cand_resp[k]) << "cell " << c;
  }
  // Sorted by decreasing response, as in fixed mode.
  for (std::size_t k = 1; k < r.features.size(); ++k) {
    EXPECT_GE(r.features.keypoints[k - 1].response, r.features.keypoints[k].response);
  }
}

TEST(SurfAdaptive, ReachesTheTargetOnALowContrastFrameWhereTheFixedThresholdFindsFew) {
  const int w = 640, h = 512, target = 800;
  const GrayImage dim = MakeTexture(w, h, 11, 128, 12);  // ~24 grey levels of texture
  const std::size_t fixed = Surf().Detect(dim.view()).size();
  const SurfResult r = Surf(Adaptive(target, 4)).DetectAndDescribe(dim.view());
  EXPECT_LT(fixed, static_cast<std::size_t>(target / 10)) << "MATLAB's threshold on a dim frame";
  EXPECT_EQ(static_cast<int>(r.features.size()), target);
  EXPECT_NEAR(r.contrast_range, 19, 6) << "1st to 99th percentile of the texture";
  // Every cell of the 4x4 grid has points.
  std::vector<int> per_cell(16, 0);
  for (const Keypoint& kp : r.features.keypoints) ++per_cell[CellOf(kp, w, h, 4)];
  for (int c = 0; c < 16; ++c) EXPECT_GE(per_cell[c], target / 16) << "cell " << c;
}

TEST(SurfAdaptive, TheWeakHalfOfAHalfTexturedFrameGetsItsShare) {
  const int w = 600, h = 300, g = 6, target = 720;
  const GrayImage img = MakeTexture(w, h, 3, 128, 110, 8);  // right half nearly flat
  int fixed_right = 0;
  for (const Keypoint& kp : Surf().Detect(img.view())) fixed_right += kp.x >= w / 2 ? 1 : 0;
  // The weak half's responses are ~(8/110)^2 of the strong half's: below the default floor
  // (min_response 100 gives it 50 points); a floor of 20 gives it its share.
  SurfOptions o = Adaptive(target, g);
  o.min_response = 20;
  const SurfResult r = Surf(o).DetectAndDescribe(img.view());
  int right = 0;
  for (const Keypoint& kp : r.features.keypoints) right += kp.x >= w / 2 + 2 ? 1 : 0;
  EXPECT_LT(fixed_right, 10);
  // Half of the cells, each with its quota (target / 36 = 20), at least.
  EXPECT_GE(right, target / 2 - 2 * h / 50);
}

TEST(SurfAdaptive, ScalingTheBrightnessKeepsThePoints) {
  // k = 0.25 as in the paper's illumination experiment: the floor follows the contrast, so
  // most points are the same (rounding to 8 bits moves some).
  const GrayImage img = MakeTexture(480, 360, 5, 128, 110);
  GrayImage dark(480, 360);
  for (int y = 0; y < 360; ++y) {
    for (int x = 0; x < 480; ++x) dark.at(x, y) = static_cast<std::uint8_t>(std::lround(img.at(x, y) * 0.25));
  }
  Surf surf(Adaptive(400, 4));
  const SurfResult a = surf.DetectAndDescribe(img.view());
  const SurfResult b = surf.DetectAndDescribe(dark.view());
  ASSERT_EQ(a.features.size(), 400u);
  ASSERT_EQ(b.features.size(), 400u);
  EXPECT_NEAR(b.floor_response / a.floor_response, 0.0625, 0.01);
  int same = 0;
  for (const Keypoint& p : a.features.keypoints) {
    for (const Keypoint& q : b.features.keypoints) {
      if (std::hypot(p.x - q.x, p.y - q.y) < 1.0 && std::abs(p.scale - q.scale) < 0.3f * p.scale) {
        ++same;
        break;
      }
    }
  }
  EXPECT_GT(same, 300) << "of 400";
}

TEST(SurfAdaptive, IdenticalForIdenticalInputAndAnyThreadCount) {
  const GrayImage img = MakeTexture(640, 480, 9, 120, 90);
  SurfOptions o = Adaptive(500, 6);
  o.num_threads = 1;
  Surf one(o);
  const SurfResult a = one.DetectAndDescribe(img.view());
  const SurfResult a2 = one.DetectAndDescribe(img.view());
  o.num_threads = 3;
  const SurfResult b = Surf(o).DetectAndDescribe(img.view());
  ASSERT_EQ(a.features.size(), 500u);
  for (const SurfResult* other : {&a2, &b}) {
    ASSERT_EQ(other->features.size(), a.features.size());
    EXPECT_EQ(other->candidates, a.candidates);
    for (std::size_t k = 0; k < a.features.size(); ++k) {
      const Keypoint &p = a.features.keypoints[k], &q = other->features.keypoints[k];
      ASSERT_EQ(p.x, q.x);
      ASSERT_EQ(p.y, q.y);
      ASSERT_EQ(p.scale, q.scale);
      ASSERT_EQ(p.orientation, q.orientation);
    }
    EXPECT_EQ(other->features.descriptors, a.features.descriptors);
  }
}

TEST(SurfAdaptive, FewerCandidatesThanTheTargetAreAllKeptAndABlankFrameHasNone) {
  const GrayImage img = MakeTexture(200, 160, 2, 128, 100);
  const SurfResult r = Surf(Adaptive(100000, 4)).DetectAndDescribe(img.view());
  EXPECT_EQ(static_cast<int>(r.features.size()), r.candidates);
  GrayImage blank(200, 160);
  for (int y = 0; y < 160; ++y) {
    for (int x = 0; x < 200; ++x) blank.at(x, y) = 90;
  }
  EXPECT_EQ(Surf(Adaptive(500, 4)).DetectAndDescribe(blank.view()).features.size(), 0u);
}

TEST(SurfAdaptive, FixedModeIsUnchangedByTheAdaptiveOptions) {
  const GrayImage img = MakeTexture(320, 240, 4, 128, 100);
  SurfOptions o;
  const std::vector<Keypoint> a = Surf(o).Detect(img.view());
  o.target_points = 10;
  o.grid = 2;
  o.min_response = 500;
  const std::vector<Keypoint> b = Surf(o).Detect(img.view());
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].response, b[k].response);
}

// ---------------------------------------------------------------- exactness of the selection

// StrongerFirst of surf.cc, restated: response, then y, x, scale (a total order).
bool Stronger(const Keypoint& a, const Keypoint& b) {
  if (a.response != b.response) return a.response > b.response;
  if (a.y != b.y) return a.y < b.y;
  if (a.x != b.x) return a.x < b.x;
  return a.scale < b.scale;
}

// The selection of SurfOptions::adaptive written out plainly on every candidate (the
// fixed-threshold detector at the adaptive floor): each cell of the grid over `r` keeps its
// strongest quota = max(1, target / cells), the strongest of the others fill up to the target;
// sorted strongest first. *next_min_response as SurfResult's.
std::vector<Keypoint> ReferenceSelection(std::vector<Keypoint> cand, const RectI& r, int g,
                                         int target, double floor, double min_response,
                                         double* next_min_response) {
  const double c2 = floor / min_response;
  std::sort(cand.begin(), cand.end(), Stronger);
  if (static_cast<int>(cand.size()) <= target) {
    *next_min_response = 0.5 * min_response;
    return cand;
  }
  const int cells = g * g, quota = std::max(1, target / cells);
  std::vector<int> taken(cells, 0);
  std::vector<Keypoint> kept, rest;
  double weakest = std::numeric_limits<double>::infinity();
  for (const Keypoint& kp : cand) {  // strongest first
    const int cx = std::clamp(static_cast<int>((kp.x - r.x) * g / r.width), 0, g - 1);
    const int cy = std::clamp(static_cast<int>((kp.y - r.y) * g / r.height), 0, g - 1);
    int& n = taken[cy * g + cx];
    if (n < quota) {
      kept.push_back(kp);
    } else {
      if (n == quota) weakest = std::min(weakest, static_cast<double>(kp.response));
      rest.push_back(kp);
    }
    ++n;
  }
  for (int c = 0; c < cells; ++c) {
    if (taken[c] <= quota) weakest = std::min(weakest, floor);
  }
  *next_min_response = 0.5 * weakest / c2;
  for (std::size_t k = 0; k < rest.size() && static_cast<int>(kept.size()) < target; ++k) {
    kept.push_back(rest[k]);
  }
  std::sort(kept.begin(), kept.end(), Stronger);
  return kept;
}

void ExpectSameKeypoints(const std::vector<Keypoint>& want, const std::vector<Keypoint>& got,
                         const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k) {
    const Keypoint &p = want[k], &q = got[k];
    ASSERT_TRUE(p.x == q.x && p.y == q.y && p.scale == q.scale && p.response == q.response &&
                p.orientation == q.orientation && p.laplacian == q.laplacian &&
                p.octave == q.octave)
        << what << ": keypoint " << k << " expected (" << p.x << ", " << p.y << ", scale "
        << p.scale << ", response " << p.response << "), got (" << q.x << ", " << q.y << ", scale "
        << q.scale << ", response " << q.response << ")";
  }
}

// The adaptive output is exactly the plain selection over every candidate above the floor
// (same points, same order, same values), for several grids, targets, a roi, steered floors and
// thread counts: whatever shortcut the detector takes to reject candidates early must not
// change what is kept. The descriptors are those of Describe on the kept points.
TEST(SurfAdaptive, TheSelectionIsExactlyThePlainSelectionOverAllCandidates) {
  struct Case {
    int w, h, target, grid, threads;
    std::optional<RectI> roi;
    double steer;
  };
  const Case cases[] = {
      {1920, 1080, 1500, 6, 1, std::nullopt, 0.0},
      {1920, 1080, 1500, 6, 2, std::nullopt, 0.0},
      {1920, 1080, 1500, 6, 1, std::nullopt, 300.0},
      {1280, 720, 700, 5, 1, std::nullopt, 0.0},
      {1280, 720, 400, 3, 3, RectI{101, 37, 1000, 601}, 0.0},
      {800, 600, 2000, 7, 1, std::nullopt, 0.0},
      {640, 480, 300, 1, 1, std::nullopt, 0.0},
  };
  std::uint32_t seed = 21;
  for (const Case& c : cases) {
    const GrayImage img = MakeTexture(c.w, c.h, seed++, 128, 100);
    SurfOptions o = Adaptive(c.target, c.grid);
    o.num_threads = c.threads;
    o.roi = c.roi;
    const std::string what = std::to_string(c.w) + "x" + std::to_string(c.h) + " target " +
                             std::to_string(c.target) + " grid " + std::to_string(c.grid) +
                             " threads " + std::to_string(c.threads) + (c.roi ? " roi" : "") +
                             " steer " + std::to_string(c.steer);
    Surf surf(o);
    const SurfResult r = surf.DetectAndDescribe(img.view(), c.steer);
    SurfOptions all;
    all.hessian_threshold = r.floor_response;
    all.roi = c.roi;
    const std::vector<Keypoint> cand = Surf(all).Detect(img.view());
    EXPECT_LE(r.candidates, static_cast<int>(cand.size())) << what;
    EXPECT_GT(r.candidates, c.target) << what;
    const RectI rect = c.roi ? *c.roi : RectI{0, 0, c.w, c.h};
    double next = 0.0;
    const std::vector<Keypoint> want = ReferenceSelection(
        cand, rect, c.grid, c.target, r.floor_response, std::max(o.min_response, c.steer), &next);
    ExpectSameKeypoints(want, r.features.keypoints, what);
    EXPECT_DOUBLE_EQ(r.next_min_response, next) << what;
    SurfOptions d = o;
    const FeatureSet described = Surf(d).Describe(img.view(), r.features.keypoints);
    EXPECT_EQ(described.descriptors, r.features.descriptors) << what;
  }
}

// A 64-bit FNV-1a over the bytes of every keypoint field, every descriptor value and the
// steering output (next_min_response) of an adaptive result: any change of any bit of the
// output changes it. `candidates` is left out: a count of the work, not an output.
std::uint64_t Fingerprint(const SurfResult& r) {
  std::uint64_t h = 1469598103934665603ull;
  const auto add = [&h](const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) h = (h ^ b[k]) * 1099511628211ull;
  };
  for (const Keypoint& kp : r.features.keypoints) {
    add(&kp.x, sizeof kp.x);
    add(&kp.y, sizeof kp.y);
    add(&kp.scale, sizeof kp.scale);
    add(&kp.orientation, sizeof kp.orientation);
    add(&kp.response, sizeof kp.response);
    add(&kp.laplacian, sizeof kp.laplacian);
    add(&kp.octave, sizeof kp.octave);
  }
  add(r.features.descriptors.data(), r.features.descriptors.size() * sizeof(float));
  add(&r.next_min_response, sizeof r.next_min_response);
  return h;
}

// The adaptive defaults' output, bit for bit, as computed before the early rejection of
// candidates (the SURF speed budget; recorded with main at 94bfcea): a first
// call and a call steered by its next_min_response (as bench_features and a stream do), with 1
// and 2 threads. The values are those of the native kernels on x86-64 with AVX2+FMA (the
// Hessian rows may fuse a multiply-add, hessian.h); elsewhere only the thread invariance is
// checked. TheSelectionIsExactlyThePlainSelectionOverAllCandidates is the portable check.
void ExpectFingerprints(const GrayImage& img, std::uint64_t first, std::uint64_t steered,
                        int points, const std::string& what) {
  // Pinned to the optimised build: the sanitizer build (-O1, instrumented) rounds a few
  // operations differently, as for the reference outputs (tests/CMakeLists.txt).
#if defined(__SANITIZE_ADDRESS__)
  const bool pinned = false;
#else
  const bool pinned = ActiveSimdMode() == SimdMode::kNative && SimdTargetName() == "avx2";
#endif
  std::uint64_t got_first[2] = {}, got_steered[2] = {};
  for (int t = 0; t < 2; ++t) {
    SurfOptions o = Adaptive(1500, 6);
    o.num_threads = t + 1;
    Surf surf(o);
    const SurfResult a = surf.DetectAndDescribe(img.view());
    const SurfResult b = surf.DetectAndDescribe(img.view(), a.next_min_response);
    // Steered per cell too (as the odometry does): the same output, fewer candidates.
    const SurfResult c =
        surf.DetectAndDescribe(img.view(), a.next_min_response, a.next_cell_min_response);
    EXPECT_EQ(Fingerprint(c), Fingerprint(b)) << what << ": the cell floors changed the output";
    EXPECT_EQ(c.next_cell_min_response, b.next_cell_min_response) << what;
    EXPECT_EQ(c.cells_redone, 0) << what;
    EXPECT_LT(c.candidates, b.candidates) << what;
    EXPECT_EQ(static_cast<int>(a.features.size()), points) << what;
    got_first[t] = Fingerprint(a);
    got_steered[t] = Fingerprint(b);
    std::printf(
        "%s, %d thread(s): %d points of %d candidates, fingerprints 0x%016llxull "
        "0x%016llxull (steered by %.3f: %d candidates; and per cell: %d)\n",
        what.c_str(), t + 1, static_cast<int>(a.features.size()), a.candidates,
        static_cast<unsigned long long>(got_first[t]),
        static_cast<unsigned long long>(got_steered[t]), a.next_min_response, b.candidates,
        c.candidates);
  }
  EXPECT_EQ(got_first[0], got_first[1]) << what << ": thread count changed the output";
  EXPECT_EQ(got_steered[0], got_steered[1]) << what << ": thread count changed the output";
  if (!pinned) {
    std::printf(
        "fingerprints not compared: recorded with the native AVX2 kernels of the optimised "
        "build, this run uses %s (or is instrumented)\n",
        SimdTargetName().c_str());
    return;
  }
  EXPECT_EQ(got_first[0], first) << what << ": the adaptive output changed";
  EXPECT_EQ(got_steered[0], steered) << what << ": the steered adaptive output changed";
}

TEST(SurfAdaptive, OutputUnchangedOnASynthetic1080pFrame) {
  const GrayImage img = MakeTexture(1920, 1080, 1080, 128, 100);
  ExpectFingerprints(img, 0x58cf3892ea85e8f1ull, 0x58cf3892ea85e8f1ull, 1500,
                     "synthetic 1920x1080");
}

#if AEROVO_TESTS_HAVE_OPENCV
TEST(SurfAdaptive, OutputUnchangedOnTheBench1080pCrop) {
  AEROVO_REQUIRE_SHARED(path, "data/ortho/callas-quarry.jpg");
  // bench_features' image 2: the 1920x1080 crop at (4000, 2500), the decoder's grey.
  const cv::Mat grey = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(grey.empty()) << path;
  const cv::Mat crop = grey(cv::Rect(4000, 2500, 1920, 1080)).clone();
  GrayImage img(crop.cols, crop.rows);
  for (int y = 0; y < crop.rows; ++y) {
    for (int x = 0; x < crop.cols; ++x) img.at(x, y) = crop.at<std::uint8_t>(y, x);
  }
  ExpectFingerprints(img, 0x860c3aa1de94b904ull, 0x860c3aa1de94b904ull, 1500,
                     "bench 1080p callas crop");
}
#endif

// ---------------------------------------------------------------- cell floors of a stream

// The w x h window of `src` at (x0, y0), intensities v -> mean + gain * (v - mean).
GrayImage Window(const GrayImage& src, int x0, int y0, int w, int h, double gain = 1.0) {
  GrayImage out(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double v = 128.0 + gain * (src.at(x0 + x, y0 + y) - 128.0);
      out.at(x, y) = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  }
  return out;
}

// A stream steered per cell (next_cell_min_response passed on, as the odometry does) gives,
// frame by frame, exactly the output of the stream steered by next_min_response alone: the same
// points, descriptors and next_min_response, whether the cell floors held (fewer candidates) or
// cut a point the selection needs (those cells searched again). The frames: a window moving over a
// texture whose right half is nearly flat (a flat cell holds the frame's floor low), a jump to new
// ground, a contrast change; then cell floors far too high, every one cut.
TEST(SurfAdaptive, CellFloorsChangeNoPointOfAStream) {
  const GrayImage ground = MakeTexture(1100, 700, 31, 128, 100, 6);
  struct Step {
    int x, y;
    double gain;
  };
  const Step steps[] = {{0, 0, 1.0},     {9, 4, 1.0},     {18, 8, 1.0},    {27, 12, 1.0},
                        {420, 150, 1.0}, {429, 154, 1.0}, {438, 158, 0.6}, {447, 162, 0.6}};
  const int w = 640, h = 480, g = 6;
  for (const int threads : {1, 2}) {
    SurfOptions o = Adaptive(600, g);
    o.num_threads = threads;
    Surf cells(o), plain(o);
    double steer = 0.0;
    std::vector<float> steer_cells;
    int fewer = 0, redone = 0;
    for (const Step& s : steps) {
      const GrayImage img = Window(ground, s.x, s.y, w, h, s.gain);
      const std::string what = "frame at (" + std::to_string(s.x) + ", " + std::to_string(s.y) +
                               "), " + std::to_string(threads) + " thread(s)";
      const SurfResult a = cells.DetectAndDescribe(img.view(), steer, steer_cells);
      const SurfResult b = plain.DetectAndDescribe(img.view(), steer);
      ExpectSameKeypoints(b.features.keypoints, a.features.keypoints, what);
      EXPECT_EQ(a.features.descriptors, b.features.descriptors) << what;
      EXPECT_EQ(a.next_min_response, b.next_min_response) << what;
      EXPECT_EQ(b.cells_redone, 0) << what;
      // The next cell floors: 0.8 of each cell's bound after floors that all held (and without
      // floors), 0.5 after a cut.
      ASSERT_EQ(a.next_cell_min_response.size(), static_cast<std::size_t>(g * g)) << what;
      ASSERT_EQ(b.next_cell_min_response.size(), static_cast<std::size_t>(g * g)) << what;
      const double ratio = a.cells_redone > 0 ? 0.5 / 0.8 : 1.0;
      for (int c = 0; c < g * g; ++c) {
        EXPECT_NEAR(a.next_cell_min_response[c], ratio * b.next_cell_min_response[c],
                    1e-6 * b.next_cell_min_response[c])
            << what << ", cell " << c;
      }
      EXPECT_LE(a.candidates, b.candidates) << what;
      fewer += a.candidates < b.candidates ? 1 : 0;
      redone += a.cells_redone;
      steer = a.next_min_response;
      steer_cells = a.next_cell_min_response;
    }
    // The floors save candidates on most frames, and cut needed points on some (the jump to
    // new ground above all), whose cells were searched again: the check, not luck, keeps the
    // output.
    EXPECT_GE(fewer, 5) << threads << " thread(s)";
    EXPECT_GT(redone, 0) << threads << " thread(s)";
    // Floors far above every response: each cell cut, so the detection is redone.
    const GrayImage img = Window(ground, 0, 0, w, h);
    const SurfResult want = plain.DetectAndDescribe(img.view());
    const SurfResult got =
        cells.DetectAndDescribe(img.view(), 0.0, std::vector<float>(g * g, 1e9f));
    EXPECT_EQ(got.cells_redone, g * g);
    ExpectSameKeypoints(want.features.keypoints, got.features.keypoints, "floors of 1e9");
    EXPECT_EQ(got.features.descriptors, want.features.descriptors);
    EXPECT_EQ(got.next_min_response, want.next_min_response);
    // With a roi: the cells (over the roi) searched again reach beyond it, the roi still holds.
    SurfOptions r = o;
    r.roi = RectI{37, 21, 560, 433};
    Surf cells_roi(r), plain_roi(r);
    const SurfResult first = plain_roi.DetectAndDescribe(img.view());
    const GrayImage next = Window(ground, 9, 4, w, h);
    const SurfResult want_roi = plain_roi.DetectAndDescribe(next.view(), first.next_min_response);
    for (const float scale : {1.f, 1e9f}) {
      std::vector<float> floors = first.next_cell_min_response;
      for (float& f : floors) f *= scale;
      const SurfResult got_roi =
          cells_roi.DetectAndDescribe(next.view(), first.next_min_response, floors);
      ExpectSameKeypoints(want_roi.features.keypoints, got_roi.features.keypoints, "roi");
      EXPECT_EQ(got_roi.features.descriptors, want_roi.features.descriptors);
      if (scale > 1.f) {
        EXPECT_GT(got_roi.cells_redone, 0);
      }
    }
    std::printf("%d thread(s): %zu frames, fewer candidates on %d, %d cells redone\n", threads,
                std::size(steps), fewer, redone);
  }
}

TEST(SurfAdaptive, CellFloorsOfTheWrongSizeOrValueAreRefused) {
  const GrayImage img = MakeTexture(320, 240, 5, 128, 100);
  Surf surf(Adaptive(300, 4));
  EXPECT_THROW(surf.DetectAndDescribe(img.view(), 0.0, std::vector<float>(15, 1.f)),
               InvalidArgument);
  std::vector<float> bad(16, 1.f);
  bad[3] = -1.f;
  EXPECT_THROW(surf.DetectAndDescribe(img.view(), 0.0, bad), InvalidArgument);
  bad[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(surf.DetectAndDescribe(img.view(), 0.0, bad), InvalidArgument);
  // Fixed-threshold mode ignores them (as steered_min_response).
  EXPECT_NO_THROW(Surf(SurfOptions{}).DetectAndDescribe(img.view(), 0.0, bad));
}

}  // namespace
}  // namespace aerovo::surf_adaptive_test
