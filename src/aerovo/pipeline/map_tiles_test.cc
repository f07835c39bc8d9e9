// MapTileCache (map_tiles.h) on a GeoTIFF of random texture written here (a transverse Mercator
// CRS centred on the map's north-west corner, 0.5 m/px): a window's points gathered from the
// tiles are the SURF points of the window read and detected directly (same places, same scales),
// the tiles are made once and serve the next windows, and the map fixer with the cache gives
// the same fixes as without it.
#include "aerovo/pipeline/map_tiles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/testing.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/reference_map.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps {
namespace {

namespace fs = std::filesystem;

constexpr double kMpp = 0.5, kLat0 = 45.0, kLon0 = 7.0;
constexpr int kSize = 800;

struct TexturedMap {
  cv::Mat grey;
  fs::path path;
  TexturedMap() {
    cv::Mat noise(kSize, kSize, CV_32F);
    cv::theRNG().state = 7;
    cv::randu(noise, 0.0, 1.0);
    cv::GaussianBlur(noise, noise, cv::Size(), 2.0);
    cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
    noise.convertTo(grey, CV_8U);
    path = ::aerovo::testing::FreshTempDir("aerovo_map_tiles", "map") / "map.tif";
    GDALAllRegister();
    GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        path.c_str(), kSize, kSize, 1, GDT_Byte, nullptr);
    EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, kSize, kSize, grey.data, kSize, kSize,
                                             GDT_Byte, 0, 0, nullptr),
              CE_None);
    double gt[6] = {0.0, kMpp, 0.0, 0.0, 0.0, -kMpp};
    ds->SetGeoTransform(gt);
    OGRSpatialReference srs;
    srs.importFromProj4("+proj=tmerc +lat_0=45 +lon_0=7 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m");
    ds->SetSpatialRef(&srs);
    GDALClose(ds);
  }
  ~TexturedMap() {
    std::error_code ec;
    fs::remove_all(path.parent_path(), ec);
  }
  // The WGS84 point at map pixel centre (cx, cy) shifted `off_east_m` east.
  static GeoPoint At(double cx, double cy, double off_east_m = 0.0) {
    const LocalEnu enu(kLat0, kLon0, 0.0);
    return enu.Reverse((cx + 0.5) * kMpp + off_east_m, -(cy + 0.5) * kMpp, 0.0);
  }
  // A 240 x 180 frame whose centre is at map pixel (cx, cy), heading 0, 0.5 m/px (focal 100 px
  // at 50 m), predicted `off_east_m` east of its true place.
  MapFixJob Job(int frame, int cx, int cy, double off_east_m) const {
    MapFixJob job;
    job.frame = frame;
    job.time_s = frame;
    job.pixels = GrayImage(240, 180);
    for (int y = 0; y < 180; ++y) {
      for (int x = 0; x < 240; ++x)
        job.pixels.at(x, y) = grey.at<std::uint8_t>(cy - 90 + y, cx - 120 + x);
    }
    job.focal_px = 100.0;
    job.height_m = 50.0;
    job.heading_rad = 0.0;
    const LocalEnu enu(kLat0, kLon0, 0.0);
    job.gps = enu.Reverse(cx * kMpp, -cy * kMpp, 0.0);
    job.predicted = enu.Reverse(cx * kMpp + off_east_m, -cy * kMpp, 0.0);
    return job;
  }
};

const TexturedMap& Map() {
  static const TexturedMap m;
  return m;
}

// The points of a window gathered from the tiles against those of the same window read and
// detected as one image: the same SURF points where both have one (the tiles' and the window's
// pixels are resampled from the map at other sub-pixel offsets: positions agree to a fraction
// of a pixel, not bit for bit), in the same number within 25 %.
TEST(MapTileCache, WindowPointsAreTheWindowsOwnSurfPoints) {
  const map::ReferenceMaps maps({Map().path});
  MapTileCache cache(maps, MapTileCache::Options{256, 120, 16});
  const GeoPoint centre = TexturedMap::At(400, 380, 3.3);
  const int size = 300;
  const double density = 600.0 / (240.0 * 180.0);
  const MapWindowFeatures cached = cache.Window(centre, size, kMpp, true, density, 100000);
  const std::optional<map::MapWindow> read = maps.Window(centre, size, kMpp);
  ASSERT_TRUE(read.has_value());
  const FeatureSet direct = DetectMapFeatures(
      read->pixels.view(), read->valid.view(),
      static_cast<int>(density * size * size), /*upright=*/true);
  EXPECT_EQ(cached.size_px, size);
  EXPECT_EQ(cached.valid_px, static_cast<std::size_t>(size) * size);
  ASSERT_GT(direct.size(), 500u);
  EXPECT_NEAR(static_cast<double>(cached.features.size()), static_cast<double>(direct.size()),
              0.25 * direct.size());
  int same = 0;
  double worst = 0.0;
  for (const Keypoint& c : cached.features.keypoints) {
    double best = 1e9;
    for (const Keypoint& d : direct.keypoints) {
      if (std::abs(d.scale - c.scale) > 0.1 * c.scale) continue;
      best = std::min(best, static_cast<double>(std::hypot(d.x - c.x, d.y - c.y)));
    }
    if (best < 0.5) {
      ++same;
      worst = std::max(worst, best);
    }
  }
  std::printf("cached %zu, direct %zu, same %d (worst %.3f px)\n", cached.features.size(),
              direct.size(), same, worst);
  EXPECT_GT(same, 0.6 * static_cast<double>(cached.features.size()));
  EXPECT_GT(cache.tiles_made(), 1);
  // A window moved by 20 m within the same tiles makes none, and gives the same points moved.
  const int made = cache.tiles_made();
  const MapWindowFeatures moved =
      cache.Window(TexturedMap::At(400, 380, 3.3 + 20.0), size, kMpp, true, density, 100000);
  EXPECT_EQ(cache.tiles_made(), made);
  EXPECT_EQ(cache.windows(), 2);
  int shifted = 0;
  for (const Keypoint& m : moved.features.keypoints) {
    for (const Keypoint& c : cached.features.keypoints) {
      if (std::hypot(m.x + 40.0 - c.x, m.y - c.y) < 0.01 && m.scale == c.scale) {
        ++shifted;
        break;
      }
    }
  }
  EXPECT_GT(shifted, 0.8 * static_cast<double>(moved.features.size()) - 150);
}

// The fixer with and without the cache: the same attempts, every one a fix, at the same places
// within 5 cm (the truth within 0.3 m), and the cached run twice gives the same positions to
// the last digit.
TEST(MapTileCache, FixerGivesTheSameFixesWithTheCache) {
  const map::ReferenceMaps maps({Map().path});
  const auto run = [&](bool cache) {
    MapMatchOptions o;
    o.search_radius_m = 30.0;
    o.search_at_start = false;
    o.tile_cache = cache;
    MapFixer fixer(maps, o, /*live=*/false);
    std::vector<MapFixRecord> fixes;
    const int places[5][3] = {{300, 300, 12}, {340, 310, -8}, {380, 330, 5}, {420, 360, 0},
                              {460, 400, 9}};
    for (int k = 0; k < 5; ++k) {
      fixer.Submit(Map().Job(2 * k, places[k][0], places[k][1], places[k][2]));
      if (std::optional<MapFixRecord> r = fixer.TakeFix(true)) fixes.push_back(*r);
    }
    RunSummary summary;
    fixer.Finish(Map().path.parent_path(), &summary);
    EXPECT_EQ(summary.map_fixes->fixes, 5);
    EXPECT_LT(summary.map_fixes->max_m, 0.3);
    return fixes;
  };
  const std::vector<MapFixRecord> read = run(false), cached = run(true), again = run(true);
  ASSERT_EQ(read.size(), 5u);
  ASSERT_EQ(cached.size(), 5u);
  ASSERT_EQ(again.size(), 5u);
  const LocalEnu enu(kLat0, kLon0, 0.0);
  for (std::size_t k = 0; k < 5; ++k) {
    ASSERT_TRUE(read[k].geo && cached[k].geo && again[k].geo);
    const double d = (enu.Forward(*read[k].geo) - enu.Forward(*cached[k].geo)).head<2>().norm();
    std::printf("attempt %zu: cached - read %.4f m, inliers %d vs %d\n", k, d,
                cached[k].fix.inliers, read[k].fix.inliers);
    EXPECT_LT(d, 0.05) << k;
    EXPECT_EQ(cached[k].geo->lat_deg, again[k].geo->lat_deg) << k;
    EXPECT_EQ(cached[k].geo->lon_deg, again[k].geo->lon_deg) << k;
    EXPECT_EQ(cached[k].fix.inliers, again[k].fix.inliers) << k;
  }
}

}  // namespace
}  // namespace aerovo::run_steps
