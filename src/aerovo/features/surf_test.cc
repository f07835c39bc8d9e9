#include "aerovo/features/surf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "aerovo/core/cancel.h"
#include "aerovo/core/error.h"

namespace aerovo::surf_test {
namespace {

GrayImage MakeBlob(int w, int h, double cx, double cy, double sigma, double background = 60,
                   double amplitude = 180) {
  GrayImage image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
      image.at(x, y) = static_cast<std::uint8_t>(
          std::lround(background + amplitude * std::exp(-d2 / (2 * sigma * sigma))));
    }
  }
  return image;
}

// Scale relation used below. SURF reports s = 1.2 * size / 9 (the sigma of the Gaussian the
// 9x9 filter was designed to approximate). The Dxx box filter is, however, a second difference
// with spacing size/3 of a box of width size/3, i.e. the second derivative of three nested boxes
// of width size/3: an effective smoothing variance of 3 * (size/3)^2 / 12 = (size/6)^2 across the
// lobes (and (5*size/9)^2 / 12 = (0.16*size)^2 along them). The scale-normalised determinant of a
// Gaussian blob of std sigma peaks where the smoothing sigma equals sigma (Lindeberg), so
// size ~= 6 * sigma and s = 1.2 * size / 9 ~= 0.8 * sigma. The quadratic fit across layers
// 6 * 2^octave apart pulls it down a little: measured s / sigma is 0.70..0.80 for sigma 2.5..14
// (mean 0.75). We assert s / sigma = 0.75 +- 10 %. OpenCV's and MATLAB's SURF use the same
// filters, so the same relation holds for them.
constexpr double kScalePerSigma = 0.75;

class SurfBlobTest : public ::testing::TestWithParam<double> {};

TEST_P(SurfBlobTest, DetectsCentreAndScale) {
  const double sigma = GetParam();
  const double cx = 128.3, cy = 120.6;
  const GrayImage img = MakeBlob(256, 256, cx, cy, sigma);
  Surf surf;
  const std::vector<Keypoint> kps = surf.Detect(img.view());
  ASSERT_FALSE(kps.empty()) << "sigma " << sigma;
  const Keypoint& kp = kps[0];  // Strongest.
  EXPECT_NEAR(kp.x, cx, 0.5) << "sigma " << sigma;
  EXPECT_NEAR(kp.y, cy, 0.5) << "sigma " << sigma;
  EXPECT_NEAR(kp.scale / sigma, kScalePerSigma, 0.1 * kScalePerSigma) << "sigma " << sigma;
  EXPECT_EQ(kp.laplacian, -1) << "a bright blob has a negative Hessian trace";
  EXPECT_GT(kp.response, 1000.f);
  // A dark blob on a bright background: same place, positive trace.
  const GrayImage dark = MakeBlob(256, 256, cx, cy, sigma, 230, -180);
  const std::vector<Keypoint> dk = surf.Detect(dark.view());
  ASSERT_FALSE(dk.empty());
  EXPECT_NEAR(dk[0].x, cx, 0.5);
  EXPECT_NEAR(dk[0].y, cy, 0.5);
  EXPECT_EQ(dk[0].laplacian, 1);
}

// 2.5 to 4.5 are found in octave 0, 5 to 8 in octave 1, 9 to 14 in octave 2.
INSTANTIATE_TEST_SUITE_P(Sigmas, SurfBlobTest,
                         ::testing::Values(2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0,
                                           12.0, 14.0));

TEST(SurfBlob, DescriptorIsNormalised) {
  const GrayImage img = MakeBlob(256, 256, 128.3, 120.6, 5.0);
  for (bool extended : {false, true}) {
    SurfOptions options;
    options.extended = extended;
    Surf surf(options);
    const SurfResult r = surf.DetectAndDescribe(img.view());
    ASSERT_FALSE(r.features.empty());
    ASSERT_EQ(r.features.descriptor_size, extended ? 128 : 64);
    ASSERT_EQ(r.features.descriptors.size(), r.features.size() * r.features.descriptor_size);
    for (std::size_t i = 0; i < r.features.size(); ++i) {
      double n2 = 0;
      for (int k = 0; k < r.features.descriptor_size; ++k) {
        n2 += r.features.descriptor(i)[k] * r.features.descriptor(i)[k];
      }
      EXPECT_NEAR(n2, 1.0, 1e-4);
    }
  }
}

// A stop request (core/cancel.h) ends detection and description with Cancelled; without one,
// or with the flag clear, the result is the same as without a scope.
TEST(SurfCancel, AStopRequestEndsTheFrameAndAClearFlagChangesNothing) {
  const GrayImage image = MakeBlob(320, 240, 160, 120, 6.0);
  Surf surf;
  const SurfResult plain = surf.DetectAndDescribe(image.view());
  ASSERT_FALSE(plain.features.keypoints.empty());
  std::atomic<bool> stop{false};
  {
    const CancelScope scope(&stop);
    const SurfResult same = surf.DetectAndDescribe(image.view());
    EXPECT_EQ(same.features.keypoints.size(), plain.features.keypoints.size());
    EXPECT_EQ(same.features.descriptors, plain.features.descriptors);
    stop = true;
    EXPECT_THROW(surf.DetectAndDescribe(image.view()), Cancelled);
    EXPECT_THROW(surf.Detect(image.view()), Cancelled);
  }
  EXPECT_FALSE(CancelRequested());  // the scope is gone
  EXPECT_EQ(surf.DetectAndDescribe(image.view()).features.keypoints.size(),
            plain.features.keypoints.size());
}

TEST(SurfErrors, BadOptionsNameTheField) {
  const auto expect_field = [](SurfOptions o, const char* field) {
    try {
      Validate(o);
      ADD_FAILURE() << "no error for " << field;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
    EXPECT_THROW(Surf{o}, InvalidArgument);
  };
  SurfOptions o;
  EXPECT_NO_THROW(Validate(o));
  o.hessian_threshold = -1;
  expect_field(o, "hessian_threshold");
  o = {};
  o.hessian_threshold = std::nan("");
  expect_field(o, "hessian_threshold");
  o = {};
  o.num_octaves = 0;
  expect_field(o, "num_octaves");
  o = {};
  o.num_scale_levels = 2;
  expect_field(o, "num_scale_levels");
  o = {};
  o.max_keypoints = -5;
  expect_field(o, "max_keypoints");
  o = {};
  o.num_threads = -1;
  expect_field(o, "num_threads");
  o = {};
  o.roi = RectI{0, 0, 0, 10};
  expect_field(o, "roi");
}

TEST(SurfErrors, BadImages) {
  Surf surf;
  const auto expect_message = [&](const GrayImageView& v, const char* text) {
    try {
      surf.DetectAndDescribe(v);
      ADD_FAILURE() << "no error, expected " << text;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  expect_message(GrayImageView{}, "empty");
  const GrayImage tiny(8, 40, 100);
  expect_message(tiny.view(), "smaller than the smallest SURF filter");
  EXPECT_THROW(surf.Detect(tiny.view()), InvalidArgument);
  EXPECT_THROW(surf.Describe(tiny.view(), {}), InvalidArgument);
  GrayImageView bad_stride = GrayImage(20, 20).view();
  bad_stride.stride = 10;
  expect_message(bad_stride, "stride");
  // An image just big enough for the smallest filter is valid (and has no room for maxima).
  const GrayImage nine(9, 9, 50);
  EXPECT_TRUE(surf.DetectAndDescribe(nine.view()).features.empty());
  // Keypoints that cannot be described.
  const GrayImage ok(64, 64, 100);
  Keypoint bad;
  bad.x = 10;
  bad.y = 10;
  bad.scale = 0;
  EXPECT_NO_THROW(surf.DetectAndDescribe(ok.view()));
  EXPECT_THROW(surf.Describe(ok.view(), {bad}), InvalidArgument);
  bad.scale = 2;
  bad.x = std::nanf("");
  EXPECT_THROW(surf.Describe(ok.view(), {bad}), InvalidArgument);
  bad.x = -5;  // Finite but outside: described with clamped samples.
  EXPECT_EQ(surf.Describe(ok.view(), {bad}).descriptors.size(), 64u);
  // ROI outside the image.
  SurfOptions o;
  o.roi = RectI{100, 100, 50, 50};
  Surf roi_surf(o);
  const GrayImage img(120, 120, 10);
  EXPECT_THROW(roi_surf.Detect(img.view()), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::surf_test
