#include "aerovo/estimation/samplers.h"

#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/error.h"

namespace aerovo {
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

}  // namespace
}  // namespace aerovo
