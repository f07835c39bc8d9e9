#include "aerovo/pipeline/preprocess.h"

#include <cmath>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/io/camera.h"

namespace aerovo {
namespace {

// The run's undistorter is io's Undistorter with the run's camera: the same pixels.
TEST(Preprocess, FrameUndistorterIsTheCameraUndistorter) {
  const int w = 96, h = 64;
  GrayImage frame(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) frame.at(x, y) = static_cast<std::uint8_t>((x * 7 + y * 13) % 251);
  }
  FrameUndistorter run(w, h, 80.0, -0.3, 0.05, 0.002, -0.001, 0.0);
  CameraIntrinsics k = IntrinsicsFromFocalPx(80.0, w, h);
  k.distortion = {-0.3, 0.05, 0.002, -0.001, 0.0};
  GrayImage want;
  Undistorter(k).Apply(frame, want);
  const GrayImageView got = run.Apply(frame.view());
  int differ = 0, moved = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      differ += got.at(x, y) != want.at(x, y);
      moved += got.at(x, y) != frame.at(x, y);
    }
  }
  EXPECT_EQ(differ, 0);
  EXPECT_GT(moved, w * h / 4);  // the lens model is strong enough to move most pixels
  EXPECT_THROW(FrameUndistorter(w, h, 0.0, 0, 0, 0, 0, 0), InvalidArgument);
  EXPECT_THROW(run.Apply(GrayImage(w, h + 1).view()), InvalidArgument);
}

TEST(Preprocess, UndistorterMovesADistortedDotBackToItsPinholePosition) {
  // A dot whose pinhole (undistorted) position is p_u is drawn where the lens puts it,
  // p_d = centre + f * distort((p_u - centre) / f); undistortion must bring it back to p_u.
  const int w = 640, h = 480;
  const double f = 500.0, k1 = -0.2, k2 = 0.05;
  const Eigen::Vector2d c(0.5 * (w - 1), 0.5 * (h - 1)), pu(560.0, 420.0);
  const Eigen::Vector2d n = (pu - c) / f;
  const double r2 = n.squaredNorm();
  const Eigen::Vector2d pd = c + f * n * (1.0 + k1 * r2 + k2 * r2 * r2);
  cv::Mat img(h, w, CV_8UC1, cv::Scalar(0));
  cv::circle(img,
             cv::Point(static_cast<int>(std::lround(pd.x() * 16)),
                       static_cast<int>(std::lround(pd.y() * 16))),
             3 * 16, cv::Scalar(255), cv::FILLED, cv::LINE_AA, 4);
  FrameUndistorter und(w, h, f, k1, k2, 0.0, 0.0, 0.0);
  const GrayImageView out =
      und.Apply(GrayImageView{img.data, w, h, static_cast<std::ptrdiff_t>(img.step)});
  double sx = 0, sy = 0, sw = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double v = out.at(x, y);
      sx += v * x;
      sy += v * y;
      sw += v;
    }
  }
  ASSERT_GT(sw, 0.0);
  EXPECT_GT((pd - pu).norm(), 10.0);  // the distortion is substantial there
  EXPECT_NEAR(sx / sw, pu.x(), 0.5);
  EXPECT_NEAR(sy / sw, pu.y(), 0.5);
  cv::Mat other(h + 1, w, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(und.Apply(GrayImageView{other.data, w, h + 1, w}), InvalidArgument);
}

TEST(Preprocess, ScaleBrightnessRoundsHalfUpAndSaturates) {
  GrayImage frame(3, 1);
  frame.at(0, 0) = 1;
  frame.at(1, 0) = 100;
  frame.at(2, 0) = 200;
  GrayImage buffer;
  const GrayImageView out = ScaleBrightness(frame.view(), 1.5, &buffer);
  EXPECT_EQ(out.at(0, 0), 2);  // 1.5 -> 2 (half up)
  EXPECT_EQ(out.at(1, 0), 150);
  EXPECT_EQ(out.at(2, 0), 255);  // 300 saturates
  EXPECT_THROW(ScaleBrightness(frame.view(), -1.0, &buffer), InvalidArgument);
}

}  // namespace
}  // namespace aerovo
