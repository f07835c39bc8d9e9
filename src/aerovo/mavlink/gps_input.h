// GPS_INPUT (#232) from a geographic position with its accuracy and time: what aerovo sends for
// ArduPilot to take as a GPS receiver (GPS1_TYPE = 14; docs/autopilot.md "GPS_INPUT"). The input
// is a plain GeoFix, whatever made it (a geo-referenced odometry pose, an absolute fix against a
// map), so that every absolute position aerovo has goes through one conversion.
//
// GPS time: GPS_INPUT carries GPS time as a week number and milliseconds into the week. GPS time
// started at 1980-01-06 00:00:00 UTC (Unix time 315964800 s) and does not count leap seconds, so
// it runs ahead of UTC by the leap seconds inserted since: 18 s from 2017-01-01 on (IERS Bulletin
// C 52 to this day; kGpsMinusUtcS must follow the next one the IERS announces).
#pragma once

#include <cstdint>
#include <optional>

#include "aerovo/mavlink/messages.h"

namespace aerovo::mavlink {

/// Unix time of the GPS epoch, 1980-01-06 00:00:00 UTC, s.
inline constexpr double kGpsEpochUnixS = 315964800.0;
/// GPS time minus UTC, s: the leap seconds since the GPS epoch (18 from 2017-01-01).
inline constexpr int kGpsMinusUtcS = 18;
inline constexpr uint32_t kMsPerGpsWeek = 7u * 24u * 3600u * 1000u;

/// A GPS week and the milliseconds into it.
struct GpsWeekTime {
  uint16_t week = 0;
  uint32_t ms = 0;  ///< [0, kMsPerGpsWeek)
};

/// The GPS time of a Unix (UTC) time, `unix_s` seconds, rounded to the millisecond; nullopt when
/// it is not finite, before the GPS epoch, or past week 65535.
std::optional<GpsWeekTime> GpsTimeOfUnix(double unix_s);

/// A geographic position with its accuracy at one instant.
struct GeoFix {
  /// The instant the position is of (a frame's capture), Unix time (UTC), s.
  double unix_time_s = 0.0;
  /// GPS_INPUT.time_usec: the same instant on the clock the run's messages use (boot or Unix), us.
  uint64_t time_usec = 0;
  /// WGS84 degrees; a position that is not finite or out of range is not sent as a fix.
  double lat_deg = 0.0, lon_deg = 0.0;
  /// Above mean sea level, m; unset (or not finite): GPS_INPUT's alt is marked ignored.
  std::optional<double> alt_msl_m;
  /// Standard deviation of the horizontal position along its worse axis, m (GPS "hAcc").
  double sigma_horizontal_m = 0.0;
  /// Velocity north and east, m/s, and its standard deviation per axis, m/s; unset: ignored.
  std::optional<double> vel_north_mps, vel_east_mps;
  double sigma_velocity_mps = 0.0;
  /// The vehicle's heading, degrees clockwise from true north; unset: unknown (yaw 0).
  std::optional<double> yaw_deg;
};

/// How a GeoFix is sent.
struct GpsInputOptions {
  /// A 3D fix only when sigma_horizontal_m is at most this, m; else GPS_FIX_TYPE_NO_FIX.
  double max_horizontal_sigma_m = 10.0;
  /// GPS_INPUT.gps_id: the receiving GPS instance, 0 = the first (GPS1_TYPE = 14).
  uint8_t gps_id = 0;
};

/// satellites_visible sent with a 3D fix. A camera fix has no satellites; ArduPilot's EKF3 will
/// not start using a GPS that reports fewer than 6 (AP_NavEKF3_VehicleStatus.cpp
/// calcGpsGoodToAlign), so a count above that is sent. 0 without a fix.
inline constexpr uint8_t kGpsInputSatellitesWithFix = 10;
/// hdop sent with a 3D fix (a dimensionless geometry factor; 1 = ideal: the accuracy itself is
/// horiz_accuracy) and without one (99.99, the largest DOP GPS receivers report).
inline constexpr float kGpsInputHdopWithFix = 1.0f, kGpsInputHdopNoFix = 99.99f;

/// The GPS_INPUT of `fix`. Every float sent is finite, every value within the field's range
/// (a field aerovo cannot fill is 0 and its ignore flag set). vdop, vd and vert_accuracy are
/// always ignored: aerovo does not measure height. fix_type is 3 (3D) when the position is
/// finite and in range, the time is after the GPS epoch and sigma_horizontal_m is finite and at
/// most options.max_horizontal_sigma_m; else 1 (no fix, which ArduPilot's EKF3 does not use).
GpsInput MakeGpsInput(const GeoFix& fix, const GpsInputOptions& options);

}  // namespace aerovo::mavlink
