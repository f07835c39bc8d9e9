#include "aerovo/estimation/samplers.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/error.h"

namespace aerovo::samplers_test {
namespace {

// Every entry of the sampler list: ToString is the class's kName, ParseSamplerKind inverts it,
// the dispatch constructs the class of that value, and the values are the enum's, in order.
TEST(SamplerList, EveryEntryRoundTrips) {
  ASSERT_EQ(kNumSamplerKinds, 2u);
  std::set<std::string> names;
  for (std::size_t k = 0; k < kNumSamplerKinds; ++k) {
    const SamplerKind kind = kAllSamplerKinds[k];
    EXPECT_EQ(static_cast<std::size_t>(kind), k);
    const std::string name = ToString(kind);
    names.insert(name);
    EXPECT_EQ(ParseSamplerKind(name.c_str()), kind) << name;
    const std::string visited =
        VisitSampler(kind, [](auto& sampler) -> std::string { return sampler.kName; });
    EXPECT_EQ(visited, name);
  }
  EXPECT_EQ(names.size(), kNumSamplerKinds);
  EXPECT_STREQ(ToString(SamplerKind::kUniform), "uniform");
  EXPECT_STREQ(ToString(SamplerKind::kProsac), "prosac");
  EXPECT_STREQ(ToString(static_cast<SamplerKind>(99)), "unknown");
  const bool prosac = VisitSampler(SamplerKind::kProsac, [](auto& sampler) {
    return std::is_same_v<std::decay_t<decltype(sampler)>, ProsacSampler>;
  });
  EXPECT_TRUE(prosac);
}

TEST(SamplerList, ParseNamesEveryAcceptedValue) {
  for (const char* bad : {"PROSAC", "", "lo-ransac"}) {
    try {
      ParseSamplerKind(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(std::string(e.what()),
                "unknown sampler '" + std::string(bad) + "' (expected uniform or prosac)");
    }
  }
  EXPECT_THROW(ParseSamplerKind(nullptr), InvalidArgument);
}

// The sampler the dispatch hands out is ready for Reset / Draw and draws what a directly
// constructed one draws.
TEST(SamplerList, DispatchedSamplerDrawsAsTheClass) {
  for (SamplerKind kind : kAllSamplerKinds) {
    std::vector<int> via_dispatch = VisitSampler(kind, [](auto& sampler) {
      std::vector<int> out(3 * 50);
      sampler.Reset(42, 100, 3, nullptr);
      for (int t = 0; t < 50; ++t) sampler.Draw(out.data() + 3 * t);
      return out;
    });
    std::vector<int> direct(3 * 50);
    if (kind == SamplerKind::kProsac) {
      ProsacSampler s;
      s.Reset(42, 100, 3, nullptr);
      for (int t = 0; t < 50; ++t) s.Draw(direct.data() + 3 * t);
    } else {
      UniformSampler s;
      s.Reset(42, 100, 3, nullptr);
      for (int t = 0; t < 50; ++t) s.Draw(direct.data() + 3 * t);
    }
    EXPECT_EQ(via_dispatch, direct) << ToString(kind);
    for (int v : via_dispatch) {
      EXPECT_GE(v, 0);
      EXPECT_LT(v, 100);
    }
  }
}

// Every draw of every sampler is sample_size DISTINCT indices in [0, num_points): a repeated
// index makes a degenerate minimal sample. Small sets (sample_size == num_points, one spare)
// are where a careless without-replacement draw repeats.
TEST(SamplerDraws, IndicesAreDistinctAndInRange) {
  std::vector<float> quality(1000);
  for (std::size_t k = 0; k < quality.size(); ++k)
    quality[k] = static_cast<float>((k * 7919) % 1000);
  for (SamplerKind kind : kAllSamplerKinds) {
    for (const int n : {2, 3, 4, 5, 10, 100, 1000}) {
      for (const int m : {2, 3, 4}) {
        if (m > n) continue;
        for (const float* q :
             {static_cast<const float*>(nullptr), static_cast<const float*>(quality.data())}) {
          VisitSampler(kind, [&](auto& sampler) {
            sampler.Reset(7, n, m, q);
            std::vector<int> seen(static_cast<std::size_t>(n), 0);
            std::vector<int> sample(static_cast<std::size_t>(m));
            for (int t = 0; t < 3000; ++t) {
              sampler.Draw(sample.data());
              const std::set<int> distinct(sample.begin(), sample.end());
              ASSERT_EQ(distinct.size(), static_cast<std::size_t>(m))
                  << ToString(kind) << " n " << n << " m " << m << " draw " << t;
              for (int v : sample) {
                ASSERT_GE(v, 0);
                ASSERT_LT(v, n);
                ++seen[static_cast<std::size_t>(v)];
              }
            }
            // Uniform: 3000 draws reach every index of a small set (PROSAC reaches the
            // worst ones only after its growth schedule, tested below).
            if (kind == SamplerKind::kUniform && n <= 100) {
              for (int v = 0; v < n; ++v) {
                EXPECT_GT(seen[static_cast<std::size_t>(v)], 0)
                    << ToString(kind) << " n " << n << " m " << m << " never drew " << v;
              }
            }
          });
        }
      }
    }
  }
}

// PROSAC's growth order (Chum & Matas 2005, Sec. 2.2 and 2.3), checked against the paper's
// schedule computed here from its definitions: with the correspondences ranked by quality
// (lower = better), T_n = T_N * prod_{i<m} (n - i) / (N - i) and T'_m = 1,
// T'_{n+1} = T'_n + ceil(T_{n+1} - T_n); the sampled top set grows from n to n + 1 at draw
// T'_n + 1, whose sample holds the (n+1)-th best correspondence. So the first draw is the m
// best, rank r >= m first appears exactly at draw T'_r + 1 (ranks from 0), and no draw before
// that holds a rank >= r.
TEST(SamplerDraws, ProsacGrowsTheTopSetInTheOrderOfThePaper) {
  const int N = 30, m = 3;
  // Qualities in a shuffled order, all distinct: rank_of[index] is the index's place.
  std::vector<float> quality(N);
  std::vector<int> rank_of(N);
  for (int i = 0; i < N; ++i) {
    const int rank = (i * 11) % N;  // 11 and 30 are coprime: a permutation
    quality[static_cast<std::size_t>(i)] = 0.5f + static_cast<float>(rank);
    rank_of[static_cast<std::size_t>(i)] = rank;
  }
  const double t_max = ProsacSampler::kGrowthMaxSamples;
  const auto T = [&](int n) {
    double v = t_max;
    for (int i = 0; i < m; ++i) v *= static_cast<double>(n - i) / static_cast<double>(N - i);
    return v;
  };
  // growth_draw[r]: the draw (from 1) at which rank r may first appear.
  std::vector<std::int64_t> growth_draw(N, 1);
  std::int64_t t_prime = 1;  // T'_n for n = m
  for (int n = m; n < N; ++n) {
    growth_draw[static_cast<std::size_t>(n)] = t_prime + 1;
    t_prime += static_cast<std::int64_t>(std::ceil(T(n + 1) - T(n)));
  }
  ASSERT_LT(growth_draw[N - 1], 250000);

  ProsacSampler sampler;
  sampler.Reset(3, N, m, quality.data());
  std::vector<std::int64_t> first_seen(N, -1);
  int sample[m];
  for (std::int64_t t = 1; t <= growth_draw[N - 1]; ++t) {
    sampler.Draw(sample);
    int worst = -1;
    for (int k = 0; k < m; ++k) {
      const int r = rank_of[static_cast<std::size_t>(sample[k])];
      worst = std::max(worst, r);
      if (first_seen[static_cast<std::size_t>(r)] < 0) first_seen[static_cast<std::size_t>(r)] = t;
    }
    if (t == 1) {
      EXPECT_EQ(worst, m - 1) << "the first sample is the m best";
    }
    // The top set at draw t: every rank whose growth draw has come.
    const auto top = static_cast<int>(
        std::upper_bound(growth_draw.begin() + m, growth_draw.end(), t) - growth_draw.begin());
    ASSERT_LT(worst, top) << "draw " << t << " took a rank outside the top " << top;
  }
  for (int r = 0; r < m; ++r) EXPECT_EQ(first_seen[static_cast<std::size_t>(r)], 1) << r;
  for (int r = m; r < N; ++r) {
    EXPECT_EQ(first_seen[static_cast<std::size_t>(r)], growth_draw[static_cast<std::size_t>(r)])
        << "rank " << r;
    EXPECT_GT(growth_draw[static_cast<std::size_t>(r)],
              growth_draw[static_cast<std::size_t>(r - 1)]);
  }
}

}  // namespace
}  // namespace aerovo::samplers_test
