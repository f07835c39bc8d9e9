#include "aerovo/estimation/models.h"

#include <cmath>
#include <numeric>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/estimation/testing.h"

namespace aerovo::models_test {
namespace {

using testing::kFrameHeight;
using testing::kFrameWidth;
using testing::MakeCorrespondences;

Eigen::Matrix3d GeneralHomography() {
  Eigen::Matrix3d m;
  m << 0.95, -0.12, 40.0, 0.08, 1.07, -25.0, 1e-4, -6e-5, 1;
  return m;
}

template <class Model>
Eigen::Matrix3d ModelTransform() {
  Eigen::Matrix3d h = GeneralHomography();
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  if constexpr (Model::kDof == 2) {
    m.block<2, 1>(0, 2) = h.block<2, 1>(0, 2);
  } else if constexpr (Model::kDof == 4) {
    m << 0.9, -0.3, 40.0, 0.3, 0.9, -25.0, 0, 0, 1;
  } else if constexpr (Model::kDof == 6) {
    m.topRows<2>() = h.topRows<2>();
  } else {
    m = h;
  }
  return m;
}

template <class Model>
class ModelTest : public ::testing::Test {};
using AllModels = ForAllMotionModels<::testing::Types>;
TYPED_TEST_SUITE(ModelTest, AllModels);

// The list generates the same four types, in enum order, as the typed tests listed by hand.
static_assert(std::is_same_v<AllModels, ::testing::Types<TranslationModel, SimilarityModel,
                                                         AffineModel, HomographyModel>>);
static_assert(std::is_same_v<MotionModelType<MotionModel::kHomography>, HomographyModel>);

TYPED_TEST(ModelTest, MinimalSolverAndLeastSquaresAreExactOnExactData) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = ModelTransform<Model>();
  const auto data = MakeCorrespondences(truth, 40, 0, 0.0, 4);
  std::vector<int> idx(40);
  std::iota(idx.begin(), idx.end(), 0);
  Eigen::Matrix3d m;
  ASSERT_TRUE(Model::SolveMinimal(data.prev, data.curr, idx.data(), &m));
  EXPECT_LT(MaxCornerDisplacementPx(m, truth, kFrameWidth, kFrameHeight), 1e-7) << m;
  ASSERT_TRUE(Model::FitLeastSquares(data.prev, data.curr, idx.data(), 40, &m));
  EXPECT_LT(MaxCornerDisplacementPx(m, truth, kFrameWidth, kFrameHeight), 1e-7) << m;
  std::vector<double> r(40);
  Model::SquaredResiduals(m, data.prev, data.curr, r.data());
  for (double v : r) EXPECT_LT(v, 1e-12);
}

TYPED_TEST(ModelTest, SquaredResidualsAreTransferErrors) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = ModelTransform<Model>();
  Eigen::Matrix2Xd prev(2, 2), curr(2, 2);
  prev << 100, 700, 50, 500;
  for (int i = 0; i < 2; ++i) curr.col(i) = TransformPoint(truth, prev.col(i));
  curr(0, 0) += 3.0;  // 3 px off in x.
  curr(1, 1) -= 4.0;  // 4 px off in y.
  double r[2];
  Model::SquaredResiduals(truth, prev, curr, r);
  EXPECT_NEAR(r[0], 9.0, 1e-9);
  EXPECT_NEAR(r[1], 16.0, 1e-9);
}

TYPED_TEST(ModelTest, LeastSquaresAveragesNoise) {
  using Model = TypeParam;
  const Eigen::Matrix3d truth = ModelTransform<Model>();
  const auto data = MakeCorrespondences(truth, 400, 0, 0.5, 6);
  std::vector<int> idx(400);
  std::iota(idx.begin(), idx.end(), 0);
  Eigen::Matrix3d m;
  ASSERT_TRUE(Model::FitLeastSquares(data.prev, data.curr, idx.data(), 400, &m));
  // Standard error of a corner from 400 points with sigma 0.5 px: ~0.1 px for the homography.
  EXPECT_LT(MaxCornerDisplacementPx(m, truth, kFrameWidth, kFrameHeight), 0.35) << m;
}

TEST(MotionModelHelpers, CornersAndAffinePart) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity(), b = Eigen::Matrix3d::Identity();
  b(0, 2) = 3.0;
  b(1, 2) = 4.0;
  EXPECT_DOUBLE_EQ(MaxCornerDisplacementPx(a, b, 800, 600), 5.0);
  b(0, 0) = 1.01;  // Corner (799, 599) moves 7.99 px more in x.
  EXPECT_NEAR(MaxCornerDisplacementPx(a, b, 800, 600), std::hypot(3.0 + 7.99, 4.0), 1e-9);
  const Eigen::Matrix<double, 2, 3> aff = AffinePart(b);
  EXPECT_EQ(FromAffine(aff), b);
  EXPECT_EQ(MinSampleSize(MotionModel::kHomography), 4);
  EXPECT_STREQ(ToString(MotionModel::kAffine), "affine");
}

// Every entry of the model list: ToString is the policy's kName, ParseMotionModel inverts it,
// MinSampleSize is the policy's kMinSample, the dispatch reaches the policy of that value, and
// the values are the enum's, in order, with distinct names.
TEST(MotionModelList, EveryEntryRoundTrips) {
  ASSERT_EQ(kNumMotionModels, 4u);
  std::set<std::string> names;
  for (std::size_t k = 0; k < kNumMotionModels; ++k) {
    const MotionModel m = kAllMotionModels[k];
    EXPECT_EQ(static_cast<std::size_t>(m), k);
    const std::string name = ToString(m);
    names.insert(name);
    EXPECT_EQ(ParseMotionModel(name.c_str()), m) << name;
    VisitMotionModel(m, [&](auto model) {
      using Model = decltype(model);
      EXPECT_EQ(name, Model::kName);
      EXPECT_EQ(MinSampleSize(m), Model::kMinSample) << name;
      // Minimal: each point gives two equations, and one point fewer would not do.
      EXPECT_GE(2 * Model::kMinSample, Model::kDof) << name;
      EXPECT_LT(2 * (Model::kMinSample - 1), Model::kDof) << name;
    });
  }
  EXPECT_EQ(names.size(), kNumMotionModels);
  EXPECT_EQ(MinSampleSize(MotionModel::kTranslation), 1);
  EXPECT_EQ(MinSampleSize(MotionModel::kSimilarity), 2);
  EXPECT_EQ(MinSampleSize(MotionModel::kAffine), 3);
  EXPECT_EQ(MinSampleSize(MotionModel::kHomography), 4);
  EXPECT_STREQ(ToString(static_cast<MotionModel>(99)), "unknown");
  EXPECT_EQ(MinSampleSize(static_cast<MotionModel>(99)), 0);
}

TEST(MotionModelList, ParseNamesEveryAcceptedValue) {
  for (const char* bad : {"projective", "Affine", "", "affine "}) {
    try {
      ParseMotionModel(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(std::string(e.what()),
                "unknown motion model '" + std::string(bad) +
                    "' (expected translation, similarity, affine or homography)");
    }
  }
  EXPECT_THROW(ParseMotionModel(nullptr), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::models_test
