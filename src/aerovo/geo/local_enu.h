// Local East-North-Up frame tangent to the WGS84 ellipsoid at an origin (GeographicLib's
// LocalCartesian). This is the frame aerovo uses for metric trajectories: GPS fixes and the
// geo-referenced visual odometry both live in it (docs/method.md, "Trajectory
// evaluation": first GPS fix as origin).
#pragma once

#include <memory>

#include <Eigen/Core>

#include "aerovo/geo/geo_point.h"

namespace aerovo {

/// Converts between WGS84 geodetic coordinates and a local Cartesian East-North-Up frame
/// (metres; x = east, y = north, z = up, origin at `origin`, z = 0 at the origin's height).
/// Exact (no small-area approximation): the conversion goes through Earth-centred
/// Earth-fixed coordinates, so it is valid at any distance from the origin; beyond a few km
/// the ENU plane departs from the ellipsoid (the Earth curves ~7.8 cm below the plane at 1 km),
/// which is why the horizontal ENU coordinates of a point at the origin's height are not the
/// geodesic distances along the surface.
/// Copies are cheap and share the immutable converter; all methods are const and thread-safe.
class LocalEnu {
 public:
  /// Throws InvalidArgument when `origin` is invalid (see Validate(GeoPoint)).
  explicit LocalEnu(const GeoPoint& origin);
  LocalEnu(double origin_lat_deg, double origin_lon_deg, double origin_alt_m);

  const GeoPoint& origin() const { return origin_; }

  /// enu_from_wgs84: the position of (lat_deg, lon_deg, alt_m) in this frame, metres.
  Eigen::Vector3d Forward(double lat_deg, double lon_deg, double alt_m) const;
  Eigen::Vector3d Forward(const GeoPoint& point) const {
    return Forward(point.lat_deg, point.lon_deg, point.alt_m);
  }

  /// wgs84_from_enu: the geodetic position of ENU point `enu_m` (metres). Longitude is in
  /// [-180, 180).
  GeoPoint Reverse(const Eigen::Vector3d& enu_m) const;
  GeoPoint Reverse(double east_m, double north_m, double up_m) const {
    return Reverse(Eigen::Vector3d(east_m, north_m, up_m));
  }

 private:
  struct Impl;
  GeoPoint origin_;
  std::shared_ptr<const Impl> impl_;
};

}  // namespace aerovo
