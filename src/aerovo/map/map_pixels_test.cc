// map_pixels.h through ReferenceMaps and ReadMapInfo, on maps written here: the same smooth
// texture as 8-bit, 16-bit, floating-point (with a not-a-number corner) and palette samples
// gives the same window up to the 16-bit and float maps' stretch (a straight line, fitted);
// maps whose pixels cannot be read, or hold no valid one, are errors naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/map_info.h"
#include "aerovo/map/map_pixels.h"
#include "aerovo/map/reference_map.h"

namespace aerovo::map::map_pixels_test {
namespace {

namespace fs = std::filesystem;

fs::path Dir() {
  static const fs::path dir = aerovo::testing::FreshTempDir("aerovo_map", "pixels");
  return dir;
}

constexpr int kSize = 400;
constexpr double kLat0 = 45.0, kLon0 = 7.0, kMpp = 0.5;

// The texture at pixel (c, r), 40..216: two waves, 23 and 31 px long.
double Texture(int c, int r) {
  return 128.0 + 88.0 * std::sin(2 * M_PI * c / 23.0) * std::cos(2 * M_PI * r / 31.0);
}

// A kSize x kSize map of 0.5 m px (transverse Mercator centred on its north-west corner) of
// samples `type`, each Texture * gain + offset; NaN on the 40 x 40 px north-west corner when
// `nan_corner` (float types); a palette inverting grey (index i is the grey 255 - i) when
// `inverting_palette` (Byte). Overviews 2 and 4 when `overviews`.
fs::path WriteMap(const std::string& name, GDALDataType type, double gain, double offset,
                  bool nan_corner = false, bool inverting_palette = false, bool overviews = true) {
  GDALAllRegister();
  const fs::path p = Dir() / name;
  char** opts = CSLSetNameValue(nullptr, "TILED", "YES");
  GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(p.c_str(), kSize,
                                                                             kSize, 1, type, opts);
  CSLDestroy(opts);
  std::vector<double> px(static_cast<std::size_t>(kSize) * kSize);
  for (int r = 0; r < kSize; ++r) {
    for (int c = 0; c < kSize; ++c) {
      double v = std::round(Texture(c, r)) * gain + offset;
      if (inverting_palette) v = 255.0 - v;  // the index of the grey wanted
      if (nan_corner && r < 40 && c < 40) v = std::numeric_limits<double>::quiet_NaN();
      px[static_cast<std::size_t>(r) * kSize + c] = v;
    }
  }
  GDALRasterBand* band = ds->GetRasterBand(1);
  EXPECT_EQ(band->RasterIO(GF_Write, 0, 0, kSize, kSize, px.data(), kSize, kSize, GDT_Float64, 0, 0,
                           nullptr),
            CE_None);
  if (inverting_palette) {
    GDALColorTable table;
    for (int i = 0; i < 256; ++i) {
      const GDALColorEntry e{static_cast<short>(255 - i), static_cast<short>(255 - i),
                             static_cast<short>(255 - i), 255};
      table.SetColorEntry(i, &e);
    }
    band->SetColorTable(&table);
    band->SetColorInterpretation(GCI_PaletteIndex);
  }
  double gt[6] = {0.0, kMpp, 0.0, 0.0, 0.0, -kMpp};
  ds->SetGeoTransform(gt);
  OGRSpatialReference srs;
  srs.importFromProj4("+proj=tmerc +lat_0=45 +lon_0=7 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m");
  ds->SetSpatialRef(&srs);
  int levels[2] = {2, 4};
  if (overviews) ds->BuildOverviews("AVERAGE", 2, levels, 0, nullptr, nullptr, nullptr);
  GDALClose(ds);
  return p;
}

// The WGS84 point at map pixel (c, r) (corner coordinates).
GeoPoint At(double c, double r) {
  return LocalEnu(kLat0, kLon0, 0.0).Reverse(c * kMpp, -r * kMpp, 0.0);
}

// The least-squares line b = slope a + intercept over the pixels valid in both windows and not
// clipped in b (0 or 255), and the largest distance of such a pixel from it; `n` the pixels
// compared, `clipped` those left out.
struct Line {
  double slope = 0, intercept = 0, worst = 0, rms = 0;
  int n = 0, clipped = 0;
};
Line Fit(const MapWindow& a, const MapWindow& b) {
  double sa = 0, sb = 0, saa = 0, sab = 0;
  Line l;
  for (int y = 0; y < a.pixels.height(); ++y) {
    for (int x = 0; x < a.pixels.width(); ++x) {
      if (!a.valid.at(x, y) || !b.valid.at(x, y)) continue;
      const double u = a.pixels.at(x, y), v = b.pixels.at(x, y);
      if (v == 0 || v == 255) {
        ++l.clipped;
        continue;
      }
      sa += u, sb += v, saa += u * u, sab += u * v, ++l.n;
    }
  }
  l.slope = (l.n * sab - sa * sb) / (l.n * saa - sa * sa);
  l.intercept = (sb - l.slope * sa) / l.n;
  for (int y = 0; y < a.pixels.height(); ++y) {
    for (int x = 0; x < a.pixels.width(); ++x) {
      if (!a.valid.at(x, y) || !b.valid.at(x, y) || b.pixels.at(x, y) == 0 ||
          b.pixels.at(x, y) == 255) {
        continue;
      }
      l.worst = std::max(l.worst,
                         std::abs(b.pixels.at(x, y) - (l.slope * a.pixels.at(x, y) + l.intercept)));
    }
  }
  return l;
}

MapWindow WindowOf(const fs::path& map, double c, double r, double m_per_px) {
  const ReferenceMaps maps({map});
  auto w = maps.Window(At(c, r), 101, m_per_px);
  EXPECT_TRUE(w.has_value());
  return w ? *w : MapWindow{};
}

TEST(MapPixels, SixteenBitAndFloatMapsAreStretchedBetweenTheirOwnPercentiles) {
  const fs::path byte = WriteMap("byte.tif", GDT_Byte, 1.0, 0.0);
  const fs::path u16 = WriteMap("u16.tif", GDT_UInt16, 200.0, 1000.0);
  const fs::path f32 = WriteMap("f32.tif", GDT_Float32, 1.0 / 255.0, -0.2, /*nan_corner=*/true);
  EXPECT_EQ(ReadMapInfo(byte).radiometry.sample_type, "Byte");
  EXPECT_EQ(ReadMapInfo(byte).radiometry.lo, 0.0);
  EXPECT_EQ(ReadMapInfo(byte).radiometry.hi, 255.0);
  // The texture's 1st and 99th percentiles (of its coarsest overview, averaged 4 x 4): about
  // 50 and 206 grey, i.e. 11000 and 42200 in the 16-bit map.
  const MapRadiometry r16 = ReadMapInfo(u16).radiometry;
  EXPECT_EQ(r16.sample_type, "UInt16");
  EXPECT_NEAR(r16.lo, 1000.0 + 200.0 * 50.0, 200.0 * 8.0);
  EXPECT_NEAR(r16.hi, 1000.0 + 200.0 * 206.0, 200.0 * 8.0);
  EXPECT_EQ(ReadMapInfo(f32).radiometry.sample_type, "Float32");
  // Full resolution (0.5 m) and from the overview of 2 (1 m), away from the NaN corner.
  for (const double m : {0.5, 1.0}) {
    const MapWindow w8 = WindowOf(byte, 200, 200, m);
    for (const fs::path& p : {u16, f32}) {
      SCOPED_TRACE(p.filename().string() + " at " + std::to_string(m) + " m/px");
      const MapWindow w = WindowOf(p, 200, 200, m);
      const Line l = Fit(w8, w);
      EXPECT_EQ(l.n + l.clipped, 101 * 101);
      // The stretch of the 1st-99th percentiles (about 50-206) to 0-255: a slope of about 1.6;
      // the pixels beyond the percentiles clipped (a few %), the rest on the line within the
      // two windows' rounding (RMS), and within 3 grey where the bilinear sampling mixes in a
      // clipped neighbour.
      EXPECT_LT(l.clipped, 101 * 101 / 20);
      EXPECT_NEAR(l.slope, 255.0 / 156.0, 0.1);
      EXPECT_LE(l.rms, 0.5 * l.slope + 0.5);
      EXPECT_LE(l.worst, 3.0 * l.slope);
    }
  }
  // A window over the NaN corner: window pixel i is map pixel 10 + i (0.5 m each); the corner's
  // 30 x 30 of them (map pixels 10-39) are not map, within the bilinear sampling's pixel.
  const MapWindow corner = WindowOf(f32, 60, 60, 0.5);
  int valid = 0;
  for (int y = 0; y < 101; ++y) {
    for (int x = 0; x < 101; ++x) valid += corner.valid.at(x, y) != 0;
  }
  EXPECT_GE(valid, 101 * 101 - 32 * 32);
  EXPECT_LE(valid, 101 * 101 - 28 * 28);
}

// A map 4 times finer than the texture (each texture pixel 4 x 4 pixels of 0.125 m) without
// overviews, read for 0.5 m samples: 4 x 4 blocks averaged as they are read (ReadGreyBlock),
// each sample exactly one texture pixel, and a quarter of the samples a side that a read at full
// resolution would hold (16 times fewer in all; before, such a map made a window's read 16
// times larger, e.g. 1 GB for tampa's map made 4 times finer).
TEST(MapPixels, AFineMapWithoutOverviewsIsReadAveragedAsAnOverviewWouldBe) {
  const fs::path fine = Dir() / "fine.tif";
  GDALAllRegister();
  {
    const int n = 4 * kSize;
    GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        fine.c_str(), n, n, 1, GDT_Byte, nullptr);
    ASSERT_NE(ds, nullptr);
    std::vector<unsigned char> px(static_cast<std::size_t>(n) * n);
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        px[static_cast<std::size_t>(r) * n + c] =
            static_cast<unsigned char>(std::lround(Texture(c / 4, r / 4)));
      }
    }
    ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, n, n, px.data(), n, n, GDT_Byte, 0, 0,
                                             nullptr),
              CE_None);
    double gt[6] = {0.0, kMpp / 4, 0.0, 0.0, 0.0, -kMpp / 4};
    ds->SetGeoTransform(gt);
    OGRSpatialReference srs;
    srs.importFromProj4("+proj=tmerc +lat_0=45 +lon_0=7 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m");
    ds->SetSpatialRef(&srs);
    GDALClose(ds);
  }
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(fine.c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  GreyBlock b;
  ASSERT_TRUE(ReadGreyBlock(*ds, fine, ReadMapInfo(fine).radiometry, 400, 400, 800, 800, 4.0, &b));
  GDALClose(ds);
  EXPECT_EQ(b.dx, 4.0);
  EXPECT_EQ(b.x0, 396.0);       // one sample of margin, on the grid of 4
  EXPECT_EQ(b.w, 400 / 4 + 2);  // 102 samples a side for 400 pixels, not 402
  EXPECT_EQ(b.h, 400 / 4 + 2);
  int wrong = 0;
  for (int j = 0; j < b.h; ++j) {
    for (int i = 0; i < b.w; ++i) {
      const float want = static_cast<float>(std::lround(Texture(99 + i, 99 + j)));
      wrong += std::abs(b.grey[static_cast<std::size_t>(j) * b.w + i] - want) > 0.01f;
    }
  }
  EXPECT_EQ(wrong, 0);
  // A window of it: the 0.5 m map's.
  const Line l =
      Fit(WindowOf(WriteMap("coarse.tif", GDT_Byte, 1.0, 0.0, false, false, false), 200, 200, 0.5),
          WindowOf(fine, 200, 200, 0.5));
  EXPECT_NEAR(l.slope, 1.0, 1e-3);
  EXPECT_LE(l.worst, 1.0);
}

TEST(MapPixels, AHugeMapWithoutOverviewsFinerThanTheWindowIsAnErrorNotMinutesOfReading) {
  // 100000 x 100000 px of 1 mm, tiled and sparse (no tile written: a few MB on disk, GDAL reads
  // the missing tiles as zeros; GDAL's GTiff driver, SPARSE_OK creation option).
  const fs::path huge = Dir() / "huge_sparse.tif";
  GDALAllRegister();
  {
    const char* options[] = {"TILED=YES", "SPARSE_OK=TRUE", nullptr};
    GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
        huge.c_str(), 100000, 100000, 1, GDT_Byte, const_cast<char**>(options));
    ASSERT_NE(ds, nullptr);
    double gt[6] = {0.0, 0.001, 0.0, 0.0, 0.0, -0.001};
    ds->SetGeoTransform(gt);
    OGRSpatialReference srs;
    srs.importFromProj4("+proj=tmerc +lat_0=45 +lon_0=7 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m");
    ds->SetSpatialRef(&srs);
    GDALClose(ds);
  }
  const MapInfo info = ReadMapInfo(huge);  // the probe reads 3 x 3 small windows: cheap
  EXPECT_TRUE(info.overviews.empty());
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(huge.c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  GreyBlock b;
  // A 60 m window at 0.5 m per sample, a sample of margin a side: (122 x 500)^2 = 3.72e9 map
  // pixels averaged.
  try {
    ReadGreyBlock(*ds, huge, info.radiometry, 20000, 20000, 80000, 80000, 500.0, &b);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'" + huge.string() +
                     "': a window at 500 map pixels per sample would read "
                     "3.72e+09 of the map's pixels"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("gdaladdo"), std::string::npos) << m;
  }
  // A window of 4 m at 0.05 m per sample (16e6 pixels) is read, zeros.
  ASSERT_TRUE(ReadGreyBlock(*ds, huge, info.radiometry, 50000, 50000, 54000, 54000, 50.0, &b));
  EXPECT_EQ(b.dx, 50.0);
  EXPECT_EQ(b.w, 4000 / 50 + 2);
  EXPECT_EQ(b.grey[0], 0.0f);
  // Pixel sizes that overflow an int in samples (1e9 map pixels per sample) are refused too,
  // or off the map: never undefined behaviour.
  EXPECT_FALSE(ReadGreyBlock(*ds, huge, info.radiometry, -1e15, -1e15, -1e14, -1e14, 1e9, &b));
  GDALClose(ds);
}

TEST(MapPixels, APaletteMapIsReadAsItsColours) {
  const fs::path byte = WriteMap("byte_ref.tif", GDT_Byte, 1.0, 0.0);
  const fs::path pal = WriteMap("palette.tif", GDT_Byte, 1.0, 0.0, false, true);
  EXPECT_TRUE(ReadMapInfo(pal).radiometry.palette);
  const Line l = Fit(WindowOf(byte, 200, 200, 0.5), WindowOf(pal, 200, 200, 0.5));
  EXPECT_NEAR(l.slope, 1.0, 1e-3);
  EXPECT_NEAR(l.intercept, 0.0, 0.2);
  EXPECT_LE(l.worst, 1.0);
}

void ExpectError(const fs::path& p, const std::string& says) {
  try {
    ReferenceMaps maps({p});
    ADD_FAILURE() << p << ": no error";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'" + p.string() + "'"), std::string::npos) << m;
    EXPECT_NE(m.find(says), std::string::npos) << m;
  }
}

TEST(MapPixels, UnreadableOrEmptyMapsAreErrorsNamingThem) {
  // A GeoTIFF cut short (its header and tile index whole, its tiles and overviews gone).
  const fs::path whole = WriteMap("whole.tif", GDT_Byte, 1.0, 0.0);
  const fs::path cut = Dir() / "cut.tif";
  {
    std::ifstream in(whole, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, 4096);
  }
  ExpectError(cut, "the map's pixels cannot be read");
  // A VRT whose source is gone.
  const fs::path src = WriteMap("source.tif", GDT_Byte, 1.0, 0.0);
  const fs::path vrt = Dir() / "over_source.vrt";
  {
    GDALDataset* s = static_cast<GDALDataset*>(GDALOpen(src.c_str(), GA_ReadOnly));
    ASSERT_NE(s, nullptr);
    GDALDataset* v = GetGDALDriverManager()->GetDriverByName("VRT")->CreateCopy(
        vrt.c_str(), s, FALSE, nullptr, nullptr, nullptr);
    ASSERT_NE(v, nullptr);
    GDALClose(v);
    GDALClose(s);
  }
  fs::remove(src);
  ExpectError(vrt, "source.tif");
  // Every pixel NaN, with and without overviews.
  ExpectError(WriteMap("nan.tif", GDT_Float32, std::numeric_limits<double>::quiet_NaN(), 0.0),
              "the map has no valid pixel");
  ExpectError(WriteMap("nan_no_ov.tif", GDT_Float32, std::numeric_limits<double>::quiet_NaN(), 0.0,
                       false, false, false),
              "the map has no valid pixel");
}

}  // namespace
}  // namespace aerovo::map::map_pixels_test
