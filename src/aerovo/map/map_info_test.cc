// ReadMapInfo (map_info.h) on rasters written here with GDAL, whose extent, CRS and resolution are
// known: a UTM GeoTIFF with overviews, a geographic one, a VRT over a tile, an MBTiles file, and
// the bad maps (missing, corrupt, no CRS, no geotransform) whose errors must name the file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <GeographicLib/UTMUPS.hpp>
#include <cpl_string.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/map/map_info.h"

namespace aerovo::map::map_info_test {
namespace {

namespace fs = std::filesystem;

fs::path Dir() {
  static const fs::path dir = aerovo::testing::FreshTempDir("aerovo_map", "info");
  return dir;
}

// A w x h single-band GTiff (a gradient) at `path`; `epsg` 0: no CRS; `gt` null: no geotransform.
void WriteTiff(const fs::path& path, int w, int h, int epsg, const double* gt,
               const std::vector<int>& overviews = {}) {
  GDALAllRegister();
  GDALDriver* d = GetGDALDriverManager()->GetDriverByName("GTiff");
  GDALDataset* ds = d->Create(path.c_str(), w, h, 1, GDT_Byte, nullptr);
  ASSERT_NE(ds, nullptr);
  std::vector<unsigned char> px(static_cast<std::size_t>(w) * h);
  for (int i = 0; i < w * h; ++i) px[static_cast<std::size_t>(i)] = static_cast<unsigned char>(i % 251);
  ASSERT_EQ(ds->RasterIO(GF_Write, 0, 0, w, h, px.data(), w, h, GDT_Byte, 1, nullptr, 0, 0, 0,
                         nullptr),
            CE_None);
  if (gt != nullptr) ds->SetGeoTransform(const_cast<double*>(gt));
  if (epsg != 0) {
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromEPSG(epsg), OGRERR_NONE);
    ds->SetSpatialRef(&srs);
  }
  if (!overviews.empty()) {
    ASSERT_EQ(ds->BuildOverviews("AVERAGE", static_cast<int>(overviews.size()), overviews.data(),
                                 0, nullptr, nullptr, nullptr),
              CE_None);
  }
  GDALClose(ds);
}

// UTM zone 17N, 400 x 200 px of 0.5 m, west 356000 m, north 3102000 m (Tampa).
constexpr double kUtmGt[6] = {356000.0, 0.5, 0.0, 3102000.0, 0.0, -0.5};

TEST(MapInfo, UtmGeoTiffWithOverviews) {
  const fs::path p = Dir() / "utm.tif";
  WriteTiff(p, 400, 200, 32617, kUtmGt, {2, 4});
  const MapInfo m = ReadMapInfo(p);
  EXPECT_EQ(m.driver, "GTiff");
  EXPECT_EQ(m.width_px, 400);
  EXPECT_EQ(m.height_px, 200);
  ASSERT_TRUE(m.epsg.has_value());
  EXPECT_EQ(*m.epsg, 32617);
  EXPECT_FALSE(m.crs_geographic);
  EXPECT_NE(m.crs_name.find("UTM zone 17N"), std::string::npos) << m.crs_name;
  EXPECT_DOUBLE_EQ(m.m_per_px_x, 0.5);
  EXPECT_DOUBLE_EQ(m.m_per_px_y, 0.5);
  EXPECT_DOUBLE_EQ(m.extent_crs.min_x, 356000.0);
  EXPECT_DOUBLE_EQ(m.extent_crs.max_x, 356200.0);
  EXPECT_DOUBLE_EQ(m.extent_crs.min_y, 3101900.0);
  EXPECT_DOUBLE_EQ(m.extent_crs.max_y, 3102000.0);
  ASSERT_EQ(m.overviews.size(), 2u);
  EXPECT_EQ(m.overviews[0], std::make_pair(200, 100));
  EXPECT_EQ(m.overviews[1], std::make_pair(100, 50));
  // The WGS84 bounds: the corners by GeographicLib (the UTM edges are nearly straight in degrees
  // over 200 m: within 1e-7 deg, 1 cm).
  double lat = 0, lon = 0, lat_min = 90, lat_max = -90, lon_min = 180, lon_max = -180;
  for (const double x : {356000.0, 356200.0}) {
    for (const double y : {3101900.0, 3102000.0}) {
      GeographicLib::UTMUPS::Reverse(17, true, x, y, lat, lon);
      lat_min = std::min(lat_min, lat);
      lat_max = std::max(lat_max, lat);
      lon_min = std::min(lon_min, lon);
      lon_max = std::max(lon_max, lon);
    }
  }
  EXPECT_NEAR(m.extent_lonlat.min_x, lon_min, 1e-7);
  EXPECT_NEAR(m.extent_lonlat.max_x, lon_max, 1e-7);
  EXPECT_NEAR(m.extent_lonlat.min_y, lat_min, 1e-7);
  EXPECT_NEAR(m.extent_lonlat.max_y, lat_max, 1e-7);
  const std::string text = FormatMapInfo(m);
  EXPECT_NE(text.find("(EPSG:32617), projected"), std::string::npos) << text;
  EXPECT_NE(text.find("0.5000 x 0.5000 m/px"), std::string::npos) << text;
  EXPECT_NE(text.find("overviews    200x100, 100x50"), std::string::npos) << text;
  EXPECT_EQ(ToJson(m).at("overviews").size(), 2u);
}

TEST(MapInfo, GeographicMapHasItsResolutionInMetres) {
  // 1e-5 deg pixels at 28 N: 1.1132 m of latitude... by the geodesic; longitude times cos(28).
  const fs::path p = Dir() / "wgs84.tif";
  const double gt[6] = {-82.70, 1e-5, 0.0, 28.05, 0.0, -1e-5};
  WriteTiff(p, 300, 300, 4326, gt);
  const MapInfo m = ReadMapInfo(p);
  EXPECT_TRUE(m.crs_geographic);
  EXPECT_EQ(m.crs_units, "degree");
  EXPECT_NEAR(m.m_per_px_y, 1.1086, 0.002);  // meridian arc of 1e-5 deg at 28 N
  EXPECT_NEAR(m.m_per_px_x,
              1e-5 * kDegToRad * 6378137.0 * std::cos(28.0485 * kDegToRad) /
                  std::sqrt(1.0 - 0.00669438 * std::pow(std::sin(28.0485 * kDegToRad), 2)),
              1e-4);
  EXPECT_NEAR(m.extent_lonlat.min_x, -82.70, 1e-9);
  EXPECT_NEAR(m.extent_lonlat.max_x, -82.697, 1e-9);
  EXPECT_NEAR(m.extent_lonlat.min_y, 28.047, 1e-9);
  EXPECT_TRUE(m.overviews.empty());
}

TEST(MapInfo, WebMercatorMapHasItsGroundResolution) {
  // EPSG:3857 pixels of 2 "metres" at 28.05 N: 2 cos(lat) m on the ground (the projection's
  // scale is 1 / cos(lat) on the sphere; the ellipsoid's geodesic within 0.5 %).
  const fs::path p = Dir() / "web_mercator.tif";
  const double gt[6] = {-9205000.0, 2.0, 0.0, 3257000.0, 0.0, -2.0};
  WriteTiff(p, 256, 256, 3857, gt);
  const MapInfo m = ReadMapInfo(p);
  EXPECT_FALSE(m.crs_geographic);
  const double lat = 0.5 * (m.extent_lonlat.min_y + m.extent_lonlat.max_y) * kDegToRad;
  EXPECT_NEAR(m.m_per_px_x, 2.0 * std::cos(lat), 0.005 * 2.0);
  EXPECT_NEAR(m.m_per_px_y, 2.0 * std::cos(lat), 0.005 * 2.0);
  // A UTM map keeps its grid's metres (UtmGeoTiffWithOverviews).
}

TEST(MapInfo, VrtAndMbtilesAreMapsToo) {
  const fs::path tif = Dir() / "tile.tif";
  WriteTiff(tif, 400, 200, 32617, kUtmGt);
  GDALDataset* src = static_cast<GDALDataset*>(GDALOpen(tif.c_str(), GA_ReadOnly));
  ASSERT_NE(src, nullptr);
  const fs::path vrt = Dir() / "tiles.vrt";
  GDALDataset* v = GetGDALDriverManager()->GetDriverByName("VRT")->CreateCopy(
      vrt.c_str(), src, FALSE, nullptr, nullptr, nullptr);
  ASSERT_NE(v, nullptr);
  GDALClose(v);
  GDALClose(src);
  const MapInfo mv = ReadMapInfo(vrt);
  EXPECT_EQ(mv.driver, "VRT");
  EXPECT_DOUBLE_EQ(mv.extent_crs.max_x, 356200.0);
  // MBTiles: Web Mercator, written by GDAL's driver from a raster in EPSG:3857.
  const fs::path merc = Dir() / "merc.tif";
  const double gt[6] = {-9205000.0, 2.0, 0.0, 3257000.0, 0.0, -2.0};
  WriteTiff(merc, 256, 256, 3857, gt);
  src = static_cast<GDALDataset*>(GDALOpen(merc.c_str(), GA_ReadOnly));
  ASSERT_NE(src, nullptr);
  const fs::path mbtiles = Dir() / "map.mbtiles";
  GDALDataset* mb = GetGDALDriverManager()->GetDriverByName("MBTiles")->CreateCopy(
      mbtiles.c_str(), src, FALSE, nullptr, nullptr, nullptr);
  GDALClose(src);
  ASSERT_NE(mb, nullptr);
  GDALClose(mb);
  const MapInfo mm = ReadMapInfo(mbtiles);
  EXPECT_EQ(mm.driver, "MBTiles");
  ASSERT_TRUE(mm.epsg.has_value());
  EXPECT_EQ(*mm.epsg, 3857);
  // The source's 512 m square, resampled to the zoom level's pixels (2.39 m at zoom 16): its
  // edges within a few pixels.
  EXPECT_NEAR(mm.extent_crs.min_x, -9205000.0, 10.0);
  EXPECT_NEAR(mm.extent_crs.max_x, -9205000.0 + 512.0, 10.0);
  EXPECT_NEAR(mm.extent_crs.max_y, 3257000.0, 10.0);
  EXPECT_GT(mm.m_per_px_x, 0.5);
  EXPECT_LT(mm.m_per_px_x, 4.0);
}

void ExpectError(const fs::path& p, const std::string& says) {
  try {
    ReadMapInfo(p);
    ADD_FAILURE() << p << ": no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'" + p.string() + "'"), std::string::npos) << m;
    EXPECT_NE(m.find(says), std::string::npos) << m;
  }
}

TEST(MapInfo, BadMapsAreErrorsNamingTheFile) {
  ExpectError(Dir() / "nowhere.tif", "no such map file");
  const fs::path corrupt = Dir() / "corrupt.tif";
  std::ofstream(corrupt) << "II*\0 this is not a TIFF";
  ExpectError(corrupt, "not a raster GDAL can read");
  const fs::path no_crs = Dir() / "no_crs.tif";
  WriteTiff(no_crs, 64, 64, 0, kUtmGt);
  ExpectError(no_crs, "no coordinate reference system");
  const fs::path no_gt = Dir() / "no_gt.tif";
  WriteTiff(no_gt, 64, 64, 32617, nullptr);
  ExpectError(no_gt, "no geotransform");
  ExpectError(Dir(), "a folder, not a map file");
}

TEST(MapInfo, AGeotransformOffTheEarthIsAnErrorNamingTheFile) {
  // UTM metres written into a WGS84 (degree) map: 0.5 "degree" pixels from latitude 3102000.
  const fs::path metres = Dir() / "metres_in_degrees.tif";
  WriteTiff(metres, 64, 64, 4326, kUtmGt);
  ExpectError(metres, "outside -90 .. 90");
  // Pixels of 1e10 degrees from 49.8 N: the south edge at -6.4e11 deg. Before: GeodesicInverse's
  // own error, naming no file.
  const fs::path huge_px = Dir() / "huge_pixels.tif";
  const double gt[6] = {24.0, 1e10, 0.0, 49.8, 0.0, -1e10};
  WriteTiff(huge_px, 64, 64, 4326, gt);
  ExpectError(huge_px, "latitude -6.4e+11 .. 49.8 deg, outside -90 .. 90");
  // A Pseudo-Mercator origin 1.4e160 m west (a fuzzed tie point): PROJ's inverse did not return
  // in minutes. Refused before PROJ sees it, as is a longitude of 1e6 degrees.
  const fs::path far_x = Dir() / "far_mercator.tif";
  const double far_gt[6] = {-1.38e160, 1.0, 0.0, 3.2e6, 0.0, -1.0};
  WriteTiff(far_x, 16, 16, 3857, far_gt);
  ExpectError(far_x, "more than 1e+08 m from its CRS's origin: no place on the earth");
  const fs::path far_y = Dir() / "far_utm_north.tif";
  const double far_north[6] = {356000.0, 0.5, 0.0, 3.1e9, 0.0, -0.5};
  WriteTiff(far_y, 16, 16, 32617, far_north);
  ExpectError(far_y, "y 3.1e+09 .. 3.1e+09 metre, more than 1e+08 m");
  const fs::path far_lon = Dir() / "far_longitude.tif";
  const double far_lon_gt[6] = {1e6, 1e-5, 0.0, 45.0, 0.0, -1e-5};
  WriteTiff(far_lon, 16, 16, 4326, far_lon_gt);
  ExpectError(far_lon, "more than 1000 degrees from its CRS's origin");
  // South-up (positive row size) and a rotated map are maps, the same ground as north-up.
  const double south_up[6] = {-82.70, 1e-5, 0.0, 28.047, 0.0, 1e-5};
  const fs::path sp = Dir() / "south_up.tif";
  WriteTiff(sp, 300, 300, 4326, south_up);
  const MapInfo s = ReadMapInfo(sp);
  EXPECT_NEAR(s.extent_lonlat.min_y, 28.047, 1e-9);
  EXPECT_NEAR(s.extent_lonlat.max_y, 28.050, 1e-9);
  EXPECT_NEAR(s.m_per_px_y, 1.1086, 0.002);
  EXPECT_FALSE(s.rotated);
}

}  // namespace
}  // namespace aerovo::map::map_info_test
