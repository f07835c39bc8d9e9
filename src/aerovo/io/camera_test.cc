#include "aerovo/io/camera.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo {
namespace {

TEST(Camera, FocalFrom35mmUsesTheDiagonal) {
  EXPECT_NEAR(kFullFrameDiagonalMm, std::sqrt(36.0 * 36.0 + 24.0 * 24.0), 1e-12);
  // Tampa (FC300S): 20 mm equivalent at 800x600 (diagonal 1000 px).
  EXPECT_NEAR(FocalPxFrom35mm(20.0, 800, 600), 462.25, 0.01);
  // A full-frame 36x24 "sensor" of 3600x2400 px at 50 mm: 100 px/mm -> 5000 px.
  EXPECT_NEAR(FocalPxFrom35mm(50.0, 3600, 2400), 5000.0, 1e-9);
  EXPECT_THROW(FocalPxFrom35mm(0.0, 800, 600), InvalidArgument);
  EXPECT_THROW(FocalPxFrom35mm(20.0, 0, 600), InvalidArgument);
}

TEST(Camera, FieldOfView) {
  EXPECT_NEAR(FocalPxFromHorizontalFov(90.0, 1000), 500.0, 1e-9);
  EXPECT_NEAR(HorizontalFovDeg(500.0, 1000), 90.0, 1e-9);
  EXPECT_NEAR(HorizontalFovDeg(FocalPxFromHorizontalFov(73.7, 4000), 4000), 73.7, 1e-9);
  EXPECT_THROW(FocalPxFromHorizontalFov(180.0, 1000), InvalidArgument);
  EXPECT_THROW(FocalPxFromHorizontalFov(0.0, 1000), InvalidArgument);
}

TEST(Camera, ResolvePriorityAndMessages) {
  ImageMetadata m;
  m.source = "x.jpg";
  m.width_px = 1600;
  m.height_px = 1300;
  m.focal_length_35mm_mm = 40.0;
  m.calibrated_focal_px = 1913.33;
  CameraOptions o;
  ResolvedCamera r = ResolveCamera(o, 1600, 1300, &m);
  EXPECT_DOUBLE_EQ(r.intrinsics.fx_px, 1913.33);  // calibrated value, same image size
  EXPECT_THAT(r.source, ::testing::HasSubstr("CalibratedFocalLength"));
  EXPECT_DOUBLE_EQ(r.intrinsics.cx_px, 799.5);
  EXPECT_DOUBLE_EQ(r.intrinsics.cy_px, 649.5);
  r = ResolveCamera(o, 800, 650, &m);  // frames downscaled: calibration does not apply
  EXPECT_NEAR(r.intrinsics.fx_px, 40.0 / kFullFrameDiagonalMm * std::hypot(800.0, 650.0), 1e-9);
  EXPECT_THAT(r.source, ::testing::HasSubstr("FocalLengthIn35mmFilm"));
  o.focal_35mm_mm = 24.0;
  EXPECT_NEAR(ResolveCamera(o, 1600, 1300, &m).intrinsics.fx_px, FocalPxFrom35mm(24.0, 1600, 1300),
              1e-9);
  o.hfov_deg = 90.0;
  EXPECT_NEAR(ResolveCamera(o, 1600, 1300, &m).intrinsics.fx_px, 800.0, 1e-9);
  o.focal_px = 1234.0;
  o.cx_px = 700.0;
  o.distortion = {0.1, 0.0, 0.0, 0.0};
  r = ResolveCamera(o, 1600, 1300, &m);
  EXPECT_DOUBLE_EQ(r.intrinsics.fx_px, 1234.0);
  EXPECT_DOUBLE_EQ(r.intrinsics.cx_px, 700.0);
  EXPECT_TRUE(r.intrinsics.HasDistortion());

  try {
    ResolveCamera(CameraOptions{}, 640, 480, nullptr);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("no focal length"));
  }
  CameraOptions bad;
  bad.distortion = {0.1, 0.2};
  EXPECT_THROW(ResolveCamera(bad, 640, 480, nullptr), InvalidArgument);
  bad = {};
  bad.focal_px = -1.0;
  EXPECT_THROW(Validate(bad), InvalidArgument);
  bad = {};
  bad.focal_px = 500.0;
  bad.cx_px = 900.0;
  EXPECT_THROW(ResolveCamera(bad, 640, 480, nullptr), InvalidArgument);
}

TEST(Camera, TampaFromExif) {
  AEROVO_REQUIRE_SHARED(path, "data/flights/tampa-phantom3/DJI_0054.JPG");
  const ImageMetadata m = ReadImageMetadata(path);
  const ResolvedCamera r = ResolveCamera({}, m.width_px, m.height_px, &m);
  EXPECT_NEAR(r.intrinsics.fx_px, 462.2, 0.1);  // 20 / 43.27 * 1000
}

TEST(Camera, TurinCalibratedAgreesWith35mm) {
  AEROVO_REQUIRE_SHARED(path, "data/flights/turin-p4m/DJI_0010.JPG");
  const ImageMetadata m = ReadImageMetadata(path);
  const double f35 = FocalPxFrom35mm(*m.focal_length_35mm_mm, m.width_px, m.height_px);
  EXPECT_NEAR(f35, 1905.9, 0.1);
  // DJI's calibrated focal length (1913.3 px) is within 0.5 % of the 35 mm-equivalent value,
  // which supports the diagonal definition (the width one would give 1777.8 px).
  EXPECT_NEAR(*m.calibrated_focal_px / f35, 1.0, 0.005);
}

TEST(Camera, UndistorterMovesPointsToThePinholePosition) {
  const int w = 200, h = 160;
  CameraIntrinsics k = IntrinsicsFromFocalPx(150.0, w, h);
  k.distortion = {-0.2, 0.0, 0.0, 0.0};
  // Undistorted point (xu, yu) -> where the lens images it: x_d = x_u (1 + k1 r^2).
  const double xu = 170.0, yu = 130.0;
  const double nx = (xu - k.cx_px) / k.fx_px, ny = (yu - k.cy_px) / k.fy_px;
  const double s = 1.0 + k.distortion[0] * (nx * nx + ny * ny);
  const double xd = k.cx_px + nx * s * k.fx_px, yd = k.cy_px + ny * s * k.fy_px;
  ASSERT_GT(std::hypot(xd - xu, yd - yu), 3.0);  // the lens moves it visibly

  GrayImage in(w, h, 0);
  for (int y = -1; y <= 1; ++y) {
    for (int x = -1; x <= 1; ++x) {
      in.at(static_cast<int>(std::lround(xd)) + x, static_cast<int>(std::lround(yd)) + y) = 255;
    }
  }
  Undistorter u(k);
  GrayImage out;
  u.Apply(in, out);
  double sx = 0, sy = 0, sw = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      sx += x * out.at(x, y);
      sy += y * out.at(x, y);
      sw += out.at(x, y);
    }
  }
  ASSERT_GT(sw, 0.0);
  EXPECT_NEAR(sx / sw, xu, 0.75);
  EXPECT_NEAR(sy / sw, yu, 0.75);
  EXPECT_THROW(u.Apply(GrayImage(10, 10), out), InvalidArgument);
}

}  // namespace
}  // namespace aerovo
