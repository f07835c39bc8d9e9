#include "aerovo/odometry/attitude_estimation.h"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"

namespace aerovo::attitude_estimation_test {
namespace {

constexpr double kFocal = 800.0, kCx = 479.5, kCy = 359.5;
constexpr int kWidth = 960, kHeight = 720;

// camera (x right, y down, z optical) to camera FRD axes (odometry/attitude.h).
Eigen::Matrix3d FrdFromCamera() {
  return (Eigen::Matrix3d() << 0, -1, 0, 1, 0, 0, 0, 0, 1).finished();
}

// A camera `height_m` above flat ground at (x_m, y_m) of the level frame (x north-ish forward, y
// right, z down), heading `yaw_deg`, with the camera attitude `a` relative to its heading.
struct View {
  Eigen::Vector3d centre;
  Eigen::Matrix3d level_from_camera;
};
View MakeView(double x_m, double y_m, double height_m, double yaw_deg, const CameraAttitude& a) {
  View v;
  v.centre = Eigen::Vector3d(x_m, y_m, -height_m);
  v.level_from_camera = Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
                        LevelFromCameraFrd(a) * FrdFromCamera();
  return v;
}
// The pixel of ground point g (z = 0) in view v; false when behind or outside the frame.
bool Project(const View& v, const Eigen::Vector3d& g, Eigen::Vector2d* px) {
  const Eigen::Vector3d ray = v.level_from_camera.transpose() * (g - v.centre);
  if (ray.z() <= 0.0) return false;
  *px = Eigen::Vector2d(kFocal * ray.x() / ray.z() + kCx, kFocal * ray.y() / ray.z() + kCy);
  return px->x() >= 0 && px->y() >= 0 && px->x() <= kWidth - 1 && px->y() <= kHeight - 1;
}

// The matches of ground points seen in both views: 400 random ground points under the first
// view's footprint, pixel noise `noise_px`, a fraction `outliers` of random wrong matches.
LensPair PairOf(const View& a, const View& b, double noise_px, double outliers, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<Eigen::Vector2d> pa, pb;
  int tries = 0;
  while (pa.size() < 400 && ++tries < 200000) {
    // A pixel of view a, its ray to the ground.
    const Eigen::Vector2d px((u(rng) + 1.0) / 2.0 * (kWidth - 1), (u(rng) + 1.0) / 2.0 * (kHeight - 1));
    const Eigen::Vector3d ray = a.level_from_camera *
                                Eigen::Vector3d((px.x() - kCx) / kFocal, (px.y() - kCy) / kFocal, 1);
    if (ray.z() <= 1e-3) continue;
    const Eigen::Vector3d g = a.centre + ray * (-a.centre.z() / ray.z());
    Eigen::Vector2d qa, qb;
    if (!Project(a, g, &qa) || !Project(b, g, &qb)) continue;
    pa.push_back(qa + Eigen::Vector2d(noise(rng), noise(rng)));
    if (std::uniform_real_distribution<double>(0, 1)(rng) < outliers) {
      qb = Eigen::Vector2d((u(rng) + 1.0) / 2.0 * (kWidth - 1), (u(rng) + 1.0) / 2.0 * (kHeight - 1));
    }
    pb.push_back(qb + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  LensPair pair;
  pair.prev_px.resize(2, static_cast<Eigen::Index>(pa.size()));
  pair.curr_px.resize(2, static_cast<Eigen::Index>(pb.size()));
  for (std::size_t i = 0; i < pa.size(); ++i) {
    pair.prev_px.col(static_cast<Eigen::Index>(i)) = pa[i];
    pair.curr_px.col(static_cast<Eigen::Index>(i)) = pb[i];
  }
  return pair;
}

AttitudeEstimationOptions Options() {
  AttitudeEstimationOptions o;
  o.focal_px = kFocal;
  o.cx_px = kCx;
  o.cy_px = kCy;
  o.width_px = kWidth;
  o.height_px = kHeight;
  return o;
}

// Five pairs of a survey at 60 m: 25 m steps (about 40 % of the footprint) on headings 0, 90,
// 180, 270 and 45 degrees, the camera at attitude `a`; heights 60 +- 2 m and a 3 degree turn
// between the frames of a pair.
std::vector<LensPair> Survey(const CameraAttitude& a, double noise_px, double outliers,
                             double step_m = 25.0) {
  std::mt19937 rng(7);
  std::vector<LensPair> pairs;
  const double headings[] = {0.0, 90.0, 180.0, 270.0, 45.0};
  for (int k = 0; k < 5; ++k) {
    const double h = headings[k];
    const View first = MakeView(100.0 * k, 0.0, 60.0, h, a);
    const View second =
        MakeView(100.0 * k + step_m * std::cos(h * kDegToRad), step_m * std::sin(h * kDegToRad),
                 60.0 + (k % 2 ? 2.0 : -2.0), h + 3.0, a);
    pairs.push_back(PairOf(first, second, noise_px, outliers, rng));
  }
  return pairs;
}

TEST(AttitudeEstimation, RecoversAForwardTiltOfFifteenDegrees) {
  const AttitudeEstimate e = EstimateCameraAttitude(Survey({0.0, 15.0}, 0.3, 0.1), Options());
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_TRUE(e.significant) << e.why;
  EXPECT_NEAR(e.attitude.pitch_deg, 15.0, 0.3) << e.why;
  EXPECT_NEAR(e.attitude.roll_deg, 0.0, 0.3) << e.why;
  EXPECT_EQ(e.pairs_used, 5);
  EXPECT_GT(e.cost_drop, 0.5) << e.why;
  EXPECT_LT(e.median_residual_px, 0.6) << e.why;
  EXPECT_GT(e.median_residual_nadir_px, 2.0) << e.why;
}

TEST(AttitudeEstimation, RecoversRollAndPitchTogether) {
  const AttitudeEstimate e = EstimateCameraAttitude(Survey({-8.0, 6.0}, 0.3, 0.1), Options());
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_TRUE(e.significant) << e.why;
  EXPECT_NEAR(e.attitude.roll_deg, -8.0, 0.3) << e.why;
  EXPECT_NEAR(e.attitude.pitch_deg, 6.0, 0.3) << e.why;
}

TEST(AttitudeEstimation, ANadirCameraIsNadirAndNotSignificant) {
  const AttitudeEstimate e = EstimateCameraAttitude(Survey({0.0, 0.0}, 0.3, 0.1), Options());
  ASSERT_TRUE(e.valid) << e.why;
  EXPECT_FALSE(e.significant) << e.why;
  EXPECT_LT(e.tilt_deg, 0.5) << e.why;
  EXPECT_LT(e.cost_drop, 0.05) << e.why;
}

TEST(AttitudeEstimation, AHoverTellsNothing) {
  // 0.5 m between the frames of each pair at 60 m: under the motion threshold.
  const AttitudeEstimate e =
      EstimateCameraAttitude(Survey({0.0, 15.0}, 0.3, 0.1, /*step_m=*/0.5), Options());
  EXPECT_FALSE(e.valid) << e.why;
  EXPECT_FALSE(e.significant);
  EXPECT_EQ(e.pairs_used, 0);
  EXPECT_NE(e.why.find("0 of 5 pairs"), std::string::npos) << e.why;
}

TEST(AttitudeEstimation, SameSeedSameEstimate) {
  const std::vector<LensPair> pairs = Survey({3.0, 11.0}, 0.5, 0.2);
  const AttitudeEstimate a = EstimateCameraAttitude(pairs, Options());
  const AttitudeEstimate b = EstimateCameraAttitude(pairs, Options());
  EXPECT_EQ(a.attitude.roll_deg, b.attitude.roll_deg);
  EXPECT_EQ(a.attitude.pitch_deg, b.attitude.pitch_deg);
  EXPECT_EQ(a.cost, b.cost);
  EXPECT_NEAR(a.attitude.pitch_deg, 11.0, 0.4) << a.why;
}

TEST(AttitudeEstimation, BadOptionsAndPairsAreNamed) {
  AttitudeEstimationOptions o = Options();
  o.focal_px = 0.0;
  try {
    EstimateCameraAttitude({}, o);
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("focal_px"), std::string::npos) << e.what();
  }
  LensPair bad;
  bad.prev_px.resize(2, 40);
  bad.curr_px.resize(2, 39);
  bad.prev_px.setZero();
  bad.curr_px.setZero();
  EXPECT_THROW(EstimateCameraAttitude({bad}, Options()), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::attitude_estimation_test
