#include "aerovo/backend/pixel_step.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "aerovo/backend/testing.h"
#include "aerovo/core/error.h"

namespace aerovo::backend::pixel_step_test {
namespace {

const Eigen::Vector2d kCentre(399.5, 299.5);  // An 800 x 600 frame.

// Pixel of a ground point of a frame (the inverse of the header's p_m formula).
Eigen::Vector2d PixelOfGround(const Eigen::Vector2d& p_m, double gsd) {
  return Eigen::Vector2d(kCentre.x() + p_m.x() / gsd, kCentre.y() - p_m.y() / gsd);
}

// curr_from_prev in pixels of a ground step prev_from_curr.
Eigen::Matrix3d PixelStepOf(const Similarity2& prev_from_curr, double gsd_prev, double gsd_curr) {
  // Three points fix an affine map.
  Eigen::Matrix3d prev, curr;
  const Eigen::Vector2d q[3] = {{0.0, 0.0}, {30.0, 0.0}, {0.0, 20.0}};
  for (int i = 0; i < 3; ++i) {
    curr.col(i) << PixelOfGround(q[i], gsd_curr), 1.0;
    prev.col(i) << PixelOfGround(prev_from_curr.Apply(q[i]), gsd_prev), 1.0;
  }
  return curr * prev.inverse();
}

TEST(PixelStep, GroundStepRoundTripsThroughPixels) {
  Similarity2 z;
  z.translation_m = {12.5, -3.0};
  z.heading_rad = 0.3;
  z.log_scale = 0.04;
  for (const double gsd_curr : {0.05, 0.055}) {
    const Eigen::Matrix3d px = PixelStepOf(z, 0.05, gsd_curr);
    const Similarity2 back = PrevFromCurrOfPixelStep(px, kCentre, 0.05, gsd_curr);
    EXPECT_LT((back.translation_m - z.translation_m).norm(), 1e-9);
    EXPECT_NEAR(back.heading_rad, z.heading_rad, 1e-12);
    EXPECT_NEAR(back.log_scale, z.log_scale, 1e-12);
    // And the inverse: the pixel step of the ground step is the same transform.
    const Eigen::Matrix3d again = PixelStepOfPrevFromCurr(z, kCentre, 0.05, gsd_curr);
    EXPECT_LT((again - px).cwiseAbs().maxCoeff(), 1e-9) << again << "\n" << px;
  }
  // A pure pixel shift: the camera moved right by 100 px of frame prev, so the scene moved left.
  Eigen::Matrix3d shift = Eigen::Matrix3d::Identity();
  shift(0, 2) = -100.0;  // Content moves left: curr = prev - 100 px.
  const Similarity2 s = PrevFromCurrOfPixelStep(shift, kCentre, 0.1, 0.1);
  EXPECT_LT((s.translation_m - Eigen::Vector2d(10.0, 0.0)).norm(), 1e-12);
  EXPECT_NEAR(s.heading_rad, 0.0, 1e-15);
  EXPECT_NEAR(s.log_scale, 0.0, 1e-15);
}

TEST(PixelStep, InformationMatchesTheSpreadOfFitsOnNoisyPoints) {
  // Monte Carlo: 3000 least-squares similarity fits of 40 noisy point pairs (0.7 px per axis in
  // each image); the covariance of the fitted parameters against the inverse information.
  Similarity2 z;
  z.translation_m = {8.0, 15.0};
  z.heading_rad = -0.2;
  z.log_scale = 0.03;
  constexpr double kGsdPrev = 0.04, kGsdCurr = 0.042, kSigmaPx = 0.7;
  testing::Gaussian noise(11);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(0.0, 799.0), uy(0.0, 599.0);
  constexpr int kPoints = 40;
  Eigen::Matrix2Xd curr_px(2, kPoints);
  for (int i = 0; i < kPoints; ++i) {
    curr_px(1, i) = uy(rng);
    curr_px(0, i) = ux(rng);
  }
  const Eigen::Matrix4d info =
      SimilarityFitInformation(curr_px, z, kCentre, kGsdPrev, kGsdCurr, kSigmaPx);
  const Eigen::Matrix4d predicted = info.inverse();
  constexpr int kTrials = 3000;
  std::vector<Eigen::Vector4d> params;
  for (int t = 0; t < kTrials; ++t) {
    // Linear least squares of p = [a -b; b a] q + t on the noisy ground points.
    Eigen::MatrixXd a(2 * kPoints, 4);
    Eigen::VectorXd b(2 * kPoints);
    for (int i = 0; i < kPoints; ++i) {
      const Eigen::Vector2d q_true(kGsdCurr * (curr_px(0, i) - kCentre.x()),
                                   kGsdCurr * (kCentre.y() - curr_px(1, i)));
      const Eigen::Vector2d p_px = PixelOfGround(z.Apply(q_true), kGsdPrev);
      const double nx = noise(), ny = noise(), mx = noise(), my = noise();
      const Eigen::Vector2d q(kGsdCurr * (curr_px(0, i) + kSigmaPx * nx - kCentre.x()),
                              kGsdCurr * (kCentre.y() - curr_px(1, i) - kSigmaPx * ny));
      const Eigen::Vector2d p(kGsdPrev * (p_px.x() + kSigmaPx * mx - kCentre.x()),
                              kGsdPrev * (kCentre.y() - p_px.y() - kSigmaPx * my));
      a.row(2 * i) << q.x(), -q.y(), 1.0, 0.0;
      a.row(2 * i + 1) << q.y(), q.x(), 0.0, 1.0;
      b(2 * i) = p.x();
      b(2 * i + 1) = p.y();
    }
    const Eigen::Vector4d x = a.colPivHouseholderQr().solve(b);
    params.emplace_back(x(2), x(3), std::atan2(x(1), x(0)), std::log(std::hypot(x(0), x(1))));
  }
  Eigen::Vector4d mean = Eigen::Vector4d::Zero();
  for (const auto& p : params) mean += p / kTrials;
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();
  for (const auto& p : params) cov += (p - mean) * (p - mean).transpose() / (kTrials - 1);
  for (int k = 0; k < 4; ++k) {
    // Standard deviations within 10 % (the sampling error of 3000 trials is about 1.3 %; the
    // errors-in-variables bias of the curr points' noise is far smaller at 40 points).
    EXPECT_NEAR(std::sqrt(cov(k, k)) / std::sqrt(predicted(k, k)), 1.0, 0.1) << "parameter " << k;
  }
  EXPECT_NEAR(mean(2), z.heading_rad, 3 * std::sqrt(predicted(2, 2)));
  // The correlation of x with heading (the points' centroid is off the camera centre).
  const double rho_pred = predicted(0, 2) / std::sqrt(predicted(0, 0) * predicted(2, 2));
  const double rho_emp = cov(0, 2) / std::sqrt(cov(0, 0) * cov(2, 2));
  EXPECT_NEAR(rho_emp, rho_pred, 0.1);
  // Usable as a factor's information.
  PoseGraph g;
  g.AddPose({});
  g.AddPose(z);
  EXPECT_NO_THROW(g.AddRelative({0, 1, z, info}));
}

TEST(PixelStep, BadInputsAreInvalidArguments) {
  EXPECT_THROW(PrevFromCurrOfPixelStep(Eigen::Matrix3d::Zero(), kCentre, 0.1, 0.1),
               InvalidArgument);
  EXPECT_THROW(PrevFromCurrOfPixelStep(Eigen::Matrix3d::Identity(), kCentre, 0.0, 0.1),
               InvalidArgument);
  Eigen::Matrix3d nan = Eigen::Matrix3d::Identity();
  nan(0, 2) = std::nan("");
  EXPECT_THROW(PrevFromCurrOfPixelStep(nan, kCentre, 0.1, 0.1), InvalidArgument);
  const Eigen::Matrix2Xd one = Eigen::Matrix2Xd::Zero(2, 1);
  EXPECT_THROW(SimilarityFitInformation(one, {}, kCentre, 0.1, 0.1, 1.0), InvalidArgument);
  const Eigen::Matrix2Xd two = Eigen::Matrix2Xd::Ones(2, 2);
  EXPECT_THROW(SimilarityFitInformation(two, {}, kCentre, 0.1, 0.1, 0.0), InvalidArgument);
  EXPECT_THROW(SimilarityFitInformation(two, {}, kCentre, -1.0, 0.1, 1.0), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::backend::pixel_step_test
