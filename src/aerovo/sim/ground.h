// The ground a simulated flight is rendered over: an orthophoto or the built-in procedural
// terrain sized for the flight. The one set-up of `aerovo simulate` and the experiments'
// simulated flights (pipeline/experiment.h SimulateExperimentFlight).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "aerovo/sim/render.h"
#include "aerovo/sim/simulator.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::sim {

struct GroundOptions {
  /// Orthophoto file (any format OpenCV reads; north-up); empty = the procedural terrain.
  std::string ortho;
  /// The orthophoto's metres per pixel; needed (> 0) with `ortho`.
  double ortho_mpp = 0.0;
  /// Outer north-west corner of the ground image (deg). Needed with `ortho`; for the terrain
  /// default kDefaultTerrainLatDeg / kDefaultTerrainLonDeg.
  std::optional<double> nw_lat_deg, nw_lon_deg;
  /// Ground altitude above MSL (m): the corner's altitude. Default kDefaultTerrainAltM.
  double ground_alt_m = kDefaultTerrainAltM;
  /// Seed of the procedural terrain. Default 1 (TerrainOptions::seed).
  std::uint64_t terrain_seed = 1;
  /// Terrain side (px); 0 = fitted to the flight (FitTerrainToFlight).
  int terrain_size_px = 0;
  /// Terrain metres per pixel; 0 = the camera's ground sampling distance (FitTerrainToFlight).
  /// With terrain_size_px both are used as given; alone, the fitted extent is kept at this
  /// resolution.
  double terrain_mpp = 0.0;
};

/// Throws InvalidArgument naming the field: an orthophoto without ortho_mpp > 0 or without its
/// corner, a corner that is not a position, a negative terrain size or resolution.
void Validate(const GroundOptions& options);

/// The procedural terrain MakeGround makes for `options` without an orthophoto: fitted to the
/// view of `simulation`'s flight (FitTerrainToFlight) unless its size and resolution are given.
/// Not validated (Validate(TerrainOptions) says whether it can be made); InvalidArgument when
/// the flight cannot be planned (too many frames).
TerrainOptions TerrainOptionsOf(const GroundOptions& options, const SimulationOptions& simulation);

/// The ground for a flight with `simulation`'s plan and camera (the terrain is fitted to its
/// view). Throws InvalidArgument for bad options, InputError when the orthophoto cannot be read.
GroundImage MakeGround(const GroundOptions& options, const SimulationOptions& simulation);

}  // namespace aerovo::sim
