#include "aerovo/sim/flight.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/sim/random.h"

namespace aerovo::sim {

namespace {

// Unit vector of a compass heading (rad, clockwise from north) in (east, north).
Eigen::Vector2d Dir(double heading_rad) { return {std::sin(heading_rad), std::cos(heading_rad)}; }
// Unit vector to the right of a compass heading.
Eigen::Vector2d Right(double heading_rad) {
  return {std::cos(heading_rad), -std::sin(heading_rad)};
}
double HeadingOf(const Eigen::Vector2d& v) { return std::atan2(v.x(), v.y()); }
double WrapPi(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a <= -kPi) a += 2 * kPi;
  return a;
}

// Appends a circular arc starting at `start` (already in the path) with compass heading
// `heading_rad`, radius `radius`, heading change `turn_rad` (positive = right). Returns the
// final heading.
double AppendArc(std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& start,
                 double heading_rad, double radius, double turn_rad) {
  const double sgn = turn_rad >= 0 ? 1.0 : -1.0;
  const Eigen::Vector2d centre = start + sgn * radius * Right(heading_rad);
  // Chords of at most 0.25 m: below a pixel at any useful height, so the tangent (the yaw when
  // following the track) changes smoothly.
  const int n = std::max(8, static_cast<int>(std::ceil(std::abs(turn_rad) * radius / 0.25)));
  for (int k = 1; k <= n; ++k) {
    const double h = heading_rad + turn_rad * k / n;
    path.push_back(centre - sgn * radius * Right(h));
  }
  return heading_rad + turn_rad;
}

// Standard gravity (m/s^2), for the coordinated turn tan(bank) = v^2 / (g r).
constexpr double kGravity = 9.80665;

double TurnRadiusM(const FlightPlan& p) {
  if (p.pattern != FlightPattern::kFixedWing) return p.turn_radius_m;
  return std::max(p.turn_radius_m,
                  p.speed_mps * p.speed_mps / (kGravity * std::tan(p.max_bank_deg * kDegToRad)));
}

std::vector<Eigen::Vector2d> PatternPath(const FlightPlan& p) {
  const double h0 = p.heading_deg * kDegToRad;
  std::vector<Eigen::Vector2d> path{Eigen::Vector2d::Zero()};
  double h = h0;
  const int legs = p.pattern == FlightPattern::kLine ? 1 : p.legs;
  for (int i = 0; i < legs; ++i) {
    path.push_back(path.back() + p.leg_length_m * Dir(h));
    if (i + 1 == legs) break;
    if (p.pattern == FlightPattern::kLawnmower) {
      const bool right = (i % 2 == 0) == p.first_turn_right;
      h = AppendArc(path, path.back(), h, 0.5 * p.spacing_m, right ? kPi : -kPi);
    } else {
      h = AppendArc(path, path.back(), h, TurnRadiusM(p), p.turn_angle_deg * kDegToRad);
    }
  }
  // Centre the bounding box, taken in the frame of the first leg, on the requested centre.
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const auto& q : path) {
    const Eigen::Vector2d local(q.dot(Dir(h0)), q.dot(Right(h0)));
    lo = lo.cwiseMin(local);
    hi = hi.cwiseMax(local);
  }
  const Eigen::Vector2d mid_local = 0.5 * (lo + hi);
  const Eigen::Vector2d shift = Eigen::Vector2d(p.centre_east_m, p.centre_north_m) -
                                (mid_local.x() * Dir(h0) + mid_local.y() * Right(h0));
  for (auto& q : path) q += shift;
  return path;
}

// Polyline through the waypoints with the corners rounded by arcs of turn_radius_m (smaller
// where the segments are short), so the track heading changes continuously.
std::vector<Eigen::Vector2d> WaypointPath(const FlightPlan& p) {
  const auto& w = p.waypoints_m;
  std::vector<Eigen::Vector2d> path{w.front()};
  for (size_t i = 1; i + 1 < w.size(); ++i) {
    const Eigen::Vector2d a = path.back(), b = w[i], c = w[i + 1];
    const Eigen::Vector2d u1 = (b - a).normalized(), u2 = (c - b).normalized();
    const double turn = WrapPi(HeadingOf(u2) - HeadingOf(u1));
    if (std::abs(turn) < 1e-6 || p.turn_radius_m <= 0) {
      path.push_back(b);
      continue;
    }
    const double half = std::tan(0.5 * std::abs(turn));
    double t = p.turn_radius_m * half;
    t = std::min({t, 0.5 * (b - a).norm(), 0.5 * (c - b).norm()});
    const Eigen::Vector2d start = b - t * u1;
    path.push_back(start);
    AppendArc(path, start, HeadingOf(u1), t / half, turn);
  }
  path.push_back(w.back());
  return path;
}

}  // namespace

FlightPattern ParseFlightPattern(const std::string& name) {
  if (name == "waypoints") return FlightPattern::kWaypoints;
  if (name == "line") return FlightPattern::kLine;
  if (name == "lawnmower") return FlightPattern::kLawnmower;
  if (name == "turns") return FlightPattern::kTurns;
  if (name == "fixed-wing") return FlightPattern::kFixedWing;
  throw InvalidArgument("unknown flight pattern '" + name +
                        "' (expected waypoints, line, lawnmower, turns or fixed-wing)");
}

const char* FlightPatternName(FlightPattern pattern) {
  switch (pattern) {
    case FlightPattern::kWaypoints:
      return "waypoints";
    case FlightPattern::kLine:
      return "line";
    case FlightPattern::kLawnmower:
      return "lawnmower";
    case FlightPattern::kTurns:
      return "turns";
    case FlightPattern::kFixedWing:
      return "fixed-wing";
  }
  return "?";
}

void Validate(const FlightPlan& p) {
  auto fail = [](const std::string& what) { throw InvalidArgument("FlightPlan: " + what); };
  auto finite = [](double v) { return std::isfinite(v); };
  if (p.pattern == FlightPattern::kWaypoints) {
    if (p.waypoints_m.size() < 2) {
      fail(fmt::format("pattern 'waypoints' needs at least 2 waypoints, got {}",
                       p.waypoints_m.size()));
    }
    for (size_t i = 0; i < p.waypoints_m.size(); ++i) {
      if (!p.waypoints_m[i].allFinite()) fail(fmt::format("waypoint {} is not finite", i));
      if (i > 0 && (p.waypoints_m[i] - p.waypoints_m[i - 1]).norm() < 1e-3) {
        fail(fmt::format("waypoints {} and {} coincide", i - 1, i));
      }
    }
  } else {
    if (!(p.leg_length_m > 0 && p.leg_length_m < 1e6)) {
      fail(fmt::format("leg_length_m = {} must be in (0, 1e6)", p.leg_length_m));
    }
    if (p.pattern != FlightPattern::kLine && (p.legs < 1 || p.legs > 10000)) {
      fail(fmt::format("legs = {} must be in [1, 10000]", p.legs));
    }
    if (p.pattern == FlightPattern::kLawnmower && !(p.spacing_m > 0 && p.spacing_m < 1e5)) {
      fail(fmt::format("spacing_m = {} must be in (0, 1e5)", p.spacing_m));
    }
    if ((p.pattern == FlightPattern::kTurns || p.pattern == FlightPattern::kFixedWing) &&
        !(std::abs(p.turn_angle_deg) <= 360 && finite(p.turn_angle_deg))) {
      fail(fmt::format("turn_angle_deg = {} must be within [-360, 360]", p.turn_angle_deg));
    }
  }
  if (!(p.turn_radius_m >= 0 && p.turn_radius_m < 1e5)) {
    fail(fmt::format("turn_radius_m = {} must be in [0, 1e5)", p.turn_radius_m));
  }
  if (p.pattern == FlightPattern::kFixedWing &&
      !(p.max_bank_deg > 0.0 && p.max_bank_deg <= 45.0 && p.bank_ramp_s > 0.0 &&
        p.bank_ramp_s <= 30.0)) {
    fail(fmt::format("max_bank_deg = {} must be in (0, 45] and bank_ramp_s = {} in (0, 30]",
                     p.max_bank_deg, p.bank_ramp_s));
  }
  if (p.pattern == FlightPattern::kTurns && !(p.turn_radius_m > 0)) {
    fail("turn_radius_m must be > 0 for pattern 'turns'");
  }
  if (!finite(p.centre_east_m) || !finite(p.centre_north_m) || !finite(p.heading_deg) ||
      !finite(p.yaw_deg)) {
    fail("centre, heading and yaw must be finite");
  }
  if (!(p.height_m >= 1.0 && p.height_m <= 10000.0)) {
    fail(fmt::format("height_m = {} must be in [1, 10000]", p.height_m));
  }
  if (!(p.speed_mps > 0.0 && p.speed_mps <= 200.0)) {
    fail(fmt::format("speed_mps = {} must be in (0, 200]", p.speed_mps));
  }
  if (!(std::abs(p.pitch_deg) <= 45.0 && std::abs(p.roll_deg) <= 45.0)) {
    fail(
        fmt::format("pitch_deg = {}, roll_deg = {}: each must be within +-45 (the ground must "
                    "fill the view)",
                    p.pitch_deg, p.roll_deg));
  }
  if (!(p.wobble_deg >= 0.0 && p.wobble_deg <= 20.0)) {
    fail(fmt::format("wobble_deg = {} must be in [0, 20]", p.wobble_deg));
  }
  if (!(p.wobble_period_s > 0.0 && finite(p.wobble_period_s))) {
    fail(fmt::format("wobble_period_s = {} must be > 0", p.wobble_period_s));
  }
  if (!(p.max_duration_s >= 0.0 && finite(p.max_duration_s))) {
    fail(fmt::format("max_duration_s = {} must be >= 0", p.max_duration_s));
  }
}

PlannedFlight PlanFlight(const FlightPlan& plan, double fps, const Eigen::Vector2d& reference_en_m,
                         std::uint64_t seed) {
  Validate(plan);
  if (!(fps > 0.0 && fps <= 1000.0)) {
    throw InvalidArgument(fmt::format("frame rate {} fps must be in (0, 1000]", fps));
  }
  PlannedFlight out;
  out.path = plan.pattern == FlightPattern::kWaypoints ? WaypointPath(plan) : PatternPath(plan);
  for (auto& q : out.path) q += reference_en_m;
  std::vector<double> cum(out.path.size(), 0.0);
  for (size_t i = 1; i < out.path.size(); ++i) {
    cum[i] = cum[i - 1] + (out.path[i] - out.path[i - 1]).norm();
  }
  out.path_length_m = cum.back();
  auto at = [&](double s) -> Eigen::Vector2d {
    s = std::clamp(s, 0.0, cum.back());
    size_t k = std::upper_bound(cum.begin(), cum.end(), s) - cum.begin();
    k = std::clamp<size_t>(k, 1, cum.size() - 1);
    const double len = cum[k] - cum[k - 1];
    const double t = len > 0 ? (s - cum[k - 1]) / len : 0.0;
    return out.path[k - 1] + t * (out.path[k] - out.path[k - 1]);
  };

  double flown = out.path_length_m;
  if (plan.max_duration_s > 0) flown = std::min(flown, plan.speed_mps * plan.max_duration_s);
  const double step = plan.speed_mps / fps;
  const long n = static_cast<long>(std::floor(flown / step + 1e-9)) + 1;
  if (n > 2'000'000) {
    throw InvalidArgument(
        fmt::format("flight of {:.0f} m at {} m/s and {} fps needs {} frames "
                    "(limit 2000000)",
                    flown, plan.speed_mps, fps, n));
  }
  Rng rng(SubSeed(seed, 101));
  const double phase_pitch = rng.Uniform(0, 2 * kPi), phase_roll = rng.Uniform(0, 2 * kPi);
  const double delta = std::min(1.0, 0.5 * out.path_length_m);  // tangent baseline (m)
  out.poses.resize(n);
  for (long i = 0; i < n; ++i) {
    CameraPose& pose = out.poses[i];
    pose.time_s = i / fps;
    const double s = std::min(i * step, out.path_length_m);
    const Eigen::Vector2d p = at(s);
    pose.position_m = Eigen::Vector3d(p.x(), p.y(), plan.height_m);
    if (plan.yaw_mode == YawMode::kFixed) {
      pose.yaw_deg = plan.yaw_deg;
    } else {
      const Eigen::Vector2d tangent = at(s + delta) - at(s - delta);
      pose.yaw_deg = HeadingOf(tangent) / kDegToRad + plan.yaw_deg;
    }
    pose.yaw_deg = std::fmod(pose.yaw_deg + 720.0, 360.0);
    const double w = 2 * kPi * pose.time_s / plan.wobble_period_s;
    pose.pitch_deg = plan.pitch_deg + plan.wobble_deg * std::sin(w + phase_pitch);
    pose.roll_deg = plan.roll_deg + plan.wobble_deg * std::sin(w + phase_roll);
    if (plan.pattern == FlightPattern::kFixedWing) {
      // Coordinated turn: bank = atan(v^2 kappa / g) with the curvature averaged over the
      // roll-in time (heading change across bank_ramp_s of flight, divided by its length).
      const double half = 0.5 * plan.speed_mps * plan.bank_ramp_s;
      const Eigen::Vector2d t0 = at(s) - at(s - half - delta), t1 = at(s + half + delta) - at(s);
      double kappa = 0.0;
      if (t0.norm() > 1e-9 && t1.norm() > 1e-9) {
        kappa = WrapPi(HeadingOf(t1) - HeadingOf(t0)) / (half + delta);
      }
      const double bank_deg = std::clamp(
          std::atan(plan.speed_mps * plan.speed_mps * kappa / kGravity) / kDegToRad,
          -plan.max_bank_deg, plan.max_bank_deg);
      pose.roll_deg -= bank_deg;
    }
  }
  out.flown_length_m = std::min(flown, (n - 1) * step);
  return out;
}

}  // namespace aerovo::sim
