// Simulated GPS: fixes sampled from the true trajectory at the receiver's rate, with Gaussian
// (optionally time-correlated) position noise.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/sim/camera.h"

namespace aerovo::sim {

struct GpsOptions {
  /// Fix rate (Hz). Default 10 Hz, the rate of DJI flight logs. Every frame of the SRT carries
  /// the latest fix (as DJI's SRT does).
  double rate_hz = 10.0;
  /// Standard deviation of the horizontal error per axis (east and north, m). Default 0 (exact).
  /// Consumer GNSS on a drone: about 1-2 m (without RTK).
  double horizontal_sigma_m = 0.0;
  /// Standard deviation of the vertical error (m). Default 0.
  double vertical_sigma_m = 0.0;
  /// Correlation time of the error (s): 0 = independent per fix (white); > 0 = first-order
  /// Gauss-Markov process with this time constant (real GNSS errors wander slowly, tau of tens of
  /// seconds). The stationary standard deviation is the sigma above either way.
  double correlation_time_s = 0.0;
};

/// Throws aerovo::InvalidArgument naming the bad field.
void Validate(const GpsOptions& gps);

struct GpsFix {
  double time_s = 0.0;  ///< Time since the first frame (s).
  GeoPoint position;    ///< Reported WGS84 position (with the error).
  Eigen::Vector3d error_enu_m = Eigen::Vector3d::Zero();  ///< Reported minus true (E, N, U), m.
};

/// Samples fixes at t = 0, 1/rate, ... up to the last pose's time. The true position at a fix
/// time is interpolated linearly between poses; `map_enu` converts map-frame metres to WGS84
/// (its origin is the map frame's origin, at the ground's altitude): latitude and longitude are
/// those of the ground point below the noisy position, altitude = ground altitude + height +
/// vertical error. Deterministic in `seed`.
std::vector<GpsFix> SimulateGps(const std::vector<CameraPose>& poses, const GpsOptions& options,
                                const LocalEnu& map_enu, std::uint64_t seed);

/// Index of the latest fix at or before time t (fixes sorted by time); 0 if t precedes all.
size_t LatestFixIndex(const std::vector<GpsFix>& fixes, double time_s);

}  // namespace aerovo::sim
