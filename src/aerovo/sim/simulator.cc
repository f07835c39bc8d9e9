#include "aerovo/sim/simulator.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/sim/random.h"

namespace aerovo::sim {

namespace {}  // namespace

void Validate(const SimulationOptions& o) {
  Validate(o.flight);
  Validate(o.camera);
  Validate(o.effects);
  Validate(o.gps);
  if (!(o.fps > 0.0 && o.fps <= 1000.0)) {
    throw InvalidArgument(fmt::format("SimulationOptions: fps = {} must be in (0, 1000]", o.fps));
  }
  if (!(o.max_nodata_fraction >= 0.0 && o.max_nodata_fraction <= 1.0)) {
    throw InvalidArgument(fmt::format(
        "SimulationOptions: max_nodata_fraction = {} must be in [0, 1]", o.max_nodata_fraction));
  }
}

namespace {
const SimulationOptions& Checked(const SimulationOptions& o) {
  Validate(o);
  return o;
}
}  // namespace

GroundImage MakeTerrainGround(const TerrainOptions& terrain, const GeoPoint& nw_corner) {
  GroundImage g;
  g.image = GenerateTerrain(terrain);
  g.metres_per_px = terrain.metres_per_px;
  g.nw_corner = nw_corner;
  g.source_kind = "terrain";
  g.terrain_seed = terrain.seed;
  Validate(g);
  return g;
}

TerrainOptions FitTerrainToFlight(const SimulationOptions& options, TerrainOptions base,
                                  double max_pixels) {
  Validate(options);
  if (!(max_pixels >= 64.0 * 64.0)) {
    throw InvalidArgument(
        fmt::format("FitTerrainToFlight: max_pixels = {} is too small", max_pixels));
  }
  const PlannedFlight plan =
      PlanFlight(options.flight, options.fps, Eigen::Vector2d::Zero(), options.seed);
  double half_e = 0.0, half_n = 0.0;
  for (const auto& p : plan.path) {
    half_e = std::max(half_e, std::abs(p.x()));
    half_n = std::max(half_n, std::abs(p.y()));
  }
  // Farthest ground point any frame can see from below the camera: the image corner ray at the
  // largest tilt the plan allows.
  const FlightPlan& f = options.flight;
  const double tilt_deg =
      std::max(std::abs(f.pitch_deg),
               std::abs(f.roll_deg) + (f.pattern == FlightPattern::kFixedWing ? f.max_bank_deg : 0.0)) +
      f.wobble_deg;
  const double fpx = FocalPx(options.camera);
  const double half_diag_px = 0.5 * std::hypot(options.camera.width_px, options.camera.height_px);
  // (Through the lens: a fisheye's corner ray is farther off axis than the pinhole's.)
  const double corner_ray =
      UndistortNormalised(options.camera,
                          Eigen::Vector2d(0.5 * options.camera.width_px / fpx,
                                          0.5 * options.camera.height_px / fpx))
          .norm();
  const double corner_angle =
      std::max(std::atan(half_diag_px / fpx), std::atan(corner_ray)) + tilt_deg * kDegToRad;
  const double reach =
      f.height_m * std::tan(std::min(corner_angle, 80.0 * kDegToRad));  // guard the horizon
  const double width_m = 2.2 * (half_e + reach), height_m = 2.2 * (half_n + reach);
  TerrainOptions t = base;
  double mpp = std::clamp(NadirGsdMetresPerPx(options.camera, f.height_m), 0.05, 1.0);
  mpp = std::max(mpp, std::sqrt(width_m * height_m / max_pixels));
  t.metres_per_px = mpp;
  t.width_px = std::max(64, static_cast<int>(std::ceil(width_m / mpp)));
  t.height_px = std::max(64, static_cast<int>(std::ceil(height_m / mpp)));
  Validate(t);
  return t;
}

std::vector<Eigen::Vector2d> WaypointsFromGeo(const GroundImage& ground,
                                              const std::vector<GeoPoint>& waypoints) {
  Validate(ground);
  const LocalEnu map_enu(ground.nw_corner);
  const Eigen::Vector2d centre = GroundCentreEnM(ground);
  std::vector<Eigen::Vector2d> out;
  for (size_t i = 0; i < waypoints.size(); ++i) {
    aerovo::Validate(waypoints[i], fmt::format("waypoint {}", i).c_str());
    const Eigen::Vector3d enu =
        map_enu.Forward(waypoints[i].lat_deg, waypoints[i].lon_deg, ground.nw_corner.alt_m);
    out.push_back(enu.head<2>() - centre);
  }
  return out;
}

Simulator::Simulator(GroundImage ground, SimulationOptions options)
    : options_(Checked(options)),
      renderer_(std::move(ground), options_.camera),
      map_enu_(renderer_.ground().nw_corner) {
  const GroundImage& g = renderer_.ground();
  flight_ = PlanFlight(options_.flight, options_.fps, GroundCentreEnM(g), options_.seed);
  const Eigen::Vector3d first = flight_.poses.front().position_m;
  origin_ = map_enu_.Reverse(Eigen::Vector3d(first.x(), first.y(), 0.0));
  origin_.alt_m = g.nw_corner.alt_m;  // the flat ground's altitude (drop the plane's curvature)
  const LocalEnu gt_enu(origin_);
  // Rotation gt_enu_from_map: the two tangent planes differ by the meridian convergence.
  const Eigen::Vector3d o_gt = gt_enu.Forward(map_enu_.Reverse(Eigen::Vector3d::Zero()));
  const Eigen::Vector3d e_gt = gt_enu.Forward(map_enu_.Reverse(Eigen::Vector3d(1000, 0, 0)));
  const double convergence = std::atan2(e_gt.y() - o_gt.y(), e_gt.x() - o_gt.x());
  const Eigen::Matrix3d gt_from_map =
      Eigen::AngleAxisd(convergence, Eigen::Vector3d::UnitZ()).toRotationMatrix();

  truth_.resize(flight_.poses.size());
  int bad_frames = 0, worst = 0;
  double worst_fraction = 0.0;
  for (size_t i = 0; i < flight_.poses.size(); ++i) {
    const CameraPose& p = flight_.poses[i];
    GroundTruthFrame& t = truth_[i];
    t.index = static_cast<int>(i);
    t.time_s = p.time_s;
    // Horizontal position: the ground point below the camera; altitude = ground altitude +
    // height (the map plane's vertical is the NW corner's, tilted by ~1e-5 rad per 100 m).
    t.position = map_enu_.Reverse(Eigen::Vector3d(p.position_m.x(), p.position_m.y(), 0.0));
    t.position.alt_m = g.nw_corner.alt_m + p.position_m.z();
    t.enu_m = gt_enu.Forward(t.position);
    t.height_above_ground_m = p.position_m.z();
    t.yaw_deg = p.yaw_deg;
    t.pitch_deg = p.pitch_deg;
    t.roll_deg = p.roll_deg;
    t.enu_from_camera = gt_from_map * MapFromCameraRotation(p);
    t.nodata_fraction = renderer_.NoDataFraction(p);
    if (t.nodata_fraction > options_.max_nodata_fraction) {
      ++bad_frames;
      if (t.nodata_fraction > worst_fraction) {
        worst_fraction = t.nodata_fraction;
        worst = static_cast<int>(i);
      }
    }
  }
  if (bad_frames > 0) {
    warnings_.push_back(fmt::format(
        "{} of {} frames show more than {:.0f} % of the view without ground data (worst: frame "
        "{} at t = {:.2f} s, {:.0f} %); move the flight (centre, heading, size) inside the valid "
        "imagery",
        bad_frames, frame_count(), 100.0 * options_.max_nodata_fraction, worst,
        truth_[worst].time_s, 100.0 * worst_fraction));
  }
  gps_ = SimulateGps(flight_.poses, options_.gps, map_enu_, options_.seed);
}

cv::Mat Simulator::RenderCleanFrame(int i) const {
  if (i < 0 || i >= frame_count()) {
    throw InvalidArgument(fmt::format("frame {} is out of range [0, {})", i, frame_count()));
  }
  return renderer_.Render(flight_.poses[i]);
}

cv::Mat Simulator::RenderFrame(int i) const {
  cv::Mat frame = RenderCleanFrame(i);
  const auto& poses = flight_.poses;
  // Blur direction: image motion over one frame interval (central where possible).
  const int a = std::max(0, i - 1), b = std::min(frame_count() - 1, i + 1);
  Eigen::Vector2d motion = Eigen::Vector2d::Zero();
  if (b > a) motion = ImageMotionPx(options_.camera, poses[a], poses[b]) / (b - a);
  ApplyEffects(frame, options_.effects, motion, SubSeed(options_.seed, 1000 + i));
  return frame;
}

Eigen::Matrix3d Simulator::ImageFromMap(int i) const {
  if (i < 0 || i >= frame_count()) {
    throw InvalidArgument(fmt::format("frame {} is out of range [0, {})", i, frame_count()));
  }
  return ImageFromGroundHomography(options_.camera, flight_.poses[i]);
}

}  // namespace aerovo::sim
