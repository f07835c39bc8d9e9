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
#include "aerovo/pipeline/map_fixer_test_util.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps::map_tiles_test {
namespace {

namespace fs = std::filesystem;

using map_testing::kLat0;
using map_testing::kLon0;
using map_testing::kMpp;
using map_testing::TexturedMap;

const TexturedMap& TilesMap() {
  static const TexturedMap m(7, "aerovo_map_tiles");
  return m;
}

// The points of a window gathered from the tiles against those of the same window read and
// detected as one image: the same SURF points where both have one (the tiles' and the window's
// pixels are resampled from the map at other sub-pixel offsets: positions agree to a fraction
// of a pixel, not bit for bit), in the same number within 25 %.
TEST(MapTileCache, WindowPointsAreTheWindowsOwnSurfPoints) {
  const map::ReferenceMaps maps({TilesMap().path});
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
  const map::ReferenceMaps maps({TilesMap().path});
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
      fixer.Submit(TilesMap().Job(2 * k, places[k][0], places[k][1], places[k][2]));
      if (std::optional<MapFixRecord> r = fixer.TakeFix(true)) fixes.push_back(*r);
    }
    RunSummary summary;
    fixer.Finish(TilesMap().path.parent_path(), &summary);
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
}  // namespace aerovo::run_steps::map_tiles_test
