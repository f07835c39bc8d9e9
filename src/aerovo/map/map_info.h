// A reference map: any geo-referenced raster GDAL opens (GeoTIFF and COG in any projected or
// geographic CRS, a VRT over many tiles, MBTiles, GeoPackage), described as `aerovo map info`
// prints it: size, CRS, geotransform, ground resolution, extent in the map's CRS and in WGS84
// longitude/latitude, overviews. File I/O through GDAL (private to this module). docs/map.md.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/map/map_pixels.h"

namespace aerovo::map {

/// An axis-aligned rectangle in some coordinates (the map's CRS units, or degrees).
struct Extent {
  double min_x = 0.0, min_y = 0.0, max_x = 0.0, max_y = 0.0;
};

struct MapInfo {
  std::filesystem::path path;
  std::string driver;  ///< GDAL's short name: "GTiff", "COG" files read as "GTiff", "VRT", ...
  int width_px = 0, height_px = 0, bands = 0;
  std::string crs_name;       ///< OGRSpatialReference::GetName, e.g. "WGS 84 / UTM zone 17N".
  std::optional<int> epsg;    ///< When the CRS is an EPSG one.
  bool crs_geographic = false;  ///< Degrees of latitude/longitude (else projected).
  std::string crs_units;      ///< The CRS's axis unit, e.g. "metre", "degree".
  /// GDAL's geotransform: x = gt[0] + col gt[1] + row gt[2], y = gt[3] + col gt[4] + row gt[5]
  /// (col, row of a pixel's corner), in the CRS's units.
  std::array<double, 6> geotransform{};
  bool rotated = false;  ///< gt[2] or gt[4] non-zero (not north-up).
  /// The ground size of a pixel along its columns and rows, metres: the CRS's linear unit for a
  /// projected CRS whose scale at the map is within 1 % of 1 (UTM, transverse Mercator); for a
  /// geographic one, or a projected one scaled more (Web Mercator, EPSG:3857), the geodesic
  /// length of one pixel at the map's centre.
  double m_per_px_x = 0.0, m_per_px_y = 0.0;
  Extent extent_crs;  ///< The corners' bounds in the CRS.
  /// The bounds in WGS84 longitude (x) / latitude (y), degrees, over points along the map's
  /// edges (a projected map's edges are curves in degrees).
  Extent extent_lonlat;
  std::vector<std::pair<int, int>> overviews;  ///< Band 1's overviews, width x height px.
  int block_x_px = 0, block_y_px = 0;          ///< Band 1's block size (tiled when not 1 row).
  std::string compression;  ///< IMAGE_STRUCTURE COMPRESSION ("" when none is said).
  /// How its samples become the grey matched (map_pixels.h ProbeMapPixels).
  MapRadiometry radiometry;
};

/// Reads `path`'s description. Throws InputError naming the file: it does not exist, GDAL cannot
/// open it as a raster (corrupt, not an image), it has no CRS, or no geotransform (only ground
/// control points, or none: a plain image), or its pixels cannot be read or none is valid where
/// ProbeMapPixels reads them (a truncated file, a VRT whose source is missing).
MapInfo ReadMapInfo(const std::filesystem::path& path);

/// The lines `aerovo map info` prints (each ending in '\n').
std::string FormatMapInfo(const MapInfo& info);

/// `aerovo map info --json`: every field of MapInfo, extents as {min_x, min_y, max_x, max_y}.
nlohmann::json ToJson(const MapInfo& info);

}  // namespace aerovo::map
