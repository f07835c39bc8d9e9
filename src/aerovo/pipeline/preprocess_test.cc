#include "aerovo/pipeline/preprocess.h"

#include <cmath>
#include <cstdint>
#include <utility>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/frames/camera.h"
#include "aerovo/odometry/visual_odometry.h"

namespace aerovo::preprocess_test {
namespace {

// The run's undistorter is frames' Undistorter with the run's camera: the same pixels.
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

TEST(Preprocess, FrameReducerKeepsFramesWithinTheBudget) {
  // Within the budget (24 MP): as read.
  FrameReducer keep(5472, 3648, 24.0);  // a 20 MP 1-inch sensor
  EXPECT_FALSE(keep.active());
  EXPECT_EQ(keep.out_width_px(), 5472);
  EXPECT_DOUBLE_EQ(keep.scale(), 1.0);
  EXPECT_TRUE(keep.reduced_from_full().isIdentity());
  EXPECT_FALSE(FrameReducer(20000, 20000, 0.0).active());  // 0 = no budget
  // 12000 x 12000 = 144 MP -> 4898 x 4898 = 23.99 MP.
  FrameReducer big(12000, 12000, 24.0);
  ASSERT_TRUE(big.active());
  EXPECT_EQ(big.out_width_px(), 4898);
  EXPECT_EQ(big.out_height_px(), 4898);
  EXPECT_LE(static_cast<double>(big.out_width_px()) * big.out_height_px(), 24e6);
  EXPECT_NEAR(big.scale(), 4898.0 / 12000.0, 1e-15);
  // The aspect ratio is kept (8000 x 6000 = 48 MP -> 5656 x 4242).
  FrameReducer wide(8000, 6000, 24.0);
  EXPECT_EQ(wide.out_width_px(), 5656);
  EXPECT_EQ(wide.out_height_px(), 4242);
  EXPECT_NEAR(wide.focal_scale(), 0.707, 1e-3);
  // The frame centre maps to the reduced centre (the principal point stays central).
  const Eigen::Vector3d c = wide.reduced_from_full() * Eigen::Vector3d(3999.5, 2999.5, 1.0);
  EXPECT_NEAR(c.x(), 0.5 * (5656 - 1), 1e-9);
  EXPECT_NEAR(c.y(), 0.5 * (4242 - 1), 1e-9);
  EXPECT_THROW(FrameReducer(0, 10, 24.0), InvalidArgument);
  EXPECT_THROW(FrameReducer(10, 10, std::nan("")), InvalidArgument);
}

TEST(Preprocess, FrameReducerAveragesAreasAndMapsPixelsConsistently) {
  // A 400 x 300 frame at a 0.03 MP budget: reduced by 1/2 exactly (200 x 150).
  GrayImage frame(400, 300);
  for (int y = 0; y < 300; ++y) {
    for (int x = 0; x < 400; ++x) frame.at(x, y) = static_cast<std::uint8_t>((x / 2 + y) % 256);
  }
  FrameReducer r(400, 300, 0.03);
  ASSERT_TRUE(r.active());
  ASSERT_EQ(r.out_width_px(), 200);
  ASSERT_EQ(r.out_height_px(), 150);
  const GrayImageView out = r.Apply(frame.view());
  ASSERT_EQ(out.width, 200);
  // Area average of the 2x2 block: (x, 2y) and (x, 2y + 1) rows -> mean of v and v + 1.
  for (const auto& [x, y] : {std::pair{0, 0}, {10, 20}, {199, 100}}) {
    const double want = 0.5 * ((x + 2 * y) % 256 + (x + 2 * y + 1) % 256);
    EXPECT_NEAR(out.at(x, y), want, 0.51) << x << "," << y;
  }
  // Full-frame pixel (2x + 0.5, 2y + 0.5), the centre of the block, is reduced pixel (x, y).
  const Eigen::Vector3d p = r.reduced_from_full() * Eigen::Vector3d(20.5, 40.5, 1.0);
  EXPECT_NEAR(p.x(), 10.0, 1e-12);
  EXPECT_NEAR(p.y(), 20.0, 1e-12);
  GrayImage other(300, 300);
  EXPECT_THROW(r.Apply(other.view()), InvalidArgument);
  // Not active: the frame itself.
  FrameReducer none(400, 300, 1.0);
  EXPECT_EQ(none.Apply(frame.view()).data, frame.view().data);
}

TEST(Preprocess, DetectionBudgetReducesByTheSmallestIntegerFactor) {
  // 4K UHD at 2.1 MP: halved exactly, 1920 x 1080; 1080p (2.07 MP) and smaller as read.
  FrameReducer uhd(3840, 2160, 24.0, 2.1);
  ASSERT_TRUE(uhd.active());
  EXPECT_EQ(uhd.factor(), 2);
  EXPECT_EQ(uhd.out_width_px(), 1920);
  EXPECT_EQ(uhd.out_height_px(), 1080);
  EXPECT_EQ(uhd.scale(), 0.5);  // exact: the focal length of the reduced frames is f / 2
  EXPECT_EQ(uhd.focal_scale(), 0.5);
  FrameReducer hd(1920, 1080, 24.0, 2.1);
  EXPECT_FALSE(hd.active());
  EXPECT_EQ(hd.factor(), 1);
  EXPECT_EQ(hd.focal_scale(), 1.0);
  EXPECT_FALSE(FrameReducer(3840, 2160, 24.0, 0.0).active());  // 0 = no detection budget
  // 8K (7680 x 4320): a factor 3 gives 2560 x 1440 = 3.7 MP, over; 4 gives 1920 x 1080.
  FrameReducer k8(7680, 4320, 0.0, 2.1);
  EXPECT_EQ(k8.factor(), 4);
  EXPECT_EQ(k8.out_width_px(), 1920);
  EXPECT_EQ(k8.focal_scale(), 0.25);
  // Both budgets are met: at max_megapixels 0.5 the factor is 5 (960 x 540 = 0.52 MP is over).
  FrameReducer both(3840, 2160, 0.5, 2.1);
  EXPECT_EQ(both.factor(), 5);
  EXPECT_EQ(both.out_width_px(), 768);
  EXPECT_EQ(both.out_height_px(), 432);
  // Odd sizes: the last column and row are dropped, whole 2 x 2 blocks only.
  FrameReducer odd(3841, 2161, 24.0, 2.1);
  EXPECT_EQ(odd.out_width_px(), 1920);
  EXPECT_EQ(odd.out_height_px(), 1080);
  EXPECT_EQ(odd.focal_scale(), 0.5);
  EXPECT_THROW(FrameReducer(10, 10, 24.0, std::nan("")), InvalidArgument);
}

TEST(Preprocess, DetectionReductionAveragesBlocksAndMapsTheirCentres) {
  // 31 x 22 at factor 3: 10 x 7 blocks of 3 x 3, each reduced pixel the rounded block mean.
  GrayImage frame(31, 22);
  for (int y = 0; y < 22; ++y) {
    for (int x = 0; x < 31; ++x)
      frame.at(x, y) = static_cast<std::uint8_t>((x * 37 + y * 11) % 256);
  }
  FrameReducer r(31, 22, 0.0, 0.0001);  // 682 px > 100 px budget; 10 x 7 = 70 px fits
  ASSERT_EQ(r.factor(), 3);
  ASSERT_EQ(r.out_width_px(), 10);
  ASSERT_EQ(r.out_height_px(), 7);
  const GrayImageView out = r.Apply(frame.view());
  int worst = 0;
  for (int by = 0; by < 7; ++by) {
    for (int bx = 0; bx < 10; ++bx) {
      int sum = 0;
      for (int dy = 0; dy < 3; ++dy) {
        for (int dx = 0; dx < 3; ++dx) sum += frame.at(3 * bx + dx, 3 * by + dy);
      }
      worst = std::max(worst, std::abs(9 * out.at(bx, by) - sum));
    }
  }
  EXPECT_LE(worst, 5);  // |9 out - sum| <= 4.5: the mean rounded to the nearest integer
  // The centre of block (bx, by), full pixel (3 bx + 1, 3 by + 1), is reduced pixel (bx, by).
  const Eigen::Vector3d p = r.reduced_from_full() * Eigen::Vector3d(3 * 4 + 1, 3 * 5 + 1, 1.0);
  EXPECT_NEAR(p.x(), 4.0, 1e-12);
  EXPECT_NEAR(p.y(), 5.0, 1e-12);
}

// A flight over textured ground seen at 640 x 480 (focal 800 px, 40 m: 5 cm/px), processed
// once as read and once reduced by 2 (focal 400 px): the positions in metres agree.
TEST(Preprocess, DetectionReductionKeepsPositionsInMetres) {
  cv::RNG rng(11);
  cv::Mat ground(1400, 1400, CV_8U, cv::Scalar(90));
  for (int i = 0; i < 9000; ++i) {
    // One draw per statement (a call's arguments are evaluated in an unspecified order): the
    // order x86-64 GCC used for the former one-call form, last argument first.
    const int grey = rng.uniform(0, 256);
    const int radius = rng.uniform(3, 16);
    const int y = rng.uniform(0, 1400);
    const int x = rng.uniform(0, 1400);
    cv::circle(ground, cv::Point(x, y), radius, cv::Scalar(grey), cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(ground, ground, cv::Size(0, 0), 1.2);
  const int w = 640, h = 480;
  const double focal_px = 800.0, height_m = 40.0, gsd = height_m / focal_px;
  OdometryOptions full_opt;
  full_opt.focal_px = focal_px;
  full_opt.default_height_m = height_m;
  full_opt.surf.num_threads = 1;
  full_opt.correspondence.match.num_threads = 1;
  FrameReducer reducer(w, h, 0.0, 0.1);  // 0.31 MP > 0.1 MP: factor 2, 320 x 240
  ASSERT_EQ(reducer.factor(), 2);
  OdometryOptions half_opt = full_opt;
  half_opt.focal_px = focal_px * reducer.focal_scale();
  VisualOdometry full(full_opt), half(half_opt);
  const int frames = 8;
  const double step_px = 36.0;  // 1.8 m per frame to the east, turning 2 degrees per frame
  for (int i = 0; i < frames; ++i) {
    const double a = 2.0 * i * kDegToRad, c = std::cos(a), s = std::sin(a);
    const double cx = 0.5 * (w - 1), cy = 0.5 * (h - 1);
    const double tx = 300.0 + step_px * i - (c * cx - s * cy), ty = 700.0 - (s * cx + c * cy);
    const cv::Matx23d ground_from_frame(c, -s, tx, s, c, ty);
    cv::Mat frame;
    cv::warpAffine(ground, frame, ground_from_frame, cv::Size(w, h),
                   cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
    const GrayImageView view{frame.data, w, h, static_cast<std::ptrdiff_t>(frame.step)};
    const FrameResult rf = full.Process(view, 0.1 * i);
    const FrameResult rh = half.Process(reducer.Apply(view), 0.1 * i);
    ASSERT_NE(rh.status, FrameStatus::kBridged) << "frame " << i;
    const double truth_m = step_px * i * gsd;
    EXPECT_NEAR(rf.position_m.norm(), truth_m, 0.01 + 0.01 * truth_m) << "frame " << i;
    EXPECT_NEAR(rh.position_m.norm(), truth_m, 0.02 + 0.01 * truth_m) << "frame " << i;
    EXPECT_NEAR((rh.position_m - rf.position_m).norm(), 0.0, 0.02 + 0.01 * truth_m)
        << "frame " << i;
    EXPECT_NEAR(rh.gsd_m_per_px, 2.0 * gsd, 1e-12);  // twice the ground sampling distance
  }
}

}  // namespace
}  // namespace aerovo::preprocess_test
