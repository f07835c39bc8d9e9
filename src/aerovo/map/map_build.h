// `aerovo map build`: a reference map from a flight with GPS. The run's geo-referenced mosaic
// (report/geo_mosaic.h: the frames placed by the transforms and the geo-referenced track, north-up
// in the UTM zone of the flight) written as a Cloud Optimized GeoTIFF (GDAL's COG driver: tiled
// 512 x 512, DEFLATE, RGB + alpha, overviews down to under 512 px, averaged). docs/map.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/map/map_info.h"

namespace aerovo::map {

/// How the frames are placed in the map (docs/map.md, "How the frames are placed").
enum class PlaceBy {
  /// By the run's offline optimisation with its GPS fixes as absolute position factors
  /// (backend.enable with backend.gps_sigma_m > 0, odometry/flight_graph.h; the run's
  /// transforms_optimized.csv): the shape from the images (steps and verified overlaps of frame
  /// pairs), the placement from all the fixes.
  kGps,
  /// By the run's causal geo-referenced VO track (transforms.csv, frames.csv): as accurate as
  /// that track (its drift, and a geo-reference from the fixes of the first tens of metres).
  kTrack,
};
/// "gps", "track".
const char* ToString(PlaceBy place_by);

struct MapBuildOptions {
  PlaceBy place_by = PlaceBy::kGps;
  /// The longer side of the map, pixels (report/mosaic.h MosaicOptions::max_size_px: the flight
  /// is scaled to fit, never finer than the frames' own ground sampling), 100..20000.
  int max_size_px = 4000;
  /// At most this many frames are warped (every n-th processed frame), >= 1.
  int max_frames = 2000;
};

/// Throws InvalidArgument naming the field.
void Validate(const MapBuildOptions& options);

struct MapBuildResult {
  MapInfo info;             ///< The written map, read back.
  int frames_used = 0;      ///< Frames warped into it.
  double fit_rmse_m = 0.0;  ///< report/geo_mosaic.h GeoMosaicResult::fit_rmse_m.
  bool placed_by_gps = false;  ///< The frames were placed by the GPS-optimised poses (kGps).
  std::vector<std::string> warnings;  ///< E.g. TiltedFramesWarning's.
};

/// The map draws each frame warped to the virtual nadir camera for the attitude the run applied
/// to it (frames.csv camera_roll_deg, camera_pitch_deg; report/mosaic.h MosaicNadirFromFrame).
/// A run folder written by an older build records only the flight's estimate (summary.json
/// "attitude_estimate"): a per-frame attitude from telemetry or the autopilot (summary.json
/// "attitude_sources" other than "estimated") is then drawn as read. For such a folder
/// (`records_attitude` false), when the run applied one and its largest tilt (summary.json
/// "max_tilt_deg") is over 1 deg: a warning saying so and how far the ground lands from its
/// place at that tilt and the run's height (config.json "altitude_m" when given); else "".
std::string TiltedFramesWarning(const nlohmann::json& summary, const nlohmann::json& config,
                                bool records_attitude = false);

/// Checks `out`, the map `map build` is to write, before anything is run: InvalidArgument when
/// its name does not end in .tif or .tiff (any case; the map is a GeoTIFF), InputError naming it
/// when it exists and is not a GeoTIFF GDAL reads (a folder, a run's file, a photo): an earlier
/// map is replaced, nothing else is.
void CheckMapOutput(const std::filesystem::path& out);

/// Builds `out` (a .tif; replaced atomically; CheckMapOutput first) from the run folder `run_dir`
/// (written by `aerovo run` on a flight with GPS: frames.csv geo-referenced, transforms.csv,
/// config.json; the frames are re-read from the run's input). Throws InputError naming the folder
/// when it is not a run or its track is not geo-referenced (no GPS, or GPS denied from the start),
/// or, with PlaceBy::kGps, when the run has no offline optimisation with its GPS
/// (transforms_optimized.csv and backend.gps_sigma_m > 0 in its config.json); or naming `out` when
/// it cannot be written.
MapBuildResult BuildMapFromRun(const std::filesystem::path& run_dir,
                               const std::filesystem::path& out,
                               const MapBuildOptions& options = {});

}  // namespace aerovo::map
