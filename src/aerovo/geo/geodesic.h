// Distances and bearings on the WGS84 ellipsoid (GeographicLib's Geodesic, Karney 2013,
// accurate to ~15 nm), and conversions between compass bearings and ENU angles.
#pragma once

#include "aerovo/geo/geo_point.h"

namespace aerovo {

/// Result of the inverse geodesic problem between two points (heights ignored).
struct GeodesicInverseResult {
  double distance_m = 0.0;    ///< Length of the shortest geodesic on the ellipsoid, metres.
  double azimuth1_deg = 0.0;  ///< Forward azimuth at the first point, degrees clockwise
                              ///< from north, [0, 360).
  double azimuth2_deg = 0.0;  ///< Forward azimuth at the second point (direction of travel
                              ///< on arrival), degrees clockwise from north, [0, 360).
};

/// Solves the inverse problem from `from` to `to` on WGS84. Heights are ignored (the
/// geodesic lies on the ellipsoid). Throws InvalidArgument for invalid points.
GeodesicInverseResult GeodesicInverse(const GeoPoint& from, const GeoPoint& to);

/// Geodesic distance from `from` to `to` on WGS84, metres (heights ignored).
double GeodesicDistance(const GeoPoint& from, const GeoPoint& to);

/// Initial bearing (forward azimuth) at `from` towards `to`, degrees clockwise from north,
/// in [0, 360). 0 when the points coincide.
double InitialBearingDeg(const GeoPoint& from, const GeoPoint& to);

/// Solves the direct problem: the point reached from `from` after `distance_m` metres along
/// the geodesic leaving at `azimuth_deg` (clockwise from north). The height is copied from
/// `from`; the longitude is in [-180, 180).
GeoPoint GeodesicDirect(const GeoPoint& from, double azimuth_deg, double distance_m);

/// Converts a compass bearing (degrees clockwise from north, as in telemetry yaw/heading) to
/// the mathematical angle in the ENU plane (radians counter-clockwise from east), wrapped to
/// (-pi, pi].
double EnuAngleRadFromBearingDeg(double bearing_deg);

/// Inverse of EnuAngleRadFromBearingDeg: degrees clockwise from north in [0, 360).
double BearingDegFromEnuAngleRad(double enu_angle_rad);

}  // namespace aerovo
