// Every Hessian-row kernel against the portable scalar loop, and SURF's keypoints with the
// scalar, Highway and native kernels.
#include "aerovo/features/hessian.h"

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "aerovo/core/simd.h"
#include "aerovo/features/integral_image.h"
#include "aerovo/features/surf.h"

namespace aerovo::hessian_test {
namespace {

using surf_detail::BoxFilterLayout;

// Restores the process's SIMD mode (and Highway's target choice) at scope exit.
struct SimdModeGuard {
  SimdMode saved = ActiveSimdMode();
  ~SimdModeGuard() {
    SetSimdMode(saved);
    hwy::SetSupportedTargetsForTest(0);
  }
};

GrayImage RandomTexture(int w, int h, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(0, 255);
  GrayImage img(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) img.at(x, y) = static_cast<std::uint8_t>(u(rng));
  }
  return img;
}

// Smooth blobs on a gradient: a SURF test image with a few hundred keypoints at every octave.
GrayImage Blobs(int w, int h, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0, w), uy(0, h), us(1.5, 12.0), ua(-120, 120);
  std::vector<double> f(static_cast<std::size_t>(w) * h, 0.0);
  for (int b = 0; b < 160; ++b) {
    const double cx = ux(rng), cy = uy(rng), s = us(rng), a = ua(rng);
    const int r = static_cast<int>(3 * s) + 1;
    for (int y = std::max(0, static_cast<int>(cy) - r); y < std::min(h, static_cast<int>(cy) + r);
         ++y) {
      for (int x = std::max(0, static_cast<int>(cx) - r);
           x < std::min(w, static_cast<int>(cx) + r); ++x) {
        const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
        f[static_cast<std::size_t>(y) * w + x] += a * std::exp(-d2 / (2 * s * s));
      }
    }
  }
  GrayImage img(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double v = 128 + 0.2 * (x - w / 2) + f[static_cast<std::size_t>(y) * w + x];
      img.at(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0)));
    }
  }
  return img;
}

// Valid sample range [jmin, jmax) of a layout on a w-pixel axis (filter inside the image).
void ValidRange(const BoxFilterLayout& l, int w, int* jmin, int* jmax) {
  *jmin = (l.border + l.step - 1) / l.step;
  *jmax = (w + l.border - l.size) / l.step + 1;
}

// Dxx*Dyy and 0.81*Dxy^2 at a sample, in double, from the integer box sums.
void Terms(const IntegralImage& ii, const BoxFilterLayout& l, int i, int j, double* p, double* q) {
  const int x0 = l.step * j - l.border, y0 = l.step * i - l.border;
  const auto box = [&](int xa, int ya, int xb, int yb) {
    return static_cast<double>(static_cast<std::int32_t>(ii.BoxSum(x0 + xa, y0 + ya, x0 + xb, y0 + yb)));
  };
  const double dxx = (box(0, l.band0, l.size, l.band1) -
                      3 * box(l.lobe, l.band0, 2 * l.lobe, l.band1)) * l.inv_area_xx;
  const double dyy = (box(l.band0, 0, l.band1, l.size) -
                      3 * box(l.band0, l.lobe, l.band1, 2 * l.lobe)) * l.inv_area_xx;
  const double dxy = (box(l.xy0, l.xy0, l.xy1, l.xy1) - box(l.xy2, l.xy0, l.xy3, l.xy1) -
                      box(l.xy0, l.xy2, l.xy1, l.xy3) + box(l.xy2, l.xy2, l.xy3, l.xy3)) *
                     l.inv_area_xy;
  *p = dxx * dyy;
  *q = 0.81 * dxy * dxy;
}

// Layouts of every sampling step the kernels specialise (1, 2, 4) and one they do not (8).
std::vector<BoxFilterLayout> TestLayouts() {
  return {surf_detail::MakeBoxFilterLayout(9, 1),  surf_detail::MakeBoxFilterLayout(27, 1),
          surf_detail::MakeBoxFilterLayout(15, 2), surf_detail::MakeBoxFilterLayout(51, 2),
          surf_detail::MakeBoxFilterLayout(27, 4), surf_detail::MakeBoxFilterLayout(99, 4),
          surf_detail::MakeBoxFilterLayout(51, 8)};
}

// Runs `rows` (the kernel under test) and the scalar loop on rows of every test layout, with
// row lengths 1 .. 40 (every tail of every vector width) and the full valid range. Both must be
// within the FMA tolerance of the double-precision reference (Terms); exact = in addition the
// kernel's results must be bit-identical to the scalar loop's.
template <class Rows>
void CompareWithScalar(const IntegralImage& ii, int w, int h, Rows rows, bool exact,
                       const std::string& what) {
  for (const BoxFilterLayout& l : TestLayouts()) {
    int jmin, jmax, imin, imax;
    ValidRange(l, w, &jmin, &jmax);
    ValidRange(l, h, &imin, &imax);
    ASSERT_LT(jmin + 41, jmax) << what << " size " << l.size;
    std::vector<std::pair<int, int>> spans;
    for (int len = 1; len <= 40; ++len) spans.emplace_back(jmin + len % 7, jmin + len % 7 + len);
    spans.emplace_back(jmin, jmax);
    spans.emplace_back(jmax - 13, jmax);  // ends at the last valid sample
    for (int i : {imin, (imin + imax) / 2, imax - 1}) {
      for (const auto& [j0, j1] : spans) {
        const int n = j1 - j0;
        std::vector<float> want(n + 1, -7.f), got(n + 1, -7.f);  // [n]: overrun guard
        surf_detail::HessianRowsScalar(ii, l, i, i + 1, j0, j1, want.data(), 0);
        rows(ii, l, i, i + 1, j0, j1, got.data(), 0);
        ASSERT_EQ(got[n], -7.f) << what << ": wrote past the row";
        for (int k = 0; k < n; ++k) {
          // Every kernel, the scalar one included, against the double-precision determinant
          // of the test's own box sums (Terms): each of the two products rounds once in float,
          // the difference once (or the fused version skips one rounding): 4 float epsilons
          // of the terms' magnitude.
          double p, q;
          Terms(ii, l, i, j0 + k, &p, &q);
          const double tol = 4 * FLT_EPSILON * (std::fabs(p) + q) + 1e-30;
          ASSERT_NEAR(got[k], p - q, tol) << what << " size " << l.size << " j " << j0 + k;
          ASSERT_NEAR(want[k], p - q, tol) << "scalar, size " << l.size << " j " << j0 + k;
          if (exact) {
            ASSERT_EQ(got[k], want[k]) << what << " size " << l.size << " step " << l.step << " i "
                                       << i << " j " << j0 + k;
          }
        }
      }
    }
  }
}

TEST(HessianKernelTest, HighwayIsBitIdenticalToScalarOnEveryTarget) {
  SimdModeGuard guard;
  const int w = 517, h = 251;  // odd sizes; wide enough for 40+ samples at step 8
  const GrayImage img = RandomTexture(w, h, 5);
  IntegralImage ii;
  ii.Compute(img.view());
  int tested = 0;
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    CompareWithScalar(ii, w, h, &surf_detail::HessianRowsHighway, true,
                      std::string("highway ") + hwy::TargetName(target));
    ++tested;
  }
  hwy::SetSupportedTargetsForTest(0);
  EXPECT_GE(tested, 1);
}

TEST(HessianKernelTest, EveryModeMatchesDoublePrecisionWithinTheFmaTolerance) {
  SimdModeGuard guard;
  const int w = 501, h = 233;
  const GrayImage img = RandomTexture(w, h, 9);
  IntegralImage ii;
  ii.Compute(img.view());
  for (SimdMode mode : {SimdMode::kNative, SimdMode::kHighway, SimdMode::kScalar}) {
    SetSimdMode(mode);
    const std::string name = SimdTargetName();
    const auto rows = [](const IntegralImage& in, const BoxFilterLayout& l, int i0, int i1,
                         int j0, int j1, float* out, std::ptrdiff_t) {
      // Through the public entry points (the mode's kernel).
      if (i1 - i0 == 1) {
        surf_detail::ComputeHessianRow(in, l, i0, j0, j1, out);
      }
    };
    CompareWithScalar(ii, w, h, rows, mode != SimdMode::kNative, name);
    // The 2-D entry point with a stride: every row as ComputeHessianRow's.
    const BoxFilterLayout l = surf_detail::MakeBoxFilterLayout(15, 1);
    int jmin, jmax, imin, imax;
    ValidRange(l, w, &jmin, &jmax);
    ValidRange(l, h, &imin, &imax);
    const std::ptrdiff_t stride = jmax + 3;
    std::vector<float> det(static_cast<std::size_t>(imax) * stride, 0.f);
    surf_detail::ComputeHessianDeterminant(ii, l, imin, imax, jmin, jmax, det.data(), stride);
    std::vector<float> row(jmax - jmin);
    for (int i = imin; i < imax; i += 17) {
      surf_detail::ComputeHessianRow(ii, l, i, jmin, jmax, row.data());
      for (int j = jmin; j < jmax; ++j) ASSERT_EQ(det[i * stride + j], row[j - jmin]) << name;
    }
  }
}

// The keypoints and descriptors SURF finds with the scalar kernels, the Highway ones and the
// native ones: identical between scalar and Highway (bit-identical determinants); with the
// native AVX2 loop (fused multiply-add in the determinant) the same points, positions and
// responses within 1e-4 (relative), descriptors within 1e-5.
TEST(HessianKernelTest, SurfKeypointsAreTheSameWithEveryKernel) {
  SimdModeGuard guard;
  const GrayImage img = Blobs(400, 300, 3);
  SurfOptions o;
  o.hessian_threshold = 100.0;
  const auto run = [&](SimdMode mode) {
    SetSimdMode(mode);
    Surf surf(o);
    return surf.DetectAndDescribe(img.view()).features;
  };
  const FeatureSet scalar = run(SimdMode::kScalar);
  const FeatureSet highway = run(SimdMode::kHighway);
  const FeatureSet native = run(SimdMode::kNative);
  ASSERT_GE(scalar.size(), 100u) << "test image too plain";
  ASSERT_EQ(highway.size(), scalar.size());
  ASSERT_EQ(native.size(), scalar.size());
  const int dim = scalar.descriptor_size;
  for (std::size_t k = 0; k < scalar.size(); ++k) {
    const Keypoint& a = scalar.keypoints[k];
    const Keypoint& b = highway.keypoints[k];
    const Keypoint& c = native.keypoints[k];
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.scale, b.scale);
    EXPECT_EQ(a.response, b.response);
    EXPECT_EQ(a.orientation, b.orientation);
    for (int d = 0; d < dim; ++d) ASSERT_EQ(scalar.descriptor(k)[d], highway.descriptor(k)[d]);
    EXPECT_NEAR(a.x, c.x, 1e-3) << k;
    EXPECT_NEAR(a.y, c.y, 1e-3) << k;
    EXPECT_NEAR(a.scale, c.scale, 1e-3) << k;
    EXPECT_NEAR(a.response, c.response, 1e-4 * std::fabs(a.response)) << k;
    EXPECT_EQ(a.laplacian, c.laplacian) << k;
    EXPECT_EQ(a.octave, c.octave) << k;
    for (int d = 0; d < dim; ++d) {
      ASSERT_NEAR(scalar.descriptor(k)[d], native.descriptor(k)[d], 1e-5) << k;
    }
  }
}

// The in-layer maximum scan: every kernel returns the scalar loop's j, from every start and end
// (every vector tail), on rows with many ties (levels from a small set), NaNs and infinities,
// for thresholds below, inside and above the values.
TEST(InLayerMaximumKernelTest, EveryKernelMatchesTheScalarLoop) {
  surf_detail::NamedInLayerMaximum kernels[4];
  const int n_kernels = surf_detail::InLayerMaximumKernels(kernels);
  ASSERT_GE(n_kernels, 2) << "no SIMD kernel on this CPU";
  std::mt19937 rng(5);
  const int n = 70;
  for (int trial = 0; trial < 60; ++trial) {
    std::uniform_int_distribution<int> level(0, trial % 3 == 0 ? 3 : 40);
    std::vector<float> rows[3];
    for (auto& r : rows) {
      r.resize(n + 2);
      for (float& v : r) v = static_cast<float>(level(rng)) * 0.5f;
    }
    if (trial % 4 == 1) {  // NaNs and infinities scattered on the rows
      std::uniform_int_distribution<int> pos(0, n + 1);
      for (int k = 0; k < 6; ++k) {
        rows[k % 3][pos(rng)] = k % 2 ? std::numeric_limits<float>::quiet_NaN()
                                      : std::numeric_limits<float>::infinity();
      }
    }
    // rows[*][0] is column -1: j runs over [1, n].
    const float* m0 = rows[0].data() + 1;
    const float* m1 = rows[1].data() + 1;
    const float* m2 = rows[2].data() + 1;
    for (const float t : {-1.f, 0.f, 3.f, 10.f, 19.5f, 25.f}) {
      for (int j0 = 0; j0 < 12; ++j0) {
        for (int end = j0; end <= n; end += (end < j0 + 20 ? 1 : 7)) {
          // Every maximum in [j0, end), found one after another as the detector does.
          std::vector<int> want;
          for (int j = surf_detail::NextInLayerMaximumScalar(m0, m1, m2, j0, end, t); j < end;
               j = surf_detail::NextInLayerMaximumScalar(m0, m1, m2, j + 1, end, t)) {
            want.push_back(j);
          }
          for (int k = 1; k < n_kernels; ++k) {
            std::vector<int> got;
            for (int j = kernels[k].fn(m0, m1, m2, j0, end, t); j < end;
                 j = kernels[k].fn(m0, m1, m2, j + 1, end, t)) {
              got.push_back(j);
            }
            ASSERT_EQ(got, want) << kernels[k].name << " trial " << trial << " threshold " << t
                                 << " range [" << j0 << ", " << end << ")";
          }
        }
      }
    }
  }
  // The scalar loop itself on hand-made rows: a plateau (ties) is no maximum, nor is a sample
  // next to a NaN; the threshold is strict.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float r0[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  const float r1[8] = {0, 5, 5, 0, 7, 0, 9, 0};
  const float r2[8] = {0, 0, 0, 0, 0, 0, 0, nan};
  EXPECT_EQ(surf_detail::NextInLayerMaximumScalar(r0, r1, r2, 1, 7, 1.f), 4);
  EXPECT_EQ(surf_detail::NextInLayerMaximumScalar(r0, r1, r2, 1, 7, 7.f), 7);
  EXPECT_EQ(surf_detail::NextInLayerMaximumScalar(r0, r1, r2, 5, 7, 1.f), 7);
}

}  // namespace
}  // namespace aerovo::hessian_test
