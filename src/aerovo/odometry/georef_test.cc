#include "aerovo/odometry/georef.h"

#include <gtest/gtest.h>

#include <cmath>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/geo/geodesic.h"

namespace aerovo::georef_test {
namespace {

Eigen::Vector2d Rot(double a, const Eigen::Vector2d& v) {
  return Eigen::Vector2d(std::cos(a) * v.x() - std::sin(a) * v.y(),
                         std::sin(a) * v.x() + std::cos(a) * v.y());
}

// A local VO track whose +y axis points at compass bearing `yaw0_deg`, and the GPS fixes of
// the same positions, with the first fix at (lat0, lon0).
struct Flight {
  std::vector<Eigen::Vector2d> local;
  std::vector<GeoPoint> gps;
};

Flight MakeFlight(double yaw0_deg, const LocalEnu& enu, const Eigen::Vector2d& noise_scale) {
  Flight f;
  const double rot = -yaw0_deg * kDegToRad;
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector2d local(3.0 * std::sin(0.1 * i) * i * 0.1, 2.5 * i);
    const Eigen::Vector2d e = Rot(rot, local) + noise_scale.cwiseProduct(Eigen::Vector2d(
                                                    std::sin(7.1 * i), std::cos(5.3 * i)));
    f.local.push_back(local);
    f.gps.push_back(enu.Reverse(e.x(), e.y(), 0.0));
  }
  return f;
}

TEST(GeoReferencer, TelemetryYawMapsLocalUpToBearing) {
  const LocalEnu enu(27.95, -82.46, 10.0);
  const Flight f = MakeFlight(70.0, enu, {0, 0});
  GeoReferencer geo;
  ASSERT_TRUE(geo.Observe(f.local[0], f.gps[0], 70.0));
  EXPECT_EQ(geo.heading_source_used(), "telemetry-yaw");
  EXPECT_TRUE(geo.altitude_known());  // the origin is a GPS fix: its altitude, 10 m
  EXPECT_NEAR(geo.Wgs84FromLocal(f.local[0]).alt_m, 10.0, 1e-6);
  for (std::size_t i = 1; i < f.local.size(); ++i) {
    geo.Observe(f.local[i], f.gps[i], 70.0);
    const GeoPoint p = geo.Wgs84FromLocal(f.local[i]);
    EXPECT_LT(GeodesicDistance(p, f.gps[i]), 0.01) << i;
  }
  // Local +y -> bearing 70 deg.
  const GeoPoint ahead = geo.Wgs84FromLocal(Eigen::Vector2d(0, 100));
  EXPECT_NEAR(InitialBearingDeg(f.gps[0], ahead), 70.0, 0.01);
}

// Fixes whose alt_m is a height above the take-off point (or 0: no height): the track is placed
// as with altitudes above sea level, but its altitude is not known, and a rebuilt referencer
// keeps the same kind.
TEST(GeoReferencer, FixesWithoutAnAltitudeAboveSeaLevelGiveNoAltitude) {
  const LocalEnu enu(27.95, -82.46, 10.0);
  const Flight f = MakeFlight(70.0, enu, {0, 0});
  GeoReferencer geo({}, /*fix_altitudes_above_sea_level=*/false);
  EXPECT_FALSE(geo.fix_altitudes_above_sea_level());
  ASSERT_TRUE(geo.Observe(f.local[0], f.gps[0], 70.0));
  EXPECT_FALSE(geo.altitude_known());
  EXPECT_LT(GeodesicDistance(geo.Wgs84FromLocal(f.local[0]), f.gps[0]), 0.01);
  EXPECT_TRUE(std::isnan(geo.TrackWgs84FromLocal(f.local[5]).alt_m));
  const GeoReferencer rebuilt(geo.options(), geo.fix_altitudes_above_sea_level());
  EXPECT_FALSE(rebuilt.fix_altitudes_above_sea_level());
}

TEST(GeoReferencer, GpsSegmentRecoversRotationWithNoisyFixes) {
  const LocalEnu enu(45.07, 7.66, 250.0);
  const Flight f = MakeFlight(-130.0, enu, {1.5, 1.5});
  GeoRefOptions opts;
  opts.heading_source = HeadingSource::kGpsSegment;
  GeoReferencer geo(opts);
  std::size_t ready_at = 0;
  for (std::size_t i = 0; i < f.local.size() && !geo.ready(); ++i) {
    geo.Observe(f.local[i], f.gps[i], 12.0);  // yaw ignored in gps mode
    ready_at = i;
  }
  ASSERT_TRUE(geo.ready());
  EXPECT_EQ(geo.heading_source_used(), "gps-segment");
  EXPECT_GE(f.local[ready_at].norm(), 30.0);
  EXPECT_LE(ready_at, 13u);  // 2.5 m per frame: ready just past 30 m
  // Rotation of enu_from_local = -yaw0 = +130 deg; 1.5 m noise over a >= 30 m segment: within
  // 3 deg.
  EXPECT_NEAR(std::remainder(geo.rotation_rad() - (130.0 * kDegToRad), 2 * M_PI), 0.0,
              3.0 * kDegToRad);
  const Eigen::Vector3d last = enu.Forward(f.gps.back());
  EXPECT_LT((geo.EnuFromLocal(f.local.back()) - last.head<2>()).norm(), 9.0);
}

// A frame fixed against a map (position and heading) seeds the geo-reference when no GPS did:
// the frame's local position lands on the fix, its heading on the fix's, and a point 100 m
// further along the local x axis lands 100 m along that heading (within 1 mm). The origin is
// the fix's position: no altitude known. A second seed is an error.
TEST(GeoReferencer, SeedFromFixPlacesTheFrameAndTurnsTheTrack) {
  GeoReferencer g;
  EXPECT_FALSE(g.Observe({0.0, 0.0}, std::nullopt, std::nullopt));
  const GeoPoint at{43.53, 6.55, 0.0};
  const Eigen::Vector2d local(12.0, -7.0);
  const double local_heading = 0.3, enu_heading = 1.2;
  g.SeedFromFix(local, local_heading, at, enu_heading);
  ASSERT_TRUE(g.ready());
  EXPECT_EQ(g.heading_source_used(), "map");
  EXPECT_FALSE(g.altitude_known());
  EXPECT_NEAR(g.rotation_rad(), 0.9, 1e-12);
  const GeoPoint p = g.Wgs84FromLocal(local);
  EXPECT_NEAR(g.enu().Forward(p).head<2>().norm(), 0.0, 1e-3);
  EXPECT_NEAR(p.lat_deg, at.lat_deg, 1e-9);
  const Eigen::Vector2d ahead = g.EnuFromLocal(
      local + 100.0 * Eigen::Vector2d(std::cos(local_heading), std::sin(local_heading)));
  EXPECT_NEAR(ahead.x(), 100.0 * std::cos(enu_heading), 1e-3);
  EXPECT_NEAR(ahead.y(), 100.0 * std::sin(enu_heading), 1e-3);
  EXPECT_THROW(g.SeedFromFix(local, 0.0, at, 0.0), InvalidArgument);
}

TEST(GeoReferencer, WaitsForGpsAndValidates) {
  GeoReferencer geo;
  EXPECT_FALSE(geo.Observe({0, 0}, std::nullopt, std::nullopt));
  EXPECT_FALSE(geo.has_enu());
  EXPECT_THROW(geo.EnuFromLocal({1, 1}), InvalidArgument);
  GeoRefOptions bad;
  bad.min_segment_m = 0.0;
  EXPECT_THROW(Validate(bad), InvalidArgument);
  GeoRefOptions yaw;
  yaw.heading_source = HeadingSource::kTelemetryYaw;
  GeoReferencer needs_yaw(yaw);
  EXPECT_THROW(needs_yaw.Observe({0, 0}, GeoPoint{1, 2, 3}, std::nullopt), InputError);
  EXPECT_EQ(ParseHeadingSource("gps"), HeadingSource::kGpsSegment);
  // A 10 m flight never reaches the 30 m segment; FixWithAvailable uses what there is.
  GeoRefOptions gps;
  gps.heading_source = HeadingSource::kGpsSegment;
  GeoReferencer short_flight(gps);
  const LocalEnu enu(10.0, 20.0, 0.0);
  EXPECT_FALSE(short_flight.FixWithAvailable());
  for (int i = 0; i <= 10; ++i) {
    // local +y points east (rotation -90 deg).
    EXPECT_FALSE(short_flight.Observe({0.0, 1.0 * i}, enu.Reverse(1.0 * i, 0.0, 0.0), {}));
  }
  EXPECT_TRUE(short_flight.FixWithAvailable());
  EXPECT_NEAR(short_flight.rotation_rad(), -M_PI / 2, 1e-6);
  EXPECT_THROW(ParseHeadingSource("north"), InvalidArgument);
}

// A fix 25 m off inside the segment (it passes a loose plausibility check): with outlier_m the
// robust pass drops it and the rotation stays that of the clean fixes.
TEST(GeoReferencer, RobustSegmentFitDropsAnOutlier) {
  const LocalEnu enu(45.07, 7.66, 250.0);
  Flight f = MakeFlight(-130.0, enu, {1.0, 1.0});
  const Eigen::Vector3d e5 = enu.Forward(f.gps[5]);
  f.gps[5] = enu.Reverse(e5.x() + 25.0, e5.y() - 25.0, 0.0);
  double rotation[2];
  for (int robust = 0; robust < 2; ++robust) {
    GeoRefOptions opts;
    opts.heading_source = HeadingSource::kGpsSegment;
    opts.outlier_m = robust ? 10.0 : 0.0;
    GeoReferencer geo(opts);
    for (std::size_t i = 0; i < f.local.size() && !geo.ready(); ++i) {
      geo.Observe(f.local[i], f.gps[i], std::nullopt);
    }
    ASSERT_TRUE(geo.ready());
    EXPECT_EQ(geo.outliers(), robust ? 1 : 0);
    rotation[robust] = geo.rotation_rad();
  }
  const double want = 130.0 * kDegToRad;  // MakeFlight: a rotation of -yaw0
  const auto err = [&](double a) { return std::abs(std::remainder(a - want, 2.0 * M_PI)); };
  EXPECT_LT(err(rotation[1]), 0.02);
  EXPECT_GT(err(rotation[0]), err(rotation[1]));
}

// Telemetry yaw with yaw_fixes = 3: the translation is the first fix's when the three agree
// (as with yaw_fixes = 1), else their median, so a bad first fix does not shift the track.
TEST(GeoReferencer, YawTranslationIsTheMedianOfTheFirstFixes) {
  const LocalEnu enu(27.95, -82.46, 10.0);
  Flight f = MakeFlight(70.0, enu, {0, 0});
  const GeoPoint good0 = f.gps[0];
  const Eigen::Vector3d e0 = enu.Forward(f.gps[0]);
  f.gps[0] = enu.Reverse(e0.x(), e0.y() + 1112.0, 0.0);
  GeoRefOptions opts;
  opts.yaw_fixes = 3;
  opts.outlier_m = 10.0;
  {
    const Flight noisy = MakeFlight(70.0, enu, {1.5, 1.5});
    GeoReferencer first_only, three(opts);
    ASSERT_TRUE(first_only.Observe(noisy.local[0], noisy.gps[0], 70.0));
    three.Observe(noisy.local[0], noisy.gps[0], 70.0);
    three.Observe(noisy.local[1], noisy.gps[1], 70.0);
    ASSERT_TRUE(three.Observe(noisy.local[2], noisy.gps[2], 70.0));
    EXPECT_EQ(three.EnuFromLocal(noisy.local[30]), first_only.EnuFromLocal(noisy.local[30]));
  }
  GeoReferencer geo(opts);
  EXPECT_FALSE(geo.Observe(f.local[0], f.gps[0], 70.0));
  EXPECT_FALSE(geo.Observe(f.local[1], f.gps[1], 70.0));
  ASSERT_TRUE(geo.Observe(f.local[2], f.gps[2], 70.0));
  EXPECT_LT(GeodesicDistance(geo.Wgs84FromLocal(f.local[0]), good0), 0.01);
  EXPECT_LT(GeodesicDistance(geo.Wgs84FromLocal(f.local[40]), f.gps[40]), 0.01);
}

// Restart forgets the segment (the fixes were outliers) and the origin they set: the ENU frame's
// origin is the new segment's first fix, not the outlier 500 m away.
TEST(GeoReferencer, RestartStartsANewSegment) {
  const LocalEnu enu(45.07, 7.66, 250.0);
  const Flight f = MakeFlight(-130.0, enu, {0, 0});
  GeoRefOptions opts;
  opts.heading_source = HeadingSource::kGpsSegment;
  GeoReferencer geo(opts);
  const Eigen::Vector3d e1 = enu.Forward(f.gps[1]);
  const GeoPoint outlier = enu.Reverse(e1.x() + 500.0, e1.y(), 0.0);
  geo.Observe(f.local[0], outlier, std::nullopt);
  ASSERT_TRUE(geo.has_enu());
  EXPECT_DOUBLE_EQ(geo.enu().origin().lat_deg, outlier.lat_deg);
  geo.Restart();
  EXPECT_FALSE(geo.has_enu());
  for (std::size_t i = 1; i < f.local.size() && !geo.ready(); ++i) {
    geo.Observe(f.local[i], f.gps[i], std::nullopt);
  }
  ASSERT_TRUE(geo.ready());
  EXPECT_DOUBLE_EQ(geo.enu().origin().lat_deg, f.gps[1].lat_deg);
  EXPECT_DOUBLE_EQ(geo.enu().origin().lon_deg, f.gps[1].lon_deg);
  EXPECT_LT(GeodesicDistance(geo.Wgs84FromLocal(f.local[50]), f.gps[50]), 0.01);
  EXPECT_THROW(geo.Restart(), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::georef_test
