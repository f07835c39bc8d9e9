#include "aerovo/map/reference_map.h"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <cpl_error.h>
#include <fmt/format.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/error.h"
#include "aerovo/geo/local_enu.h"

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

// A block of a map read into memory: grey and validity, `w` x `h` samples covering map pixels
// [x0, x0 + w dx) x [y0, y0 + h dy).
struct Block {
  int w = 0, h = 0;
  double x0 = 0, y0 = 0, dx = 1, dy = 1;
  std::vector<float> grey, valid;
};

// `band` at overview `level` (-1: itself); null when it has no such overview.
GDALRasterBand* AtLevel(GDALRasterBand* band, int level) {
  if (level < 0) return band;
  return level < band->GetOverviewCount() ? band->GetOverview(level) : nullptr;
}

// Reads the map around map pixels [c0, c1) x [r0, r1) (full resolution, continuous) from the
// coarsest overview at least as fine as `px_per_sample` map pixels per sample (each level read
// pixel for pixel, on its own grid: GDAL's resampling of a window that is not aligned with an
// overview's pixels would shift it by up to half of one). Grey from 1 band or the luma of the
// first 3, validity from the mask band (alpha, nodata; all valid without).
bool ReadBlock(GDALDataset& ds, double c0, double r0, double c1, double r1, double px_per_sample,
               Block* b) {
  GDALRasterBand* first = ds.GetRasterBand(1);
  int level = -1;
  for (int i = 0; i < first->GetOverviewCount(); ++i) {
    const double f = static_cast<double>(ds.GetRasterXSize()) / first->GetOverview(i)->GetXSize();
    if (f <= px_per_sample) level = i;
  }
  GDALRasterBand* base = AtLevel(first, level);
  const double fx = static_cast<double>(ds.GetRasterXSize()) / base->GetXSize();
  const double fy = static_cast<double>(ds.GetRasterYSize()) / base->GetYSize();
  const int x0 = std::max(0, static_cast<int>(std::floor(c0 / fx)) - 1);
  const int y0 = std::max(0, static_cast<int>(std::floor(r0 / fy)) - 1);
  const int x1 = std::min(base->GetXSize(), static_cast<int>(std::ceil(c1 / fx)) + 1);
  const int y1 = std::min(base->GetYSize(), static_cast<int>(std::ceil(r1 / fy)) + 1);
  if (x1 - x0 < 1 || y1 - y0 < 1) return false;
  const int w = x1 - x0, h = y1 - y0;
  *b = Block{w, h, x0 * fx, y0 * fy, fx, fy, {}, {}};
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<float> band(n);
  const int bands = ds.GetRasterCount() >= 3 ? 3 : 1;
  const float weight[3] = {0.299f, 0.587f, 0.114f};
  b->grey.assign(n, 0.0f);
  const auto read = [&](GDALRasterBand* src, float* out) {
    return src != nullptr && src->RasterIO(GF_Read, x0, y0, w, h, out, w, h, GDT_Float32, 0, 0,
                                           nullptr) == CE_None;
  };
  for (int k = 0; k < bands; ++k) {
    if (!read(AtLevel(ds.GetRasterBand(k + 1), level), band.data())) return false;
    const float wk = bands == 1 ? 1.0f : weight[k];
    for (std::size_t i = 0; i < n; ++i) b->grey[i] += wk * band[i];
  }
  b->valid.assign(n, 255.0f);
  if ((first->GetMaskFlags() & GMF_ALL_VALID) == 0) {
    if (!read(AtLevel(first->GetMaskBand(), level), b->valid.data())) return false;
  }
  return true;
}

// Bilinear sample of `v` at block coordinates (u, v) (sample centres at integers), clamped.
float Sample(const Block& b, const std::vector<float>& v, double u, double w) {
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
    Block b;
    const int x = static_cast<int>(col), y = static_cast<int>(row);
    if (ReadBlock(*open_[m]->ds, x, y, x + 1, y + 1, 1.0, &b) &&
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
  Block b;
  {
    const std::lock_guard<std::mutex> lock(open_[m]->mutex);
    CPLErrorReset();
    if (!ReadBlock(*open_[m]->ds, cmin, rmin, cmax, rmax, step, &b)) {
      throw InputError("'" + info.path.string() + "': reading the map failed: " +
                       std::string(CPLGetLastErrorMsg()));
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
