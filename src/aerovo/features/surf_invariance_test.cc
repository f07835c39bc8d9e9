// Geometric behaviour of SURF: 90-degree rotation, 2x scaling, descriptor matching across a
// rotation, no drift on large images, and the option semantics (ROI, cap, threads, upright).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "aerovo/core/angles.h"
#include "aerovo/core/testing.h"
#include "aerovo/features/surf.h"

namespace aerovo::surf_invariance_test {
namespace {

GrayImageView View(const cv::Mat& m) {
  return GrayImageView{m.data, m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step)};
}

// Smooth random texture with blobs at several scales (seeded, so every run sees the same).
cv::Mat SyntheticTexture(int width, int height, unsigned seed) {
  cv::RNG rng(seed);
  cv::Mat acc(height, width, CV_32F, cv::Scalar(0));
  for (double sigma : {1.5, 3.0, 6.0}) {
    cv::Mat noise(height, width, CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), sigma);
    cv::Scalar mean, stddev;
    cv::meanStdDev(noise, mean, stddev);
    acc += noise * (1.0 / stddev[0]);
  }
  cv::Mat out;
  acc.convertTo(out, CV_8U, 25.0, 128.0);
  return out;
}

// Keypoint of `set` nearest to (x, y) within `radius` px, or nullptr.
const Keypoint* Nearest(const std::vector<Keypoint>& set, float x, float y, float radius,
                        std::size_t* index = nullptr) {
  const Keypoint* best = nullptr;
  float best_d2 = radius * radius;
  for (std::size_t k = 0; k < set.size(); ++k) {
    const float dx = set[k].x - x, dy = set[k].y - y;
    const float d2 = dx * dx + dy * dy;
    if (d2 <= best_d2) {
      best_d2 = d2;
      best = &set[k];
      if (index) *index = k;
    }
  }
  return best;
}

double AngleDiffDeg(double a, double b) {
  double d = std::fmod(a - b, 2 * kPi);
  if (d > kPi) d -= 2 * kPi;
  if (d < -kPi) d += 2 * kPi;
  return std::fabs(d) * 180.0 / kPi;
}

struct RotationStats {
  int repeated = 0;
  int orientation_ok = 0;  // Orientation rotated by 90 degrees within 5 degrees.
  int descriptor_nn = 0;   // Nearest descriptor in the rotated set is the repeated point.
  double max_orientation_error_deg = 0;
};

// Rotates `image` by 90 degrees clockwise: (x, y) -> (H - 1 - y, x); orientations (image
// frame, y down) gain +90 degrees. Sides divisible by 4 keep the sampling grids of octaves 0-2
// aligned, so the same points are found.
RotationStats CheckRotation(const cv::Mat& image, const SurfOptions& options) {
  cv::Mat rotated;
  cv::rotate(image, rotated, cv::ROTATE_90_CLOCKWISE);
  Surf surf(options);
  const SurfResult a = surf.DetectAndDescribe(View(image));
  const SurfResult b = surf.DetectAndDescribe(View(rotated));
  RotationStats st;
  const int H = image.rows;
  for (std::size_t i = 0; i < a.features.size(); ++i) {
    const Keypoint& ka = a.features.keypoints[i];
    std::size_t j = 0;
    const Keypoint* kb =
        Nearest(b.features.keypoints, static_cast<float>(H - 1 - ka.y), ka.x, 0.5f, &j);
    if (kb == nullptr || std::fabs(kb->scale / ka.scale - 1.f) > 0.05f) continue;
    ++st.repeated;
    const double err = AngleDiffDeg(kb->orientation, ka.orientation + kPi / 2);
    st.max_orientation_error_deg = std::max(st.max_orientation_error_deg, err);
    if (err <= 5.0) ++st.orientation_ok;
    // Nearest neighbour of descriptor i among all descriptors of the rotated image.
    std::size_t best = 0;
    float best_d2 = 1e30f;
    for (std::size_t k = 0; k < b.features.size(); ++k) {
      float d2 = 0.f;
      for (int q = 0; q < a.features.descriptor_size; ++q) {
        const float d = a.features.descriptor(i)[q] - b.features.descriptor(k)[q];
        d2 += d * d;
      }
      if (d2 < best_d2) {
        best_d2 = d2;
        best = k;
      }
    }
    if (best == j) ++st.descriptor_nn;
  }
  return st;
}

// Rotation assertions. The detector is exactly equivariant under a 90-degree rotation (the box
// filters map onto each other: Dxx <-> Dyy, Dxy -> -Dxy), so the same points are found. Each
// repeated point's orientation must turn by 90 degrees within 5 degrees; the only exceptions
// are points whose orientation histogram has two windows of nearly equal strength, where a
// rounding difference picks the other one (measured: 0-1 such points of 570-850, i.e. <= 0.2 %);
// we allow 1 %. Descriptors: measured 99.8-100 % of repeated points have their own counterpart
// as nearest neighbour among all points of the rotated image; we assert >= 95 %.
void ExpectRotationInvariance(const RotationStats& st, int min_repeated) {
  std::printf(
      "repeated %d, orientation within 5 deg %d (%.1f %%), max error %.2f deg, "
      "descriptor NN correct %d (%.1f %%)\n",
      st.repeated, st.orientation_ok, 100.0 * st.orientation_ok / std::max(1, st.repeated),
      st.max_orientation_error_deg, st.descriptor_nn,
      100.0 * st.descriptor_nn / std::max(1, st.repeated));
  ASSERT_GE(st.repeated, min_repeated);
  EXPECT_GE(st.orientation_ok, 0.99 * st.repeated);
  EXPECT_GE(st.descriptor_nn, 0.95 * st.repeated);
}

TEST(SurfRotation, SyntheticTexture90Degrees) {
  const cv::Mat image = SyntheticTexture(400, 320, 7);
  const RotationStats st = CheckRotation(image, SurfOptions{});
  ExpectRotationInvariance(st, 100);
}

TEST(SurfRotation, SyntheticTexture90DegreesExtended) {
  const cv::Mat image = SyntheticTexture(320, 320, 11);
  SurfOptions o;
  o.extended = true;
  ExpectRotationInvariance(CheckRotation(image, o), 100);
}

TEST(SurfRotation, CallasOrthophoto90Degrees) {
  AEROVO_REQUIRE_SHARED(path, "data/ortho/callas-quarry.jpg");
  const cv::Mat full = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(full.empty());
  const cv::Mat crop = full(cv::Rect(4600, 2600, 640, 480)).clone();
  ExpectRotationInvariance(CheckRotation(crop, SurfOptions{}), 200);
}

TEST(SurfRotation, TampaFrame90Degrees) {
  AEROVO_REQUIRE_SHARED(path, "data/flights/tampa-phantom3/DJI_0100.JPG");
  const cv::Mat frame = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(frame.empty());
  ExpectRotationInvariance(CheckRotation(frame, SurfOptions{}), 200);
}

// Upscaling by 2 (pixel centres: x2 = 2 x + 0.5) must double the scale of repeated points.
void CheckScaleDoubling(const cv::Mat& image) {
  cv::Mat big;
  cv::resize(image, big, cv::Size(), 2.0, 2.0, cv::INTER_CUBIC);
  SurfOptions o;
  o.num_octaves = 2;  // Points of octaves 0-1 reappear in octaves 1-2 of the doubled image.
  Surf small_surf(o);
  o.num_octaves = 3;
  Surf big_surf(o);
  const std::vector<Keypoint> a = small_surf.Detect(View(image));
  const std::vector<Keypoint> b = big_surf.Detect(View(big));
  int repeated = 0, within = 0;
  std::vector<double> ratios;
  for (const Keypoint& ka : a) {
    const Keypoint* kb = Nearest(b, 2 * ka.x + 0.5f, 2 * ka.y + 0.5f, 1.0f);
    if (kb == nullptr || kb->laplacian != ka.laplacian) continue;
    ++repeated;
    const double ratio = kb->scale / ka.scale;
    ratios.push_back(ratio);
    if (std::fabs(ratio / 2.0 - 1.0) <= 0.10) ++within;
  }
  std::sort(ratios.begin(), ratios.end());
  std::printf(
      "points %zu -> %zu, repeated %d, scale ratio within 10 %% of 2: %d (%.1f %%), "
      "median ratio %.3f\n",
      a.size(), b.size(), repeated, within, 100.0 * within / std::max(1, repeated),
      ratios.empty() ? 0.0 : ratios[ratios.size() / 2]);
  // Measured: 97-99 % of repeated points within 10 %, median ratio 1.99-2.00. The box filters
  // of the two octaves are not exact 2x copies (lobe rounding), hence a few outliers.
  ASSERT_GE(repeated, 50);
  EXPECT_NEAR(ratios[ratios.size() / 2], 2.0, 0.05);
  EXPECT_GE(within, 0.95 * repeated);
}

TEST(SurfScale, SyntheticTextureDoubled) { CheckScaleDoubling(SyntheticTexture(320, 240, 3)); }

TEST(SurfScale, TampaFrameDoubled) {
  AEROVO_REQUIRE_SHARED(path, "data/flights/tampa-phantom3/DJI_0100.JPG");
  const cv::Mat frame = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(frame.empty());
  CheckScaleDoubling(frame(cv::Rect(100, 100, 400, 300)).clone());
}

bool SameKeypoint(const Keypoint& a, const Keypoint& b) {
  return a.x == b.x && a.y == b.y && a.scale == b.scale && a.orientation == b.orientation &&
         a.response == b.response && a.laplacian == b.laplacian && a.octave == b.octave;
}

void ExpectIdentical(const SurfResult& a, const SurfResult& b) {
  ASSERT_EQ(a.features.size(), b.features.size());
  for (std::size_t i = 0; i < a.features.size(); ++i) {
    ASSERT_TRUE(SameKeypoint(a.features.keypoints[i], b.features.keypoints[i])) << i;
  }
  EXPECT_EQ(a.features.descriptors, b.features.descriptors);
}

// A 4096x4096 bright image: its integral image reaches 4.2e9, near the uint32 limit (a float
// table would have lost ~8 bits there). Keypoints inside its top-left 2048x2048 crop, away from
// the crop's border by more than any filter, wavelet or descriptor window reaches (256 px),
// must be bit-identical to those found in the crop alone.
TEST(SurfLargeImage, NoDriftAgainstCrop) {
  cv::Mat big = SyntheticTexture(4096, 4096, 5);
  big = big * 0.4 + 150;  // 150..252: large sums.
  const cv::Mat crop = big(cv::Rect(0, 0, 2048, 2048)).clone();
  SurfOptions o;
  o.num_threads = 0;
  Surf surf(o);
  const SurfResult a = surf.DetectAndDescribe(View(big));
  const SurfResult b = surf.DetectAndDescribe(View(crop));
  const auto inner = [](const Keypoint& k) { return k.x < 2048 - 256 && k.y < 2048 - 256; };
  std::vector<std::size_t> ia, ib;
  for (std::size_t i = 0; i < a.features.size(); ++i) {
    if (inner(a.features.keypoints[i])) ia.push_back(i);
  }
  for (std::size_t i = 0; i < b.features.size(); ++i) {
    if (inner(b.features.keypoints[i])) ib.push_back(i);
  }
  std::printf("4096x4096: %zu points, 2048 crop: %zu, compared inside: %zu\n", a.features.size(),
              b.features.size(), ia.size());
  ASSERT_GT(ia.size(), 1000u);
  ASSERT_EQ(ia.size(), ib.size());
  for (std::size_t k = 0; k < ia.size(); ++k) {
    const Keypoint& ka = a.features.keypoints[ia[k]];
    const Keypoint& kb = b.features.keypoints[ib[k]];
    ASSERT_TRUE(SameKeypoint(ka, kb)) << "point " << k << " at (" << ka.x << ", " << ka.y << ")";
    for (int q = 0; q < 64; ++q) {
      ASSERT_EQ(a.features.descriptor(ia[k])[q], b.features.descriptor(ib[k])[q]);
    }
  }
}

TEST(SurfOptionsTest, DeterministicAndThreadIndependent) {
  const cv::Mat image = SyntheticTexture(640, 480, 9);
  SurfOptions o;
  Surf one(o);
  const SurfResult r1 = one.DetectAndDescribe(View(image));
  const SurfResult r1b = one.DetectAndDescribe(View(image));
  o.num_threads = 0;
  Surf all(o);
  const SurfResult r0 = all.DetectAndDescribe(View(image));
  o.num_threads = 3;
  Surf three(o);
  const SurfResult r3 = three.DetectAndDescribe(View(image));
  ASSERT_GT(r1.features.size(), 200u);
  ExpectIdentical(r1, r1b);
  ExpectIdentical(r1, r0);
  ExpectIdentical(r1, r3);
  for (std::size_t i = 1; i < r1.features.size(); ++i) {
    EXPECT_GE(r1.features.keypoints[i - 1].response, r1.features.keypoints[i].response);
  }
  // Detect + Describe equals DetectAndDescribe.
  const std::vector<Keypoint> kps = one.Detect(View(image));
  const FeatureSet fs = one.Describe(View(image), kps);
  EXPECT_EQ(fs.descriptors, r1.features.descriptors);
}

TEST(SurfOptionsTest, RoiKeepsExactlyThePointsInside) {
  const cv::Mat image = SyntheticTexture(640, 480, 13);
  Surf full;
  const std::vector<Keypoint> all = full.Detect(View(image));
  SurfOptions o;
  o.roi = RectI{150, 100, 300, 200};
  Surf roi(o);
  const std::vector<Keypoint> inside = roi.Detect(View(image));
  std::vector<Keypoint> expected;
  for (const Keypoint& k : all) {
    if (o.roi->contains(k.x, k.y)) expected.push_back(k);
  }
  ASSERT_GT(expected.size(), 50u);
  ASSERT_EQ(inside.size(), expected.size());
  for (std::size_t i = 0; i < inside.size(); ++i) {
    EXPECT_TRUE(SameKeypoint(inside[i], expected[i])) << i;
  }
}

TEST(SurfOptionsTest, MaxKeypointsKeepsTheStrongest) {
  const cv::Mat image = SyntheticTexture(640, 480, 17);
  Surf full;
  const SurfResult all = full.DetectAndDescribe(View(image));
  SurfOptions o;
  o.max_keypoints = 100;
  Surf capped(o);
  const SurfResult top = capped.DetectAndDescribe(View(image));
  ASSERT_GT(all.features.size(), 100u);
  ASSERT_EQ(top.features.size(), 100u);
  for (std::size_t i = 0; i < 100; ++i) {
    EXPECT_TRUE(SameKeypoint(top.features.keypoints[i], all.features.keypoints[i])) << i;
  }
  EXPECT_TRUE(std::equal(top.features.descriptors.begin(), top.features.descriptors.end(),
                         all.features.descriptors.begin()));
}

TEST(SurfOptionsTest, UprightAndThreshold) {
  const cv::Mat image = SyntheticTexture(480, 360, 19);
  SurfOptions o;
  o.upright = true;
  Surf upright(o);
  const std::vector<Keypoint> u = upright.Detect(View(image));
  ASSERT_FALSE(u.empty());
  for (const Keypoint& k : u) EXPECT_EQ(k.orientation, 0.f);
  // A higher threshold keeps exactly the points whose response exceeds it.
  Surf base;
  const std::vector<Keypoint> all = base.Detect(View(image));
  o = {};
  o.hessian_threshold = 5000;
  Surf strict(o);
  const std::vector<Keypoint> strong = strict.Detect(View(image));
  const auto n =
      std::count_if(all.begin(), all.end(), [](const Keypoint& k) { return k.response > 5000.f; });
  EXPECT_EQ(static_cast<long>(strong.size()), static_cast<long>(n));
  EXPECT_LT(strong.size(), all.size());
  for (const Keypoint& k : strong) EXPECT_GT(k.response, 5000.f);
}

}  // namespace
}  // namespace aerovo::surf_invariance_test
