// The geo-referenced, north-up orthomosaics of a geo-referenced run, written by `aerovo report`
// beside its report.html (run folder DIR):
//   mosaic.tif       GeoTIFF (GDAL), RGBA (alpha 0 outside the frames), north-up in the UTM zone
//                    of the flight's centre (WGS84, EPSG:326zz north / 327zz south); geotransform
//                    [west_m, m_per_px, 0, north_m, 0, -m_per_px] (no rotation terms). QGIS:
//                    drag it in; gdalinfo shows the CRS and corners.
//   mosaic.kmz       zip of doc.kml (a GroundOverlay, LatLonBox north/south/east/west, rotation 0)
//                    and mosaic_geo.png, for Google Earth (File > Open).
//   mosaic_geo.png   RGBA, transparent outside the frames, longer side <= max_size_px, north-up in
//                    the local ENU plane at the flight's centre (true north; an image overlay for
//                    Leaflet, report.html's map).
//   mosaic_geo.json  {"image": "mosaic_geo.png", "south", "west", "north", "east" (WGS84 degrees
//                    of the image's outer edges), "width_px", "height_px", "m_per_px",
//                    "overlay_max_error_m", "optimized" (frames placed by the optimised poses)}.
//
// How a pixel is placed: first-frame pixel (transforms.csv, first_px_from_frame) -> ENU metres
// by the similarity fitted by least squares between the frames' centres in first-frame pixels and
// their geo-referenced VO positions (frames.csv lat/lon, i.e. enu_from_local of the run's
// geo-reference, odometry/georef.h) -> WGS84 (geo/local_enu.h) -> UTM (GeographicLib UTMUPS). The
// ENU -> UTM step is applied as one affine fitted on a grid over the mosaic (its largest residual
// is reported; millimetres over a few km). The overlay is stretched linearly between its lat/lon
// bounds by Leaflet and Google Earth: over a flight of a few km the linear stretch departs from the
// ENU plane by less than overlay_max_error_m (computed at the corners, centimetres at 2 km).
//
// The frames are placed by transforms_optimized.csv when the run ran the offline optimisation
// (MosaicPlacements, report/mosaic.h; the fit above stays the causal frames' against frames.csv).
//
// A run without geo-referenced frames (no GPS, or no heading) gets no geo mosaic: written = false
// with a one-line note, not an error. File I/O: report module.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "aerovo/report/mosaic.h"
#include "aerovo/report/run_reader.h"

namespace aerovo {

/// File names in the run folder.
struct GeoMosaicFileNames {
  static constexpr const char* kGeoTiff = "mosaic.tif";
  static constexpr const char* kKmz = "mosaic.kmz";
  static constexpr const char* kPng = "mosaic_geo.png";
  static constexpr const char* kJson = "mosaic_geo.json";
  static std::vector<std::string> All();
};

/// What WriteGeoMosaic wrote.
struct GeoMosaicResult {
  bool written = false;  ///< false: skipped, see note.
  std::string note;      ///< Why skipped, or a summary of what was written.
  std::vector<std::filesystem::path> files;  ///< The four files, when written.
  int width_px = 0, height_px = 0;           ///< mosaic_geo.png (ENU plane).
  int tif_width_px = 0, tif_height_px = 0;   ///< mosaic.tif (UTM grid).
  double m_per_px = 0.0;                     ///< Ground sampling of both images, metres.
  int utm_zone = 0;                          ///< 1..60.
  bool utm_north = true;
  int epsg = 0;                              ///< 326zz or 327zz.
  double south_deg = 0, west_deg = 0, north_deg = 0, east_deg = 0;  ///< mosaic_geo.png's edges.
  double fit_rmse_m = 0.0;  ///< RMS residual of the first-frame pixel -> ENU similarity.
  int frames_used = 0;
  bool optimized = false;   ///< Frames placed by transforms_optimized.csv (MosaicPlacements).
};

/// Writes mosaic.tif, mosaic.kmz, mosaic_geo.png and mosaic_geo.json into `dir` for `run`
/// (needs transforms.csv, config.json's input and frame size, frames.csv with lat/lon on at least
/// 3 frames). `name` is the GroundOverlay's name in the KMZ. `options`: max_size_px bounds the
/// longer side of both images, max_frames the frames warped (MosaicOptions). Returns written =
/// false with a note when the run is not geo-referenced or its frames cannot be re-read (as
/// BuildMosaic); throws InputError naming the file when an output cannot be written.
GeoMosaicResult WriteGeoMosaic(const RunData& run, const std::filesystem::path& dir,
                               const std::string& name, const MosaicOptions& options = {});

}  // namespace aerovo
