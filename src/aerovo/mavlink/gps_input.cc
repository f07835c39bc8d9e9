#include "aerovo/mavlink/gps_input.h"

#include <cmath>

namespace aerovo::mavlink {
namespace {

bool Finite(const std::optional<double>& v) { return v && std::isfinite(*v); }

// The heading in centidegrees, 1..36000 (north sent as 36000: 0 means unknown).
uint16_t YawCentidegrees(double yaw_deg) {
  double d = std::fmod(yaw_deg, 360.0);
  if (d < 0.0) d += 360.0;
  long cdeg = std::lround(d * 100.0);
  if (cdeg <= 0 || cdeg > 36000) cdeg = 36000;
  return static_cast<uint16_t>(cdeg);
}

}  // namespace

std::optional<GpsWeekTime> GpsTimeOfUnix(double unix_s) {
  if (!std::isfinite(unix_s)) return std::nullopt;
  const double gps_s = unix_s - kGpsEpochUnixS + kGpsMinusUtcS;
  if (gps_s < 0.0) return std::nullopt;
  const long long total_ms = std::llround(gps_s * 1000.0);
  const long long week = total_ms / kMsPerGpsWeek;
  if (week > 65535) return std::nullopt;
  return GpsWeekTime{static_cast<uint16_t>(week), static_cast<uint32_t>(total_ms % kMsPerGpsWeek)};
}

GpsInput MakeGpsInput(const GeoFix& fix, const GpsInputOptions& options) {
  GpsInput m;
  m.time_usec = fix.time_usec;
  m.gps_id = options.gps_id;
  m.ignore_flags = kGpsInputIgnoreVdop | kGpsInputIgnoreVelVert | kGpsInputIgnoreVerticalAccuracy;
  const std::optional<GpsWeekTime> t = GpsTimeOfUnix(fix.unix_time_s);
  if (t) {
    m.time_week = t->week;
    m.time_week_ms = t->ms;
  }
  const bool position = std::isfinite(fix.lat_deg) && std::isfinite(fix.lon_deg) &&
                        std::abs(fix.lat_deg) <= 90.0 && std::abs(fix.lon_deg) <= 180.0;
  if (position) {
    m.lat = static_cast<int32_t>(std::lround(fix.lat_deg * 1e7));
    m.lon = static_cast<int32_t>(std::lround(fix.lon_deg * 1e7));
  }
  if (Finite(fix.alt_msl_m) && std::abs(*fix.alt_msl_m) < 1e6) {
    m.alt = static_cast<float>(*fix.alt_msl_m);
  } else {
    m.ignore_flags |= kGpsInputIgnoreAlt;
  }
  const bool accuracy = std::isfinite(fix.sigma_horizontal_m) && fix.sigma_horizontal_m >= 0.0 &&
                        fix.sigma_horizontal_m < 1e6;
  if (accuracy) {
    m.horiz_accuracy = static_cast<float>(fix.sigma_horizontal_m);
  } else {
    m.ignore_flags |= kGpsInputIgnoreHorizontalAccuracy;
  }
  const bool velocity = Finite(fix.vel_north_mps) && Finite(fix.vel_east_mps) &&
                        std::abs(*fix.vel_north_mps) < 1e4 && std::abs(*fix.vel_east_mps) < 1e4;
  if (velocity) {
    m.vn = static_cast<float>(*fix.vel_north_mps);
    m.ve = static_cast<float>(*fix.vel_east_mps);
  } else {
    m.ignore_flags |= kGpsInputIgnoreVelHoriz;
  }
  if (velocity && std::isfinite(fix.sigma_velocity_mps) && fix.sigma_velocity_mps >= 0.0 &&
      fix.sigma_velocity_mps < 1e4) {
    m.speed_accuracy = static_cast<float>(fix.sigma_velocity_mps);
  } else {
    m.ignore_flags |= kGpsInputIgnoreSpeedAccuracy;
  }
  const bool good = position && t && accuracy && fix.sigma_horizontal_m <= options.max_horizontal_sigma_m;
  m.fix_type = good ? kGpsFixType3d : kGpsFixTypeNoFix;
  m.satellites_visible = good ? kGpsInputSatellitesWithFix : 0;
  m.hdop = good ? kGpsInputHdopWithFix : kGpsInputHdopNoFix;
  if (Finite(fix.yaw_deg)) m.yaw = YawCentidegrees(*fix.yaw_deg);
  return m;
}

}  // namespace aerovo::mavlink
