// Test helper of pipeline/map_fixer.h and pipeline/map_tiles.h (not installed): a GeoTIFF of
// random texture (smoothed noise, full contrast; a transverse Mercator CRS centred on the map's
// north-west corner, 0.5 m/px) and frames cut from the same texture, so that each frame's true
// position is known.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/testing.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/pipeline/map_fixer.h"

namespace aerovo::run_steps::map_testing {

inline constexpr double kMpp = 0.5, kLat0 = 45.0, kLon0 = 7.0;
inline constexpr int kSize = 800;

// The texture (OpenCV's generator seeded with `seed`) and its map, in a fresh folder under the
// temporary directory named after `prefix` (removed with the object).
struct TexturedMap {
  cv::Mat grey;
  std::filesystem::path path;
  TexturedMap(std::uint64_t seed, const std::string& prefix) {
    cv::Mat noise(kSize, kSize, CV_32F);
    cv::theRNG().state = seed;
    cv::randu(noise, 0.0, 1.0);
    cv::GaussianBlur(noise, noise, cv::Size(), 2.0);
    cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
    noise.convertTo(grey, CV_8U);
    path = ::aerovo::testing::FreshTempDir(prefix, "map") / "map.tif";
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
    std::filesystem::remove_all(path.parent_path(), ec);
  }
  TexturedMap(const TexturedMap&) = delete;
  TexturedMap& operator=(const TexturedMap&) = delete;
  // The WGS84 point at map pixel centre (cx, cy) shifted `off_east_m` east.
  static GeoPoint At(double cx, double cy, double off_east_m = 0.0) {
    const LocalEnu enu(kLat0, kLon0, 0.0);
    return enu.Reverse((cx + 0.5) * kMpp + off_east_m, -(cy + 0.5) * kMpp, 0.0);
  }
  // A 240 x 180 frame whose centre is at map pixel (cx, cy) (heading 0, 0.5 m/px: focal 100 px
  // at 50 m), its true position and a prediction `off_east_m` east of it.
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
    // The frame's centre pixel (119.5, 89.5) is map pixel (cx - 0.5, cy - 0.5), whose centre is
    // at east (cx) kMpp, north -(cy) kMpp in the map's CRS (the local plane of its origin).
    const LocalEnu enu(kLat0, kLon0, 0.0);
    job.gps = enu.Reverse(cx * kMpp, -cy * kMpp, 0.0);
    job.predicted = enu.Reverse(cx * kMpp + off_east_m, -cy * kMpp, 0.0);
    return job;
  }
};

}  // namespace aerovo::run_steps::map_testing
