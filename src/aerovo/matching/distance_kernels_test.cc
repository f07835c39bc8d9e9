// Every distance-kernel set (hand-written SSE4 / AVX2, Highway on every target this CPU runs,
// the active SimdMode's) against the portable scalar loops on random inputs, odd dimensions
// and tails included. Slots, ids and orderings must be identical; scores (dot products) may
// differ by the rounding of fused multiply-adds: |diff| <= 1e-5 * (|norm| + 2 |q| |c|); the
// exact SSD and the squared norms must be bit-identical.
#include "aerovo/matching/distance_kernels.h"

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "aerovo/core/simd.h"

namespace aerovo::matching_detail::distance_kernels_test {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kDims[] = {64, 128, 37, 16, 8, 3, 1};

// Calls fn(kernels, name) for every kernel set there is on this CPU.
void ForEachKernelSet(const std::function<void(const Kernels&, const std::string&)>& fn) {
  if (const Kernels* k = Sse4Kernels()) fn(*k, "sse4");
  if (const Kernels* k = Avx2Kernels()) fn(*k, "avx2");
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    fn(HighwayKernels(), std::string("highway ") + hwy::TargetName(target));
  }
  hwy::SetSupportedTargetsForTest(0);
  fn(SelectKernels(true), std::string("active ") + SelectKernels(true).name);
}

struct Data {
  std::vector<float> rows;   // n x dim, row-major
  std::vector<float> norms;  // n
};

// n random descriptors (with a duplicate of row 1 at row n - 2: an exact tie).
Data RandomRows(int n, int dim, std::mt19937& rng) {
  std::normal_distribution<float> g(0.f, 0.3f);
  Data d;
  d.rows.resize(static_cast<std::size_t>(n) * dim);
  for (float& v : d.rows) v = g(rng);
  if (n >= 4) {
    for (int k = 0; k < dim; ++k) d.rows[static_cast<std::size_t>(n - 2) * dim + k] = d.rows[dim + k];
  }
  for (int j = 0; j < n; ++j) d.norms.push_back(ScalarKernels().norm(&d.rows[j * dim], dim));
  return d;
}

// Dimension-major panels of 8 candidates (kPanelWidth), padded to a multiple of kCandStep.
void Pack(const Data& c, int n, int dim, std::vector<float>* panels, std::vector<float>* norms) {
  const int padded = (n + kCandStep - 1) / kCandStep * kCandStep;
  panels->assign(static_cast<std::size_t>(padded) * dim, 0.f);
  norms->assign(padded, kInf);
  for (int j = 0; j < n; ++j) {
    const int p = j / kPanelWidth, l = j % kPanelWidth;
    for (int d = 0; d < dim; ++d) {
      (*panels)[static_cast<std::size_t>(p) * dim * kPanelWidth + d * kPanelWidth + l] =
          c.rows[static_cast<std::size_t>(j) * dim + d];
    }
    (*norms)[j] = c.norms[j];
  }
}

float ScoreTolerance(int dim) { return 1e-5f * (1.f + 3.f * 0.09f * dim); }

void ExpectSameLanes(const LaneTop2& want, const LaneTop2& got, float tol, const std::string& what) {
  for (int l = 0; l < kPanelWidth; ++l) {
    ASSERT_EQ(got.i1[l], want.i1[l]) << what << " lane " << l;
    ASSERT_EQ(got.i2[l], want.i2[l]) << what << " lane " << l;
    if (want.i1[l] >= 0) {
      ASSERT_NEAR(got.b1[l], want.b1[l], tol) << what << " lane " << l;
    }
    if (want.i2[l] >= 0) {
      ASSERT_NEAR(got.b2[l], want.b2[l], tol) << what << " lane " << l;
    }
  }
}

TEST(DistanceKernelsTest, TileMatchesScalar) {
  std::mt19937 rng(21);
  for (int dim : kDims) {
    for (int n : {1, 16, 45, 64}) {
      const Data cand = RandomRows(n, dim, rng);
      const Data q = RandomRows(kQueryTile, dim, rng);
      std::vector<float> panels, norms;
      Pack(cand, n, dim, &panels, &norms);
      const int num_slots = static_cast<int>(norms.size());
      LaneTop2 want[kQueryTile];
      for (auto& s : want) ResetLanes(&s);
      // Two calls (the second continues the first's state), as the matcher's blocks.
      const int half = num_slots >= 2 * kCandStep ? kCandStep : num_slots;
      const auto run = [&](const Kernels& k, LaneTop2* st) {
        k.tile(q.rows.data(), dim, panels.data(), norms.data(), 1000, half, st);
        if (half < num_slots) {
          k.tile(q.rows.data(), dim, panels.data() + static_cast<std::size_t>(half) * dim,
                 norms.data() + half, 1000 + half, num_slots - half, st);
        }
      };
      run(ScalarKernels(), want);
      ForEachKernelSet([&](const Kernels& k, const std::string& name) {
        LaneTop2 got[kQueryTile];
        for (auto& s : got) ResetLanes(&s);
        run(k, got);
        for (int t = 0; t < kQueryTile; ++t) {
          ExpectSameLanes(want[t], got[t], ScoreTolerance(dim),
                          name + " tile dim " + std::to_string(dim) + " n " + std::to_string(n));
        }
      });
    }
  }
}

TEST(DistanceKernelsTest, StreamMatchesScalar) {
  std::mt19937 rng(22);
  for (int dim : kDims) {
    for (int num_panels : {1, 2, 3}) {
      const Data q = RandomRows(num_panels * kPanelWidth, dim, rng);
      std::vector<float> panels, qnorms;
      Pack(q, num_panels * kPanelWidth, dim, &panels, &qnorms);
      const Data cand = RandomRows(2 * kStreamRows, dim, rng);
      LaneTop2 want[3];
      for (auto& s : want) ResetLanes(&s);
      const auto run = [&](const Kernels& k, LaneTop2* st) {
        for (int b = 0; b < 2; ++b) {  // two batches of rows, increasing ids
          const float* rows[kStreamRows];
          float norms[kStreamRows];
          std::int32_t ids[kStreamRows];
          for (int r = 0; r < kStreamRows; ++r) {
            const int j = b * kStreamRows + r;
            rows[r] = &cand.rows[static_cast<std::size_t>(j) * dim];
            norms[r] = b == 1 && r == kStreamRows - 1 ? kInf : cand.norms[j];  // padding
            ids[r] = 5 + j;
          }
          k.stream(rows, norms, ids, dim, panels.data(), num_panels, st);
        }
      };
      run(ScalarKernels(), want);
      ForEachKernelSet([&](const Kernels& k, const std::string& name) {
        LaneTop2 got[3];
        for (auto& s : got) ResetLanes(&s);
        run(k, got);
        for (int p = 0; p < num_panels; ++p) {
          ExpectSameLanes(want[p], got[p], ScoreTolerance(dim),
                          name + " stream dim " + std::to_string(dim));
        }
      });
    }
  }
}

TEST(DistanceKernelsTest, ListMatchesScalarIncludingTiesAndTails) {
  std::mt19937 rng(23);
  for (int dim : kDims) {
    const int n = 40;
    const Data cand = RandomRows(n, dim, rng);  // rows 1 and 38 are equal
    const Data q = RandomRows(1, dim, rng);
    std::vector<std::int32_t> tie_key(n);
    for (int j = 0; j < n; ++j) tie_key[j] = (j * 7) % n;  // not the slot order
    for (int num : {0, 1, 2, 3, 4, 5, 7, 8, 13, 40}) {
      std::vector<std::int32_t> slots;
      for (int k = 0; k < num; ++k) slots.push_back((k * 13 + 38) % n);  // 38 first, then ..., 1
      // Make the tie decide: the query equals row 1 (= row 38) when the list has both.
      std::vector<float> query = q.rows;
      if (num == n) query.assign(cand.rows.begin() + dim, cand.rows.begin() + 2 * dim);
      Best2 want;
      ScalarKernels().list(query.data(), dim, cand.rows.data(), cand.norms.data(), slots.data(),
                           num, tie_key.data(), &want);
      ForEachKernelSet([&](const Kernels& k, const std::string& name) {
        Best2 got;
        k.list(query.data(), dim, cand.rows.data(), cand.norms.data(), slots.data(), num,
               tie_key.data(), &got);
        const std::string what = name + " list dim " + std::to_string(dim) + " num " +
                                 std::to_string(num);
        ASSERT_EQ(got.j1, want.j1) << what;
        ASSERT_EQ(got.j2, want.j2) << what;
        if (want.j1 >= 0) {
          ASSERT_NEAR(got.s1, want.s1, ScoreTolerance(dim)) << what;
        }
        if (want.j2 >= 0) {
          ASSERT_NEAR(got.s2, want.s2, ScoreTolerance(dim)) << what;
        }
      });
      if (num == n) {
        // Rows 1 and 38 tie exactly; tie_key[1] = 7 < tie_key[38] = 26.
        EXPECT_EQ(want.j1, 1);
        EXPECT_EQ(want.j2, 38);
      }
    }
  }
}

TEST(DistanceKernelsTest, ExactSsdAndNormIdenticalInEverySet) {
  std::mt19937 rng(24);
  std::normal_distribution<float> g(0.f, 0.2f);
  for (int dim : {64, 128, 37, 15, 8, 7, 3, 1, 0}) {
    std::vector<float> a(dim + 1), b(dim + 1);
    for (int trial = 0; trial < 50; ++trial) {
      for (int k = 0; k < dim; ++k) {
        a[k] = g(rng);
        b[k] = trial % 2 ? a[k] + 1e-4f * g(rng) : g(rng);
      }
      const double want = ScalarKernels().exact(a.data(), b.data(), dim);
      const float want_norm = ScalarKernels().norm(a.data(), dim);
      double ref = 0.0;
      for (int k = 0; k < dim; ++k) ref += (double(a[k]) - b[k]) * (double(a[k]) - b[k]);
      ASSERT_NEAR(want, ref, 1e-12 * (1.0 + ref));
      ForEachKernelSet([&](const Kernels& k, const std::string& name) {
        ASSERT_EQ(k.exact(a.data(), b.data(), dim), want) << name << " dim " << dim;
        ASSERT_EQ(k.norm(a.data(), dim), want_norm) << name << " dim " << dim;
      });
    }
  }
}

TEST(DistanceKernelsTest, SelectKernelsFollowsTheSimdMode) {
  const SimdMode saved = ActiveSimdMode();
  SetSimdMode(SimdMode::kScalar);
  EXPECT_STREQ(SelectKernels(true).name, "scalar");
  SetSimdMode(SimdMode::kHighway);
  EXPECT_STREQ(SelectKernels(true).name, "highway");
  SetSimdMode(SimdMode::kNative);
#if defined(__x86_64__)
  EXPECT_STREQ(SelectKernels(true).name, CpuHasAvx2Fma() ? "avx2" : "sse4");
  EXPECT_STREQ(SelectKernels(false).name, "sse4");
#else
  EXPECT_STREQ(SelectKernels(true).name, "highway");
#endif
  SetSimdMode(saved);
}

}  // namespace
}  // namespace aerovo::matching_detail::distance_kernels_test
