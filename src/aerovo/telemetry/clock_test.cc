// The telemetry's clock against the frames' (clock.h): mismatched spans named with their
// likely cause, and the offset estimated from the speeds.
#include "aerovo/telemetry/clock.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "aerovo/geo/local_enu.h"

namespace aerovo::clock_test {
namespace {

TelemetrySample Fix(double time_s, std::optional<double> rel_alt_m) {
  TelemetrySample s;
  s.time_s = time_s;
  s.lat_deg = 45.0;
  s.lon_deg = 7.0;
  s.rel_alt_m = rel_alt_m;
  return s;
}

// The telemetry's clock against the frames'.
TEST(TelemetryClock, MismatchIsNamed) {
  std::vector<TelemetrySample> ms, ok;
  for (int i = 0; i <= 60; ++i) {
    ms.push_back(Fix(1000.0 * i, 100.0));
    ok.push_back(Fix(1.0 * i, 100.0));
  }
  const std::string w = CheckTelemetryClock(Telemetry(ms), "flight.csv", 0.0, 60.0);
  EXPECT_NE(w.find("flight.csv"), std::string::npos) << w;
  EXPECT_NE(w.find("milliseconds"), std::string::npos) << w;
  EXPECT_NE(w.find("1000x"), std::string::npos) << w;
  EXPECT_EQ(CheckTelemetryClock(Telemetry(ok), "flight.csv", 0.0, 60.0), "");
  // Every frame in the first seconds of a much longer telemetry, in seconds.
  EXPECT_NE(CheckTelemetryClock(Telemetry(ok), "long.csv", 0.0, 2.0).find("30x"),
            std::string::npos);
  // Microseconds: the unit is named (before: "another flight, or a clip").
  std::vector<TelemetrySample> us, week;
  for (int i = 0; i <= 60; ++i) {
    us.push_back(Fix(1e6 * i, 100.0));
    week.push_back(Fix(345600.0 + i, 100.0));  // seconds of the GPS week
  }
  const std::string u = CheckTelemetryClock(Telemetry(us), "us.csv", 0.0, 60.0);
  EXPECT_NE(u.find("microseconds"), std::string::npos) << u;
  EXPECT_NE(u.find("1000000x"), std::string::npos) << u;
  // No overlap at all (GPS-week seconds against frames from 0; the same span): said with both
  // spans (before: nothing, the spans' ratio is 1).
  const std::string g = CheckTelemetryClock(Telemetry(week), "week.csv", 0.0, 60.0);
  EXPECT_NE(g.find("week.csv: no time overlap with the frames: the telemetry spans 345600.000 to "
                   "345660.000 s, the frames 0.000 to 60.000 s"),
            std::string::npos)
      << g;
  // The offset that aligns them: no warning.
  EXPECT_EQ(CheckTelemetryClock(Telemetry(week), "week.csv", 0.0, 60.0, 345600.0), "");
}

// The offset from the motion: a VO track with changing speed against the same track 2.5 s later
// on the telemetry's clock.
TEST(TelemetryClock, OffsetIsEstimatedFromTheSpeeds) {
  // A chirp: the speed changes without a period (a periodic one would be ambiguous).
  const auto x_at = [](double t) { return 10.0 * t + 6.0 * std::sin(0.05 * t * t); };
  std::vector<PlanarTrackPoint> vo;
  for (int i = 0; i <= 300; ++i) vo.push_back({0.2 * i, 0.0, x_at(0.2 * i)});  // local +y
  std::vector<TelemetrySample> fixes;
  const LocalEnu enu(45.0, 7.0, 0.0);
  for (int i = 0; i <= 140; ++i) {
    const double tel = 0.5 * i;
    const GeoPoint g = enu.Reverse(x_at(std::max(0.0, tel - 2.5)), 0.0, 0.0);
    TelemetrySample s = Fix(tel, 100.0);
    s.lat_deg = g.lat_deg;
    s.lon_deg = g.lon_deg;
    fixes.push_back(s);
  }
  const OffsetEstimate e = EstimateTelemetryOffset(vo, Telemetry(fixes));
  ASSERT_TRUE(e.valid);
  EXPECT_NEAR(e.offset_s, 2.5, 0.1);
  EXPECT_GT(e.correlation, 0.95);
  EXPECT_TRUE(e.clear);
  // A constant speed says nothing.
  std::vector<PlanarTrackPoint> steady;
  for (int i = 0; i <= 300; ++i) steady.push_back({0.2 * i, 0.0, 2.0 * i});
  EXPECT_FALSE(EstimateTelemetryOffset(steady, Telemetry(fixes)).valid &&
               EstimateTelemetryOffset(steady, Telemetry(fixes)).clear);
}

}  // namespace
}  // namespace aerovo::clock_test
