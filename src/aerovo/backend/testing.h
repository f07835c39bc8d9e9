// Test-only helpers (not installed: testing.h is excluded): a synthetic lawnmower survey with
// exact truth, its graph and its online sliding-window solve, for the back-end's tests and
// benchmark (pose_graph_test.cc, bench/bench_backend.cc).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "aerovo/backend/pose_graph.h"
#include "aerovo/core/angles.h"

namespace aerovo::backend::testing {

/// Standard normal numbers from std::mt19937 (whose output sequence the standard fixes) by the
/// Box-Muller transform, so that the data are the same with every standard library
/// (std::normal_distribution's algorithm is the library's choice).
class Gaussian {
 public:
  explicit Gaussian(std::uint32_t seed) : rng_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(rng_()) + 0.5) / 4294967296.0;
    const double u2 = (static_cast<double>(rng_()) + 0.5) / 4294967296.0;
    const double r = std::sqrt(-2.0 * std::log(u1));
    constexpr double kTwoPi = 6.283185307179586;
    spare_ = r * std::sin(kTwoPi * u2);
    has_spare_ = true;
    return r * std::cos(kTwoPi * u2);
  }

 private:
  std::mt19937 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

struct LawnmowerSpec {
  int strips = 8;
  double strip_length_m = 400.0;
  double strip_spacing_m = 40.0;
  double step_m = 10.0;  ///< Ground distance between consecutive frames.
  /// Odometry noise per step (standard deviations): translation (metres, each axis), heading
  /// (rad), log-scale.
  double odo_sigma_m = 0.05, odo_sigma_rad = 0.01, odo_sigma_log_scale = 0.003;
  /// Loop closures between neighbouring strips: one every closure_every poses of a strip, to the
  /// pose of the previous strip closest to it; their noise.
  int closure_every = 3;
  double closure_sigma_m = 0.3, closure_sigma_rad = 0.01, closure_sigma_log_scale = 0.005;
  std::uint32_t seed = 1;
};

struct Lawnmower {
  std::vector<Similarity2> truth;        ///< local_from_frame, exact.
  std::vector<Similarity2> chained;      ///< The odometry chained from the first (true) pose.
  std::vector<int> strip_of_pose;        ///< Strip index; -1 on the turns between strips.
  std::vector<RelativeFactor> odometry;  ///< Consecutive poses, noisy.
  std::vector<RelativeFactor> closures;  ///< Between neighbouring strips, noisy.
};

inline Eigen::Matrix4d DiagonalInformation(double sigma_m, double sigma_rad,
                                           double sigma_log_scale) {
  return Eigen::Vector4d(1.0 / (sigma_m * sigma_m), 1.0 / (sigma_m * sigma_m),
                         1.0 / (sigma_rad * sigma_rad), 1.0 / (sigma_log_scale * sigma_log_scale))
      .asDiagonal();
}

/// A noisy measurement of prev_from_curr between two true poses.
inline Similarity2 NoisyBetween(const Similarity2& a, const Similarity2& b, double sigma_m,
                                double sigma_rad, double sigma_log_scale, Gaussian& noise) {
  Similarity2 z = Between(a, b);
  z.translation_m.x() += sigma_m * noise();
  z.translation_m.y() += sigma_m * noise();
  z.heading_rad = WrapAngleRad(z.heading_rad + sigma_rad * noise());
  z.log_scale += sigma_log_scale * noise();
  return z;
}

/// Strips along local x (east), alternating direction, stacked along y (north); a turn of
/// strip_spacing_m between strips flown at the same step. The camera's image up points along
/// the flight (heading -pi/2 flying east, +pi/2 flying west); the true log-scale varies slowly
/// (height changes of a few percent).
inline Lawnmower MakeLawnmower(const LawnmowerSpec& spec) {
  Lawnmower out;
  const int per_strip = static_cast<int>(std::lround(spec.strip_length_m / spec.step_m)) + 1;
  const int per_turn = static_cast<int>(std::lround(spec.strip_spacing_m / spec.step_m)) - 1;
  for (int s = 0; s < spec.strips; ++s) {
    const bool east = s % 2 == 0;
    for (int k = 0; k < per_strip; ++k) {
      Similarity2 p;
      const double along = k * spec.step_m;
      p.translation_m = {east ? along : spec.strip_length_m - along, s * spec.strip_spacing_m};
      p.heading_rad = east ? -kPi / 2 : kPi / 2;
      p.log_scale = 0.03 * std::sin(0.01 * static_cast<double>(out.truth.size()));
      out.truth.push_back(p);
      out.strip_of_pose.push_back(s);
    }
    if (s + 1 == spec.strips) break;
    for (int k = 1; k <= per_turn; ++k) {
      Similarity2 p;
      p.translation_m = {east ? spec.strip_length_m : 0.0,
                         s * spec.strip_spacing_m + k * spec.step_m};
      p.heading_rad = 0.0;  // Flying north.
      p.log_scale = 0.03 * std::sin(0.01 * static_cast<double>(out.truth.size()));
      out.truth.push_back(p);
      out.strip_of_pose.push_back(-1);
    }
  }
  Gaussian noise(spec.seed);
  const Eigen::Matrix4d odo_info =
      DiagonalInformation(spec.odo_sigma_m, spec.odo_sigma_rad, spec.odo_sigma_log_scale);
  out.chained.push_back(out.truth[0]);
  for (std::size_t i = 1; i < out.truth.size(); ++i) {
    RelativeFactor f;
    f.prev = static_cast<int>(i) - 1;
    f.curr = static_cast<int>(i);
    f.prev_from_curr = NoisyBetween(out.truth[i - 1], out.truth[i], spec.odo_sigma_m,
                                    spec.odo_sigma_rad, spec.odo_sigma_log_scale, noise);
    f.information = odo_info;
    out.odometry.push_back(f);
    out.chained.push_back(out.chained.back() * f.prev_from_curr);
  }
  const Eigen::Matrix4d closure_info = DiagonalInformation(
      spec.closure_sigma_m, spec.closure_sigma_rad, spec.closure_sigma_log_scale);
  for (std::size_t j = 0; j < out.truth.size(); ++j) {
    const int s = out.strip_of_pose[j];
    if (s < 1 || static_cast<int>(j) % spec.closure_every != 0) continue;
    int best = -1;
    double best_d = 1e300;
    for (std::size_t i = 0; i < j; ++i) {
      if (out.strip_of_pose[i] != s - 1) continue;
      const double d = (out.truth[i].translation_m - out.truth[j].translation_m).norm();
      if (d < best_d) best_d = d, best = static_cast<int>(i);
    }
    if (best < 0) continue;
    RelativeFactor f;
    f.prev = best;
    f.curr = static_cast<int>(j);
    f.prev_from_curr =
        NoisyBetween(out.truth[static_cast<std::size_t>(best)], out.truth[j], spec.closure_sigma_m,
                     spec.closure_sigma_rad, spec.closure_sigma_log_scale, noise);
    f.information = closure_info;
    out.closures.push_back(f);
  }
  return out;
}

/// The graph of the survey: poses at the chained estimate, odometry factors, and the closures
/// when `with_closures`.
inline PoseGraph MakeGraph(const Lawnmower& l, bool with_closures) {
  PoseGraph g;
  for (const Similarity2& p : l.chained) g.AddPose(p);
  for (const RelativeFactor& f : l.odometry) g.AddRelative(f);
  if (with_closures) {
    for (const RelativeFactor& f : l.closures) g.AddRelative(f);
  }
  return g;
}

/// The online use of the back-end through the whole survey: each pose added at its
/// predecessor's estimate times its odometry (the first at the truth) with its odometry factor
/// and the closures whose later pose it is, then the last `window` poses optimised with the older
/// ones held at their estimates (pose 0 always held), as a run would per frame. Returns the graph
/// at the final estimates.
inline PoseGraph SlideWindow(const Lawnmower& l, int window) {
  PoseGraph g;
  std::size_t next_closure = 0;
  for (std::size_t i = 0; i < l.truth.size(); ++i) {
    g.AddPose(i == 0 ? l.truth[0] : g.estimates().back() * l.odometry[i - 1].prev_from_curr);
    if (i == 0) continue;
    g.AddRelative(l.odometry[i - 1]);
    while (next_closure < l.closures.size() &&
           l.closures[next_closure].curr <= static_cast<int>(i)) {
      g.AddRelative(l.closures[next_closure++]);
    }
    const int last = static_cast<int>(i);
    g.SetEstimates(OptimizeWindow(g, std::max(1, last - window + 1), last).local_from_frame);
  }
  return g;
}

/// Largest position error (metres) of `poses` against `truth`.
inline double MaxPositionError(const std::vector<Similarity2>& poses,
                               const std::vector<Similarity2>& truth) {
  double worst = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    worst = std::max(worst, (poses[i].translation_m - truth[i].translation_m).norm());
  }
  return worst;
}

/// Root mean square position error (metres) of `poses` against `truth`.
inline double RmsPositionError(const std::vector<Similarity2>& poses,
                               const std::vector<Similarity2>& truth) {
  double sum = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    sum += (poses[i].translation_m - truth[i].translation_m).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(poses.size()));
}

}  // namespace aerovo::backend::testing
