#include "aerovo/frames/camera.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/camera/lens.h"
#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::camera_test {
namespace {

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

// The source keys and the last resort, the telemetry's 35 mm equivalent (a video with a DJI
// SRT): the same arithmetic as FocalPxFrom35mm, bit for bit.
TEST(Camera, ResolveSourceKeysAndTelemetryFallback) {
  CameraOptions o;
  ResolvedCamera r = ResolveCamera(o, 1280, 720, nullptr, 25.16);
  EXPECT_EQ(r.source_key, "telemetry-35mm");
  EXPECT_EQ(r.intrinsics.fx_px, FocalPxFrom35mm(25.16, 1280, 720));
  EXPECT_THAT(r.source, ::testing::HasSubstr("telemetry"));
  ImageMetadata m;
  m.source = "y.jpg";
  m.width_px = 1280;
  m.height_px = 720;
  m.focal_length_35mm_mm = 24.0;
  r = ResolveCamera(o, 1280, 720, &m, 25.16);  // the photo's EXIF comes first
  EXPECT_EQ(r.source_key, "exif-35mm");
  // A 16:9 photo: over the 4:3 sensor frame it is a crop of (1280x960), the video's telemetry
  // over its own frame.
  EXPECT_EQ(r.intrinsics.fx_px, FocalPxFrom35mm(24.0, 1280, 960));
  m.calibrated_focal_px = 900.0;
  EXPECT_EQ(ResolveCamera(o, 1280, 720, &m).source_key, "xmp-calibrated");
  o.focal_35mm_mm = 28.0;
  EXPECT_EQ(ResolveCamera(o, 1280, 720, &m).source_key, "35mm");
  o.hfov_deg = 70.0;
  r = ResolveCamera(o, 1280, 720, &m);
  EXPECT_EQ(r.source_key, "hfov");
  EXPECT_EQ(r.intrinsics.fx_px, FocalPxFromHorizontalFov(70.0, 1280));
  o.focal_px = 1000.0;
  EXPECT_EQ(ResolveCamera(o, 1280, 720, &m).source_key, "flag");
  EXPECT_THROW(ResolveCamera(CameraOptions{}, 1280, 720, nullptr, -3.0), InvalidArgument);
}

// A photo without a 35 mm equivalent (a multispectral band of 1280x960 px, a 5.5 mm lens and
// 3.75 um pixels: FocalPlaneXResolution 266.67 px/mm): its focal length in pixels is their
// product, 1466.7 px, before the telemetry's; only at the photo's own size.
TEST(Camera, FocalPlaneResolutionWhenThePhotoHasNo35mmEquivalent) {
  ImageMetadata m;
  m.source = "IMG_0001_2.tif";
  m.width_px = 1280;
  m.height_px = 960;
  m.focal_length_mm = 5.5;
  m.focal_plane_px_per_mm = 266.67;
  const ResolvedCamera r = ResolveCamera(CameraOptions{}, 1280, 960, &m, 30.0);
  EXPECT_EQ(r.source_key, "exif-focal-plane");
  EXPECT_DOUBLE_EQ(r.intrinsics.fx_px, 5.5 * 266.67);
  EXPECT_THAT(r.source, ::testing::HasSubstr("FocalPlaneXResolution 266.67 px/mm of "
                                             "'IMG_0001_2.tif'"));
  // Frames of another size (the pitch is the photo's): the next source.
  EXPECT_EQ(ResolveCamera(CameraOptions{}, 640, 480, &m, 30.0).source_key, "telemetry-35mm");
  // The 35 mm equivalent, when written, comes first (the shared flights' DJI photos).
  m.focal_length_35mm_mm = 40.0;
  EXPECT_EQ(ResolveCamera(CameraOptions{}, 1280, 960, &m).source_key, "exif-35mm");
  m.focal_length_35mm_mm.reset();
  m.focal_plane_px_per_mm.reset();
  try {
    ResolveCamera(CameraOptions{}, 1280, 960, &m);
    ADD_FAILURE() << "no focal length must throw";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("nor FocalLength with FocalPlaneXResolution"));
  }
}

// A 16:9 photo of a 4:3 sensor: the 35 mm equivalent belongs to the sensor's full frame. Truth:
// the 16:9 photo (4000x2250) is the middle of the 4:3 frame (4000x3000) through the same lens,
// so its focal length in pixels is the 4:3 photo's: 20 mm equivalent (FC300S: 3.61 mm lens, crop
// factor 5.54) over the 5000 px diagonal = 2311 px.
TEST(Camera, SixteenByNinePhotoUsesTheSensorsFullFrame) {
  ImageMetadata m;
  m.source = "DJI_0001.JPG";
  m.make = "DJI";
  m.model = "FC300S";
  m.width_px = 4000;
  m.height_px = 2250;
  m.focal_length_35mm_mm = 20.0;
  const double truth_px = 20.0 / kFullFrameDiagonalMm * 5000.0;
  const ResolvedCamera r = ResolveCamera({}, 4000, 2250, &m);
  EXPECT_NEAR(r.intrinsics.fx_px, truth_px, 0.01 * truth_px);
  EXPECT_THAT(r.source, ::testing::HasSubstr("FC300S's 4:3 sensor"));
  // An unknown model's 16:9 photo: taken as a crop of a 4:3 sensor, said so.
  m.model = "FC9999";
  const ResolvedCamera u = ResolveCamera({}, 4000, 2250, &m);
  EXPECT_NEAR(u.intrinsics.fx_px, truth_px, 0.01 * truth_px);
  EXPECT_THAT(u.source, ::testing::HasSubstr("crop of a 4:3 sensor"));
  // Given: a 3:2 sensor; and a 4:3 photo stays on its own diagonal (unchanged).
  CameraOptions o;
  o.sensor_aspect = 1.5;
  EXPECT_NEAR(ResolveCamera(o, 4000, 2250, &m).intrinsics.fx_px,
              20.0 / kFullFrameDiagonalMm * std::hypot(4000.0, 4000.0 / 1.5), 1e-6);
  m.width_px = 4000;
  m.height_px = 3000;
  EXPECT_NEAR(ResolveCamera({}, 4000, 3000, &m).intrinsics.fx_px,
              FocalPxFrom35mm(20.0, 4000, 3000), 1e-9);
  m.model = "FC6310";  // Phantom 4 Pro: 3:2 sensor, its 16:9 photo 5472x3078
  EXPECT_NEAR(ResolveCamera({}, 5472, 3078, &m).intrinsics.fx_px,
              20.0 / kFullFrameDiagonalMm * std::hypot(5472.0, 3648.0), 1e-6);
  o.sensor_aspect = 0.5;
  EXPECT_THROW(ResolveCamera(o, 4000, 2250, &m), InvalidArgument);
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

// A black w x h image with a 3x3 white dot centred on the pixel nearest (x, y) (pixels).
GrayImage Dot(int w, int h, double x, double y) {
  GrayImage img(w, h, 0);
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) img.at(cx + dx, cy + dy) = 255;
  }
  return img;
}

// The intensity-weighted centroid of an image (pixels) and its weight, the sum of the grey
// levels (0 for a black image, whose centroid is then (0, 0)).
struct Centroid {
  double x = 0.0, y = 0.0, weight = 0.0;
};
Centroid CentroidOf(const GrayImage& img) {
  double sx = 0, sy = 0, sw = 0;
  for (int y = 0; y < img.height(); ++y) {
    for (int x = 0; x < img.width(); ++x) {
      sx += x * img.at(x, y);
      sy += y * img.at(x, y);
      sw += img.at(x, y);
    }
  }
  return sw > 0.0 ? Centroid{sx / sw, sy / sw, sw} : Centroid{};
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

  const GrayImage in = Dot(w, h, xd, yd);
  Undistorter u(k);
  GrayImage out;
  u.Apply(in, out);
  const Centroid c = CentroidOf(out);
  ASSERT_GT(c.weight, 0.0);
  EXPECT_NEAR(c.x, xu, 0.75);
  EXPECT_NEAR(c.y, yu, 0.75);
  EXPECT_THROW(u.Apply(GrayImage(10, 10), out), InvalidArgument);
}

// The maps and the remap of the run's frames before this class was the one undistorter
// (pipeline FrameUndistorter, report mosaic): the same pixels, bit for bit, grey and colour.
TEST(Camera, UndistorterEqualsTheDirectOpenCvMapsBitForBit) {
  const int w = 160, h = 120;
  const double f = 130.0, k1 = -0.21, k2 = 0.04, p1 = 1e-3, p2 = -2e-3, k3 = 0.01;
  cv::Mat gray(h, w, CV_8UC1), color(h, w, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(gray, cv::RNG::UNIFORM, 0, 256);
  rng.fill(color, cv::RNG::UNIFORM, 0, 256);
  const cv::Matx33d km(f, 0, 0.5 * (w - 1), 0, f, 0.5 * (h - 1), 0, 0, 1);
  cv::Mat map1, map2;
  cv::initUndistortRectifyMap(km, cv::Vec<double, 5>(k1, k2, p1, p2, k3), cv::Matx33d::eye(), km,
                              cv::Size(w, h), CV_16SC2, map1, map2);
  cv::Mat want_gray, want_color;
  cv::remap(gray, want_gray, map1, map2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::remap(color, want_color, map1, map2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);

  CameraIntrinsics k = IntrinsicsFromFocalPx(f, w, h);
  k.distortion = {k1, k2, p1, p2, k3};
  const Undistorter u(k);
  EXPECT_EQ(u.width_px(), w);
  EXPECT_EQ(u.height_px(), h);
  GrayImage buffer;
  const GrayImageView got =
      u.Apply(GrayImageView{gray.data, w, h, static_cast<std::ptrdiff_t>(gray.step)}, &buffer);
  ASSERT_EQ(got.width, w);
  ASSERT_EQ(got.height, h);
  int differ = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) differ += got.at(x, y) != want_gray.at<std::uint8_t>(y, x);
  }
  EXPECT_EQ(differ, 0);
  cv::Mat got_color;
  u.Apply(color, got_color);
  ASSERT_EQ(got_color.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(got_color, want_color, cv::NORM_INF), 0.0);
  // A strided view (a crop of a wider image) gives the same pixels.
  cv::Mat wide(h, w + 24, CV_8UC1, cv::Scalar(9));
  gray.copyTo(wide(cv::Rect(0, 0, w, h)));
  GrayImage again;
  const GrayImageView strided =
      u.Apply(GrayImageView{wide.data, w, h, static_cast<std::ptrdiff_t>(wide.step)}, &again);
  differ = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) differ += strided.at(x, y) != want_gray.at<std::uint8_t>(y, x);
  }
  EXPECT_EQ(differ, 0);
  cv::Mat small(h - 1, w, CV_8UC3);
  EXPECT_THROW(u.Apply(small, got_color), InvalidArgument);
}


// The fisheye lens (equidistant model with k1..k4): the ray of an undistorted pinhole pixel,
// imaged by the lens at cv::fisheye::distortPoints' position, is brought back by both the
// image remap and the points' undistortion.
TEST(Camera, FisheyeUndistorterImageAndPointsAgree) {
  const int w = 320, h = 240;
  CameraIntrinsics k = IntrinsicsFromFocalPx(160.0, w, h);
  k.model = LensModel::kFisheye;
  k.distortion = {-0.05, 0.01, -0.002, 0.0005};
  Undistorter u(k);
  EXPECT_EQ(u.output().fx_px, 160.0);
  EXPECT_EQ(u.output().cx_px, 0.5 * (w - 1));
  // A pinhole point far off-centre: normalised (0.8, 0.5) (about 43 degrees off axis).
  const cv::Point2d pu(k.cx_px + 0.8 * 160.0, k.cy_px + 0.5 * 160.0);
  std::vector<cv::Point2d> norm = {{0.8, 0.5}}, dist;
  const cv::Matx33d km(160.0, 0, k.cx_px, 0, 160.0, k.cy_px, 0, 0, 1);
  cv::fisheye::distortPoints(norm, dist, km, cv::Vec4d(-0.05, 0.01, -0.002, 0.0005));
  // theta = atan(0.943) = 0.756 rad; theta_d = theta (1 - 0.05 theta^2 + ...) = 0.736 rad, so
  // the lens images the point at 0.736 / 0.943 of the pinhole radius.
  ASSERT_GT(std::hypot(dist[0].x - pu.x, dist[0].y - pu.y), 25.0);
  std::vector<cv::Point2f> pts = {cv::Point2f(static_cast<float>(dist[0].x),
                                              static_cast<float>(dist[0].y))};
  u.UndistortPoints(&pts);
  EXPECT_NEAR(pts[0].x, pu.x, 0.01);
  EXPECT_NEAR(pts[0].y, pu.y, 0.01);
  GrayImage out;
  u.Apply(Dot(w, h, dist[0].x, dist[0].y), out);
  const Centroid c = CentroidOf(out);
  ASSERT_GT(c.weight, 0.0);
  EXPECT_NEAR(c.x, pu.x, 1.0);
  EXPECT_NEAR(c.y, pu.y, 1.0);
  // A fisheye camera takes 0 or 4 coefficients.
  k.distortion = {0.1, 0.0, 0.0, 0.0, 0.0};
  EXPECT_THROW(Undistorter{k}, InvalidArgument);
}

// The points path (camera/lens.h LensUndistortion, OpenCV-free): its forward map is the frame
// path's remap map (OpenCV's initUndistortRectifyMap, output pixel -> distorted pixel) within
// 1e-3 px, and its iterative inverse undoes it within 1e-6 px, over the whole output frame.
TEST(Camera, LensUndistortionMatchesTheFramePathsMapsAndInvertsThem) {
  const int w = 400, h = 300;
  for (const bool fisheye : {false, true}) {
    SCOPED_TRACE(fisheye ? "fisheye" : "pinhole");
    CameraIntrinsics k = IntrinsicsFromFocalPx(260.0, w, h);
    k.fy_px = 262.0;
    k.cx_px = 203.0;
    k.cy_px = 147.0;
    if (fisheye) {
      k.model = LensModel::kFisheye;
      k.distortion = {-0.05, 0.01, -0.002, 0.0005};
    } else {
      k.distortion = {-0.08, 0.01, 0.001, -0.0005, 0.0};
    }
    const LensUndistortion lens(k);
    const cv::Matx33d km(k.fx_px, 0, k.cx_px, 0, k.fy_px, k.cy_px, 0, 0, 1);
    const cv::Matx33d out(260.0, 0, 199.5, 0, 260.0, 149.5, 0, 0, 1);
    cv::Mat mx, my;
    if (fisheye) {
      cv::fisheye::initUndistortRectifyMap(km, k.distortion, cv::Matx33d::eye(), out,
                                           cv::Size(w, h), CV_32FC1, mx, my);
    } else {
      cv::initUndistortRectifyMap(km, k.distortion, cv::Matx33d::eye(), out, cv::Size(w, h),
                                  CV_32FC1, mx, my);
    }
    double worst_map = 0.0, worst_inverse = 0.0;
    for (int y = 0; y < h; y += 7) {
      for (int x = 0; x < w; x += 7) {
        double u = 0.0, v = 0.0, uo = 0.0, vo = 0.0;
        ASSERT_TRUE(lens.DistortPixel(x, y, &u, &v));
        worst_map = std::max({worst_map, std::abs(u - mx.at<float>(y, x)),
                              std::abs(v - my.at<float>(y, x))});
        ASSERT_TRUE(lens.UndistortPixel(u, v, &uo, &vo)) << x << "," << y;
        worst_inverse = std::max({worst_inverse, std::abs(uo - x), std::abs(vo - y)});
      }
    }
    EXPECT_LT(worst_map, 1e-3);
    EXPECT_LT(worst_inverse, 1e-6);
  }
}

// The auto rule's measure (MaxLensScaleChange): 0 for an ideal pinhole; the fisheye's
// tangential scale theta_d / tan(theta) at 43 degrees off axis; the mild pinhole lens and the
// fisheye of tests/e2e/wide_lens_test.cc on either side of kPointsMaxScaleChange.
TEST(Camera, LensScaleChangeOfTheAutoRule) {
  EXPECT_EQ(MaxLensScaleChange(IntrinsicsFromFocalPx(500.0, 960, 720)), 0.0);
  CameraIntrinsics f = IntrinsicsFromFocalPx(450.0, 960, 720);
  f.model = LensModel::kFisheye;
  f.distortion = {-0.05, 0.01, -0.002, 0.0005};
  const LensUndistortion fl(f);
  // Normalised (0.8, 0.5): r = 0.943, theta = 0.756 rad.
  const double r = std::hypot(0.8, 0.5), t = std::atan(r);
  const double td = t * (1 - 0.05 * t * t + 0.01 * std::pow(t, 4) - 0.002 * std::pow(t, 6) +
                         0.0005 * std::pow(t, 8));
  const std::array<double, 2> s = fl.LocalScale(479.5 + 0.8 * 450.0, 359.5 + 0.5 * 450.0);
  EXPECT_NEAR(s[1], td / r, 1e-9) << "the tangential scale is the larger one";
  EXPECT_LT(s[0], s[1]);
  EXPECT_GT(fl.MaxScaleChange(), kPointsMaxScaleChange);
  // 960x720 at 73.7 degrees (the simulator's default), k1 = -0.05: 0.145 (measured).
  CameraIntrinsics p = IntrinsicsFromFocalPx(FocalPxFromHorizontalFov(73.7, 960), 960, 720);
  p.distortion = {-0.05, 0.0, 0.0, 0.0, 0.0};
  const double mild = MaxLensScaleChange(p);
  EXPECT_GT(mild, 0.1);
  EXPECT_LT(mild, kPointsMaxScaleChange);
}

TEST(Camera, FirstFoldedPixelIsBeyondTheDistortionsPeak) {
  // r_d(r) = r (1 + k1 r^2), k1 = -2: peaks at r = 1 / sqrt(6) = 0.408 with r_d = 0.272, i.e.
  // 108.9 px from the centre at focal 400 px. On a 320x240 frame, pixels farther out have no ray.
  CameraIntrinsics k = IntrinsicsFromFocalPx(400.0, 320, 240);
  k.distortion = {-2.0, 0.0, 0.0, 0.0, 0.0};
  const std::optional<std::array<double, 2>> p = FirstFoldedPixel(k);
  ASSERT_TRUE(p.has_value());
  const double r_px = std::hypot((*p)[0] - k.cx_px, (*p)[1] - k.cy_px);
  EXPECT_GT(r_px, 400.0 * 2.0 / 3.0 / std::sqrt(6.0));
  // The first grid point of the top row within 90 % of the corner's 199.3 px (row by row).
  EXPECT_DOUBLE_EQ((*p)[0], 319.0 * 3 / 32);  // the grid's 4th column
  EXPECT_EQ((*p)[1], 0.0);
  // The check stops at 90 % of the corner's distance (179 px): k1 = -0.9 peaks at r_d = 162 px,
  // inside it, and folds; k1 = -0.6 peaks at 198.8 px, beyond it, and is accepted.
  k.distortion = {-0.6, 0.0, 0.0, 0.0, 0.0};
  EXPECT_FALSE(FirstFoldedPixel(k).has_value());
  k.distortion = {-0.9, 0.0, 0.0, 0.0, 0.0};
  EXPECT_TRUE(FirstFoldedPixel(k).has_value());
  // No distortion, and a fisheye, are not checked.
  EXPECT_FALSE(FirstFoldedPixel(IntrinsicsFromFocalPx(400.0, 320, 240)).has_value());
  k.model = LensModel::kFisheye;
  k.distortion = {-0.9, 0.0, 0.0, 0.0};
  EXPECT_FALSE(FirstFoldedPixel(k).has_value());
}

// An off-centre principal point and fx != fy: the output is the centred square-pixel camera.
TEST(Camera, PinholeUndistorterPointsMatchOpenCv) {
  const int w = 400, h = 300;
  CameraIntrinsics k = IntrinsicsFromFocalPx(300.0, w, h);
  k.fy_px = 303.0;
  k.cx_px = 205.0;
  k.cy_px = 146.0;
  k.distortion = {-0.2, 0.05, 0.001, -0.001, 0.0};
  Undistorter u(k);
  std::vector<cv::Point2f> pts = {{10.0f, 20.0f}, {390.0f, 280.0f}, {205.0f, 146.0f}};
  std::vector<cv::Point2f> want;
  const cv::Matx33d km(300, 0, 205, 0, 303, 146, 0, 0, 1);
  const cv::Matx33d out(300, 0, 199.5, 0, 300, 149.5, 0, 0, 1);
  cv::undistortPoints(pts, want, km, k.distortion, cv::noArray(), out);
  u.UndistortPoints(&pts);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    EXPECT_NEAR(pts[i].x, want[i].x, 1e-3);
    EXPECT_NEAR(pts[i].y, want[i].y, 1e-3);
  }
  // The principal point maps to the output's centre.
  EXPECT_NEAR(pts[2].x, 199.5, 1e-3);
  EXPECT_NEAR(pts[2].y, 149.5, 1e-3);
}

TEST(Camera, ScaledToKeepsTheRaysAndRefusesAnotherAspect) {
  CameraIntrinsics k = IntrinsicsFromFocalPx(3000.0, 4000, 3000);
  k.cx_px = 2010.0;
  k.model = LensModel::kFisheye;
  k.distortion = {0.1, 0.0, 0.0, 0.0};
  const CameraIntrinsics s = ScaledTo(k, 1000, 750);
  EXPECT_DOUBLE_EQ(s.fx_px, 750.0);
  EXPECT_DOUBLE_EQ(s.fy_px, 750.0);
  EXPECT_DOUBLE_EQ(s.cx_px, (2010.0 + 0.5) * 0.25 - 0.5);
  EXPECT_DOUBLE_EQ(s.cy_px, 374.5);  // the centre stays the centre
  EXPECT_EQ(s.model, LensModel::kFisheye);
  EXPECT_EQ(s.distortion, k.distortion);
  try {
    ScaledTo(k, 1920, 1080);
    FAIL() << "a 16:9 crop of a 4:3 calibration must be refused";
  } catch (const InvalidArgument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("4000x3000"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("1920x1080"));
  }
}

TEST(Camera, CalibrationWinsTheFocalChain) {
  CameraOptions o;
  o.focal_px = 500.0;
  CameraIntrinsics k = IntrinsicsFromFocalPx(1600.0, 1920, 1080);
  k.model = LensModel::kFisheye;
  k.distortion = {0.02, 0.0, 0.0, 0.0};
  o.calibration = k;
  o.calibration_source = "cam.yaml";
  const ResolvedCamera r = ResolveCamera(o, 960, 540, nullptr);
  EXPECT_EQ(r.source_key, "calibration");
  EXPECT_DOUBLE_EQ(r.intrinsics.fx_px, 800.0);
  EXPECT_EQ(r.intrinsics.model, LensModel::kFisheye);
  EXPECT_THAT(r.source, ::testing::HasSubstr("cam.yaml"));
  EXPECT_THAT(r.source, ::testing::HasSubstr("scaled from 1920x1080"));
  EXPECT_THROW(ResolveCamera(o, 960, 720, nullptr), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::camera_test
