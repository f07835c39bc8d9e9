#include "aerovo/sim/ground.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/sim/sim_writer.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::sim {

void Validate(const GroundOptions& o) {
  if (!o.ortho.empty()) {
    if (!(o.ortho_mpp > 0.0)) {
      throw InvalidArgument(fmt::format(
          "GroundOptions: the orthophoto '{}' needs ortho_mpp (metres per pixel, > 0)", o.ortho));
    }
    if (!o.nw_lat_deg || !o.nw_lon_deg) {
      throw InvalidArgument(fmt::format(
          "GroundOptions: the orthophoto '{}' needs nw_lat_deg and nw_lon_deg (its north-west "
          "corner)",
          o.ortho));
    }
  }
  if ((o.nw_lat_deg && !(std::abs(*o.nw_lat_deg) <= 90.0)) ||
      (o.nw_lon_deg && !(std::abs(*o.nw_lon_deg) <= 360.0))) {
    throw InvalidArgument(
        "GroundOptions: the north-west corner (nw_lat_deg, nw_lon_deg) is not "
        "a position");
  }
  if (o.terrain_size_px < 0 || !(o.terrain_mpp >= 0.0)) {
    throw InvalidArgument(fmt::format(
        "GroundOptions: terrain_size_px {} and terrain_mpp {} must be >= 0 (0 = fitted)",
        o.terrain_size_px, o.terrain_mpp));
  }
}

TerrainOptions TerrainOptionsOf(const GroundOptions& o, const SimulationOptions& simulation) {
  TerrainOptions t;
  t.seed = o.terrain_seed;
  if (o.terrain_size_px > 0 && o.terrain_mpp > 0) {
    t.width_px = t.height_px = o.terrain_size_px;
    t.metres_per_px = o.terrain_mpp;
    return t;
  }
  t = FitTerrainToFlight(simulation, t);
  if (o.terrain_mpp > 0) {  // keep the fitted extent at the requested resolution
    const double w = std::ceil(t.width_px * t.metres_per_px / o.terrain_mpp);
    const double h = std::ceil(t.height_px * t.metres_per_px / o.terrain_mpp);
    // Saturated, so that Validate(TerrainOptions) refuses a size beyond int.
    t.width_px = static_cast<int>(std::min(w, 1e9));
    t.height_px = static_cast<int>(std::min(h, 1e9));
    t.metres_per_px = o.terrain_mpp;
  }
  if (o.terrain_size_px > 0) t.width_px = t.height_px = o.terrain_size_px;
  return t;
}

GroundImage MakeGround(const GroundOptions& o, const SimulationOptions& simulation) {
  Validate(o);
  if (!o.ortho.empty()) {
    return LoadOrthophoto(o.ortho, o.ortho_mpp,
                          GeoPoint{*o.nw_lat_deg, *o.nw_lon_deg, o.ground_alt_m});
  }
  const TerrainOptions t = TerrainOptionsOf(o, simulation);
  const GeoPoint nw{o.nw_lat_deg.value_or(kDefaultTerrainLatDeg),
                    o.nw_lon_deg.value_or(kDefaultTerrainLonDeg), o.ground_alt_m};
  return MakeTerrainGround(t, nw);
}

}  // namespace aerovo::sim
