// libFuzzer target: reference maps (map/map_info.h ReadMapInfo, map/reference_map.h
// ReferenceMaps), what `aerovo map info` and `aerovo run --map` read. Each input is written to
// map.tif in a private temporary folder and opened as a user's map is. GDAL is Debian's
// uninstrumented build: the coverage feedback comes from aerovo's map code, ASan still sees the
// heap. Only GDAL's GeoTIFF driver is left registered, so that an input cannot become a VRT or
// a WMS description naming other files or network addresses (GDAL's behaviour, not aerovo's,
// and not reproducible), and GDAL's block cache is held to 64 MB (the fuzzer's memory limit is
// 2 GB; GDAL's default is 5 % of the machine's memory).
//
// A read either throws InputError, or returns a map whose description holds what map_info.h
// promises (size and bands >= 1, a finite non-degenerate geotransform, a ground resolution
// finite and > 0, a WGS84 extent on the globe, a grey range lo < hi); then the cover of its
// centre and corners, and windows of 32 x 32 px at its own resolution and 64 times coarser
// centred on its centre and a corner, throw nothing but InputError and hold what
// reference_map.h promises (the size asked, validity 0 or 255 with the fraction it counts, grey
// 0 where invalid). Anything else (another exception, a crash, a sanitizer report, a broken
// promise) is a bug.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <cpl_conv.h>
#include <gdal_priv.h>

#include "aerovo/core/error.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/map/map_info.h"
#include "aerovo/map/reference_map.h"
#include "fuzz_files.h"

namespace {

void Check(bool ok) {
  if (!ok) std::abort();
}

// GDAL registered by aerovo's own first open (map_info.cc registers it once per process), then
// every driver but GTiff deregistered.
void KeepOnlyGeoTiff(const std::string& folder) {
  CPLSetConfigOption("GDAL_CACHEMAX", "64");
  try {
    aerovo::map::ReadMapInfo(folder + "absent.tif");
  } catch (const aerovo::InputError&) {
  }
  GDALDriverManager* drivers = GetGDALDriverManager();
  for (int i = drivers->GetDriverCount() - 1; i >= 0; --i) {
    GDALDriver* d = drivers->GetDriver(i);
    if (std::string(d->GetDescription()) == "GTiff") continue;
    drivers->DeregisterDriver(d);
    GDALDestroyDriver(d);  // deregistering does not free it
  }
  Check(drivers->GetDriverCount() == 1);
}

void CheckWindow(const std::optional<aerovo::map::MapWindow>& w, int size_px) {
  if (!w) return;
  Check(w->pixels.width() == size_px && w->pixels.height() == size_px);
  Check(w->valid.width() == size_px && w->valid.height() == size_px);
  int valid = 0;
  for (int y = 0; y < size_px; ++y) {
    for (int x = 0; x < size_px; ++x) {
      const int v = w->valid.at(x, y);
      Check(v == 0 || v == 255);
      if (v == 0) Check(w->pixels.at(x, y) == 0);
      valid += v == 255;
    }
  }
  Check(valid > 0);
  Check(std::abs(w->valid_fraction - static_cast<double>(valid) / (size_px * size_px)) < 1e-9);
  Check(w->map_index == 0 && w->pixels_from_map.size() == 1);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string folder = aerovo::fuzz::MakeFolder("map");
  static const bool registered = (KeepOnlyGeoTiff(folder), true);
  (void)registered;
  const std::string path = folder + "map.tif";
  aerovo::fuzz::WriteInput(path, data, size);
  try {
    const aerovo::map::ReferenceMaps maps({path});
    const aerovo::map::MapInfo& m = maps.infos().at(0);
    Check(m.width_px >= 1 && m.height_px >= 1 && m.bands >= 1);
    const auto& gt = m.geotransform;
    Check(std::all_of(gt.begin(), gt.end(), [](double v) { return std::isfinite(v); }));
    Check(gt[1] * gt[5] - gt[2] * gt[4] != 0.0);
    Check(std::isfinite(m.m_per_px_x) && m.m_per_px_x > 0.0);
    Check(std::isfinite(m.m_per_px_y) && m.m_per_px_y > 0.0);
    const aerovo::map::Extent& g = m.extent_lonlat;
    Check(g.min_x <= g.max_x && g.min_y <= g.max_y && g.min_y >= -90.0 && g.max_y <= 90.0);
    Check(m.radiometry.lo < m.radiometry.hi);
    (void)aerovo::map::FormatMapInfo(m);
    (void)aerovo::map::ToJson(m).dump();

    const double lat = 0.5 * (g.min_y + g.max_y), lon = 0.5 * (g.min_x + g.max_x);
    const std::vector<aerovo::GeoPoint> points = {
        {lat, lon, 0.0}, {g.min_y, g.min_x, 0.0}, {g.max_y, g.max_x, 0.0}};
    const aerovo::map::MapCover cover = maps.CoverOf(points);
    Check(cover.points == 3 && cover.covered >= 0 && cover.covered <= 3);
    const double m_per_px = std::clamp(std::min(m.m_per_px_x, m.m_per_px_y), 1e-3, 1e5);
    for (const double scale : {1.0, 64.0}) {
      CheckWindow(maps.Window(points[0], 32, m_per_px * scale), 32);
      CheckWindow(maps.Window(points[1], 32, m_per_px * scale), 32);
    }
  } catch (const aerovo::InputError&) {
  }
  return 0;
}
