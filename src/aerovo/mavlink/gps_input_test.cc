// GPS_INPUT from a GeoFix: GPS week and milliseconds against dates whose GPS week is published
// (2017-01-01 00:00 UTC began GPS week 1930; the leap second of 2016-12-31 made GPS - UTC 18 s),
// the fix type, flags and ranges for good, poor and broken inputs.
#include "aerovo/mavlink/gps_input.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace aerovo::mavlink::gps_input_test {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(GpsTime, PublishedWeeksAndWeekBoundaries) {
  const auto t2017 = GpsTimeOfUnix(1483228800.0);  // 2017-01-01 00:00:00 UTC
  ASSERT_TRUE(t2017);
  EXPECT_EQ(t2017->week, 1930);
  EXPECT_EQ(t2017->ms, 18000u);  // 18 leap seconds into the week
  // The first millisecond of week 2395 and the last of week 2394.
  const double start = kGpsEpochUnixS + 2395.0 * 604800.0 - kGpsMinusUtcS;
  const auto a = GpsTimeOfUnix(start);
  const auto b = GpsTimeOfUnix(start - 0.001);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->week, 2395);
  EXPECT_EQ(a->ms, 0u);
  EXPECT_EQ(b->week, 2394);
  EXPECT_EQ(b->ms, kMsPerGpsWeek - 1);
  // Half a millisecond rounds to the nearest millisecond.
  EXPECT_EQ(GpsTimeOfUnix(start + 0.1234996)->ms, 123u);
  EXPECT_FALSE(GpsTimeOfUnix(kGpsEpochUnixS - 100.0));  // before the GPS epoch
  EXPECT_FALSE(GpsTimeOfUnix(kNaN));
  EXPECT_FALSE(GpsTimeOfUnix(4.0e10));  // past week 65535
}

GeoFix GoodFix() {
  GeoFix f;
  f.unix_time_s = 1764806400.25;
  f.time_usec = 123456789;
  f.lat_deg = 43.551123456;
  f.lon_deg = -7.123456789;
  f.alt_msl_m = 182.5;
  f.sigma_horizontal_m = 1.5;
  f.vel_north_mps = 4.0;
  f.vel_east_mps = -3.0;
  f.sigma_velocity_mps = 0.2;
  f.yaw_deg = 0.0;
  return f;
}

TEST(GpsInput, GoodFixIs3dWithEverythingButTheVerticalFields) {
  const GpsInput m = MakeGpsInput(GoodFix(), {});
  EXPECT_EQ(m.fix_type, kGpsFixType3d);
  EXPECT_EQ(m.ignore_flags,
            kGpsInputIgnoreVdop | kGpsInputIgnoreVelVert | kGpsInputIgnoreVerticalAccuracy);
  EXPECT_EQ(m.lat, 435511235);  // 43.551123456 degE7, rounded
  EXPECT_EQ(m.lon, -71234568);
  EXPECT_FLOAT_EQ(m.alt, 182.5f);
  EXPECT_FLOAT_EQ(m.horiz_accuracy, 1.5f);
  EXPECT_FLOAT_EQ(m.vn, 4.0f);
  EXPECT_FLOAT_EQ(m.ve, -3.0f);
  EXPECT_FLOAT_EQ(m.vd, 0.0f);
  EXPECT_FLOAT_EQ(m.speed_accuracy, 0.2f);
  EXPECT_EQ(m.satellites_visible, kGpsInputSatellitesWithFix);
  EXPECT_FLOAT_EQ(m.hdop, 1.0f);
  EXPECT_EQ(m.yaw, 36000);  // north is 36000, 0 would be "unknown"
  EXPECT_EQ(m.time_usec, 123456789u);
  const auto t = GpsTimeOfUnix(1764806400.25);
  EXPECT_EQ(m.time_week, t->week);
  EXPECT_EQ(m.time_week_ms, t->ms);
  EXPECT_EQ(m.gps_id, 0);
  GpsInputOptions second;
  second.gps_id = 1;
  EXPECT_EQ(MakeGpsInput(GoodFix(), second).gps_id, 1);
}

TEST(GpsInput, YawWrapsToCentidegreesClockwiseFromNorth) {
  GeoFix f = GoodFix();
  f.yaw_deg = -90.0;  // west
  EXPECT_EQ(MakeGpsInput(f, {}).yaw, 27000);
  f.yaw_deg = 359.999;  // rounds to north
  EXPECT_EQ(MakeGpsInput(f, {}).yaw, 36000);
  f.yaw_deg = 725.5;
  EXPECT_EQ(MakeGpsInput(f, {}).yaw, 550);
  f.yaw_deg.reset();
  EXPECT_EQ(MakeGpsInput(f, {}).yaw, 0);
  f.yaw_deg = kNaN;
  EXPECT_EQ(MakeGpsInput(f, {}).yaw, 0);
}

TEST(GpsInput, PoorAccuracyIsNoFix) {
  GeoFix f = GoodFix();
  f.sigma_horizontal_m = 12.0;
  GpsInputOptions o;
  o.max_horizontal_sigma_m = 10.0;
  const GpsInput m = MakeGpsInput(f, o);
  EXPECT_EQ(m.fix_type, kGpsFixTypeNoFix);
  EXPECT_EQ(m.satellites_visible, 0);
  EXPECT_FLOAT_EQ(m.hdop, 99.99f);
  EXPECT_FLOAT_EQ(m.horiz_accuracy, 12.0f);  // still said, with the position
  EXPECT_EQ(m.lat, 435511235);
  o.max_horizontal_sigma_m = 12.0;
  EXPECT_EQ(MakeGpsInput(f, o).fix_type, kGpsFixType3d);  // the limit is inclusive
}

TEST(GpsInput, UnknownOrBrokenFieldsAreIgnoredNeverSentAsNaN) {
  GeoFix f = GoodFix();
  f.alt_msl_m = kNaN;
  f.vel_north_mps.reset();
  f.sigma_horizontal_m = kNaN;
  const GpsInput m = MakeGpsInput(f, {});
  EXPECT_EQ(m.fix_type, kGpsFixTypeNoFix);
  EXPECT_EQ(m.ignore_flags & kGpsInputIgnoreAlt, kGpsInputIgnoreAlt);
  EXPECT_EQ(m.ignore_flags & kGpsInputIgnoreVelHoriz, kGpsInputIgnoreVelHoriz);
  EXPECT_EQ(m.ignore_flags & kGpsInputIgnoreSpeedAccuracy, kGpsInputIgnoreSpeedAccuracy);
  EXPECT_EQ(m.ignore_flags & kGpsInputIgnoreHorizontalAccuracy, kGpsInputIgnoreHorizontalAccuracy);
  for (float v : {m.alt, m.hdop, m.vdop, m.vn, m.ve, m.vd, m.speed_accuracy, m.horiz_accuracy,
                  m.vert_accuracy}) {
    EXPECT_TRUE(std::isfinite(v));
  }
  EXPECT_EQ(m.alt, 0.0f);
  EXPECT_EQ(m.vn, 0.0f);

  GeoFix bad = GoodFix();
  bad.lat_deg = 91.0;  // out of range: no position, no fix
  const GpsInput b = MakeGpsInput(bad, {});
  EXPECT_EQ(b.fix_type, kGpsFixTypeNoFix);
  EXPECT_EQ(b.lat, 0);
  EXPECT_EQ(b.lon, 0);
  bad = GoodFix();
  bad.lon_deg = kNaN;
  EXPECT_EQ(MakeGpsInput(bad, {}).fix_type, kGpsFixTypeNoFix);
  bad = GoodFix();
  bad.unix_time_s = 1000.0;  // before the GPS epoch: no GPS time, no fix
  const GpsInput early = MakeGpsInput(bad, {});
  EXPECT_EQ(early.fix_type, kGpsFixTypeNoFix);
  EXPECT_EQ(early.time_week, 0);
  bad = GoodFix();
  bad.vel_east_mps = std::numeric_limits<double>::infinity();
  EXPECT_EQ(MakeGpsInput(bad, {}).ignore_flags & kGpsInputIgnoreVelHoriz, kGpsInputIgnoreVelHoriz);
}

}  // namespace
}  // namespace aerovo::mavlink::gps_input_test
