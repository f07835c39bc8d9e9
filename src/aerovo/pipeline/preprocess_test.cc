#include "aerovo/pipeline/preprocess.h"

#include <gtest/gtest.h>

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

TEST(Preprocess, ScaleBrightnessRoundsHalfUpAndSaturates) {
  GrayImage frame(3, 1);
  frame.at(0, 0) = 1;
  frame.at(1, 0) = 100;
  frame.at(2, 0) = 200;
  GrayImage buffer;
  const GrayImageView out = ScaleBrightness(frame.view(), 1.5, &buffer);
  EXPECT_EQ(out.at(0, 0), 2);    // 1.5 -> 2 (half up)
  EXPECT_EQ(out.at(1, 0), 150);
  EXPECT_EQ(out.at(2, 0), 255);  // 300 saturates
  EXPECT_THROW(ScaleBrightness(frame.view(), -1.0, &buffer), InvalidArgument);
}

}  // namespace
}  // namespace aerovo
