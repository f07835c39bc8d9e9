// MapFixer (map_fixer.h) through the other raster kinds GDAL opens as a map (docs/map.md): a VRT
// over the GeoTIFF of map_fixer_test_util.h gives the same fixes as the GeoTIFF itself, to the
// bit; MBTiles (the texture warped to Web Mercator, EPSG:3857, and cut into the zoom level's
// RGBA PNG tiles by GDAL's driver) gives fixes on the truth within the extra resampling.
#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <vector>

#include <gdal_priv.h>
#include <gdalwarper.h>
#include <ogr_spatialref.h>

#include "aerovo/map/reference_map.h"
#include "aerovo/pipeline/map_fixer.h"
#include "aerovo/pipeline/map_fixer_test_util.h"

namespace aerovo::run_steps::map_fixer_formats_test {
namespace {

namespace fs = std::filesystem;

using map_testing::TexturedMap;

const TexturedMap& Map() {
  static const TexturedMap m(11, "aerovo_map_formats");
  return m;
}

// Four frames of the texture, predicted 12, -8, 5 and 0 m east of their true positions; the fix
// of each (nullopt: none), with its distance to the truth (MapFixRecord::gps_error_m; the
// GeoTIFF's fixes are within 0.05 m of it, a tenth of its 0.5 m pixels).
std::vector<std::optional<MapFixRecord>> FixesThrough(const fs::path& map_path) {
  const map::ReferenceMaps maps({map_path});
  MapMatchOptions o;
  o.every_n_frames = 1;
  o.search_radius_m = 30.0;
  MapFixer fixer(maps, o, /*live=*/false);
  std::vector<std::optional<MapFixRecord>> fixes;
  const int cx[] = {300, 420, 500, 250}, cy[] = {300, 380, 450, 520};
  const double off_m[] = {12.0, -8.0, 5.0, 0.0};
  for (int i = 0; i < 4; ++i) {
    fixer.Submit(Map().Job(i, cx[i], cy[i], off_m[i]));
    fixes.push_back(fixer.TakeFix(/*due=*/true));
  }
  RunSummary summary;
  fixer.Finish(map_path.parent_path(), &summary);
  return fixes;
}

GDALDataset* OpenRaster(const fs::path& p) {
  return static_cast<GDALDataset*>(GDALOpen(p.c_str(), GA_ReadOnly));
}

TEST(MapFixerFormats, AVrtOverTheGeoTiffGivesTheSameFixes) {
  const fs::path vrt = Map().path.parent_path() / "map.vrt";
  GDALDataset* src = OpenRaster(Map().path);
  ASSERT_NE(src, nullptr);
  GDALDataset* v = GetGDALDriverManager()->GetDriverByName("VRT")->CreateCopy(
      vrt.c_str(), src, FALSE, nullptr, nullptr, nullptr);
  ASSERT_NE(v, nullptr);
  GDALClose(v);
  GDALClose(src);
  const auto tif = FixesThrough(Map().path);
  const auto through_vrt = FixesThrough(vrt);
  ASSERT_EQ(through_vrt.size(), tif.size());
  for (std::size_t i = 0; i < tif.size(); ++i) {
    ASSERT_TRUE(tif[i].has_value()) << "frame " << i;
    ASSERT_TRUE(through_vrt[i].has_value()) << "frame " << i;
    ASSERT_TRUE(tif[i]->gps_error_m && through_vrt[i]->gps_error_m);
    EXPECT_LT(*tif[i]->gps_error_m, 0.05) << "frame " << i;
    EXPECT_EQ(through_vrt[i]->geo->lat_deg, tif[i]->geo->lat_deg) << "frame " << i;
    EXPECT_EQ(through_vrt[i]->geo->lon_deg, tif[i]->geo->lon_deg) << "frame " << i;
    EXPECT_EQ(through_vrt[i]->fix.inliers, tif[i]->fix.inliers) << "frame " << i;
  }
}

TEST(MapFixerFormats, MbtilesInWebMercatorGivesFixesOnTheTruth) {
  GDALDataset* src = OpenRaster(Map().path);
  ASSERT_NE(src, nullptr);
  OGRSpatialReference web_mercator;
  web_mercator.importFromEPSG(3857);
  char* wkt = nullptr;
  web_mercator.exportToWkt(&wkt);
  // Bilinear, as a tile server resamples; 0.125 px of error allowed in the approximation.
  GDALDatasetH warped = GDALAutoCreateWarpedVRT(src, nullptr, wkt, GRA_Bilinear, 0.125, nullptr);
  CPLFree(wkt);
  ASSERT_NE(warped, nullptr);
  const fs::path mbtiles = Map().path.parent_path() / "map.mbtiles";
  GDALDataset* mb = GetGDALDriverManager()->GetDriverByName("MBTiles")->CreateCopy(
      mbtiles.c_str(), GDALDataset::FromHandle(warped), FALSE, nullptr, nullptr, nullptr);
  ASSERT_NE(mb, nullptr);
  // The zoom level nearest the source's 0.71 m (0.5 m / cos 45 deg) Web Mercator pixels: 18,
  // 0.597 m per Web Mercator pixel, 0.42 m on the ground at 45 N.
  double gt[6];
  ASSERT_EQ(mb->GetGeoTransform(gt), CE_None);
  EXPECT_NEAR(gt[1], 0.597, 0.001);
  GDALClose(mb);
  GDALClose(warped);
  GDALClose(src);
  const auto fixes = FixesThrough(mbtiles);
  for (std::size_t i = 0; i < fixes.size(); ++i) {
    ASSERT_TRUE(fixes[i].has_value()) << "frame " << i;
    ASSERT_TRUE(fixes[i]->gps_error_m.has_value());
    // Two resamplings (to the tiles, then to the frame's scale) of 0.5 m pixels: within a
    // fifth of a map pixel (measured 0.6-0.9 cm, as through the GeoTIFF: 0.5-1.3 cm).
    EXPECT_LT(*fixes[i]->gps_error_m, 0.1) << "frame " << i;
  }
}

}  // namespace
}  // namespace aerovo::run_steps::map_fixer_formats_test
