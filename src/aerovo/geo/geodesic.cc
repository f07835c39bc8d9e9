#include "aerovo/geo/geodesic.h"

#include <cmath>
#include <string>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/Math.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"

namespace aerovo {
namespace {

// GeographicLib returns azimuths in [-180, 180]; compass bearings are conventionally [0, 360).
double ToCompass(double azimuth_deg) {
  double b = std::fmod(azimuth_deg, 360.0);
  if (b < 0.0) b += 360.0;
  if (b >= 360.0) b -= 360.0;  // fmod of a tiny negative value plus 360 can round to 360
  return b;
}

}  // namespace

GeodesicInverseResult GeodesicInverse(const GeoPoint& from, const GeoPoint& to) {
  Validate(from, "GeodesicInverse: from");
  Validate(to, "GeodesicInverse: to");
  GeodesicInverseResult r;
  GeographicLib::Geodesic::WGS84().Inverse(from.lat_deg, from.lon_deg, to.lat_deg, to.lon_deg,
                                           r.distance_m, r.azimuth1_deg, r.azimuth2_deg);
  // Coincident points have no bearing: 0 by convention. Equal coordinates are tested as well as
  // a zero distance: GeographicLib built for aarch64 (fused multiply-adds) returns a distance of
  // a few nanometres and an azimuth of 180 degrees for two identical points.
  if (r.distance_m == 0.0 || (from.lat_deg == to.lat_deg && from.lon_deg == to.lon_deg)) {
    r.distance_m = 0.0;
    r.azimuth1_deg = 0.0;
    r.azimuth2_deg = 0.0;
  }
  r.azimuth1_deg = ToCompass(r.azimuth1_deg);
  r.azimuth2_deg = ToCompass(r.azimuth2_deg);
  return r;
}

double GeodesicDistance(const GeoPoint& from, const GeoPoint& to) {
  return GeodesicInverse(from, to).distance_m;
}

double InitialBearingDeg(const GeoPoint& from, const GeoPoint& to) {
  return GeodesicInverse(from, to).azimuth1_deg;
}

GeoPoint GeodesicDirect(const GeoPoint& from, double azimuth_deg, double distance_m) {
  Validate(from, "GeodesicDirect: from");
  if (!std::isfinite(azimuth_deg) || !std::isfinite(distance_m)) {
    throw InvalidArgument("GeodesicDirect: azimuth (" + std::to_string(azimuth_deg) +
                          " deg) and distance (" + std::to_string(distance_m) +
                          " m) must be finite");
  }
  GeoPoint p;
  p.alt_m = from.alt_m;
  GeographicLib::Geodesic::WGS84().Direct(from.lat_deg, from.lon_deg, azimuth_deg, distance_m,
                                          p.lat_deg, p.lon_deg);
  p.lon_deg = GeographicLib::Math::AngNormalize(p.lon_deg);
  if (p.lon_deg >= 180.0) p.lon_deg -= 360.0;
  return p;
}

double EnuAngleRadFromBearingDeg(double bearing_deg) {
  // Bearing runs clockwise from north (y); the ENU angle counter-clockwise from east (x).
  double a = std::remainder((90.0 - bearing_deg) * kPi / 180.0, 2.0 * kPi);
  if (a <= -kPi) a += 2.0 * kPi;
  return a;
}

double BearingDegFromEnuAngleRad(double enu_angle_rad) {
  return ToCompass(90.0 - enu_angle_rad * 180.0 / kPi);
}

}  // namespace aerovo
