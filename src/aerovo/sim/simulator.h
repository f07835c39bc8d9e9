// The flight simulator: a camera flying a plan over a geo-referenced ground image, with exact
// ground truth, simulated GPS and image effects. In memory only (sim_writer.h writes the files).
//
// Ground-truth frame ("GT ENU"): East-North-Up metres with its origin on the ground directly
// below the first frame's camera centre (so the first pose is (0, 0, height)); the origin's
// WGS84 position is origin(). GT ENU positions are LocalEnu(origin()).Forward(lat, lon, alt) of
// the exact geographic positions, i.e. exactly what a pipeline gets from noise-free GPS with the
// same origin. (The images are rendered in the ground image's plane; over 1 km the two frames
// differ by about 1e-4 relative, far below any visual-odometry error.)
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/sim/camera.h"
#include "aerovo/sim/flight.h"
#include "aerovo/sim/gps.h"
#include "aerovo/sim/render.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::sim {

struct SimulationOptions {
  FlightPlan flight;
  CameraModel camera;
  EffectsOptions effects;
  GpsOptions gps;
  /// Video frame rate (frames per second). Default 30 fps (DJI video default is 29.97/30).
  double fps = 30.0;
  /// Seed of every random part (attitude wobble, sensor noise per frame, GPS error): the same
  /// options and ground give the same frames and telemetry.
  std::uint64_t seed = 1;
  /// Warn (Simulator::warnings) when some frame shows more than this fraction of no-data ground.
  /// Default 0.01.
  double max_nodata_fraction = 0.01;
};

/// Throws aerovo::InvalidArgument naming the first bad field (of any nested struct).
void Validate(const SimulationOptions& options);

/// Default geographic placement of the procedural terrain (its NW corner): Lviv, Ukraine, the
/// home of the paper's authors; 300 m above MSL.
inline constexpr double kDefaultTerrainLatDeg = 49.8397;
inline constexpr double kDefaultTerrainLonDeg = 24.0297;
inline constexpr double kDefaultTerrainAltM = 300.0;

/// Generates the procedural terrain and geo-references it with its outer NW corner at
/// `nw_corner` (whose alt_m is the ground altitude).
GroundImage MakeTerrainGround(const TerrainOptions& terrain,
                              const GeoPoint& nw_corner = GeoPoint{kDefaultTerrainLatDeg,
                                                                   kDefaultTerrainLonDeg,
                                                                   kDefaultTerrainAltM});

/// Sizes procedural terrain for a flight: metres_per_px = the camera's nadir ground sampling
/// distance (so frames are neither blurred by upsampling nor aliased; clamped to [0.05, 1] m/px),
/// and width/height so that the flight's whole view (path extent plus the footprint at the
/// largest tilt, plus 10 %) lies inside the terrain centred on the flight's reference point.
/// When that exceeds `max_pixels`, metres_per_px grows to fit. Other fields come from `base`.
/// Throws InvalidArgument for invalid options.
TerrainOptions FitTerrainToFlight(const SimulationOptions& options, TerrainOptions base = {},
                                  double max_pixels = 64.0e6);

/// Converts geographic waypoints to FlightPlan::waypoints_m (ENU metres relative to the centre
/// of `ground`). Throws InvalidArgument for invalid points.
std::vector<Eigen::Vector2d> WaypointsFromGeo(const GroundImage& ground,
                                              const std::vector<GeoPoint>& waypoints);

/// Exact ground truth of one frame.
struct GroundTruthFrame {
  int index = 0;
  double time_s = 0.0;
  Eigen::Vector3d enu_m = Eigen::Vector3d::Zero();  ///< Camera centre in GT ENU (m).
  GeoPoint position;                                ///< Camera centre, WGS84 (alt above MSL).
  double height_above_ground_m = 0.0;
  double yaw_deg = 0.0, pitch_deg = 0.0, roll_deg = 0.0;  ///< As in CameraPose.
  /// Rotation gt_enu_from_camera (camera x right, y down, z optical axis).
  Eigen::Matrix3d enu_from_camera = Eigen::Matrix3d::Identity();
  double nodata_fraction = 0.0;  ///< Share of the view without ground data.
};

class Simulator {
 public:
  /// Validates, plans the flight (reference point = ground image centre), builds the renderer and
  /// simulates the GPS. Throws InvalidArgument on bad options or ground.
  Simulator(GroundImage ground, SimulationOptions options);

  const SimulationOptions& options() const { return options_; }
  const GroundRenderer& renderer() const { return renderer_; }
  const PlannedFlight& flight() const { return flight_; }
  int frame_count() const { return static_cast<int>(flight_.poses.size()); }
  /// Poses in the map frame (see camera.h), one per frame.
  const std::vector<CameraPose>& poses() const { return flight_.poses; }
  const std::vector<GroundTruthFrame>& ground_truth() const { return truth_; }
  const std::vector<GpsFix>& gps() const { return gps_; }
  /// WGS84 origin of the GT ENU frame (on the ground below the first frame).
  const GeoPoint& origin() const { return origin_; }
  /// Converter between WGS84 and the map frame (origin: ground image NW corner).
  const LocalEnu& map_enu() const { return map_enu_; }
  /// Problems worth telling the user (e.g. frames that leave the valid ground).
  const std::vector<std::string>& warnings() const { return warnings_; }

  /// Renders frame i with the effects. Thread-safe. Throws InvalidArgument for a bad index.
  cv::Mat RenderFrame(int i) const;
  /// Renders frame i without effects (exact geometry).
  cv::Mat RenderCleanFrame(int i) const;
  /// Homography image_from_map of frame i (map-frame east, north in metres -> pixels).
  Eigen::Matrix3d ImageFromMap(int i) const;

 private:
  SimulationOptions options_;
  GroundRenderer renderer_;
  LocalEnu map_enu_;
  PlannedFlight flight_;
  GeoPoint origin_;
  std::vector<GroundTruthFrame> truth_;
  std::vector<GpsFix> gps_;
  std::vector<std::string> warnings_;
};

}  // namespace aerovo::sim
