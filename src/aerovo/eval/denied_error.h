// The error of a track without GPS against the GPS it was denied (RunConfig::gps_denied_after_s,
// pipeline/run_config.h): the estimate as the run had it (geo-referenced, never re-aligned)
// against the withheld fixes, in the same metric frame, over time and distance since the denial.
// The figures a navigation engineer asks of a GPS-denied flight: the error 1, 5 and 10 minutes
// after the denial, and per km flown without GPS. Pure math, no I/O; units: seconds and metres.
#pragma once

#include <optional>
#include <vector>

#include "aerovo/eval/trajectory_eval.h"

namespace aerovo {

/// The error at a time after the denial: at the first pair at or after denied_at_s + after_s.
struct DeniedErrorAt {
  double after_s = 0.0;     ///< The time asked for, s after the denial.
  double time_s = 0.0;      ///< The pair's time, s (the estimate's clock).
  double error_m = 0.0;     ///< Horizontal distance between the estimate and the fix, m.
  double distance_m = 0.0;  ///< Flown since the denial (along the fixes) up to that pair, m.
};

/// The unaligned error since the denial.
struct DeniedError {
  double denied_at_s = 0.0;  ///< The denial, s (the estimate's clock).
  int pairs = 0;             ///< Pairs compared (at or after the denial).
  double duration_s = 0.0;   ///< From the denial to the last pair, s.
  /// Flown without GPS: the fixes' path length from the first pair to the last, m.
  double distance_m = 0.0;
  double first_error_m = 0.0;  ///< At the first pair (what the track carried into the denial).
  double end_error_m = 0.0;    ///< At the last pair.
  double max_error_m = 0.0;
  double rmse_m = 0.0;
  /// end_error_m / (distance_m in km), m per km; nullopt when under 1 m was flown.
  std::optional<double> end_error_per_km_m;
  /// One entry per asked time inside the flight (times past the last pair are left out).
  std::vector<DeniedErrorAt> at;
};

/// Compares `estimate` with `reference` (paired by index: the same frames, the same times, the
/// same metric frame, e.g. the run's ENU) from the first pair with t >= denied_at_s on; the
/// times `after_s` (s after the denial, increasing) give DeniedError::at. nullopt when no pair
/// is at or after the denial. Throws InvalidArgument when the sizes differ or a time goes back.
std::optional<DeniedError> CompareSinceDenial(const std::vector<TrajectoryPoint2D>& estimate,
                                              const std::vector<TrajectoryPoint2D>& reference,
                                              double denied_at_s,
                                              const std::vector<double>& after_s = {60.0, 300.0,
                                                                                    600.0});

}  // namespace aerovo
