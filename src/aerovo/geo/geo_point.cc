#include "aerovo/geo/geo_point.h"

#include <cmath>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {

void Validate(const GeoPoint& point, const char* what) {
  if (!std::isfinite(point.lat_deg) || !std::isfinite(point.lon_deg) ||
      !std::isfinite(point.alt_m)) {
    throw InvalidArgument(std::string(what) + ": coordinates must be finite (lat " +
                          std::to_string(point.lat_deg) + ", lon " + std::to_string(point.lon_deg) +
                          ", alt " + std::to_string(point.alt_m) + ")");
  }
  if (point.lat_deg < -90.0 || point.lat_deg > 90.0) {
    throw InvalidArgument(std::string(what) + ": latitude " + std::to_string(point.lat_deg) +
                          " deg is outside [-90, 90]");
  }
}

}  // namespace aerovo
