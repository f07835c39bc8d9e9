#include <cmath>

#include <gtest/gtest.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/geo/geodesic.h"
#include "aerovo/geo/local_enu.h"

namespace aerovo::geo_test {
namespace {

// WGS84 defining constants (NIMA TR8350.2): semi-major axis and flattening.
constexpr double kA = 6378137.0;
constexpr double kF = 1.0 / 298.257223563;
constexpr double kE2 = kF * (2.0 - kF);
constexpr double kCm = 0.01;

// Hand-derived geodetic -> Earth-centred Earth-fixed conversion (textbook formula:
// N = a / sqrt(1 - e^2 sin^2 phi); X = (N+h) cos phi cos lam, Y = (N+h) cos phi sin lam,
// Z = (N (1-e^2) + h) sin phi), independent of GeographicLib.
Eigen::Vector3d Ecef(double lat_deg, double lon_deg, double h) {
  const double phi = lat_deg * kDegToRad, lam = lon_deg * kDegToRad;
  const double n = kA / std::sqrt(1.0 - kE2 * std::sin(phi) * std::sin(phi));
  return {(n + h) * std::cos(phi) * std::cos(lam), (n + h) * std::cos(phi) * std::sin(lam),
          (n * (1.0 - kE2) + h) * std::sin(phi)};
}

// ENU of a point relative to an origin: rotate the ECEF difference by the textbook
// east/north/up unit vectors of the origin.
Eigen::Vector3d HandEnu(const GeoPoint& o, const GeoPoint& p) {
  const double phi = o.lat_deg * kDegToRad, lam = o.lon_deg * kDegToRad;
  const Eigen::Vector3d d =
      Ecef(p.lat_deg, p.lon_deg, p.alt_m) - Ecef(o.lat_deg, o.lon_deg, o.alt_m);
  const Eigen::Vector3d east(-std::sin(lam), std::cos(lam), 0.0);
  const Eigen::Vector3d north(-std::sin(phi) * std::cos(lam), -std::sin(phi) * std::sin(lam),
                              std::cos(phi));
  const Eigen::Vector3d up(std::cos(phi) * std::cos(lam), std::cos(phi) * std::sin(lam),
                           std::sin(phi));
  return {east.dot(d), north.dot(d), up.dot(d)};
}

// Meridian arc from the equator to lat_deg, by Simpson integration of the meridional radius
// of curvature M(phi) = a (1-e^2) / (1 - e^2 sin^2 phi)^(3/2): an independent reference.
double MeridianArc(double lat_deg) {
  const int n = 2000;  // even; the integrand is smooth, error << 1e-9 m
  const double h = lat_deg * kDegToRad / n;
  auto m = [](double phi) {
    return kA * (1.0 - kE2) / std::pow(1.0 - kE2 * std::sin(phi) * std::sin(phi), 1.5);
  };
  double s = m(0.0) + m(n * h);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * m(i * h);
  return s * h / 3.0;
}

TEST(Geodesic, MatchesGeographicLibPublishedTestCases) {
  // Rows of the `testcases` table in GeographicLib's tests/geodtest.cpp (Karney's GeodTest
  // data set): lat1, lon1, azi1, lat2, lon2, azi2, s12 (metres).
  struct Case {
    double lat1, lon1, azi1, lat2, lon2, azi2, s12;
  };
  const Case cases[] = {
      {35.60777, -139.44815, 111.098748429560326, -11.17491, -69.95921, 129.289270889708762,
       8935244.5604818305},
      {55.52454, 106.05087, 22.020059880982801, 77.03196, 197.18234, 109.112041110671519,
       4105086.1713924406},
      {-21.97856, 142.59065, -32.44456876433189, 41.84138, 98.56635, -41.84359951440466,
       8394328.894657671},
  };
  for (const Case& c : cases) {
    const GeoPoint a{c.lat1, c.lon1, 0.0}, b{c.lat2, c.lon2, 0.0};
    const GeodesicInverseResult r = GeodesicInverse(a, b);
    EXPECT_NEAR(r.distance_m, c.s12, 1e-6);
    EXPECT_NEAR(r.azimuth1_deg, c.azi1 < 0 ? c.azi1 + 360.0 : c.azi1, 1e-9);
    EXPECT_NEAR(r.azimuth2_deg, c.azi2 < 0 ? c.azi2 + 360.0 : c.azi2, 1e-9);
    EXPECT_NEAR(GeodesicDistance(a, b), c.s12, 1e-6);
    // Direct problem: going s12 along azi1 lands on the second point.
    const GeoPoint d = GeodesicDirect(a, c.azi1, c.s12);
    EXPECT_NEAR(d.lat_deg, c.lat2, 1e-9);
    EXPECT_NEAR(std::remainder(d.lon_deg - c.lon2, 360.0), 0.0, 1e-9);
    EXPECT_GE(d.lon_deg, -180.0);
    EXPECT_LT(d.lon_deg, 180.0);
  }
}

TEST(Geodesic, MeridianAndEquatorArcs) {
  const GeoPoint origin{0.0, 0.0, 0.0};
  // One degree of latitude at the equator: 110574.4 m (published WGS84 value, e.g. the
  // "Latitude" table of length of a degree); checked to 1 mm against numerical integration.
  const double one_deg_north = GeodesicDistance(origin, {1.0, 0.0, 0.0});
  EXPECT_NEAR(one_deg_north, MeridianArc(1.0), 1e-3);
  EXPECT_NEAR(one_deg_north, 110574.4, 0.05);
  // Quarter meridian of WGS84: 10001965.729313 m (GeographicLib GeodSolve, 0 0 90 0).
  EXPECT_NEAR(GeodesicDistance(origin, {90.0, 0.0, 0.0}), 10001965.729313, 1e-3);
  EXPECT_NEAR(GeodesicDistance(origin, {90.0, 0.0, 0.0}), MeridianArc(90.0), 1e-3);
  // Along the equator the geodesic is the equatorial circle (for < ~179.4 deg): a * dlon.
  EXPECT_NEAR(GeodesicDistance(origin, {0.0, 1.0, 0.0}), kA * kDegToRad, 1e-6);  // 111319.4908 m
  EXPECT_NEAR(GeodesicDistance({0.0, 10.0, 0.0}, {0.0, 70.0, 0.0}), kA * 60.0 * kDegToRad, 1e-6);
  // Heights are ignored by geodesics.
  EXPECT_DOUBLE_EQ(GeodesicDistance({0.0, 0.0, 500.0}, {1.0, 0.0, -20.0}), one_deg_north);
}

TEST(Geodesic, Bearings) {
  const GeoPoint o{50.45, 30.52, 0.0};  // Kyiv
  EXPECT_NEAR(InitialBearingDeg(o, GeodesicDirect(o, 0.0, 1000.0)), 0.0, 1e-9);
  EXPECT_NEAR(InitialBearingDeg(o, GeodesicDirect(o, 90.0, 1000.0)), 90.0, 1e-9);
  EXPECT_NEAR(InitialBearingDeg(o, GeodesicDirect(o, 200.0, 1000.0)), 200.0, 1e-9);
  EXPECT_NEAR(InitialBearingDeg(o, GeodesicDirect(o, -45.0, 1000.0)), 315.0, 1e-9);
  EXPECT_EQ(InitialBearingDeg(o, o), 0.0);
  // Due north along a meridian and due east along the equator.
  EXPECT_NEAR(InitialBearingDeg({0, 0, 0}, {1, 0, 0}), 0.0, 1e-12);
  EXPECT_NEAR(InitialBearingDeg({0, 0, 0}, {0, 1, 0}), 90.0, 1e-12);
  EXPECT_NEAR(InitialBearingDeg({0, 0, 0}, {-1, 0, 0}), 180.0, 1e-12);
  EXPECT_NEAR(InitialBearingDeg({0, 0, 0}, {0, -1, 0}), 270.0, 1e-12);
  // A 1 km leg's length is preserved by Direct then Inverse.
  EXPECT_NEAR(GeodesicDistance(o, GeodesicDirect(o, 123.0, 1000.0)), 1000.0, 1e-8);
}

TEST(Geodesic, CompassEnuAngleConversions) {
  EXPECT_NEAR(EnuAngleRadFromBearingDeg(0.0), kPi / 2, 1e-15);     // north = +y
  EXPECT_NEAR(EnuAngleRadFromBearingDeg(90.0), 0.0, 1e-15);        // east = +x
  EXPECT_NEAR(EnuAngleRadFromBearingDeg(180.0), -kPi / 2, 1e-15);  // south
  EXPECT_NEAR(EnuAngleRadFromBearingDeg(270.0), kPi, 1e-15);       // west, wrapped to +pi
  EXPECT_NEAR(EnuAngleRadFromBearingDeg(-90.0), kPi, 1e-15);
  EXPECT_NEAR(EnuAngleRadFromBearingDeg(45.0 + 720.0), kPi / 4, 1e-13);
  for (double b = 0.0; b < 360.0; b += 7.5) {
    EXPECT_NEAR(BearingDegFromEnuAngleRad(EnuAngleRadFromBearingDeg(b)), b, 1e-10) << b;
  }
  EXPECT_NEAR(BearingDegFromEnuAngleRad(-kPi / 2), 180.0, 1e-12);
}

TEST(LocalEnu, MatchesHandDerivedEcefRotation) {
  const GeoPoint origins[] = {{0.0, 0.0, 0.0},
                              {27.9506, -82.4572, 12.0},
                              {45.0703, 7.6869, 240.0},
                              {-33.86, 151.21, 5.0},
                              {78.22, 15.65, 0.0}};
  const double offsets[][3] = {
      {1e-3, 2e-3, 30.0}, {-0.01, 0.004, -5.0}, {0.05, -0.08, 100.0}, {1.0, 0.0, 0.0}};
  for (const GeoPoint& o : origins) {
    const LocalEnu enu(o);
    EXPECT_NEAR(enu.Forward(o).norm(), 0.0, 1e-9);
    for (const auto& d : offsets) {
      const GeoPoint p{o.lat_deg + d[0], o.lon_deg + d[1], o.alt_m + d[2]};
      const Eigen::Vector3d got = enu.Forward(p);
      const Eigen::Vector3d want = HandEnu(o, p);
      EXPECT_NEAR((got - want).norm(), 0.0, 1e-6) << o.lat_deg << " " << p.lat_deg;
    }
  }
}

TEST(LocalEnu, OneDegreeNorthAtEquator) {
  // From (0, 0, 0) the point 1 deg north lies in the meridian plane: ENU north is its ECEF Z
  // = N(1 deg) (1 - e^2) sin(1 deg), up = N cos(1 deg) - a (hand-derived).
  const LocalEnu enu(0.0, 0.0, 0.0);
  const Eigen::Vector3d p = enu.Forward(1.0, 0.0, 0.0);
  const double n1 = kA / std::sqrt(1.0 - kE2 * std::sin(kDegToRad) * std::sin(kDegToRad));
  EXPECT_NEAR(p.x(), 0.0, 1e-9);
  EXPECT_NEAR(p.y(), n1 * (1.0 - kE2) * std::sin(kDegToRad), kCm);
  EXPECT_NEAR(p.z(), n1 * std::cos(kDegToRad) - kA, kCm);
  // The tangent-plane coordinate is not the arc: it is 5.6 m shorter than the 110574.4 m
  // meridian arc (the point lies 965 m below the plane).
  EXPECT_NEAR(MeridianArc(1.0) - p.y(), 5.614, 0.005);
  // Short displacements agree with the geodesic to far better than 1 cm: 100 m due north
  // and due east of Tampa are (0, 100) and (100, 0) in ENU (the ground drops 0.8 mm below
  // the tangent plane).
  const GeoPoint tampa{27.9506, -82.4572, 12.0};
  const LocalEnu t(tampa);
  const Eigen::Vector3d n = t.Forward(GeodesicDirect(tampa, 0.0, 100.0));
  EXPECT_NEAR(n.x(), 0.0, 1e-6);
  EXPECT_NEAR(n.y(), 100.0, kCm);
  EXPECT_NEAR(n.z(), 0.0, kCm);
  const Eigen::Vector3d e = t.Forward(GeodesicDirect(tampa, 90.0, 100.0));
  EXPECT_NEAR(e.x(), 100.0, kCm);
  EXPECT_NEAR(e.y(), 0.0, kCm);
  // Height maps to up.
  EXPECT_NEAR(t.Forward(tampa.lat_deg, tampa.lon_deg, 112.0).z(), 100.0, 1e-6);
}

TEST(LocalEnu, RoundTrip) {
  const LocalEnu enu(45.0703, 7.6869, 240.0);
  EXPECT_EQ(enu.origin().lat_deg, 45.0703);
  for (double e = -5000.0; e <= 5000.0; e += 1250.0) {
    for (double n = -5000.0; n <= 5000.0; n += 2500.0) {
      for (double u : {-100.0, 0.0, 350.0}) {
        const Eigen::Vector3d p(e, n, u);
        const GeoPoint g = enu.Reverse(p);
        EXPECT_NEAR((enu.Forward(g) - p).norm(), 0.0, 1e-6);
        // And the geodetic side: lat/lon back within 1e-11 deg (~1 um).
        const GeoPoint g2 = enu.Reverse(enu.Forward(g));
        EXPECT_NEAR(g2.lat_deg, g.lat_deg, 1e-11);
        EXPECT_NEAR(g2.lon_deg, g.lon_deg, 1e-11);
        EXPECT_NEAR(g2.alt_m, g.alt_m, 1e-6);
      }
    }
  }
  // Across the antimeridian the longitude comes back in [-180, 180).
  const LocalEnu date_line(10.0, 179.9999, 0.0);
  const GeoPoint w = date_line.Reverse(100.0, 0.0, 0.0);
  EXPECT_LT(w.lon_deg, -179.0);
  EXPECT_NEAR((date_line.Forward(w) - Eigen::Vector3d(100.0, 0.0, 0.0)).norm(), 0.0, 1e-6);
  // Copies share the converter and give identical results.
  const LocalEnu copy = enu;
  EXPECT_EQ(copy.Forward(45.1, 7.7, 250.0), enu.Forward(45.1, 7.7, 250.0));
}

TEST(Geo, InvalidInputThrows) {
  EXPECT_THROW(LocalEnu(91.0, 0.0, 0.0), InvalidArgument);
  EXPECT_THROW(LocalEnu(std::nan(""), 0.0, 0.0), InvalidArgument);
  const LocalEnu enu(0.0, 0.0, 0.0);
  EXPECT_THROW(enu.Forward(0.0, INFINITY, 0.0), InvalidArgument);
  EXPECT_THROW(enu.Reverse(Eigen::Vector3d(0.0, std::nan(""), 0.0)), InvalidArgument);
  EXPECT_THROW(GeodesicDistance({-90.5, 0.0, 0.0}, {0.0, 0.0, 0.0}), InvalidArgument);
  EXPECT_THROW(GeodesicDirect({0.0, 0.0, 0.0}, std::nan(""), 1.0), InvalidArgument);
  try {
    Validate(GeoPoint{95.0, 0.0, 0.0}, "fix 3");
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("fix 3"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("latitude"), std::string::npos);
  }
}

}  // namespace
}  // namespace aerovo::geo_test
