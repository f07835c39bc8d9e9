#include "aerovo/telemetry/telemetry.h"

#include <gtest/gtest.h>

#include "aerovo/core/error.h"

namespace aerovo::telemetry_test {
namespace {

TelemetrySample Fix(double t, double lat, double lon, std::optional<int> frame = std::nullopt) {
  TelemetrySample s;
  s.time_s = t;
  s.lat_deg = lat;
  s.lon_deg = lon;
  s.frame_index = frame;
  return s;
}

TEST(Telemetry, SortsByTimeAndInterpolates) {
  TelemetrySample a = Fix(2.0, 44.0, 7.0, 20);
  a.rel_alt_m = 100.0;
  a.yaw_deg = 350.0;
  TelemetrySample b = Fix(0.0, 43.0, 6.0, 0);
  b.rel_alt_m = 50.0;
  b.yaw_deg = 330.0;
  TelemetrySample c = Fix(4.0, 45.0, 8.0, 40);
  c.rel_alt_m = 100.0;
  c.yaw_deg = 10.0;  // 350 -> 10 crosses north
  Telemetry tel({a, b, c}, "test");
  ASSERT_EQ(tel.size(), 3u);
  EXPECT_DOUBLE_EQ(tel[0].time_s, 0.0);
  EXPECT_DOUBLE_EQ(tel.start_time_s(), 0.0);
  EXPECT_DOUBLE_EQ(tel.end_time_s(), 4.0);

  auto m = tel.Lookup(1.0);
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->lat_deg, 43.5, 1e-12);
  EXPECT_NEAR(m->lon_deg, 6.5, 1e-12);
  EXPECT_NEAR(*m->rel_alt_m, 75.0, 1e-12);
  EXPECT_NEAR(*m->yaw_deg, 340.0, 1e-9);
  EXPECT_FALSE(m->frame_index);

  auto n = tel.Lookup(3.0);
  ASSERT_TRUE(n);
  EXPECT_NEAR(*n->yaw_deg, 0.0, 1e-9);  // shorter arc through north, not 180
  EXPECT_NEAR(n->lat_deg, 44.5, 1e-12);

  auto exact = tel.Lookup(2.0);
  ASSERT_TRUE(exact);
  EXPECT_EQ(exact->frame_index, 20);
}

TEST(Telemetry, LookupNeverExtrapolates) {
  Telemetry tel({Fix(0.0, 10.0, 20.0), Fix(1.0, 11.0, 21.0)});
  EXPECT_FALSE(tel.Lookup(-0.01));
  EXPECT_FALSE(tel.Lookup(1.5));
  auto held = tel.Lookup(1.2, 0.5);
  ASSERT_TRUE(held);
  EXPECT_DOUBLE_EQ(held->lat_deg, 11.0);
  EXPECT_DOUBLE_EQ(held->time_s, 1.2);
  EXPECT_FALSE(Telemetry().Lookup(0.0));
}

TEST(Telemetry, LongitudeAcrossAntimeridian) {
  Telemetry tel({Fix(0.0, 0.5, 179.0), Fix(1.0, 0.5, -179.0)});
  auto m = tel.Lookup(0.75);
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->lon_deg, -179.5, 1e-9);
}

TEST(Telemetry, AtFrameExactAndInterpolated) {
  Telemetry tel({Fix(0.0, 10.0, 20.0, 0), Fix(1.0, 11.0, 22.0, 10), Fix(2.0, 12.0, 24.0, 30)});
  ASSERT_TRUE(tel.HasFrameIndices());
  auto f10 = tel.AtFrame(10);
  ASSERT_TRUE(f10);
  EXPECT_DOUBLE_EQ(f10->lat_deg, 11.0);
  auto f20 = tel.AtFrame(20);
  ASSERT_TRUE(f20);
  EXPECT_NEAR(f20->lat_deg, 11.5, 1e-12);
  EXPECT_NEAR(f20->lon_deg, 23.0, 1e-12);
  EXPECT_NEAR(f20->time_s, 1.5, 1e-12);
  EXPECT_EQ(f20->frame_index, 20);
  EXPECT_FALSE(tel.AtFrame(31));
  EXPECT_FALSE(tel.AtFrame(-1));
  EXPECT_FALSE(Telemetry({Fix(0.0, 1.0, 1.0)}).AtFrame(0));
}

TEST(Telemetry, ForFrameAndUnixTime) {
  TelemetrySample a = Fix(0.0, 10.0, 20.0), b = Fix(10.0, 11.0, 21.0);
  a.unix_time_s = 1000.0;
  b.unix_time_s = 1010.0;
  Telemetry by_time({a, b});
  auto m = by_time.ForFrame(99, 2.0, Telemetry::Match::kAuto, 3.0);  // no frame indices: time
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->lat_deg, 10.5, 1e-12);
  EXPECT_FALSE(by_time.ForFrame(0, 0.0, Telemetry::Match::kByFrameIndex));
  auto u = by_time.LookupUnix(1002.5);
  ASSERT_TRUE(u);
  EXPECT_NEAR(u->lat_deg, 10.25, 1e-12);
  EXPECT_FALSE(by_time.LookupUnix(1011.0));
  EXPECT_FALSE(Telemetry({Fix(0.0, 1.0, 2.0)}).LookupUnix(0.0));

  Telemetry by_frame({Fix(0.0, 10.0, 20.0, 0), Fix(1.0, 11.0, 21.0, 10)});
  auto f = by_frame.ForFrame(5, 123.0);  // frame indices win over the (wrong) time
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->lat_deg, 10.5, 1e-12);
  auto t = by_frame.ForFrame(5, 0.25, Telemetry::Match::kByTime);
  ASSERT_TRUE(t);
  EXPECT_NEAR(t->lat_deg, 10.25, 1e-12);
}

TEST(Telemetry, CameraYawPrefersGimbal) {
  TelemetrySample s;
  EXPECT_FALSE(s.CameraYawDeg());
  s.yaw_deg = 10.0;
  EXPECT_EQ(s.CameraYawDeg(), 10.0);
  s.gimbal_yaw_deg = 12.0;
  EXPECT_EQ(s.CameraYawDeg(), 12.0);
}

TEST(Telemetry, ValidateSampleNamesTheProblem) {
  TelemetrySample s = Fix(0.0, 123.4, 6.0);
  try {
    ValidateSample(s, "flight.srt:42");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "flight.srt:42: latitude 123.4 out of range [-90, 90]");
  }
  s = Fix(0.0, 1.0, 181.0);
  EXPECT_THROW(ValidateSample(s, "x"), InputError);
  s = Fix(0.0, 1.0, 1.0);
  s.focal_length_35mm_mm = 0.0;
  EXPECT_THROW(ValidateSample(s, "x"), InputError);
  s = Fix(0.0, 1.0, 1.0);
  s.rel_alt_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ValidateSample(s, "x"), InputError);
  EXPECT_NO_THROW(ValidateSample(Fix(0.0, -90.0, 180.0), "x"));
}

// Runs of equal times and the interval each is spread over: the gap to the next time, at most the
// clock's step (the median gap between distinct times, 1 s here), that step for the last run.
TEST(Telemetry, RepeatedTimeRunsAndTheirSteps) {
  const std::vector<double> t = {0, 0, 0, 1, 1, 2, 3, 3.5, 3.5, 10, 11, 12, 12};
  const std::vector<RepeatedTimeRun> runs = RepeatedTimeRuns(t);
  ASSERT_EQ(runs.size(), 4u);
  EXPECT_EQ(runs[0].first, 0u);
  EXPECT_EQ(runs[0].count, 3u);
  EXPECT_DOUBLE_EQ(runs[0].step_s, 1.0);
  EXPECT_DOUBLE_EQ(SpreadTime(runs[0], 2), 2.0 / 3.0);
  EXPECT_EQ(runs[1].first, 3u);
  EXPECT_DOUBLE_EQ(runs[1].step_s, 1.0);
  EXPECT_EQ(runs[2].first, 7u);
  EXPECT_DOUBLE_EQ(runs[2].time_s, 3.5);
  EXPECT_DOUBLE_EQ(runs[2].step_s, 1.0);  // not the 6.5 s pause that follows
  EXPECT_DOUBLE_EQ(SpreadTime(runs[2], 1), 4.0);
  EXPECT_EQ(runs[3].first, 11u);
  EXPECT_DOUBLE_EQ(runs[3].step_s, 1.0);  // the last run: the clock's step
  EXPECT_TRUE(RepeatedTimeRuns({0, 1, 2}).empty());
  // One time for all: no step known.
  const std::vector<RepeatedTimeRun> one = RepeatedTimeRuns({4, 4});
  ASSERT_EQ(one.size(), 1u);
  EXPECT_DOUBLE_EQ(one[0].step_s, 0.0);
}

}  // namespace
}  // namespace aerovo::telemetry_test
