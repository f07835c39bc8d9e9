// ReferenceMaps (reference_map.h) on GeoTIFFs written here whose every pixel is known: a smooth
// pattern of the UTM coordinates, so that a window's pixel can be predicted from its position
// alone (east/north of the window's centre -> WGS84 by geo/local_enu.h -> UTM by GeographicLib),
// independently of the code under test; an RGBA map half transparent; two maps side by side.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <GeographicLib/UTMUPS.hpp>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/reference_map.h"

namespace aerovo::map::reference_map_test {
namespace {

namespace fs = std::filesystem;

fs::path Dir() {
  static const fs::path dir = aerovo::testing::FreshTempDir("aerovo_map", "windows");
  return dir;
}

// The pattern at UTM (x, y) metres, 38..218 DN: wavelengths 47 m east, 61 m north.
double Pattern(double x, double y) {
  return 128.0 + 90.0 * std::sin(2 * M_PI * x / 47.0) * std::cos(2 * M_PI * y / 61.0);
}

// A `size` x `size` px map of `m` m/px in UTM 17N, west `x0`, north `y0`; RGBA when `alpha_west`
// (the western half transparent), else grey; overviews 2, 4, 8.
fs::path WriteMap(const std::string& name, double x0, double y0, double m, int size,
                  bool alpha_west = false) {
  GDALAllRegister();
  const fs::path p = Dir() / name;
  const int bands = alpha_west ? 4 : 1;
  char** opts = nullptr;
  if (alpha_west) opts = CSLSetNameValue(opts, "ALPHA", "YES");
  GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
      p.c_str(), size, size, bands, GDT_Byte, opts);
  CSLDestroy(opts);
  std::vector<unsigned char> px(static_cast<std::size_t>(size) * size);
  for (int b = 1; b <= bands; ++b) {
    for (int r = 0; r < size; ++r) {
      for (int c = 0; c < size; ++c) {
        const double v = Pattern(x0 + (c + 0.5) * m, y0 - (r + 0.5) * m);
        // RGB: the same grey in each (luma = grey); alpha 0 on the western half.
        px[static_cast<std::size_t>(r) * size + c] =
            static_cast<unsigned char>(b == 4 ? (c < size / 2 ? 0 : 255) : std::lround(v));
      }
    }
    EXPECT_EQ(ds->GetRasterBand(b)->RasterIO(GF_Write, 0, 0, size, size, px.data(), size, size,
                                             GDT_Byte, 0, 0, nullptr),
              CE_None);
  }
  if (alpha_west) ds->GetRasterBand(4)->SetColorInterpretation(GCI_AlphaBand);
  double gt[6] = {x0, m, 0.0, y0, 0.0, -m};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.importFromEPSG(32617);
  ds->SetSpatialRef(&srs);
  int levels[3] = {2, 4, 8};
  ds->BuildOverviews("AVERAGE", 3, levels, 0, nullptr, nullptr, nullptr);
  GDALClose(ds);
  return p;
}

GeoPoint Wgs84(double x, double y) {
  double lat = 0, lon = 0;
  GeographicLib::UTMUPS::Reverse(17, true, x, y, lat, lon);
  return {lat, lon, 0.0};
}

// Largest and mean |window - pattern| over the valid pixels.
void ExpectPattern(const MapWindow& w, double max_dn, double mean_dn) {
  const LocalEnu enu(w.centre);
  const double h = 0.5 * (w.pixels.width() - 1);
  double worst = 0, sum = 0;
  int n = 0;
  for (int y = 0; y < w.pixels.height(); ++y) {
    for (int x = 0; x < w.pixels.width(); ++x) {
      if (!w.valid.at(x, y)) continue;
      const GeoPoint g = enu.Reverse((x - h) * w.m_per_px, (h - y) * w.m_per_px, 0.0);
      double ux = 0, uy = 0, gamma = 0, k = 0;
      int zone = 0;
      bool north = true;
      GeographicLib::UTMUPS::Forward(g.lat_deg, g.lon_deg, zone, north, ux, uy, gamma, k, 17);
      const double d = std::abs(w.pixels.at(x, y) - Pattern(ux, uy));
      worst = std::max(worst, d);
      sum += d;
      ++n;
    }
  }
  ASSERT_GT(n, 0);
  EXPECT_LE(worst, max_dn);
  EXPECT_LE(sum / n, mean_dn);
}

// 1000 x 1000 px of 0.5 m from (356000, 3102000): a 500 m square.
const fs::path& GreyMap() {
  static const fs::path p = WriteMap("grey.tif", 356000.0, 3102000.0, 0.5, 1000);
  return p;
}

TEST(ReferenceMaps, WindowIsTheMapAroundThePointAtTheResolutionAsked) {
  const ReferenceMaps maps({GreyMap()});
  const GeoPoint centre = Wgs84(356250.0, 3101750.0);
  // 1 m/px (the map's 0.5 m averaged 2 x 2), 121 m square; the UTM grid is turned 1.4 degrees
  // from true north there, which the window undoes.
  const auto w = maps.Window(centre, 121, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(w->map_index, 0);
  EXPECT_DOUBLE_EQ(w->valid_fraction, 1.0);
  ExpectPattern(*w, 3.0, 0.8);
  // 4 m/px: from the overviews (averaged 8 x 8 map pixels: the 47 m wave loses 1 %).
  const auto coarse = maps.Window(centre, 101, 4.0);
  ASSERT_TRUE(coarse.has_value());
  ExpectPattern(*coarse, 5.0, 1.5);
}

TEST(ReferenceMaps, TransparentPixelsAreNotMapAndTheFirstMapWins) {
  // RGBA, west half transparent, 200 m square at 1 m/px east of the grey map: a window on its
  // middle is half valid; one on the grey map comes from the grey map (given first).
  const fs::path rgba = WriteMap("rgba.tif", 356500.0, 3102000.0, 1.0, 200, true);
  const ReferenceMaps maps({GreyMap(), rgba});
  EXPECT_EQ(maps.infos().size(), 2u);
  const auto half = maps.Window(Wgs84(356600.0, 3101900.0), 81, 1.0);
  ASSERT_TRUE(half.has_value());
  EXPECT_EQ(half->map_index, 1);
  EXPECT_NEAR(half->valid_fraction, 0.5, 0.05);
  ExpectPattern(*half, 3.0, 1.0);
  const auto first = maps.Window(Wgs84(356400.0, 3101900.0), 41, 1.0);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->map_index, 0);
  EXPECT_FALSE(maps.Window(Wgs84(358000.0, 3101900.0), 41, 1.0).has_value());
  EXPECT_THROW(maps.Window(Wgs84(356400.0, 3101900.0), 1, 1.0), InvalidArgument);
  EXPECT_THROW(maps.Window(Wgs84(356400.0, 3101900.0), 41, 0.0), InvalidArgument);
}

TEST(ReferenceMaps, AWindowThePreferredMapCoversInPartIsFilledFromTheNext) {
  // A 400 m square at 2 m/px from x = 356400, overlapping the grey map's east 100 m: a 101 m
  // window centred on the grey map's east edge (x = 356500) takes its west half from the grey map
  // given first and its east half from the other; given the other way round, the coarser map
  // wins wherever it has data. Both draw the same pattern: the window is the pattern throughout.
  const fs::path east = WriteMap("east.tif", 356400.0, 3102000.0, 2.0, 200);
  const GeoPoint edge = Wgs84(356500.0, 3101800.0);
  const ReferenceMaps maps({GreyMap(), east});
  const auto w = maps.Window(edge, 101, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_DOUBLE_EQ(w->valid_fraction, 1.0);
  ASSERT_EQ(w->pixels_from_map.size(), 2u);
  EXPECT_NEAR(w->pixels_from_map[0], 101 * 50.5, 101 * 2);  // west of the edge (1.4 deg grid turn)
  EXPECT_EQ(w->pixels_from_map[0] + w->pixels_from_map[1], 101 * 101);
  ExpectPattern(*w, 6.0, 1.5);
  EXPECT_EQ(maps.MapAt(Wgs84(356450.0, 3101800.0)), 0);
  EXPECT_EQ(maps.MapAt(Wgs84(356550.0, 3101800.0)), 1);
  EXPECT_EQ(maps.MapAt(Wgs84(357000.0, 3101800.0)), std::nullopt);
  const ReferenceMaps reversed({east, GreyMap()});
  const auto r = reversed.Window(edge, 101, 1.0);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->pixels_from_map[0], 101 * 101);
  EXPECT_EQ(r->pixels_from_map[1], 0);
  EXPECT_EQ(r->map_index, 0);
  EXPECT_EQ(reversed.MapAt(Wgs84(356450.0, 3101800.0)), 0);
  EXPECT_EQ(reversed.MapAt(Wgs84(356300.0, 3101800.0)), 1);
  // Neither covers all of a window west of the square: filled as far as they reach.
  const auto west = maps.Window(Wgs84(356010.0, 3101800.0), 41, 1.0);
  ASSERT_TRUE(west.has_value());
  EXPECT_NEAR(west->valid_fraction, 30.5 / 41.0, 0.05);
}

TEST(ReferenceMaps, CoverOfTheFlightIsAnErrorOrAWarningNamingTheMaps) {
  const ReferenceMaps maps({GreyMap()});
  const std::vector<GeoPoint> inside{Wgs84(356100, 3101900), Wgs84(356400, 3101600)};
  EXPECT_EQ(CheckCover(maps, inside), "");
  std::vector<GeoPoint> partial = inside;
  partial.push_back(Wgs84(357000, 3101600));
  const std::string w = CheckCover(maps, partial);
  EXPECT_NE(w.find("'" + GreyMap().string() + "': the map covers 2 of the flight's 3 positions"),
            std::string::npos)
      << w;
  try {
    CheckCover(maps, {Wgs84(357000, 3101600)});
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(GreyMap().string()), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReferenceMaps({Dir() / "missing.tif"}), InputError);
  EXPECT_THROW(ReferenceMaps({}), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::map::reference_map_test
