#include "aerovo/map/map_info.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <system_error>

#include <cpl_error.h>
#include <fmt/format.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/error.h"
#include "aerovo/geo/geodesic.h"
#include "aerovo/map/gdal_error.h"

namespace aerovo::map {

std::string internal::LastGdalError(const std::string& fallback) {
  const char* m = CPLGetLastErrorMsg();
  return m != nullptr && *m != '\0' ? std::string(m) : fallback;
}

namespace {

struct DatasetCloser {
  void operator()(GDALDataset* ds) const {
    if (ds != nullptr) GDALClose(ds);
  }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

// GDALAllRegister once per process.
void RegisterGdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

using internal::LastGdalError;

// `path` opened read-only as a raster; InputError naming the file when it does not exist or
// GDAL cannot open it (with GDAL's message).
DatasetPtr OpenRaster(const std::filesystem::path& path) {
  RegisterGdal();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError("'" + path.string() + "': no such map file");
  }
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError("'" + path.string() + "': a folder, not a map file");
  }
  const QuietGdal quiet;
  GDALDataset* ds = static_cast<GDALDataset*>(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  if (ds == nullptr) {
    throw InputError("'" + path.string() + "': not a raster GDAL can read (corrupt, or not an "
                     "image): " + LastGdalError("unrecognised format"));
  }
  DatasetPtr out(ds);
  if (ds->GetRasterCount() < 1 || ds->GetRasterXSize() < 1 || ds->GetRasterYSize() < 1) {
    throw InputError("'" + path.string() + "': the raster has no band or no pixel");
  }
  return out;
}


// The map's CRS (InputError naming the file when it has none) into `info`.
OGRSpatialReference CrsOf(GDALDataset& ds, MapInfo* info) {
  const OGRSpatialReference* srs = ds.GetSpatialRef();
  if (srs == nullptr || srs->IsEmpty()) {
    throw InputError("'" + info->path.string() +
                     "': the raster has no coordinate reference system (CRS): a map must be "
                     "geo-referenced (GeoTIFF keys, or a .prj / .aux.xml beside it)");
  }
  OGRSpatialReference crs(*srs);
  crs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  info->crs_name = crs.GetName() != nullptr ? crs.GetName() : "";
  const char* auth = crs.GetAuthorityName(nullptr);
  const char* code = crs.GetAuthorityCode(nullptr);
  if (auth != nullptr && code != nullptr && std::string(auth) == "EPSG") {
    info->epsg = std::atoi(code);
  }
  info->crs_geographic = crs.IsGeographic() != 0;
  const char* unit = nullptr;
  if (info->crs_geographic) {
    crs.GetAngularUnits(&unit);
  } else {
    crs.GetLinearUnits(&unit);
  }
  info->crs_units = unit != nullptr ? unit : "";
  return crs;
}

// The CRS coordinates of pixel corner (col, row).
std::pair<double, double> At(const std::array<double, 6>& gt, double col, double row) {
  return {gt[0] + col * gt[1] + row * gt[2], gt[3] + col * gt[4] + row * gt[5]};
}

// extent_crs, extent_lonlat (edges sampled: 32 points a side) and the resolution in metres.
void PlaceOnEarth(const OGRSpatialReference& crs, MapInfo* info) {
  const std::array<double, 6>& gt = info->geotransform;
  const double w = info->width_px, h = info->height_px;
  std::vector<std::pair<double, double>> edge;
  constexpr int kSteps = 32;
  for (int i = 0; i <= kSteps; ++i) {
    const double f = static_cast<double>(i) / kSteps;
    for (const auto& [c, r] : {std::pair{f * w, 0.0}, {f * w, h}, {0.0, f * h}, {w, f * h}}) {
      edge.push_back(At(gt, c, r));
    }
  }
  Extent& e = info->extent_crs;
  e = {1e300, 1e300, -1e300, -1e300};
  for (const auto& [x, y] : edge) {
    e = {std::min(e.min_x, x), std::min(e.min_y, y), std::max(e.max_x, x), std::max(e.max_y, y)};
  }
  // Coordinates no place on the earth has, refused before PROJ sees them: PROJ's inverse
  // projections take time growing with the coordinate (a Pseudo-Mercator x of 1e160 m did not
  // return in minutes, GDAL 3.6 / PROJ 9.1 of Debian 12). The bound is loose: 1e8 m is 2.5 times
  // the equator's length, 1000 degrees under three turns (0-360 degree longitudes are valid).
  // A geographic map's latitudes are checked first, with their own message.
  const double unit = info->crs_geographic ? crs.GetAngularUnits(nullptr) * 180.0 / M_PI
                                           : crs.GetLinearUnits(nullptr);
  const double bound = info->crs_geographic ? 1e3 : 1e8;
  const auto check_latitude = [&](double lo, double hi) {
    // A geographic CRS is not checked by the transform (WGS84 to itself): a geotransform in the
    // wrong units (metres in a degree CRS) puts the map beyond the poles.
    if (lo < -90.0 || hi > 90.0) {
      throw InputError(fmt::format(
          "'{}': its geotransform puts the map at latitude {:.6g} .. {:.6g} deg, outside -90 .. "
          "90 (an origin or pixel size in other units than its CRS's, {})",
          info->path.string(), lo, hi, info->crs_name));
    }
  };
  if (info->crs_geographic) check_latitude(e.min_y * unit, e.max_y * unit);
  double far = std::max(std::abs(e.min_x), std::abs(e.max_x));
  if (!info->crs_geographic) far = std::max({far, std::abs(e.min_y), std::abs(e.max_y)});
  far *= unit;
  if (!(far <= bound)) {
    throw InputError(fmt::format(
        "'{}': its geotransform puts the map's corners at x {:.6g} .. {:.6g}, y {:.6g} .. {:.6g} "
        "{}, more than {:g} {} from its CRS's origin: no place on the earth (an origin or pixel "
        "size in other units than its CRS's, {})",
        info->path.string(), e.min_x, e.max_x, e.min_y, e.max_y, info->crs_units, bound,
        info->crs_geographic ? "degrees" : "m", info->crs_name));
  }
  OGRSpatialReference wgs84;
  wgs84.importFromEPSG(4326);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to_lonlat(
      OGRCreateCoordinateTransformation(&crs, &wgs84));
  if (!to_lonlat) {
    throw InputError("'" + info->path.string() + "': its CRS (" + info->crs_name +
                     ") cannot be transformed to WGS84: " + LastGdalError("PROJ error"));
  }
  std::vector<double> xs, ys;
  for (const auto& [x, y] : edge) {
    xs.push_back(x);
    ys.push_back(y);
  }
  std::vector<int> ok(xs.size(), 0);
  to_lonlat->Transform(static_cast<int>(xs.size()), xs.data(), ys.data(), nullptr, ok.data());
  Extent& g = info->extent_lonlat;
  g = {1e300, 1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < xs.size(); ++i) {
    if (!ok[i]) continue;
    g = {std::min(g.min_x, xs[i]), std::min(g.min_y, ys[i]), std::max(g.max_x, xs[i]),
         std::max(g.max_y, ys[i])};
  }
  if (g.min_x > g.max_x) {
    throw InputError("'" + info->path.string() + "': no point of the map's edges has a WGS84 "
                     "position in its CRS (" + info->crs_name + ")");
  }
  check_latitude(g.min_y, g.max_y);
  // One pixel's geodesic length at the centre (through WGS84 lon, lat in degrees).
  double x = 0.5 * (e.min_x + e.max_x), y = 0.5 * (e.min_y + e.max_y);
  double x1 = x + gt[1], y1 = y + gt[4], x2 = x + gt[2], y2 = y + gt[5];
  int ok_c[3] = {0, 0, 0};
  to_lonlat->Transform(1, &x, &y, nullptr, &ok_c[0]);
  to_lonlat->Transform(1, &x1, &y1, nullptr, &ok_c[1]);
  to_lonlat->Transform(1, &x2, &y2, nullptr, &ok_c[2]);
  double geo_x = 0.0, geo_y = 0.0;
  try {
    if (!ok_c[0] || !ok_c[1] || !ok_c[2]) throw InvalidArgument("no WGS84 position");
    geo_x = GeodesicDistance({y, x, 0.0}, {y1, x1, 0.0});
    geo_y = GeodesicDistance({y, x, 0.0}, {y2, x2, 0.0});
  } catch (const InvalidArgument& err) {
    throw InputError(
        fmt::format("'{}': the pixel at the map's centre has no size on the earth "
                    "in its CRS ({}): {}",
                    info->path.string(), info->crs_name, err.what()));
  }
  if (!(geo_x > 0.0) || !(geo_y > 0.0) || !std::isfinite(geo_x) || !std::isfinite(geo_y)) {
    throw InputError(
        fmt::format("'{}': the pixel at the map's centre is {:.3g} x {:.3g} m on the "
                    "earth: not a map's pixel",
                    info->path.string(), geo_x, geo_y));
  }
  info->m_per_px_x = geo_x;
  info->m_per_px_y = geo_y;
  if (info->crs_geographic) return;
  // Projected: the CRS's linear unit, unless the projection's scale at the map is more than 1 %
  // from 1 (Web Mercator, EPSG:3857: 1 / cos(latitude), 38 % at 43 deg), whose metres are not
  // the ground's; a UTM or local transverse Mercator grid (scale within 0.1 %) keeps its unit.
  const double unit_m = crs.GetLinearUnits(nullptr);
  const double col_m = std::hypot(gt[1], gt[4]) * unit_m, row_m = std::hypot(gt[2], gt[5]) * unit_m;
  const bool scaled =
      !(std::abs(geo_x / col_m - 1.0) <= 0.01 && std::abs(geo_y / row_m - 1.0) <= 0.01);
  info->m_per_px_x = scaled ? geo_x : col_m;
  info->m_per_px_y = scaled ? geo_y : row_m;
}

}  // namespace

MapInfo ReadMapInfo(const std::filesystem::path& path) {
  const QuietGdal quiet;
  MapInfo info;
  info.path = path;
  const DatasetPtr ds = OpenRaster(path);
  info.driver = ds->GetDriver() != nullptr ? ds->GetDriver()->GetDescription() : "";
  info.width_px = ds->GetRasterXSize();
  info.height_px = ds->GetRasterYSize();
  info.bands = ds->GetRasterCount();
  const OGRSpatialReference crs = CrsOf(*ds, &info);
  if (ds->GetGeoTransform(info.geotransform.data()) != CE_None) {
    throw InputError("'" + path.string() + "': the raster has no geotransform (" +
                     (ds->GetGCPCount() > 0 ? "only ground control points: warp it first, "
                                              "gdalwarp"
                                            : "a plain image") +
                     "): a map must say where each pixel is");
  }
  const std::array<double, 6>& gt = info.geotransform;
  if (!(gt[1] * gt[5] - gt[2] * gt[4] != 0.0) ||
      !std::all_of(gt.begin(), gt.end(), [](double v) { return std::isfinite(v); })) {
    throw InputError("'" + path.string() + "': its geotransform is degenerate");
  }
  info.rotated = gt[2] != 0.0 || gt[4] != 0.0;
  PlaceOnEarth(crs, &info);
  GDALRasterBand* band = ds->GetRasterBand(1);
  for (int i = 0; i < band->GetOverviewCount(); ++i) {
    GDALRasterBand* o = band->GetOverview(i);
    if (o != nullptr) info.overviews.emplace_back(o->GetXSize(), o->GetYSize());
  }
  band->GetBlockSize(&info.block_x_px, &info.block_y_px);
  const char* c = ds->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
  info.compression = c != nullptr ? c : "";
  info.radiometry = ProbeMapPixels(*ds, path);
  return info;
}

std::string FormatMapInfo(const MapInfo& m) {
  std::string t = fmt::format("{:<13}{}\n", "map", m.path.string());
  t += fmt::format("{:<13}{} x {} px, {} band{} ({})\n", "size", m.width_px, m.height_px, m.bands,
                   m.bands == 1 ? "" : "s", m.driver);
  t += fmt::format("{:<13}{}{}, {}\n", "crs", m.crs_name,
                   m.epsg ? fmt::format(" (EPSG:{})", *m.epsg) : std::string(),
                   m.crs_geographic ? "geographic" : "projected");
  t += fmt::format("{:<13}{:.4f} x {:.4f} m/px ({:.9g} x {:.9g} {} per px){}\n", "resolution",
                   m.m_per_px_x, m.m_per_px_y, std::hypot(m.geotransform[1], m.geotransform[4]),
                   std::hypot(m.geotransform[2], m.geotransform[5]), m.crs_units,
                   m.rotated ? ", rotated" : "");
  const Extent& e = m.extent_crs;
  t += fmt::format("{:<13}x {:.9g} .. {:.9g}, y {:.9g} .. {:.9g} {} ({:.1f} x {:.1f} m)\n",
                   "extent", e.min_x, e.max_x, e.min_y, e.max_y, m.crs_units,
                   m.width_px * m.m_per_px_x, m.height_px * m.m_per_px_y);
  const Extent& g = m.extent_lonlat;
  t += fmt::format("{:<13}lon {:.7f} .. {:.7f}, lat {:.7f} .. {:.7f} deg\n", "extent wgs84",
                   g.min_x, g.max_x, g.min_y, g.max_y);
  std::string ov;
  for (const auto& [w, h] : m.overviews) ov += fmt::format("{}{}x{}", ov.empty() ? "" : ", ", w, h);
  t += fmt::format("{:<13}{}\n", "overviews", ov.empty() ? "none" : ov);
  t += fmt::format("{:<13}{} x {} px blocks, compression {}\n", "layout", m.block_x_px,
                   m.block_y_px, m.compression.empty() ? "none" : m.compression);
  const MapRadiometry& r = m.radiometry;
  t += fmt::format("{:<13}{}{}{}\n", "samples", r.sample_type, r.palette ? ", palette colours" : "",
                   r.lo != 0.0 || r.hi != 255.0
                       ? fmt::format(", grey {:.6g} .. {:.6g} stretched to 0 .. 255 (1st-99th "
                                     "percentile)",
                                     r.lo, r.hi)
                       : std::string());
  return t;
}

nlohmann::json ToJson(const MapInfo& m) {
  const auto extent = [](const Extent& e) {
    return nlohmann::json{{"min_x", e.min_x}, {"min_y", e.min_y}, {"max_x", e.max_x},
                          {"max_y", e.max_y}};
  };
  nlohmann::json overviews = nlohmann::json::array();
  for (const auto& [w, h] : m.overviews) overviews.push_back({w, h});
  return {{"path", m.path.string()},
          {"driver", m.driver},
          {"width_px", m.width_px},
          {"height_px", m.height_px},
          {"bands", m.bands},
          {"crs_name", m.crs_name},
          {"epsg", m.epsg ? nlohmann::json(*m.epsg) : nlohmann::json()},
          {"crs_geographic", m.crs_geographic},
          {"crs_units", m.crs_units},
          {"geotransform", m.geotransform},
          {"rotated", m.rotated},
          {"m_per_px_x", m.m_per_px_x},
          {"m_per_px_y", m.m_per_px_y},
          {"extent_crs", extent(m.extent_crs)},
          {"extent_lonlat", extent(m.extent_lonlat)},
          {"overviews", overviews},
          {"block_x_px", m.block_x_px},
          {"block_y_px", m.block_y_px},
          {"compression", m.compression},
          {"sample_type", m.radiometry.sample_type},
          {"palette", m.radiometry.palette},
          {"grey_range", {m.radiometry.lo, m.radiometry.hi}}};
}

}  // namespace aerovo::map
