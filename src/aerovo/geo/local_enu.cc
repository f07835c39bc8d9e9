#include "aerovo/geo/local_enu.h"

#include <cmath>

#include <GeographicLib/LocalCartesian.hpp>

#include "aerovo/core/error.h"

namespace aerovo {

struct LocalEnu::Impl {
  explicit Impl(const GeoPoint& o)
      : cartesian(o.lat_deg, o.lon_deg, o.alt_m, GeographicLib::Geocentric::WGS84()) {}
  GeographicLib::LocalCartesian cartesian;
};

LocalEnu::LocalEnu(const GeoPoint& origin) : origin_(origin) {
  Validate(origin, "LocalEnu origin");
  impl_ = std::make_shared<const Impl>(origin);
}

LocalEnu::LocalEnu(double origin_lat_deg, double origin_lon_deg, double origin_alt_m)
    : LocalEnu(GeoPoint{origin_lat_deg, origin_lon_deg, origin_alt_m}) {}

Eigen::Vector3d LocalEnu::Forward(double lat_deg, double lon_deg, double alt_m) const {
  Validate(GeoPoint{lat_deg, lon_deg, alt_m}, "LocalEnu::Forward");
  Eigen::Vector3d enu;
  impl_->cartesian.Forward(lat_deg, lon_deg, alt_m, enu.x(), enu.y(), enu.z());
  return enu;
}

GeoPoint LocalEnu::Reverse(const Eigen::Vector3d& enu_m) const {
  if (!enu_m.allFinite()) throw InvalidArgument("LocalEnu::Reverse: ENU point must be finite");
  GeoPoint p;
  impl_->cartesian.Reverse(enu_m.x(), enu_m.y(), enu_m.z(), p.lat_deg, p.lon_deg, p.alt_m);
  if (p.lon_deg >= 180.0) p.lon_deg -= 360.0;
  return p;
}

}  // namespace aerovo
