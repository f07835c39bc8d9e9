#include "aerovo/sim/gps.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/sim/random.h"

namespace aerovo::sim {
namespace {

// Three standard normals (x, y, z), drawn z, then y, then x, one per statement: the evaluation
// order of a call's arguments is unspecified, and the former Eigen::Vector3d(rng.Normal(),
// rng.Normal(), rng.Normal()) drew z first with GCC on x86-64 (right to left) but x first on
// aarch64, so one seed gave other GPS errors per architecture. z-y-x keeps the x86 fixes.
Eigen::Vector3d NormalZyx(Rng& rng) {
  const double z = rng.Normal();
  const double y = rng.Normal();
  const double x = rng.Normal();
  return Eigen::Vector3d(x, y, z);
}

}  // namespace

void Validate(const GpsOptions& g) {
  if (!(g.rate_hz > 0.0 && g.rate_hz <= 1000.0)) {
    throw InvalidArgument(fmt::format("GpsOptions: rate_hz = {} must be in (0, 1000]", g.rate_hz));
  }
  if (!(g.horizontal_sigma_m >= 0.0 && g.horizontal_sigma_m <= 1000.0)) {
    throw InvalidArgument(fmt::format("GpsOptions: horizontal_sigma_m = {} must be in [0, 1000]",
                                      g.horizontal_sigma_m));
  }
  if (!(g.vertical_sigma_m >= 0.0 && g.vertical_sigma_m <= 1000.0)) {
    throw InvalidArgument(
        fmt::format("GpsOptions: vertical_sigma_m = {} must be in [0, 1000]", g.vertical_sigma_m));
  }
  if (!(g.correlation_time_s >= 0.0 && std::isfinite(g.correlation_time_s))) {
    throw InvalidArgument(
        fmt::format("GpsOptions: correlation_time_s = {} must be >= 0", g.correlation_time_s));
  }
}

std::vector<GpsFix> SimulateGps(const std::vector<CameraPose>& poses, const GpsOptions& o,
                                const LocalEnu& map_enu, std::uint64_t seed) {
  Validate(o);
  std::vector<GpsFix> fixes;
  if (poses.empty()) return fixes;
  const double t_end = poses.back().time_s;
  const long n = static_cast<long>(std::floor(t_end * o.rate_hz + 1e-9)) + 1;
  fixes.reserve(n);
  Rng rng(SubSeed(seed, 201));
  const double dt = 1.0 / o.rate_hz;
  // Gauss-Markov: e_k = a e_{k-1} + sqrt(1 - a^2) sigma w_k, started from the stationary
  // distribution, so every fix has standard deviation sigma; a = 0 is white noise.
  const double a = o.correlation_time_s > 0 ? std::exp(-dt / o.correlation_time_s) : 0.0;
  const double b = std::sqrt(1.0 - a * a);
  const Eigen::Vector3d sigma(o.horizontal_sigma_m, o.horizontal_sigma_m, o.vertical_sigma_m);
  Eigen::Vector3d err = NormalZyx(rng);
  err = err.cwiseProduct(sigma);
  size_t k = 0;
  for (long i = 0; i < n; ++i) {
    const double t = i * dt;
    while (k + 1 < poses.size() && poses[k + 1].time_s <= t) ++k;
    Eigen::Vector3d truth = poses[k].position_m;
    if (k + 1 < poses.size()) {
      const double span = poses[k + 1].time_s - poses[k].time_s;
      const double f = span > 0 ? (t - poses[k].time_s) / span : 0.0;
      truth += f * (poses[k + 1].position_m - poses[k].position_m);
    }
    if (i > 0) {
      const Eigen::Vector3d w = NormalZyx(rng);
      err = a * err + b * w.cwiseProduct(sigma);
    }
    GpsFix fix;
    fix.time_s = t;
    fix.error_enu_m = err;
    // Horizontal through the ground point below (the map plane's vertical is the origin's), the
    // altitude as origin altitude + height + error: consistent with the simulator's ground truth.
    const Eigen::Vector3d reported = truth + err;
    fix.position = map_enu.Reverse(Eigen::Vector3d(reported.x(), reported.y(), 0.0));
    fix.position.alt_m = map_enu.origin().alt_m + reported.z();
    fixes.push_back(fix);
  }
  return fixes;
}

size_t LatestFixIndex(const std::vector<GpsFix>& fixes, double time_s) {
  auto it = std::upper_bound(fixes.begin(), fixes.end(), time_s + 1e-9,
                             [](double t, const GpsFix& f) { return t < f.time_s; });
  return it == fixes.begin() ? 0 : static_cast<size_t>(it - fixes.begin()) - 1;
}

}  // namespace aerovo::sim
