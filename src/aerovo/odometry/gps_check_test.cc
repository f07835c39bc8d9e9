#include "aerovo/odometry/gps_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "aerovo/core/error.h"

namespace aerovo::gps_check_test {
namespace {

// A flight at 10 m/s eastward, one fix per second (frame i at i s), with 1.5 m of deterministic
// noise; the VO sees the same motion. `edit(i, east, north, alt)` may damage fix i.
struct Result {
  std::vector<GpsFixVerdict> verdicts;
};

Result Fly(int n, const std::function<void(int, double&, double&, double&)>& edit = {},
           const GpsCheckOptions& options = {}) {
  const LocalEnu enu(49.84, 24.03, 300.0);
  GpsFixChecker checker(options);
  Result r;
  for (int i = 0; i < n; ++i) {
    double e = 10.0 * i + 1.5 * std::sin(7.1 * i), nn = 1.5 * std::cos(5.3 * i), alt = 400.0;
    if (edit) edit(i, e, nn, alt);
    const GeoPoint g = enu.Reverse(e, nn, alt - 300.0);
    r.verdicts.push_back(
        checker.Check(i, static_cast<double>(i), g, alt - 300.0, Eigen::Vector2d(10.0 * i, 0.0), 0));
  }
  return r;
}

std::vector<int> Rejected(const Result& r) {
  std::vector<int> out;
  for (std::size_t i = 0; i < r.verdicts.size(); ++i) {
    if (!r.verdicts[i].accepted) out.push_back(static_cast<int>(i));
  }
  return out;
}

TEST(GpsFixChecker, NoisyCleanFlightHasNoRejection) {
  EXPECT_TRUE(Rejected(Fly(100)).empty());
}

TEST(GpsFixChecker, SpikeIsRejectedAsSpeed) {
  const Result r = Fly(30, [](int i, double&, double& n, double&) {
    if (i == 5) n += 1112.0;  // +0.01 deg of latitude
  });
  EXPECT_EQ(Rejected(r), std::vector<int>{5});
  EXPECT_EQ(r.verdicts[5].kind, "speed");
  EXPECT_NE(r.verdicts[5].reason.find("m/s"), std::string::npos) << r.verdicts[5].reason;
}

TEST(GpsFixChecker, JumpWithinTheSpeedLimitButNotSeenByTheVoIsRejected) {
  // 45 m in 1 s is within the speed limit (40 m/s + 10 m) but the camera moved 10 m (the limit
  // against the VO: 10 m + 3 x 10 m).
  const Result r = Fly(30, [](int i, double&, double& n, double&) {
    if (i == 8) n += 45.0;
  });
  EXPECT_EQ(Rejected(r), std::vector<int>{8});
  EXPECT_EQ(r.verdicts[8].kind, "vo");
}

TEST(GpsFixChecker, RunOfBadFixesIsRejectedWhole) {
  const Result r = Fly(40, [](int i, double&, double& n, double&) {
    if (i >= 10 && i < 15) n += 1112.0;
  });
  EXPECT_EQ(Rejected(r), (std::vector<int>{10, 11, 12, 13, 14}));
}

TEST(GpsFixChecker, LateStepStaysRejected) {
  const Result r = Fly(40, [](int i, double&, double& n, double&) {
    if (i >= 30) n += 1112.0;
  });
  EXPECT_EQ(Rejected(r).size(), 10u);
  EXPECT_EQ(Rejected(r).front(), 30);
}

TEST(GpsFixChecker, AltitudeSpikeIsRejected) {
  const Result r = Fly(30, [](int i, double&, double&, double& alt) {
    if (i == 6) alt += 500.0;
  });
  EXPECT_EQ(Rejected(r), std::vector<int>{6});
  EXPECT_EQ(r.verdicts[6].kind, "altitude");
}

TEST(GpsFixChecker, BadFirstFixIsOutvotedByTheNextOnes) {
  const Result r = Fly(20, [](int i, double&, double& n, double&) {
    if (i == 0) n += 1112.0;
  });
  // Fixes 1 and 2 are rejected against the bad anchor, fix 3 makes the challengers 3 > 1.
  EXPECT_FALSE(r.verdicts[1].accepted);
  EXPECT_FALSE(r.verdicts[2].accepted);
  ASSERT_TRUE(r.verdicts[3].accepted);
  EXPECT_TRUE(r.verdicts[3].switched);
  EXPECT_EQ(r.verdicts[3].superseded, std::vector<int>{0});
  ASSERT_EQ(r.verdicts[3].reinstated.size(), 2u);
  EXPECT_EQ(r.verdicts[3].reinstated[0].frame, 1);
  EXPECT_EQ(r.verdicts[3].reinstated[1].frame, 2);
  for (int i = 4; i < 20; ++i) EXPECT_TRUE(r.verdicts[i].accepted) << i;
}

// A first fix at 0,0 (null island: a receiver without a fix yet) is outvoted, and the checker's
// ENU frame moves to the flight: a 45 m jump 8 s later is measured as 45 m (against the VO),
// not foreshortened in a horizontal plane tangent 5500 km away.
TEST(GpsFixChecker, NullIslandFirstFixIsOutvotedAndTheFrameMovesToTheFlight) {
  const LocalEnu enu(49.84, 24.03, 300.0);
  GpsFixChecker checker;
  std::vector<GpsFixVerdict> v;
  for (int i = 0; i < 20; ++i) {
    double e = 10.0 * i + 1.5 * std::sin(7.1 * i), n = 1.5 * std::cos(5.3 * i);
    if (i == 8) n += 45.0;
    const GeoPoint g = i == 0 ? GeoPoint{0.0, 0.0, 0.0} : enu.Reverse(e, n, 100.0);
    v.push_back(checker.Check(i, i, g, 100.0, Eigen::Vector2d(10.0 * i, 0.0), 0));
  }
  ASSERT_TRUE(v[3].switched);
  EXPECT_EQ(v[3].superseded, std::vector<int>{0});
  for (int i = 4; i < 20; ++i) EXPECT_EQ(v[i].accepted, i != 8) << i << ": " << v[i].reason;
  EXPECT_EQ(v[8].kind, "vo");
  EXPECT_NE(v[8].reason.find("jumps 4"), std::string::npos) << v[8].reason;
}

TEST(GpsFixChecker, DisabledAcceptsEverything) {
  GpsCheckOptions o;
  o.enabled = false;
  const Result r = Fly(
      30, [](int i, double&, double& n, double&) { if (i == 5) n += 1112.0; }, o);
  EXPECT_TRUE(Rejected(r).empty());
}

// The height's relative altitude: a jump beyond tolerance_m + max_vertical_speed_mps x dt keeps
// the height used before, and does not move the time of the last plausible altitude.
TEST(GpsFixChecker, ImplausibleRelativeAltitudeKeepsTheLastHeight) {
  GpsFixChecker c;  // 15 m/s, 10 m
  EXPECT_DOUBLE_EQ(c.PlausibleRelAlt(0.0, 50.0, std::nullopt), 50.0);
  EXPECT_DOUBLE_EQ(c.PlausibleRelAlt(1.0, 70.0, 50.0), 70.0);     // 20 m in 1 s <= 25 m
  EXPECT_DOUBLE_EQ(c.PlausibleRelAlt(2.0, 150.0, 70.0), 70.0);    // 80 m in 1 s > 25 m
  EXPECT_DOUBLE_EQ(c.PlausibleRelAlt(3.0, 110.0, 70.0), 110.0);   // 40 m in 2 s <= 40 m
  EXPECT_DOUBLE_EQ(c.PlausibleRelAlt(3.0005, 121.0, 110.0), 110.0);  // 11 m in 0.5 ms > 10 m
  GpsCheckOptions off;
  off.enabled = false;
  GpsFixChecker d(off);
  EXPECT_DOUBLE_EQ(d.PlausibleRelAlt(0.0, 50.0, std::nullopt), 50.0);
  EXPECT_DOUBLE_EQ(d.PlausibleRelAlt(1.0, 500.0, 50.0), 500.0);
}

TEST(GpsFixChecker, BadOptionsAreRejected) {
  GpsCheckOptions o;
  o.max_speed_mps = 0.0;
  EXPECT_THROW(GpsFixChecker{o}, InvalidArgument);
  o = {};
  o.tolerance_m = std::nan("");
  EXPECT_THROW(GpsFixChecker{o}, InvalidArgument);
}

}  // namespace
}  // namespace aerovo::gps_check_test
