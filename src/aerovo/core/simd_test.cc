#include "aerovo/core/simd.h"

#include <gtest/gtest.h>

#include <string>

namespace aerovo::simd_test {
namespace {

TEST(SimdTest, ParsesTheThreeModesAndRejectsOthers) {
  SimdMode m = SimdMode::kScalar;
  ASSERT_TRUE(ParseSimdMode("native", &m));
  EXPECT_EQ(m, SimdMode::kNative);
  ASSERT_TRUE(ParseSimdMode("scalar", &m));
  EXPECT_EQ(m, SimdMode::kScalar);
  ASSERT_TRUE(ParseSimdMode("highway", &m));
  EXPECT_EQ(m, SimdMode::kHighway);
  ASSERT_TRUE(ParseSimdMode("", &m));
  EXPECT_EQ(m, SimdMode::kNative);
  m = SimdMode::kScalar;
  EXPECT_FALSE(ParseSimdMode("avx2", &m));
  EXPECT_FALSE(ParseSimdMode("Scalar", &m));
  EXPECT_EQ(m, SimdMode::kScalar) << "unchanged on a bad value";
}

TEST(SimdTest, SetModeOverridesAndNamesTheTarget) {
  const SimdMode before = ActiveSimdMode();
  SetSimdMode(SimdMode::kScalar);
  EXPECT_EQ(ActiveSimdMode(), SimdMode::kScalar);
  EXPECT_EQ(SimdTargetName(), "scalar");
  SetSimdMode(SimdMode::kHighway);
  EXPECT_EQ(SimdTargetName(), HighwayTargetName());
  SetSimdMode(SimdMode::kNative);
  const std::string native = SimdTargetName();
#if defined(__x86_64__)
  // Highway on x86-64 with aerovo's -msse4.2 baseline: SSSE3 at worst.
  const std::string hwy = HighwayTargetName();
  EXPECT_TRUE(hwy == "ssse3" || hwy == "sse4" || hwy == "avx2" || hwy == "avx3") << hwy;
  EXPECT_EQ(native, CpuHasAvx2Fma() ? std::string("avx2") : HighwayTargetName());
#elif defined(__aarch64__)
  const std::string hwy = HighwayTargetName();
  EXPECT_TRUE(hwy.rfind("neon", 0) == 0 || hwy.rfind("sve", 0) == 0) << hwy;
  EXPECT_EQ(native, HighwayTargetName());
#endif
  EXPECT_FALSE(native.empty());
  EXPECT_NE(native, "scalar");
  SetSimdMode(before);
}

}  // namespace
}  // namespace aerovo::simd_test
