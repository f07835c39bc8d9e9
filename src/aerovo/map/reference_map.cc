#include "aerovo/map/reference_map.h"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <fmt/format.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/error.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/map_pixels.h"

namespace aerovo::map {

// One opened map: its dataset, WGS84 lon/lat -> its CRS, and its pixel <- CRS transform.
struct ReferenceMaps::Open {
  GDALDataset* ds = nullptr;
  std::unique_ptr<OGRCoordinateTransformation> to_crs;
  double px_from_crs[6] = {};
  std::mutex mutex;  // GDAL datasets are not to be read from two threads at once
  ~Open() {
    if (ds != nullptr) GDALClose(ds);
  }
  // The continuous pixel coordinates (0 = a pixel's left/top edge) of `p`; false when the CRS
  // transform fails.
  bool PixelOf(const GeoPoint& p, double* col, double* row) const {
    double x = p.lon_deg, y = p.lat_deg;
    if (!to_crs->Transform(1, &x, &y)) return false;
    GDALApplyGeoTransform(const_cast<double*>(px_from_crs), x, y, col, row);
    return std::isfinite(*col) && std::isfinite(*row);
  }
};

namespace {

// Bilinear sample of `v` at block coordinates (u, v) (sample centres at integers), clamped.
float Sample(const GreyBlock& b, const std::vector<float>& v, double u, double w) {
  u = std::clamp(u, 0.0, b.w - 1.0);
  w = std::clamp(w, 0.0, b.h - 1.0);
  const int i = std::min(static_cast<int>(u), b.w - 2 < 0 ? 0 : b.w - 2);
  const int j = std::min(static_cast<int>(w), b.h - 2 < 0 ? 0 : b.h - 2);
  const int i1 = std::min(i + 1, b.w - 1), j1 = std::min(j + 1, b.h - 1);
  const double fu = u - i, fw = w - j;
  const auto at = [&](int x, int y) { return v[static_cast<std::size_t>(y) * b.w + x]; };
  return static_cast<float>((1 - fw) * ((1 - fu) * at(i, j) + fu * at(i1, j)) +
                            fw * ((1 - fu) * at(i, j1) + fu * at(i1, j1)));
}

}  // namespace

ReferenceMaps::ReferenceMaps(const std::vector<std::filesystem::path>& paths) {
  if (paths.empty()) throw InvalidArgument("ReferenceMaps: no map given");
  OGRSpatialReference wgs84;
  wgs84.importFromEPSG(4326);
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  for (const auto& p : paths) {
    infos_.push_back(ReadMapInfo(p));  // registers GDAL; the errors naming the file
    auto o = std::make_unique<Open>();
    const QuietGdal quiet;
    o->ds = static_cast<GDALDataset*>(GDALOpenEx(p.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY,
                                                 nullptr, nullptr, nullptr));
    if (o->ds == nullptr) throw InputError("'" + p.string() + "': cannot be opened again");
    OGRSpatialReference crs(*o->ds->GetSpatialRef());
    crs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    o->to_crs.reset(OGRCreateCoordinateTransformation(&wgs84, &crs));
    double gt[6];
    std::copy(infos_.back().geotransform.begin(), infos_.back().geotransform.end(), gt);
    if (!o->to_crs || !GDALInvGeoTransform(gt, o->px_from_crs)) {
      throw InputError("'" + p.string() + "': WGS84 positions cannot be placed on it");
    }
    open_.push_back(std::move(o));
  }
}

ReferenceMaps::~ReferenceMaps() = default;
ReferenceMaps::ReferenceMaps(ReferenceMaps&&) noexcept = default;
ReferenceMaps& ReferenceMaps::operator=(ReferenceMaps&&) noexcept = default;

std::optional<int> ReferenceMaps::MapAt(const GeoPoint& p) const {
  for (std::size_t m = 0; m < open_.size(); ++m) {
    double col = 0, row = 0;
    const MapInfo& info = infos_[m];
    if (!open_[m]->PixelOf(p, &col, &row) || col < 0 || row < 0 || col >= info.width_px ||
        row >= info.height_px) {
      continue;
    }
    const std::lock_guard<std::mutex> lock(open_[m]->mutex);
    GreyBlock b;
    const int x = static_cast<int>(col), y = static_cast<int>(row);
    if (ReadGreyBlock(*open_[m]->ds, info.path, info.radiometry, x, y, x + 1, y + 1, 1.0, &b) &&
        Sample(b, b.valid, (col - b.x0) / b.dx - 0.5, (row - b.y0) / b.dy - 0.5) >= 128.0f) {
      return static_cast<int>(m);
    }
  }
  return std::nullopt;
}

MapCover ReferenceMaps::CoverOf(const std::vector<GeoPoint>& points) const {
  MapCover c;
  for (const GeoPoint& p : points) {
    ++c.points;
    if (MapAt(p)) ++c.covered;
  }
  return c;
}

int ReferenceMaps::Fill(std::size_t m, const LocalEnu& enu, MapWindow* win) const {
  const int size_px = win->pixels.width();
  const double half = 0.5 * (size_px - 1) * win->m_per_px;
  // The window's corner pixel centres (NW, NE, SW, SE) on the map.
  double c[4], r[4];
  const double e[4] = {-half, half, -half, half}, n[4] = {half, half, -half, -half};
  for (int k = 0; k < 4; ++k) {
    if (!open_[m]->PixelOf(enu.Reverse(e[k], n[k], 0.0), &c[k], &r[k])) return 0;
  }
  const MapInfo& info = infos_[m];
  const double cmin = *std::min_element(c, c + 4), cmax = *std::max_element(c, c + 4);
  const double rmin = *std::min_element(r, r + 4), rmax = *std::max_element(r, r + 4);
  if (cmax < 0 || rmax < 0 || cmin > info.width_px || rmin > info.height_px) return 0;
  // Map pixels per window pixel: the level read is the coarsest at least that fine.
  const double step = std::hypot(c[1] - c[0], r[1] - r[0]) / (size_px - 1);
  GreyBlock b;
  {
    const std::lock_guard<std::mutex> lock(open_[m]->mutex);
    if (!ReadGreyBlock(*open_[m]->ds, info.path, info.radiometry, cmin, rmin, cmax, rmax, step,
                       &b)) {
      return 0;
    }
  }
  int filled = 0;
  const double inv = 1.0 / (size_px - 1);
  for (int y = 0; y < size_px; ++y) {
    for (int x = 0; x < size_px; ++x) {
      if (win->valid.at(x, y) != 0) continue;  // a preferred map's data
      // The affine of the corners (bilinear in the corners, exact for an affine CRS).
      const double fx = x * inv, fy = y * inv;
      const double col = (1 - fy) * ((1 - fx) * c[0] + fx * c[1]) + fy * ((1 - fx) * c[2] + fx * c[3]);
      const double row = (1 - fy) * ((1 - fx) * r[0] + fx * r[1]) + fy * ((1 - fx) * r[2] + fx * r[3]);
      const bool inside = col >= 0 && row >= 0 && col <= info.width_px && row <= info.height_px;
      const double u = (col - b.x0) / b.dx - 0.5, v = (row - b.y0) / b.dy - 0.5;
      if (!inside || Sample(b, b.valid, u, v) < 128.0f) continue;
      win->pixels.at(x, y) = static_cast<std::uint8_t>(std::clamp(Sample(b, b.grey, u, v) + 0.5f, 0.0f, 255.0f));
      win->valid.at(x, y) = 255;
      ++filled;
    }
  }
  return filled;
}

std::optional<MapWindow> ReferenceMaps::Window(const GeoPoint& centre, int size_px,
                                               double m_per_px) const {
  if (size_px < 2 || !(m_per_px > 0.0) || !std::isfinite(m_per_px)) {
    throw InvalidArgument(fmt::format("ReferenceMaps::Window: size_px must be >= 2 and m_per_px "
                                      "finite and > 0, got {} and {}", size_px, m_per_px));
  }
  const LocalEnu enu(centre);
  MapWindow win;
  win.pixels = GrayImage(size_px, size_px);
  win.valid = GrayImage(size_px, size_px);
  win.m_per_px = m_per_px;
  win.centre = centre;
  win.pixels_from_map.assign(open_.size(), 0);
  const long long total = static_cast<long long>(size_px) * size_px;
  long long valid = 0;
  // In the order of preference: each map fills what the ones before it left empty.
  for (std::size_t m = 0; m < open_.size() && valid < total; ++m) {
    const int filled = Fill(m, enu, &win);
    win.pixels_from_map[m] = filled;
    valid += filled;
  }
  if (valid == 0) return std::nullopt;
  win.map_index = static_cast<int>(
      std::max_element(win.pixels_from_map.begin(), win.pixels_from_map.end()) -
      win.pixels_from_map.begin());
  win.valid_fraction = static_cast<double>(valid) / static_cast<double>(total);
  return win;
}

std::string CheckCover(const ReferenceMaps& maps, const std::vector<GeoPoint>& track) {
  std::string names;
  for (const MapInfo& i : maps.infos()) names += (names.empty() ? "'" : ", '") + i.path.string() + "'";
  const MapCover c = maps.CoverOf(track);
  if (c.none()) {
    throw InputError(fmt::format("{}: the map{} cover{} none of the flight's {} positions",
                                 names, maps.infos().size() > 1 ? "s" : "",
                                 maps.infos().size() > 1 ? "" : "s", c.points));
  }
  if (c.partial()) {
    return fmt::format("{}: the map{} cover{} {} of the flight's {} positions: fixes only there",
                       names, maps.infos().size() > 1 ? "s" : "",
                       maps.infos().size() > 1 ? "" : "s", c.covered, c.points);
  }
  return "";
}

}  // namespace aerovo::map
