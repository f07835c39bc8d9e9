// A reference map of the Callas orthophoto as another survey would give it, for the end-to-end
// tests of `aerovo run --map` (map_fix_test.cc, map_demo_test.cc): the orthophoto read reduced,
// its tones changed (a gamma, less contrast, a veil of haze, a gradient of light), JPEG at
// quality 40, written as a GeoTIFF in a transverse Mercator CRS centred on the orthophoto's
// north-west corner (the simulator's ENU plane there; gdal_translate, gdal-bin).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace aerovo::e2e {

struct CallasMapOptions {
  double ortho_mpp = 0.1082;  ///< The orthophoto's metres per pixel, as the flight was simulated.
  double nw_lat = 43.539340, nw_lon = 6.551628;  ///< Its north-west corner, as simulated.
  int reduction = 4;  ///< The map's pixel: this many orthophoto pixels (2, 4 or 8).
  /// The map's columns east in [band[0], band[1]) m and those band[2] m farther east swapped
  /// (two tiles each placed where the other belongs); {0, 0, 0}: none.
  std::array<double, 3> band{0, 0, 0};
  /// The map's columns east in [gap[0], gap[1]) m have no data (nodata 0); {0, 0}: none.
  std::array<double, 2> gap{0, 0};
  /// The map's content mirrored east-west (the same texture nowhere in the right place).
  bool mirror = false;
  /// The orthophoto's empty (black) surroundings, and the gap, are nodata (0) in the map;
  /// false: they are a uniform grey, as tones make them.
  bool nodata = false;
};

/// Writes `dir`/`name`.tif; false when the orthophoto cannot be read or GDAL fails.
inline bool WriteCallasMap(const std::filesystem::path& ortho, const std::filesystem::path& dir,
                           const std::string& name, const CallasMapOptions& o = {}) {
  const int mode = o.reduction == 2   ? cv::IMREAD_REDUCED_GRAYSCALE_2
                   : o.reduction == 8 ? cv::IMREAD_REDUCED_GRAYSCALE_8
                                      : cv::IMREAD_REDUCED_GRAYSCALE_4;
  cv::Mat g = cv::imread(ortho.string(), mode);
  if (g.empty()) return false;
  if (o.mirror) cv::flip(g, g, 1);
  cv::Mat map(g.size(), CV_8U);
  const double mpp = o.reduction * o.ortho_mpp;
  const int shift = static_cast<int>(std::lround(o.band[2] / mpp));
  for (int y = 0; y < g.rows; ++y) {
    for (int x = 0; x < g.cols; ++x) {
      int sx = x;
      if (x * mpp >= o.band[0] && x * mpp < o.band[1]) sx = std::min(g.cols - 1, x + shift);
      if (x * mpp >= o.band[0] + o.band[2] && x * mpp < o.band[1] + o.band[2]) sx = x - shift;
      const std::uint8_t raw = g.at<std::uint8_t>(y, sx);
      const bool in_gap = x * mpp >= o.gap[0] && x * mpp < o.gap[1];
      if (o.nodata && (raw == 0 || in_gap)) {
        map.at<std::uint8_t>(y, x) = 0;
        continue;
      }
      const double season = std::pow(raw / 255.0, 0.7) * 0.65 + 0.22 + 0.06 * x / g.cols;
      map.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(255.0 * season);
    }
  }
  const std::filesystem::path jpg = dir / (name + ".jpg");
  if (!cv::imwrite(jpg.string(), map, {cv::IMWRITE_JPEG_QUALITY, 40})) return false;
  const std::string cmd = fmt::format(
      "gdal_translate -q {} -a_srs '+proj=tmerc +lat_0={} +lon_0={} +k=1 +x_0=0 +y_0=0 "
      "+ellps=WGS84 +units=m +no_defs' -a_ullr 0 0 {} {} {} {}",
      o.nodata ? "-a_nodata 0" : "", o.nw_lat, o.nw_lon, map.cols * mpp, -map.rows * mpp,
      jpg.string(), (dir / (name + ".tif")).string());
  return std::system(cmd.c_str()) == 0;
}

}  // namespace aerovo::e2e
