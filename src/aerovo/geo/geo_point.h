// A WGS84 geographic position (latitude, longitude in degrees; ellipsoidal height in metres).
#pragma once

namespace aerovo {

/// A point on or above the WGS84 ellipsoid. Latitude and longitude are geodetic degrees
/// (north and east positive); alt_m is the height in metres above the ellipsoid, or whatever
/// vertical datum the source gave (GPS receivers and DJI EXIF usually give height above the
/// geoid/MSL: the ~tens of metres difference is a constant offset over a flight and cancels in
/// a local ENU frame whose origin uses the same datum).
struct GeoPoint {
  double lat_deg = 0.0;  ///< Geodetic latitude, degrees, [-90, 90].
  double lon_deg = 0.0;  ///< Longitude, degrees, any finite value (wrapped where needed).
  double alt_m = 0.0;    ///< Height, metres.
};

/// Throws InvalidArgument (message starting with `what`) when a coordinate is not finite or
/// the latitude is outside [-90, 90] degrees.
void Validate(const GeoPoint& point, const char* what = "GeoPoint");

}  // namespace aerovo
