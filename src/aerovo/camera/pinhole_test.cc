#include "aerovo/camera/pinhole.h"

#include <cmath>

#include <gtest/gtest.h>

#include "aerovo/core/error.h"

namespace aerovo::pinhole_test {
namespace {

TEST(Pinhole, FocalFrom35mmUsesTheDiagonal) {
  EXPECT_NEAR(kFullFrameDiagonalMm, std::sqrt(36.0 * 36.0 + 24.0 * 24.0), 1e-12);
  // Tampa (FC300S): 20 mm equivalent at 800x600 (diagonal 1000 px).
  EXPECT_NEAR(FocalPxFrom35mm(20.0, 800, 600), 462.25, 0.01);
  // A full-frame 36x24 "sensor" of 3600x2400 px at 50 mm: 100 px/mm -> 5000 px.
  EXPECT_NEAR(FocalPxFrom35mm(50.0, 3600, 2400), 5000.0, 1e-9);
  EXPECT_THROW(FocalPxFrom35mm(0.0, 800, 600), InvalidArgument);
  EXPECT_THROW(FocalPxFrom35mm(20.0, 0, 600), InvalidArgument);
}

TEST(Pinhole, FocalFrom35mmOfTheSensorsFullFrame) {
  // Phantom 3 (FC300S), 20 mm equivalent: the 4:3 frame 4000x3000 has a 5000 px diagonal.
  const double f43 = 20.0 / kFullFrameDiagonalMm * 5000.0;
  EXPECT_NEAR(FocalPxFrom35mmOfSensor(20.0, 4000, 3000, 4.0 / 3.0), f43, 1e-9);
  EXPECT_NEAR(FocalPxFrom35mm(20.0, 4000, 3000), f43, 1e-9);
  // Its 16:9 photo 4000x2250 keeps the sensor's width: same focal length, not the 16:9
  // diagonal's (8 % short).
  EXPECT_NEAR(FocalPxFrom35mmOfSensor(20.0, 4000, 2250, 4.0 / 3.0), f43, 1e-9);
  EXPECT_LT(FocalPxFrom35mm(20.0, 4000, 2250), 0.93 * f43);
  // Portrait and a 1:1 crop (keeps the short side, 3000 px: native frame 4000x3000).
  EXPECT_NEAR(FocalPxFrom35mmOfSensor(20.0, 2250, 4000, 4.0 / 3.0), f43, 1e-9);
  EXPECT_NEAR(FocalPxFrom35mmOfSensor(20.0, 3000, 3000, 4.0 / 3.0), f43, 1e-9);
  // A 3:2 sensor (5472x3648) in 16:9 (5472x3078).
  const double f32 = 24.0 / kFullFrameDiagonalMm * std::hypot(5472.0, 3648.0);
  EXPECT_NEAR(FocalPxFrom35mmOfSensor(24.0, 5472, 3078, 1.5), f32, 1e-6);
  // The image as the full frame: the plain rule.
  EXPECT_NEAR(FocalPxFrom35mmOfSensor(24.0, 1600, 1300, 1600.0 / 1300.0),
              FocalPxFrom35mm(24.0, 1600, 1300), 1e-9);
  EXPECT_THROW(FocalPxFrom35mmOfSensor(20.0, 4000, 2250, 0.9), InvalidArgument);
  EXPECT_THROW(FocalPxFrom35mmOfSensor(0.0, 4000, 2250, 1.5), InvalidArgument);
}

TEST(Pinhole, Focal35mmIsTheInverse) {
  EXPECT_NEAR(Focal35mmFromPx(5000.0, 3600, 2400), 50.0, 1e-12);
  // 1280x720 at 73.7 deg (the simulator's default camera): 853.95 px, 25.16 mm (diagonal).
  const double f = FocalPxFromHorizontalFov(73.7, 1280);
  EXPECT_NEAR(f, 853.951, 1e-3);
  EXPECT_NEAR(Focal35mmFromPx(f, 1280, 720), 25.158, 1e-3);
  EXPECT_NEAR(FocalPxFrom35mm(Focal35mmFromPx(f, 1280, 720), 1280, 720), f, 1e-9);
  EXPECT_THROW(Focal35mmFromPx(0.0, 800, 600), InvalidArgument);
  EXPECT_THROW(Focal35mmFromPx(500.0, 800, -1), InvalidArgument);
}

TEST(Pinhole, FieldOfView) {
  EXPECT_NEAR(FocalPxFromHorizontalFov(90.0, 1000), 500.0, 1e-9);
  EXPECT_NEAR(FocalPxFromHorizontalFov(90.0, 800), 400.0, 1e-9);
  EXPECT_NEAR(HorizontalFovDeg(500.0, 1000), 90.0, 1e-9);
  EXPECT_NEAR(HorizontalFovDeg(FocalPxFromHorizontalFov(73.7, 4000), 4000), 73.7, 1e-9);
  EXPECT_THROW(FocalPxFromHorizontalFov(180.0, 1000), InvalidArgument);
  EXPECT_THROW(FocalPxFromHorizontalFov(0.0, 1000), InvalidArgument);
  EXPECT_THROW(FocalPxFromHorizontalFov(60.0, 0), InvalidArgument);
}

TEST(Pinhole, IntrinsicsCentreAndMatrix) {
  const CameraIntrinsics k = IntrinsicsFromFocalPx(500.0, 640, 480);
  EXPECT_DOUBLE_EQ(k.cx_px, 319.5);
  EXPECT_DOUBLE_EQ(k.cy_px, 239.5);
  EXPECT_FALSE(k.HasDistortion());
  const Eigen::Matrix3d m = k.K();
  EXPECT_EQ(m(0, 0), 500.0);
  EXPECT_EQ(m(1, 1), 500.0);
  EXPECT_EQ(m(0, 2), 319.5);
  EXPECT_EQ(m(1, 2), 239.5);
  EXPECT_EQ(m(2, 2), 1.0);
  EXPECT_EQ(m(0, 1), 0.0);
  EXPECT_EQ(m(1, 0), 0.0);
  // A camera-frame point 1 m right of the axis at 10 m: f / 10 px right of the centre.
  const Eigen::Vector3d p = m * Eigen::Vector3d(1.0, 0.0, 10.0);
  EXPECT_NEAR(p.x() / p.z(), 319.5 + 50.0, 1e-12);
  CameraIntrinsics d = k;
  d.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
  EXPECT_FALSE(d.HasDistortion());
  d.distortion[4] = 1e-3;
  EXPECT_TRUE(d.HasDistortion());
}

TEST(Pinhole, ValidateNamesTheField) {
  EXPECT_THROW(IntrinsicsFromFocalPx(0.0, 640, 480), InvalidArgument);
  EXPECT_THROW(IntrinsicsFromFocalPx(500.0, 0, 480), InvalidArgument);
  CameraIntrinsics k = IntrinsicsFromFocalPx(500.0, 640, 480);
  k.cx_px = 700.0;
  try {
    Validate(k);
    ADD_FAILURE() << "principal point outside the image accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("principal point"), std::string::npos) << e.what();
  }
  k.cx_px = 319.5;
  k.distortion = {0.1, 0.2};
  try {
    Validate(k);
    ADD_FAILURE() << "two distortion coefficients accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("distortion"), std::string::npos) << e.what();
  }
  k.distortion = {0.1, 0.0, 0.0, std::nan("")};
  EXPECT_THROW(Validate(k), InvalidArgument);
  k.distortion = {0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  EXPECT_NO_THROW(Validate(k));
}

}  // namespace
}  // namespace aerovo::pinhole_test
