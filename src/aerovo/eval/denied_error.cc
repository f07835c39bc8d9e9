#include "aerovo/eval/denied_error.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {

std::optional<DeniedError> CompareSinceDenial(const std::vector<TrajectoryPoint2D>& estimate,
                                              const std::vector<TrajectoryPoint2D>& reference,
                                              double denied_at_s,
                                              const std::vector<double>& after_s) {
  if (estimate.size() != reference.size()) {
    throw InvalidArgument("CompareSinceDenial: " + std::to_string(estimate.size()) +
                          " estimated positions but " + std::to_string(reference.size()) +
                          " reference positions");
  }
  DeniedError d;
  d.denied_at_s = denied_at_s;
  std::size_t next_at = 0;
  double sum_sq = 0.0;
  const TrajectoryPoint2D* last = nullptr;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const TrajectoryPoint2D& e = estimate[i];
    const TrajectoryPoint2D& r = reference[i];
    if (i > 0 && e.t < estimate[i - 1].t) {
      throw InvalidArgument("CompareSinceDenial: the times go back at position " +
                            std::to_string(i));
    }
    if (e.t < denied_at_s) continue;
    if (last != nullptr) d.distance_m += std::hypot(r.x - last->x, r.y - last->y);
    last = &r;
    const double err = std::hypot(e.x - r.x, e.y - r.y);
    if (d.pairs == 0) d.first_error_m = err;
    ++d.pairs;
    sum_sq += err * err;
    d.max_error_m = std::max(d.max_error_m, err);
    d.end_error_m = err;
    d.duration_s = e.t - denied_at_s;
    while (next_at < after_s.size() && e.t >= denied_at_s + after_s[next_at]) {
      d.at.push_back({after_s[next_at], e.t, err, d.distance_m});
      ++next_at;
    }
  }
  if (d.pairs == 0) return std::nullopt;
  d.rmse_m = std::sqrt(sum_sq / d.pairs);
  if (d.distance_m >= 1.0) d.end_error_per_km_m = d.end_error_m / (d.distance_m / 1000.0);
  return d;
}

}  // namespace aerovo
