#include "aerovo/correspondence/lens_estimation.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#if AEROVO_TESTS_HAVE_OPENCV  // 0 in the builds without OpenCV (AEROVO_CORE_ONLY, aarch64)
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif

#include "aerovo/core/error.h"
#include "aerovo/core/image.h"
#include "aerovo/core/testing.h"
#include "aerovo/estimation/testing.h"
#include "aerovo/features/surf.h"
#include "aerovo/matching/matcher.h"

namespace aerovo::lens_estimation_test {
namespace {

// A true lens for the synthetic matches: OpenCV fisheye with up to 4 coefficients, or Brown k1.
struct TrueLens {
  RadialFamily family = RadialFamily::kBrownK1;
  std::vector<double> k;  // fisheye k1..k4, or Brown {k1}
  double focal_px = 0.0;
  int width = 0, height = 0;
};

// Pixel of a camera-frame ray (z forward); false behind the camera or off the frame.
bool Project(const TrueLens& lens, const Eigen::Vector3d& ray, Eigen::Vector2d* px) {
  const double rho = std::hypot(ray.x(), ray.y());
  Eigen::Vector2d xd;
  if (lens.family == RadialFamily::kFisheyeK1) {
    const double theta = std::atan2(rho, ray.z());
    if (theta > 1.5) return false;
    double poly = 1.0, t2 = theta * theta, tp = t2;
    for (double c : lens.k) {
      poly += c * tp;
      tp *= t2;
    }
    xd = rho > 0.0 ? Eigen::Vector2d(ray.x(), ray.y()) * (theta * poly / rho) : Eigen::Vector2d(0, 0);
  } else {
    if (ray.z() <= 0.0) return false;
    const Eigen::Vector2d x(ray.x() / ray.z(), ray.y() / ray.z());
    if (lens.k[0] < 0.0 && x.squaredNorm() > -1.0 / (3.0 * lens.k[0])) return false;
    xd = x * (1.0 + lens.k[0] * x.squaredNorm());
  }
  *px = lens.focal_px * xd + Eigen::Vector2d((lens.width - 1) / 2.0, (lens.height - 1) / 2.0);
  return px->x() >= 0 && px->y() >= 0 && px->x() <= lens.width - 1 && px->y() <= lens.height - 1;
}

// Camera-frame ray of world point p for a nadir camera at c with yaw psi (x = image right,
// y = image down, z = down).
Eigen::Vector3d CameraRay(const Eigen::Vector3d& p, const Eigen::Vector3d& c, double psi) {
  const Eigen::Vector3d d = p - c;
  const Eigen::Vector3d x(std::cos(psi), std::sin(psi), 0.0), y(std::sin(psi), -std::cos(psi), 0.0);
  return Eigen::Vector3d(x.dot(d), y.dot(d), -d.z());
}

// `num_pairs` pairs of a nadir flight at `height_m` over flat ground (z = 0) stepping `step_m`
// along x with small random yaw and side offsets; ground points uniform over +-2.5 heights;
// pixel noise `noise_px` (Gaussian), a fraction `outliers` of the matches random.
std::vector<LensPair> Synthetic(const TrueLens& lens, int num_pairs, double height_m,
                                double step_m, double noise_px, double outliers,
                                unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ground(-2.5 * height_m, 2.5 * height_m);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<LensPair> pairs;
  for (int p = 0; p < num_pairs; ++p) {
    const Eigen::Vector3d ca(100.0 * p, 0.0, height_m);
    const Eigen::Vector3d cb = ca + Eigen::Vector3d(step_m, (unit(rng) - 0.5) * 0.2 * step_m, 0.0);
    const double psi_a = (unit(rng) - 0.5) * 0.1, psi_b = psi_a + (unit(rng) - 0.5) * 0.1;
    std::vector<Eigen::Vector2d> a, b;
    while (a.size() < 500) {
      // Two draws per point in a fixed order (testing::DrawYThenX: y first, as x86-64 GCC
      // evaluated the former Vector3d(ca.x() + ground(rng), ca.y() + ground(rng), 0) arguments).
      const Eigen::Vector2d gxy = testing::DrawYThenX(ground, ground, rng);
      const Eigen::Vector3d g(ca.x() + gxy.x(), ca.y() + gxy.y(), 0.0);
      Eigen::Vector2d pa, pb;
      if (!Project(lens, CameraRay(g, ca, psi_a), &pa) || !Project(lens, CameraRay(g, cb, psi_b), &pb)) {
        continue;
      }
      pa += testing::DrawYThenX(noise, noise, rng);
      pb += testing::DrawYThenX(noise, noise, rng);
      if (unit(rng) < outliers) {
        pb = testing::DrawYThenX(unit, unit, rng).cwiseProduct(Eigen::Vector2d(lens.width, lens.height));
      }
      a.push_back(pa);
      b.push_back(pb);
    }
    LensPair pair;
    pair.prev_px.resize(2, static_cast<Eigen::Index>(a.size()));
    pair.curr_px.resize(2, static_cast<Eigen::Index>(a.size()));
    for (std::size_t i = 0; i < a.size(); ++i) {
      pair.prev_px.col(static_cast<Eigen::Index>(i)) = a[i];
      pair.curr_px.col(static_cast<Eigen::Index>(i)) = b[i];
    }
    pairs.push_back(std::move(pair));
  }
  return pairs;
}

LensEstimationOptions OptionsFor(const TrueLens& lens) {
  LensEstimationOptions o;
  o.focal_px = lens.focal_px;
  o.cx_px = (lens.width - 1) / 2.0;
  o.cy_px = (lens.height - 1) / 2.0;
  o.width_px = lens.width;
  o.height_px = lens.height;
  return o;
}

TEST(LensEstimation, RaysAndDistortionAreInverse) {
  for (RadialFamily family : {RadialFamily::kFisheyeK1, RadialFamily::kBrownK1}) {
    for (double k : {-0.06, 0.0, 0.1}) {
      for (double theta : {0.0, 0.2, 0.6, 0.9}) {
        const Eigen::Vector3d ray(std::sin(theta) * 0.6, std::sin(theta) * 0.8, std::cos(theta));
        Eigen::Vector2d xd;
        ASSERT_TRUE(DistortedOfRay(family, k, ray, &xd));
        Eigen::Vector3d back;
        ASSERT_TRUE(RayOfDistorted(family, k, xd.x(), xd.y(), &back)) << ToString(family) << k;
        EXPECT_LT((back - ray).norm(), 1e-10) << ToString(family) << " k " << k << " theta " << theta;
      }
    }
  }
  // Beyond a barrel's monotonic range there is no inverse: r (1 - 0.2 r^2) peaks at 0.861.
  Eigen::Vector3d ray;
  EXPECT_FALSE(RayOfDistorted(RadialFamily::kBrownK1, -0.2, 0.9, 0.0, &ray));
  EXPECT_TRUE(RayOfDistorted(RadialFamily::kBrownK1, -0.2, 0.8, 0.0, &ray));
}

#if AEROVO_TESTS_HAVE_OPENCV
// The families are OpenCV's models with one coefficient: the run's Undistorter and the
// calibration writers take the estimate as it is.
TEST(LensEstimation, FamiliesAreOpenCvModels) {
  const cv::Matx33d k_mat(450, 0, 479.5, 0, 450, 359.5, 0, 0, 1);
  const std::vector<cv::Point3d> points = {{0.3, -0.2, 1.0}, {1.1, 0.7, 1.0}, {-0.4, 0.9, 0.8}};
  std::vector<cv::Point2d> fish, brown;
  cv::fisheye::projectPoints(points, fish, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k_mat,
                             cv::Vec4d(-0.04, 0, 0, 0));
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k_mat,
                    std::vector<double>{-0.12, 0, 0, 0, 0}, brown);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d ray(points[i].x, points[i].y, points[i].z);
    Eigen::Vector2d f, b;
    ASSERT_TRUE(DistortedOfRay(RadialFamily::kFisheyeK1, -0.04, ray, &f));
    ASSERT_TRUE(DistortedOfRay(RadialFamily::kBrownK1, -0.12, ray, &b));
    EXPECT_NEAR(450 * f.x() + 479.5, fish[i].x, 1e-6);
    EXPECT_NEAR(450 * f.y() + 359.5, fish[i].y, 1e-6);
    EXPECT_NEAR(450 * b.x() + 479.5, brown[i].x, 1e-6);
    EXPECT_NEAR(450 * b.y() + 359.5, brown[i].y, 1e-6);
  }
}
#endif

// The lens of tests/e2e/wide_lens_test.cc, one coefficient: 960x720, f = 450 px, fisheye
// k1 = -0.04; 0.5 px noise, 20 % wrong matches.
TEST(LensEstimation, RecoversAFisheyeK1) {
  const TrueLens lens{RadialFamily::kFisheyeK1, {-0.04}, 450.0, 960, 720};
  const LensEstimate e = EstimateRadialDistortion(Synthetic(lens, 5, 80.0, 40.0, 0.5, 0.2, 1),
                                                  OptionsFor(lens));
  RecordProperty("why", e.why);
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_TRUE(e.significant) << e.why;
  EXPECT_EQ(e.family, RadialFamily::kFisheyeK1) << e.why;
  EXPECT_NEAR(e.k, -0.04, 0.002) << e.why;  // measured -0.0399 +- 0.0003
  EXPECT_GT(e.sigma_k, 0.0);
  EXPECT_LT(e.sigma_k, 0.002);
  EXPECT_GT(e.cost_drop, 0.5) << e.why;
  EXPECT_EQ(e.pairs_used, 5);
  EXPECT_EQ(e.pairs_improved, 5);
}

// A GoPro-like barrel in the pinhole model: 1280x960, f = 900 px, Brown k1 = -0.15.
TEST(LensEstimation, RecoversABrownK1) {
  const TrueLens lens{RadialFamily::kBrownK1, {-0.15}, 900.0, 1280, 960};
  const LensEstimate e = EstimateRadialDistortion(Synthetic(lens, 5, 80.0, 40.0, 0.5, 0.2, 2),
                                                  OptionsFor(lens));
  RecordProperty("why", e.why);
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_TRUE(e.significant) << e.why;
  EXPECT_EQ(e.family, RadialFamily::kBrownK1) << e.why;
  EXPECT_NEAR(e.k, -0.15, 0.005) << e.why;
}

// The simulator's 4-coefficient fisheye (wide_lens_test: -0.05, 0.01, -0.002, 0.0005) is
// approximated by one coefficient; the decision is clear.
TEST(LensEstimation, ApproximatesTheSimulatorsFourCoefficientFisheye) {
  const TrueLens lens{RadialFamily::kFisheyeK1, {-0.05, 0.01, -0.002, 0.0005}, 450.0, 960, 720};
  const LensEstimate e = EstimateRadialDistortion(Synthetic(lens, 5, 80.0, 40.0, 0.5, 0.2, 3),
                                                  OptionsFor(lens));
  RecordProperty("why", e.why);
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_TRUE(e.significant) << e.why;
  EXPECT_EQ(e.family, RadialFamily::kFisheyeK1) << e.why;
  EXPECT_NEAR(e.k, -0.035, 0.005) << e.why;  // measured -0.0347
  EXPECT_GT(e.cost_drop, 0.5) << e.why;
}

// An ideal pinhole (a lens corrected in camera, DJI-like: 4000x3000, f = 2300 px, 82 degrees
// across): k = 0 is "not significant", the estimate near 0.
TEST(LensEstimation, IdealPinholeIsNotSignificant) {
  const TrueLens lens{RadialFamily::kBrownK1, {0.0}, 2300.0, 4000, 3000};
  const LensEstimate e = EstimateRadialDistortion(Synthetic(lens, 5, 80.0, 40.0, 1.0, 0.2, 4),
                                                  OptionsFor(lens));
  RecordProperty("why", e.why);
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_FALSE(e.significant) << e.why;
  EXPECT_LT(e.cost_drop, 0.05) << e.why;
  for (const LensFamilyFit& f : e.fits) {
    if (f.family == RadialFamily::kBrownK1) {
      EXPECT_NEAR(f.k, 0.0, 0.003) << e.why;
    }
  }
}

#if AEROVO_TESTS_HAVE_OPENCV
// A lens corrected in camera (DJI Phantom 3, tampa-phantom3 in $AEROVO_SHARED): real SURF matches
// of four photo pairs spread over the flight, reduced to 1000x750 (focal 2311.2 px at 4000 px, the
// FC300S's 20 mm equivalent over its 4:3 sensor: 577.8 px). The estimate changes nothing.
TEST(LensEstimation, CorrectedDjiLensIsNotSignificant) {
  AEROVO_REQUIRE_SHARED(dir, "data/flights/tampa-phantom3/DJI_0054.JPG");
  const std::filesystem::path flight = dir.parent_path();
  SurfOptions so;
  so.adaptive = true;
  Surf surf(so);
  Matcher matcher;
  const auto features = [&](int number) {
    const cv::Mat color = cv::imread((flight / ("DJI_00" + std::to_string(number) + ".JPG")).string(),
                                     cv::IMREAD_GRAYSCALE);
    EXPECT_FALSE(color.empty());
    cv::Mat small;
    cv::resize(color, small, cv::Size(1000, 750), 0, 0, cv::INTER_AREA);
    GrayImage g(small.cols, small.rows);
    for (int y = 0; y < small.rows; ++y) std::copy_n(small.ptr<std::uint8_t>(y), small.cols, g.row(y));
    return surf.DetectAndDescribe(g.view()).features;
  };
  std::vector<LensPair> pairs;
  for (int first : {54, 58, 62, 66}) {
    const FeatureSet a = features(first), b = features(first + 1);
    const MatchResult m = matcher.Match(a, b);
    LensPair pair;
    pair.prev_px.resize(2, static_cast<Eigen::Index>(m.matches.size()));
    pair.curr_px.resize(2, static_cast<Eigen::Index>(m.matches.size()));
    for (std::size_t i = 0; i < m.matches.size(); ++i) {
      const Keypoint& p = a.keypoints[m.matches[i].prev_index];
      const Keypoint& c = b.keypoints[m.matches[i].curr_index];
      pair.prev_px.col(static_cast<Eigen::Index>(i)) = Eigen::Vector2d(p.x, p.y);
      pair.curr_px.col(static_cast<Eigen::Index>(i)) = Eigen::Vector2d(c.x, c.y);
    }
    pairs.push_back(std::move(pair));
  }
  LensEstimationOptions o;
  o.focal_px = 2311.2 / 4.0;
  o.cx_px = 499.5;
  o.cy_px = 374.5;
  o.width_px = 1000;
  o.height_px = 750;
  const LensEstimate e = EstimateRadialDistortion(pairs, o);
  RecordProperty("why", e.why);
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_EQ(e.pairs_used, 4) << e.why;
  EXPECT_FALSE(e.significant) << e.why;
  EXPECT_LT(e.cost_drop, 0.25) << e.why;
}
#endif

TEST(LensEstimation, TooFewPairsGiveNoEstimate) {
  const TrueLens lens{RadialFamily::kFisheyeK1, {-0.04}, 450.0, 960, 720};
  const LensEstimate e = EstimateRadialDistortion(Synthetic(lens, 2, 80.0, 40.0, 0.5, 0.2, 5),
                                                  OptionsFor(lens));
  EXPECT_FALSE(e.valid);
  EXPECT_FALSE(e.significant);
  EXPECT_NE(e.why.find("2 usable frame pairs"), std::string::npos) << e.why;
}

TEST(LensEstimation, SameSeedSameResult) {
  const TrueLens lens{RadialFamily::kFisheyeK1, {-0.03}, 450.0, 960, 720};
  const std::vector<LensPair> pairs = Synthetic(lens, 4, 80.0, 40.0, 0.5, 0.3, 6);
  const LensEstimate a = EstimateRadialDistortion(pairs, OptionsFor(lens));
  const LensEstimate b = EstimateRadialDistortion(pairs, OptionsFor(lens));
  EXPECT_EQ(a.k, b.k);
  EXPECT_EQ(a.cost, b.cost);
  EXPECT_EQ(a.why, b.why);
}

TEST(LensEstimation, InvalidOptionsNameTheField) {
  LensEstimationOptions o;
  EXPECT_THROW(EstimateRadialDistortion({}, o), InvalidArgument);
  o.focal_px = 100;
  o.width_px = o.height_px = 100;
  o.min_cost_drop = 1.5;
  try {
    EstimateRadialDistortion({}, o);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("min_cost_drop"), std::string::npos);
  }
}

}  // namespace
}  // namespace aerovo::lens_estimation_test
