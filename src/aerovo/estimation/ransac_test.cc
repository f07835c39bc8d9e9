#include "aerovo/estimation/ransac.h"

#include <cmath>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/cancel.h"
#include "aerovo/estimation/models.h"
#include "aerovo/estimation/samplers.h"
#include "aerovo/estimation/testing.h"

namespace aerovo::ransac_test {
namespace {

using testing::kFrameHeight;
using testing::kFrameWidth;
using testing::MakeCorrespondences;

// Ground-truth transforms: moderate frame-to-frame motions of a nadir camera.
template <class Model>
Eigen::Matrix3d TrueTransform();

template <>
Eigen::Matrix3d TrueTransform<TranslationModel>() {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m(0, 2) = 23.4;
  m(1, 2) = -17.9;
  return m;
}
template <>
Eigen::Matrix3d TrueTransform<SimilarityModel>() {
  const double s = 1.05, a = 7.0 * kDegToRad;
  Eigen::Matrix3d m;
  m << s * std::cos(a), -s * std::sin(a), 30.0, s * std::sin(a), s * std::cos(a), -12.0, 0, 0, 1;
  return m;
}
template <>
Eigen::Matrix3d TrueTransform<AffineModel>() {
  Eigen::Matrix3d m;
  m << 1.03, 0.04, 15.0, -0.05, 0.97, 25.0, 0, 0, 1;
  return m;
}
template <>
Eigen::Matrix3d TrueTransform<HomographyModel>() {
  Eigen::Matrix3d m;
  m << 1.02, 0.03, 12.0, -0.04, 0.99, -20.0, 2e-5, -3e-5, 1;
  return m;
}

template <class Model>
class RansacModelTest : public ::testing::Test {};
using AllModels = ForAllMotionModels<::testing::Types>;
TYPED_TEST_SUITE(RansacModelTest, AllModels);

// Trials needed by the closed-form rule: a 4-point homography at 20 % inliers needs 2876 samples
// for 99 % confidence, more than MATLAB's default cap of 1000.
template <class Model>
RansacOptions OptionsFor(double outlier_fraction) {
  RansacOptions o;
  const int needed =
      RansacTrialCount(o.confidence_percent, 1.0 - outlier_fraction, Model::kMinSample);
  o.max_num_trials = std::max(o.max_num_trials, needed);
  return o;
}

TYPED_TEST(RansacModelTest, RecoversTransformWithNoiseAndOutliers) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  for (double outliers : {0.1, 0.5, 0.8}) {
    const int n = 500;
    const int n_out = static_cast<int>(std::lround(outliers * n));
    const auto data = MakeCorrespondences(truth, n - n_out, n_out, 0.5, 7);
    Ransac<Model> ransac(OptionsFor<Model>(outliers));
    const RansacResult r = ransac.Estimate(data.prev, data.curr);
    ASSERT_TRUE(r.success) << Model::kName << " outliers " << outliers;
    EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, truth, kFrameWidth, kFrameHeight), 1.0)
        << Model::kName << " outliers " << outliers << "\n"
        << r.curr_from_prev;
    // With 0.5 px noise per coordinate ~1 % of inliers exceed 1.5 px; no outlier comes closer
    // than 5 px.
    int false_pos = 0;
    for (int i = 0; i < n; ++i) false_pos += r.inlier_mask[i] && !data.is_inlier[i];
    EXPECT_EQ(false_pos, 0);
    EXPECT_GT(r.num_inliers, 0.95 * (n - n_out));
    EXPECT_LE(r.num_inliers, n - n_out);
  }
}

TYPED_TEST(RansacModelTest, ExactInlierMaskWithoutNoise) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  for (double outliers : {0.1, 0.5, 0.8}) {
    const int n = 500;
    const int n_out = static_cast<int>(std::lround(outliers * n));
    const auto data = MakeCorrespondences(truth, n - n_out, n_out, 0.0, 11);
    Ransac<Model> ransac(OptionsFor<Model>(outliers));
    const RansacResult r = ransac.Estimate(data.prev, data.curr);
    ASSERT_TRUE(r.success) << Model::kName << " outliers " << outliers;
    EXPECT_EQ(r.inlier_mask, data.is_inlier) << Model::kName << " outliers " << outliers;
    EXPECT_EQ(r.num_inliers, n - n_out);
    EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, truth, kFrameWidth, kFrameHeight), 1e-6);
    // MSAC cost: inliers contribute ~0, each outlier the truncation 1.5^2.
    EXPECT_NEAR(r.score, n_out * 2.25, 1e-6);
  }
}

TYPED_TEST(RansacModelTest, SameSeedSameResultOtherSeedStillCorrect) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  const auto data = MakeCorrespondences(truth, 250, 250, 0.5, 3);
  RansacOptions o;
  o.seed = 12345;
  Ransac<Model> a(o), b(o);
  const RansacResult ra = a.Estimate(data.prev, data.curr);
  const RansacResult rb = b.Estimate(data.prev, data.curr);
  const RansacResult ra2 = a.Estimate(data.prev, data.curr);  // Reused instance.
  ASSERT_TRUE(ra.success);
  EXPECT_EQ(ra.curr_from_prev, rb.curr_from_prev);
  EXPECT_EQ(ra.inlier_mask, rb.inlier_mask);
  EXPECT_EQ(ra.num_trials, rb.num_trials);
  EXPECT_EQ(ra.curr_from_prev, ra2.curr_from_prev);
  EXPECT_EQ(ra.inlier_mask, ra2.inlier_mask);
  for (std::uint64_t seed : {1u, 2u, 99u, 2024u}) {
    o.seed = seed;
    Ransac<Model> c(o);
    const RansacResult rc = c.Estimate(data.prev, data.curr);
    ASSERT_TRUE(rc.success) << "seed " << seed;
    EXPECT_LT(MaxCornerDisplacementPx(rc.curr_from_prev, truth, kFrameWidth, kFrameHeight), 1.0)
        << "seed " << seed;
  }
}

TYPED_TEST(RansacModelTest, ProsacAndLocalOptimisationRecover) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  const auto data = MakeCorrespondences(truth, 250, 250, 0.5, 5);
  RansacOptions o;
  o.local_optimization = true;
  Ransac<Model, ProsacSampler> ransac(o);
  const RansacResult r = ransac.Estimate(data.prev, data.curr, data.quality.data());
  ASSERT_TRUE(r.success);
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, truth, kFrameWidth, kFrameHeight), 1.0);
}

TEST(RansacTrialCount, ClosedForm) {
  // ceil(log(1 - 0.99) / log(1 - w^m)).
  EXPECT_EQ(RansacTrialCount(99.0, 0.5, 3), 35);
  EXPECT_EQ(RansacTrialCount(99.0, 0.5, 4), 72);
  EXPECT_EQ(RansacTrialCount(99.0, 0.2, 3), 574);
  EXPECT_EQ(RansacTrialCount(99.0, 0.2, 4), 2876);
  EXPECT_EQ(RansacTrialCount(99.0, 0.1, 3), 4603);
  EXPECT_EQ(RansacTrialCount(99.0, 0.5, 1), 7);
  EXPECT_EQ(RansacTrialCount(99.0, 1.0, 3), 0);
  EXPECT_EQ(RansacTrialCount(99.0, 0.0, 3), std::numeric_limits<std::int32_t>::max());
}

// Noise-free data with inlier ratio exactly 1/2: once an all-inlier sample is scored the trial
// limit drops to RansacTrialCount(99, 0.5, 3) = 35.
TEST(RansacLoop, TrialCountAdaptsToInlierRatio) {
  const Eigen::Matrix3d truth = TrueTransform<AffineModel>();
  auto data = MakeCorrespondences(truth, 100, 100, 0.0, 21);
  // PROSAC tries the best-ranked matches first: rank the inliers best, so sample 1 is clean.
  for (std::size_t i = 0; i < data.quality.size(); ++i) data.quality[i] = data.is_inlier[i] ? 0 : 1;
  Ransac<AffineModel, ProsacSampler> prosac;
  const RansacResult rp = prosac.Estimate(data.prev, data.curr, data.quality.data());
  ASSERT_TRUE(rp.success);
  EXPECT_EQ(rp.num_inliers, 100);
  EXPECT_EQ(rp.num_trials, 35);

  // Uniform sampling: the loop stops at max(35, index of the first clean non-degenerate sample).
  RansacOptions o;
  o.seed = 77;
  Ransac<AffineModel> uniform(o);
  const RansacResult ru = uniform.Estimate(data.prev, data.curr);
  UniformSampler replay;
  replay.Reset(o.seed, 200, 3, nullptr);
  int first_clean = 0;
  for (int scored = 0;;) {
    int s[3];
    replay.Draw(s);
    if (AffineModel::IsDegenerate(data.prev, data.curr, s)) continue;
    ++scored;
    if (data.is_inlier[s[0]] && data.is_inlier[s[1]] && data.is_inlier[s[2]]) {
      first_clean = scored;
      break;
    }
  }
  ASSERT_TRUE(ru.success);
  EXPECT_EQ(ru.num_inliers, 100);
  EXPECT_EQ(ru.num_trials, std::max(35, first_clean));

  // Inlier ratio 0.1: even the true model asks for 4603 samples, so MATLAB's cap of 1000 ends
  // the loop (whether or not a clean sample was among them: P = 1 - 0.999^1000 = 63 %).
  const auto sparse = MakeCorrespondences(truth, 30, 270, 0.0, 22);
  Ransac<AffineModel> capped;
  const RansacResult rc = capped.Estimate(sparse.prev, sparse.curr);
  EXPECT_EQ(rc.num_trials, 1000);
  RansacOptions more;
  more.max_num_trials = 5000;
  Ransac<AffineModel> uncapped(more);
  const RansacResult rm = uncapped.Estimate(sparse.prev, sparse.curr);
  ASSERT_TRUE(rm.success);
  EXPECT_EQ(rm.inlier_mask, sparse.is_inlier);
  // Stops at 4603 if the first clean sample came earlier, else right at that sample.
  EXPECT_GE(rm.num_trials, 4603);
}

// A stop request (core/cancel.h) ends the trial loop with Cancelled; a clear flag changes
// nothing (same trials, same model).
TEST(RansacLoop, AStopRequestEndsTheLoop) {
  const Eigen::Matrix3d truth = TrueTransform<AffineModel>();
  const auto sparse = MakeCorrespondences(truth, 30, 270, 0.0, 22);
  Ransac<AffineModel> ransac;
  const RansacResult plain = ransac.Estimate(sparse.prev, sparse.curr);
  std::atomic<bool> stop{false};
  const CancelScope scope(&stop);
  const RansacResult same = ransac.Estimate(sparse.prev, sparse.curr);
  EXPECT_EQ(same.num_trials, plain.num_trials);
  EXPECT_EQ(same.inlier_mask, plain.inlier_mask);
  stop = true;
  EXPECT_THROW(ransac.Estimate(sparse.prev, sparse.curr), Cancelled);
}

TEST(Degeneracy, CollinearAndCoincidentSamplesAreRejected) {
  Eigen::Matrix2Xd prev(2, 4), curr(2, 4);
  // Points 0, 1, 2 collinear; 3 off the line.
  prev << 10, 110, 210, 50, 20, 70, 120, 300;
  curr = prev.array() + 5.0;
  const int tri[3] = {0, 1, 2};
  const int quad[4] = {0, 1, 2, 3};
  Eigen::Matrix3d m;
  EXPECT_TRUE(AffineModel::IsDegenerate(prev, curr, tri));
  EXPECT_FALSE(AffineModel::SolveMinimal(prev, curr, tri, &m));
  EXPECT_TRUE(HomographyModel::IsDegenerate(prev, curr, quad));
  EXPECT_FALSE(HomographyModel::SolveMinimal(prev, curr, quad, &m));
  const int good[3] = {0, 1, 3};
  EXPECT_FALSE(AffineModel::IsDegenerate(prev, curr, good));
  EXPECT_TRUE(AffineModel::SolveMinimal(prev, curr, good, &m));
  // Non-collinear in prev, collinear in curr: no affine maps a triangle onto a line.
  Eigen::Matrix2Xd flat = curr;
  // Put curr point 3 on the line through curr points 0 and 1.
  flat(1, 3) = curr(1, 0) +
               (curr(1, 1) - curr(1, 0)) * (flat(0, 3) - curr(0, 0)) / (curr(0, 1) - curr(0, 0));
  EXPECT_FALSE(AffineModel::SolveMinimal(prev, flat, good, &m));
  // Coincident points.
  Eigen::Matrix2Xd same(2, 3);
  same << 5, 5, 40, 7, 7, 90;
  const int pair[2] = {0, 1};
  EXPECT_FALSE(SimilarityModel::SolveMinimal(same, same, pair, &m));
  EXPECT_FALSE(AffineModel::SolveMinimal(same, same, tri, &m));
}

TYPED_TEST(RansacModelTest, AllCollinearDataNeverProducesAModel) {
  using Model = TypeParam;
  if (Model::kMinSample < 3) GTEST_SKIP() << "a line determines " << Model::kName;
  const int n = 200;
  Eigen::Matrix2Xd prev(2, n), curr(2, n);
  for (int i = 0; i < n; ++i) {
    const double x = 3.7 * i;
    prev.col(i) = Eigen::Vector2d(x, 0.4 * x + 17);
    curr.col(i) = TransformPoint(TrueTransform<AffineModel>(), prev.col(i));
  }
  Ransac<Model> ransac;
  const RansacResult r = ransac.Estimate(prev, curr);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.num_trials, 0);
  EXPECT_EQ(r.num_inliers, 0);
  EXPECT_EQ(r.num_degenerate_samples, ransac.options().max_degenerate_samples + 1);
  EXPECT_EQ(r.curr_from_prev, Eigen::Matrix3d::Identity());
  // The least-squares fit refuses collinear inliers as well.
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  Eigen::Matrix3d m;
  EXPECT_FALSE(Model::FitLeastSquares(prev, curr, all.data(), n, &m));
}

// Noise comparable to the threshold: the returned model must be (close to) the least-squares
// fit on its own inlier set, not on the best minimal sample's spatially biased one.
TEST(RansacLoop, FinalRefitConvergesToItsOwnInliers) {
  const Eigen::Matrix3d truth = TrueTransform<AffineModel>();
  const auto data = MakeCorrespondences(truth, 3000, 300, 0.6, 31);
  Ransac<AffineModel> ransac;
  const RansacResult r = ransac.Estimate(data.prev, data.curr);
  ASSERT_TRUE(r.success);
  std::vector<int> idx;
  for (int i = 0; i < static_cast<int>(r.inlier_mask.size()); ++i) {
    if (r.inlier_mask[i]) idx.push_back(i);
  }
  Eigen::Matrix3d own;
  ASSERT_TRUE(AffineModel::FitLeastSquares(data.prev, data.curr, idx.data(),
                                           static_cast<int>(idx.size()), &own));
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, own, kFrameWidth, kFrameHeight), 0.01);
  // Standard error of a corner from ~2900 points with sigma 0.6 px: ~0.03 px.
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, truth, kFrameWidth, kFrameHeight), 0.08);
}

// Weighted least squares (the polish's fit): weight 0 removes a point, a common weight changes
// nothing, and unequal weights pull the fit toward the heavy points.
TYPED_TEST(RansacModelTest, WeightedFitMatchesTheUnweightedFitOfTheWeightedPoints) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  const auto data = MakeCorrespondences(truth, 200, 100, 0.5, 11);
  const int n = static_cast<int>(data.prev.cols());
  std::vector<int> all(n), inliers;
  std::vector<double> w01(n), w_common(n, 2.5);
  for (int i = 0; i < n; ++i) {
    all[i] = i;
    w01[i] = data.is_inlier[i] ? 1.0 : 0.0;
    if (data.is_inlier[i]) inliers.push_back(i);
  }
  Eigen::Matrix3d on_inliers, weighted, plain, common;
  ASSERT_TRUE(Model::FitLeastSquares(data.prev, data.curr, inliers.data(),
                                     static_cast<int>(inliers.size()), &on_inliers));
  ASSERT_TRUE(Model::FitLeastSquares(data.prev, data.curr, all.data(), n, &weighted, w01.data()));
  EXPECT_LT(MaxCornerDisplacementPx(weighted, on_inliers, kFrameWidth, kFrameHeight), 1e-6)
      << Model::kName;
  EXPECT_LT(MaxCornerDisplacementPx(on_inliers, truth, kFrameWidth, kFrameHeight), 1.0);
  ASSERT_TRUE(Model::FitLeastSquares(data.prev, data.curr, all.data(), n, &plain));
  ASSERT_TRUE(
      Model::FitLeastSquares(data.prev, data.curr, all.data(), n, &common, w_common.data()));
  EXPECT_LT(MaxCornerDisplacementPx(common, plain, kFrameWidth, kFrameHeight), 1e-6)
      << Model::kName;
  // The outliers drag the unweighted fit far away; weights that nearly silence them do not.
  EXPECT_GT(MaxCornerDisplacementPx(plain, truth, kFrameWidth, kFrameHeight), 5.0);
  std::vector<double> w_small = w01;
  for (double& w : w_small) w = w > 0 ? 1.0 : 1e-6;
  ASSERT_TRUE(
      Model::FitLeastSquares(data.prev, data.curr, all.data(), n, &weighted, w_small.data()));
  EXPECT_LT(MaxCornerDisplacementPx(weighted, on_inliers, kFrameWidth, kFrameHeight), 0.01)
      << Model::kName;
  // All weights zero determine nothing.
  std::vector<double> zeros(n, 0.0);
  EXPECT_FALSE(
      Model::FitLeastSquares(data.prev, data.curr, all.data(), n, &weighted, zeros.data()));
}

// Two layers 1.4 px apart (a non-planar scene seen by an affine model) plus outliers: the
// hard-thresholded estimate depends on which layer the seed's best sample favours; the polish
// (smooth loss over all correspondences) ends at the same model for every seed, and still
// recovers an exact transform with an exact inlier mask.
TEST(RansacPolish, MakesTheEstimateIndependentOfTheSeed) {
  const Eigen::Matrix3d truth = TrueTransform<AffineModel>();
  Eigen::Matrix3d layer = truth;
  layer(0, 2) += 1.2;
  layer(1, 2) -= 0.7;
  const auto a = MakeCorrespondences(truth, 300, 150, 0.4, 5);
  const auto b = MakeCorrespondences(layer, 200, 0, 0.4, 6);
  Eigen::Matrix2Xd prev(2, a.prev.cols() + b.prev.cols()), curr(2, prev.cols());
  prev << a.prev, b.prev;
  curr << a.curr, b.curr;
  RansacOptions plain_options, polish_options;
  polish_options.polish_iterations = 50;
  std::vector<Eigen::Matrix3d> plain, polished;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    plain_options.seed = polish_options.seed = seed;
    const RansacResult r = Ransac<AffineModel>(plain_options).Estimate(prev, curr);
    const RansacResult p = Ransac<AffineModel>(polish_options).Estimate(prev, curr);
    ASSERT_TRUE(r.success && p.success);
    plain.push_back(r.curr_from_prev);
    polished.push_back(p.curr_from_prev);
    // Between the two layers, nearer the larger one.
    EXPECT_LT(MaxCornerDisplacementPx(p.curr_from_prev, truth, kFrameWidth, kFrameHeight), 1.4);
  }
  double plain_spread = 0, polished_spread = 0;
  for (std::size_t k = 1; k < plain.size(); ++k) {
    plain_spread = std::max(plain_spread,
                            MaxCornerDisplacementPx(plain[k], plain[0], kFrameWidth, kFrameHeight));
    polished_spread = std::max(polished_spread, MaxCornerDisplacementPx(polished[k], polished[0],
                                                                        kFrameWidth, kFrameHeight));
  }
  // The scene does exercise the problem (spreads 50x the polished bound; 0.071 px on aarch64,
  // whose libm rounds the generated data differently from x86)...
  EXPECT_GT(plain_spread, 0.05);
  EXPECT_LT(polished_spread, 1e-3)
      << "plain spread " << plain_spread;  // ...and the polish fixes it.

  // Exact data: the polish keeps the mask exact; the transform moves by what the smooth loss's
  // small weights of near outliers (5-10 px away: 0.07-0.007) pull, a few thousandths of a px.
  const auto exact = MakeCorrespondences(truth, 300, 200, 0.0, 9);
  const RansacResult e = Ransac<AffineModel>(polish_options).Estimate(exact.prev, exact.curr);
  ASSERT_TRUE(e.success);
  EXPECT_LT(MaxCornerDisplacementPx(e.curr_from_prev, truth, kFrameWidth, kFrameHeight), 0.01);
  EXPECT_EQ(e.inlier_mask, exact.is_inlier);
  EXPECT_EQ(e.num_inliers, 300);
}

TEST(RansacPolish, BadOptionsThrow) {
  RansacOptions o;
  o.polish_iterations = -1;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o.polish_iterations = 5;
  o.polish_scale_px = 0.0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o.polish_scale_px = std::numeric_limits<double>::infinity();
  EXPECT_THROW(Validate(o), InvalidArgument);
}

TEST(RansacLoop, TooFewPointsIsAFailureNotAnError) {
  const auto data = MakeCorrespondences(TrueTransform<AffineModel>(), 2, 0, 0.0, 1);
  Ransac<AffineModel> ransac;
  const RansacResult r = ransac.Estimate(data.prev, data.curr);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.inlier_mask.size(), 2u);
}

TEST(RansacLoop, BadInputAndOptionsThrow) {
  Ransac<AffineModel> ransac;
  EXPECT_THROW(ransac.Estimate(Eigen::Matrix2Xd::Zero(2, 5), Eigen::Matrix2Xd::Zero(2, 4)),
               InvalidArgument);
  Eigen::Matrix2Xd bad = Eigen::Matrix2Xd::Ones(2, 5);
  bad(1, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ransac.Estimate(bad, Eigen::Matrix2Xd::Ones(2, 5)), InvalidArgument);
  RansacOptions o;
  o.confidence_percent = 100.0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o = {};
  o.max_distance_px = 0.0;
  EXPECT_THROW(Ransac<AffineModel>{o}, InvalidArgument);
  o = {};
  o.max_num_trials = 0;
  EXPECT_THROW(Validate(o), InvalidArgument);
}

TEST(RansacLoop, RuntimeDispatchMatchesTemplate) {
  const Eigen::Matrix3d truth = TrueTransform<HomographyModel>();
  const auto data = MakeCorrespondences(truth, 300, 200, 0.5, 8);
  RansacWorkspace ws;
  RansacOptions o;
  const RansacResult a = EstimateTransform(MotionModel::kHomography, SamplerKind::kUniform, o,
                                           data.prev, data.curr, nullptr, ws);
  Ransac<HomographyModel> ransac(o);
  const RansacResult b = ransac.Estimate(data.prev, data.curr);
  EXPECT_EQ(a.curr_from_prev, b.curr_from_prev);
  EXPECT_EQ(a.inlier_mask, b.inlier_mask);
  EXPECT_EQ(ParseMotionModel("similarity"), MotionModel::kSimilarity);
  EXPECT_THROW(ParseMotionModel("projective"), InvalidArgument);
}

// ------------------------------------------------------------------- policies plugged in

// Classic RANSAC's support (Fischler & Bolles 1981): the cost is the number of outliers.
struct InlierCountScorer {
  static double Cost(const double* r, int n, double threshold2, int* num_inliers) {
    int c = 0;
    for (int i = 0; i < n; ++i) c += r[i] < threshold2;
    *num_inliers = c;
    return static_cast<double>(n - c);
  }
};

// Noise-free data: the inlier-count scorer finds the exact model and mask, and the result's score
// is its cost (the number of outliers), not MSAC's.
TYPED_TEST(RansacModelTest, CustomScorerIsTheLoopsCost) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  const auto data = MakeCorrespondences(truth, 300, 200, 0.0, 13);
  Ransac<Model, UniformSampler, InlierCountScorer> ransac(OptionsFor<Model>(0.4));
  const RansacResult r = ransac.Estimate(data.prev, data.curr);
  ASSERT_TRUE(r.success) << Model::kName;
  EXPECT_EQ(r.inlier_mask, data.is_inlier) << Model::kName;
  EXPECT_EQ(r.num_inliers, 300);
  EXPECT_EQ(r.score, 200.0);
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, truth, kFrameWidth, kFrameHeight), 1e-6);
}

// Two motions in one set: 600 correspondences of A with 0.8 px noise per coordinate (~83 %
// within 1.5 px, MSAC cost ~1.06 px^2 each) and 400 exact ones of B, 25 px away. MSAC prefers B
// (cost 600 * 2.25 = 1350 against ~640 + 400 * 2.25 = 1540); counting inliers prefers A (~500
// against 400). The scorer policy alone decides which one the loop returns.
TEST(RansacPolicies, TheScorerDecidesBetweenTwoMotions) {
  const Eigen::Matrix3d a = TrueTransform<AffineModel>();
  Eigen::Matrix3d b = a;
  b(0, 2) += 20.0;
  b(1, 2) -= 15.0;
  const auto da = MakeCorrespondences(a, 600, 0, 0.8, 41);
  const auto db = MakeCorrespondences(b, 400, 0, 0.0, 42);
  Eigen::Matrix2Xd prev(2, 1000), curr(2, 1000);
  prev << da.prev, db.prev;
  curr << da.curr, db.curr;
  RansacOptions o;
  o.confidence_percent = 99.9999;  // So that both motions are sampled whichever is found first.
  const RansacResult msac = Ransac<AffineModel>(o).Estimate(prev, curr);
  const RansacResult count =
      Ransac<AffineModel, UniformSampler, InlierCountScorer>(o).Estimate(prev, curr);
  ASSERT_TRUE(msac.success && count.success);
  EXPECT_LT(MaxCornerDisplacementPx(msac.curr_from_prev, b, kFrameWidth, kFrameHeight), 1e-6);
  EXPECT_EQ(msac.num_inliers, 400);
  EXPECT_LT(MaxCornerDisplacementPx(count.curr_from_prev, a, kFrameWidth, kFrameHeight), 0.5);
  EXPECT_GT(count.num_inliers, 450);
  for (int i = 600; i < 1000; ++i) EXPECT_EQ(count.inlier_mask[i], 0) << i;
}

// Wraps the default optimiser and counts the loop's calls of each hook.
struct CountingOptimizer {
  static inline int local_calls = 0;
  static inline int final_calls = 0;
  template <class State>
  static void Local(State& s) {
    ++local_calls;
    LeastSquaresOptimizer::Local(s);
  }
  template <class State>
  static void Final(State& s) {
    ++final_calls;
    LeastSquaresOptimizer::Final(s);
  }
};

// MATLAB's estimator: no local optimisation, one refit, built from the building blocks.
struct SingleRefitOptimizer {
  template <class State>
  static void Local(State&) {}
  template <class State>
  static void Final(State& s) {
    FinalRefit(s, 1);
  }
};

// Local optimisation on every new best model whatever the options say.
struct AlwaysLocalOptimizer {
  template <class State>
  static void Local(State& s) {
    RefitWhileCostImproves(s, 4);
  }
  template <class State>
  static void Final(State& s) {
    LeastSquaresOptimizer::Final(s);
  }
};

// Replaces the result by a known model (the ground truth), through the state's Score / Accept.
struct OracleOptimizer {
  static inline Eigen::Matrix3d oracle = Eigen::Matrix3d::Identity();
  template <class State>
  static void Local(State&) {}
  template <class State>
  static void Final(State& s) {
    int inl = 0;
    const double cost = s.Score(oracle, s.ws.residuals.data(), &inl);
    s.Accept(oracle, cost, inl, s.ws.residuals);
  }
};

TYPED_TEST(RansacModelTest, OptimizerHooksAreCalledAsDocumented) {
  using Model = TypeParam;
  const auto data = MakeCorrespondences(TrueTransform<Model>(), 250, 250, 0.5, 17);
  RansacOptions o;
  o.local_optimization = true;
  o.polish_iterations = 10;
  CountingOptimizer::local_calls = CountingOptimizer::final_calls = 0;
  const RansacResult counted =
      Ransac<Model, UniformSampler, MsacScorer, CountingOptimizer>(o).Estimate(data.prev,
                                                                               data.curr);
  const RansacResult plain = Ransac<Model>(o).Estimate(data.prev, data.curr);
  ASSERT_TRUE(plain.success);
  EXPECT_EQ(counted.curr_from_prev, plain.curr_from_prev);
  EXPECT_EQ(counted.inlier_mask, plain.inlier_mask);
  EXPECT_EQ(counted.num_trials, plain.num_trials);
  EXPECT_EQ(CountingOptimizer::final_calls, 1);
  EXPECT_GE(CountingOptimizer::local_calls, 1);
  EXPECT_LE(CountingOptimizer::local_calls, plain.num_trials);
}

TEST(RansacPolicies, NoModelNoFinalStep) {
  const int n = 100;
  Eigen::Matrix2Xd prev(2, n), curr(2, n);
  for (int i = 0; i < n; ++i) {
    prev.col(i) = Eigen::Vector2d(3.7 * i, 0.4 * 3.7 * i + 17);
    curr.col(i) = TransformPoint(TrueTransform<AffineModel>(), prev.col(i));
  }
  CountingOptimizer::local_calls = CountingOptimizer::final_calls = 0;
  const RansacResult r =
      Ransac<AffineModel, UniformSampler, MsacScorer, CountingOptimizer>().Estimate(prev, curr);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(CountingOptimizer::local_calls, 0);
  EXPECT_EQ(CountingOptimizer::final_calls, 0);
}

// Optimisers composed from the building blocks give, bit for bit, what the default optimiser
// gives with the equivalent options.
TYPED_TEST(RansacModelTest, ComposedOptimizersMatchTheEquivalentOptions) {
  using Model = TypeParam;
  const auto data = MakeCorrespondences(TrueTransform<Model>(), 300, 200, 0.7, 19);
  RansacOptions one_refit;
  one_refit.final_refit_iterations = 1;
  const RansacResult a = Ransac<Model>(one_refit).Estimate(data.prev, data.curr);
  const RansacResult b =
      Ransac<Model, UniformSampler, MsacScorer, SingleRefitOptimizer>().Estimate(data.prev,
                                                                                 data.curr);
  ASSERT_TRUE(a.success);
  EXPECT_EQ(a.curr_from_prev, b.curr_from_prev);
  EXPECT_EQ(a.inlier_mask, b.inlier_mask);
  EXPECT_EQ(a.score, b.score);

  RansacOptions lo;
  lo.local_optimization = true;
  const RansacResult c = Ransac<Model, ProsacSampler>(lo).Estimate(data.prev, data.curr,
                                                                   data.quality.data());
  const RansacResult d = Ransac<Model, ProsacSampler, MsacScorer, AlwaysLocalOptimizer>().Estimate(
      data.prev, data.curr, data.quality.data());
  ASSERT_TRUE(c.success);
  EXPECT_EQ(c.curr_from_prev, d.curr_from_prev);
  EXPECT_EQ(c.inlier_mask, d.inlier_mask);
  EXPECT_EQ(c.num_trials, d.num_trials);
  // And the options do matter here (else the equalities above would prove nothing).
  const RansacResult e = Ransac<Model>().Estimate(data.prev, data.curr);
  EXPECT_NE(a.curr_from_prev, e.curr_from_prev);
}

// Whatever model an optimiser accepts, the result's mask, count and score are that model's.
TYPED_TEST(RansacModelTest, AnAcceptedModelIsReturnedWithItsOwnMaskAndScore) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  const auto data = MakeCorrespondences(truth, 300, 200, 0.6, 23);
  OracleOptimizer::oracle = truth;
  const RansacResult r =
      Ransac<Model, UniformSampler, MsacScorer, OracleOptimizer>().Estimate(data.prev, data.curr);
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.curr_from_prev, truth);
  const int n = static_cast<int>(data.prev.cols());
  std::vector<double> r2(n);
  Model::SquaredResiduals(truth, data.prev, data.curr, r2.data());
  int inliers = 0;
  double msac = 0.0;
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(r.inlier_mask[i], r2[i] < 2.25 ? 1 : 0) << i;
    inliers += r2[i] < 2.25;
    msac += std::min(r2[i], 2.25);
  }
  EXPECT_EQ(r.num_inliers, inliers);
  EXPECT_NEAR(r.score, msac, 1e-9 * msac);
  for (int i = 0; i < n; ++i) {
    if (!data.is_inlier[i]) {
      EXPECT_EQ(r.inlier_mask[i], 0);
    }
  }
}

// The loop does not call IsDegenerate: SolveMinimal starts with it, so every sample it flags is
// one SolveMinimal refuses (and the loop counts as degenerate). Points on a coarse grid with
// repeats make such samples frequent.
TYPED_TEST(RansacModelTest, DegenerateSamplesAreThoseSolveMinimalRefuses) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = TrueTransform<Model>();
  const int n = 60;
  Eigen::Matrix2Xd prev(2, n), curr(2, n);
  for (int i = 0; i < n; ++i) {
    prev.col(i) = Eigen::Vector2d(100.0 * (i % 4), 80.0 * ((i / 4) % 3));
    curr.col(i) = TransformPoint(truth, prev.col(i));
    if (i % 7 == 0) curr.col(i) += Eigen::Vector2d(3.0, -2.0);
  }
  UniformSampler sampler;
  sampler.Reset(5, n, Model::kMinSample, nullptr);
  int flagged = 0, refused = 0;
  for (int t = 0; t < 20000; ++t) {
    int idx[Model::kMinSample];
    sampler.Draw(idx);
    Eigen::Matrix3d m;
    const bool solved = Model::SolveMinimal(prev, curr, idx, &m);
    refused += !solved;
    if (Model::IsDegenerate(prev, curr, idx)) {
      ++flagged;
      EXPECT_FALSE(solved) << Model::kName << " sample " << t;
    }
  }
  EXPECT_LE(flagged, refused);
  if (Model::kMinSample >= 2) {
    EXPECT_GT(flagged, 1000) << Model::kName;
  }
}

// The run-time dispatch reaches RunRansac with the policies of every (model, sampler) entry.
TYPED_TEST(RansacModelTest, RuntimeDispatchMatchesTheTemplateForEverySampler) {
  using Model = TypeParam;
  const auto data = MakeCorrespondences(TrueTransform<Model>(), 300, 200, 0.5, 29);
  RansacOptions o;
  o.seed = 3;
  MotionModel value = MotionModel::kAffine;
  for (MotionModel m : kAllMotionModels) {
    if (std::string(ToString(m)) == Model::kName) value = m;
  }
  for (SamplerKind kind : kAllSamplerKinds) {
    RansacWorkspace ws_dispatch, ws_template;
    const RansacResult a = EstimateTransform(value, kind, o, data.prev, data.curr,
                                             data.quality.data(), ws_dispatch);
    const RansacResult b = VisitSampler(kind, [&](auto& sampler) {
      return RunRansac<Model>(o, data.prev, data.curr, data.quality.data(), sampler, ws_template);
    });
    ASSERT_TRUE(a.success) << Model::kName << " " << ToString(kind);
    EXPECT_EQ(a.curr_from_prev, b.curr_from_prev) << Model::kName << " " << ToString(kind);
    EXPECT_EQ(a.inlier_mask, b.inlier_mask);
    EXPECT_EQ(a.num_trials, b.num_trials);
  }
}

}  // namespace
}  // namespace aerovo::ransac_test
