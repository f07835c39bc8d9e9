// Flight plans for the simulator: a path over the ground (waypoints or a pattern), flown at a
// constant height and speed, sampled at the camera frame rate into camera poses.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "aerovo/sim/camera.h"

namespace aerovo::sim {

enum class FlightPattern {
  kWaypoints,  ///< Straight segments through FlightPlan::waypoints_m.
  kLine,       ///< One straight leg of leg_length_m through the centre, along heading_deg.
  kLawnmower,  ///< `legs` parallel legs, alternating direction, joined by half-circle turns.
  kTurns,      ///< `legs` legs, each followed by a right turn of turn_angle_deg (radius
               ///< turn_radius_m); 4 legs at 90 deg make a rounded square.
  /// A fixed-wing aircraft with the camera fixed to the airframe: the legs and turns of kTurns,
  /// each turn a coordinated banked turn of radius max(turn_radius_m, v^2 / (g tan(max_bank_deg)))
  /// and the camera rolled with the wings: bank = atan(v^2 kappa / g), kappa the path's
  /// curvature averaged over bank_ramp_s of flight (the roll-in and roll-out), so the camera's
  /// roll is -bank (a right turn drops the right wing, the belly camera looks outwards, to the
  /// image's left).
  kFixedWing,
};

/// Parses "waypoints", "line", "lawnmower", "turns", "fixed-wing"; throws InvalidArgument otherwise.
FlightPattern ParseFlightPattern(const std::string& name);
const char* FlightPatternName(FlightPattern pattern);

enum class YawMode {
  kFollowTrack,  ///< Image top along the direction of flight (plus yaw_deg as an offset).
  kFixed,        ///< Image top at compass heading yaw_deg throughout.
};

/// Where and how the drone flies. Horizontal coordinates are ENU metres relative to a reference
/// point the caller gives (the simulator uses the centre of the ground image).
struct FlightPlan {
  FlightPattern pattern = FlightPattern::kLawnmower;
  /// kWaypoints: (east, north) metres relative to the reference point; at least 2.
  std::vector<Eigen::Vector2d> waypoints_m;
  /// Pattern centre (the centre of the pattern's bounding box before rotation), metres east and
  /// north of the reference point.
  double centre_east_m = 0.0;
  double centre_north_m = 0.0;
  /// Compass heading of the first leg (deg clockwise from north). Default 90 = eastwards.
  double heading_deg = 90.0;
  /// Length of each straight leg (m). Default 300 m: three legs plus turns make about 1 km.
  double leg_length_m = 300.0;
  /// Number of legs (kLawnmower, kTurns). Default 3.
  int legs = 3;
  /// kLawnmower: distance between adjacent legs (m), and the diameter of the half-circle turns.
  /// Default 50 m: a 73.7 deg camera at 100 m sees 150 m across the track (the image's long
  /// side, with the yaw following the track), so adjacent legs overlap by two thirds.
  double spacing_m = 50.0;
  /// kLawnmower: true = the second leg lies to the right of the first (seen along heading_deg).
  bool first_turn_right = true;
  /// kTurns: heading change at each turn (deg, positive = right) and the turn radius (m).
  double turn_angle_deg = 90.0;
  double turn_radius_m = 20.0;
  /// kFixedWing: the largest bank angle in turns (deg; default 20, a gentle survey turn) and the
  /// time over which the aircraft rolls in and out of a turn (s; default 1.5).
  double max_bank_deg = 20.0;
  double bank_ramp_s = 1.5;
  /// Height above the flat ground (m). Default 100 m (the simulated reference flight of
  /// BENCHMARKS.md, "Odometry on a simulated flight against exact ground truth").
  double height_m = 100.0;
  /// Ground speed (m/s). Default 10 m/s, a typical survey speed for small multirotors.
  double speed_mps = 10.0;
  YawMode yaw_mode = YawMode::kFollowTrack;
  /// kFixed: the heading of the image top (deg); kFollowTrack: offset added to the track.
  double yaw_deg = 0.0;
  /// Constant attitude offsets (deg) of the camera, see CameraPose. Default 0 (gimbal nadir).
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
  /// Attitude oscillation: pitch and roll each add wobble_deg * sin(2 pi t / wobble_period_s +
  /// random phase). Default 0 (a stabilised gimbal).
  double wobble_deg = 0.0;
  double wobble_period_s = 4.0;
  /// Stop after this many seconds (0 = fly the whole path).
  double max_duration_s = 0.0;
};

/// Throws aerovo::InvalidArgument naming the first bad field.
void Validate(const FlightPlan& plan);

/// The sampled flight.
struct PlannedFlight {
  std::vector<CameraPose> poses;      ///< One per frame, at t = i / fps.
  std::vector<Eigen::Vector2d> path;  ///< The dense path (east, north), same frame as poses.
  double path_length_m = 0.0;         ///< Length of the whole path.
  double flown_length_m = 0.0;        ///< Distance flown up to the last frame.
};

/// Builds the path of `plan` and samples it at `fps` frames per second. `reference_en_m` is the
/// (east, north) position of the plan's reference point in the output frame (the simulator
/// passes the ground image centre in the map frame). `seed` drives the attitude wobble phases.
/// Throws InvalidArgument on invalid options or fps.
PlannedFlight PlanFlight(const FlightPlan& plan, double fps, const Eigen::Vector2d& reference_en_m,
                         std::uint64_t seed);

}  // namespace aerovo::sim
