// Geometric models of the frame-to-frame motion, written as policies for the RANSAC loop
// (aerovo/estimation/ransac.h). Every model maps pixel positions of the previous frame to pixel
// positions of the current frame: the transform is curr_from_prev, a 3x3 homogeneous matrix
// acting on column vectors (x, y, 1) in the pixel frame of features/keypoint.h ((0, 0) = centre
// of the top-left pixel, x right, y down). For all models but the homography the last row is
// exactly (0, 0, 1).
//
// Policy interface (static members; no virtual calls, no allocation):
//   kMinSample                      points in a minimal sample;
//   kDof                            degrees of freedom;
//   kName                           lower-case name for logs, reports, the CLI and config files
//                                   (ToString / ParseMotionModel);
//   SolveMinimal(prev, curr, idx, &T)
//                                   model from the minimal sample idx[0..kMinSample); false if
//                                   the sample is degenerate (each model documents which
//                                   samples are) or the solution is not finite. The loop counts
//                                   a false as a degenerate sample;
//   FitLeastSquares(prev, curr, idx, n, &T, weights = nullptr)
//                                   least-squares model from the n >= kMinSample points idx[..]
//                                   on Hartley-normalised coordinates; false if the points do
//                                   not determine the model. weights (optional, >= 0, one per
//                                   idx entry, not all 0) make it the weighted least-squares
//                                   fit (weighted centroids and scatter; for the homography,
//                                   weighted DLT equations), used by the robust polish of
//                                   RansacOptions;
//   SquaredResiduals(T, prev, curr, out)
//                                   out[i] = |T(prev_i) - curr_i|^2 in px^2, for every column
//                                   (one-way transfer error in the current frame, as MATLAB's
//                                   estimateGeometricTransform2D).
// `prev` and `curr` are 2xN matrices of pixel positions, column i being one correspondence.
// The four models below also have IsDegenerate(prev, curr, idx), the sample test their
// SolveMinimal starts with; it is not part of the interface (the loop relies on SolveMinimal's
// false alone: calling IsDegenerate there as well would reject exactly the same samples, see
// ransac_test.cc "DegenerateSamplesAreThoseSolveMinimalRefuses", at the price of a second test).
//
// How to add a motion model (one struct plus one list entry):
//   1. Write its struct with the members above: declaration here, definitions in models.cc.
//      Example: struct RigidModel { static constexpr int kMinSample = 2; static constexpr int
//      kDof = 3; static constexpr const char* kName = "rigid"; static bool SolveMinimal(...);
//      ... };
//   2. Add one entry X(kRigid, RigidModel) to AEROVO_MOTION_MODELS below.
// That entry generates the enumerator MotionModel::kRigid, ToString / ParseMotionModel (from
// kName), MinSampleSize, kAllMotionModels (the CLI's and the config schema's choices),
// MotionModelType<MotionModel::kRigid>, the run-time dispatch VisitMotionModel (used by
// EstimateTransform in ransac.cc) and the typed tests' list ForAllMotionModels. The tests then
// ask for a test transform of the new model (TrueTransform<> in ransac_test.cc, ModelTransform<>
// in models_test.cc), and MotionModelList in models_test.cc, which pins the current list and
// ParseMotionModel's message, for its new entry.
#pragma once

#include <cstddef>
#include <iterator>
#include <utility>

#include <Eigen/Core>

namespace aerovo {

/// THE list of motion models: X(enumerator, policy struct), in the order of the enum. Every
/// place that enumerates the models is generated from it (see "How to add a motion model").
// clang-format off
#define AEROVO_MOTION_MODELS(X)                                                                  \
  X(kTranslation, TranslationModel) /* 2 DoF: shift only. */                                    \
  X(kSimilarity, SimilarityModel)   /* 4 DoF: rotation, uniform scale, shift. */                \
  X(kAffine, AffineModel)           /* 6 DoF: the paper's model, MATLAB's 'affine'. */          \
  X(kHomography, HomographyModel)   /* 8 DoF: projective ('projective' in MATLAB). */
// clang-format on

/// Run-time choice of the motion model (the RANSAC loop itself is a template on the policy).
enum class MotionModel {
#define AEROVO_MOTION_MODEL_ENUMERATOR(e, T) e,
  AEROVO_MOTION_MODELS(AEROVO_MOTION_MODEL_ENUMERATOR)
#undef AEROVO_MOTION_MODEL_ENUMERATOR
};

/// Every MotionModel, in enum order: the choices of a CLI flag or config key (with ToString).
inline constexpr MotionModel kAllMotionModels[] = {
#define AEROVO_MOTION_MODEL_VALUE(e, T) MotionModel::e,
    AEROVO_MOTION_MODELS(AEROVO_MOTION_MODEL_VALUE)
#undef AEROVO_MOTION_MODEL_VALUE
};
inline constexpr std::size_t kNumMotionModels = std::size(kAllMotionModels);

/// The policy's kName: "translation", "similarity", "affine", "homography".
const char* ToString(MotionModel model);
/// Inverse of ToString; throws InvalidArgument naming the accepted values.
MotionModel ParseMotionModel(const char* name);
/// Minimal sample size of the model (the policy's kMinSample: 1, 2, 3, 4).
int MinSampleSize(MotionModel model);

/// The upper 2x3 block of a curr_from_prev transform: the affine map x_curr = A x_prev + t when
/// the last row is (0, 0, 1) (true for translation, similarity and affine models; for a
/// homography it is only the affine part, exact when H(2,0) = H(2,1) = 0 and H(2,2) = 1).
inline Eigen::Matrix<double, 2, 3> AffinePart(const Eigen::Matrix3d& curr_from_prev) {
  return curr_from_prev.topRows<2>();
}

/// 3x3 homogeneous form of a 2x3 affine curr_from_prev.
inline Eigen::Matrix3d FromAffine(const Eigen::Matrix<double, 2, 3>& curr_from_prev) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topRows<2>() = curr_from_prev;
  return m;
}

/// Applies a curr_from_prev transform (with the homogeneous division) to one point (px).
inline Eigen::Vector2d TransformPoint(const Eigen::Matrix3d& curr_from_prev,
                                      const Eigen::Vector2d& prev_px) {
  const Eigen::Vector3d h = curr_from_prev * Eigen::Vector3d(prev_px.x(), prev_px.y(), 1.0);
  return Eigen::Vector2d(h.x() / h.z(), h.y() / h.z());
}

/// Largest distance (px) between the images of the four corner pixel centres (0, 0),
/// (width-1, 0), (0, height-1), (width-1, height-1) under two transforms: the usual measure of
/// how far apart two frame-to-frame transforms are for a width x height frame.
double MaxCornerDisplacementPx(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b, int width,
                               int height);

/// x_curr = x_prev + t. No sample is degenerate.
struct TranslationModel {
  static constexpr int kMinSample = 1;
  static constexpr int kDof = 2;
  static constexpr const char* kName = "translation";
  static bool IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx);
  static bool SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx, Eigen::Matrix3d* curr_from_prev);
  static bool FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                              const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                              const double* weights = nullptr);
  static void SquaredResiduals(const Eigen::Matrix3d& curr_from_prev, const Eigen::Matrix2Xd& prev,
                               const Eigen::Matrix2Xd& curr, double* out);
};

/// x_curr = s R(theta) x_prev + t (rotation and uniform scale, no reflection).
/// Degenerate sample: the two points coincide in prev or in curr (closer than
/// kMinSeparationPx).
struct SimilarityModel {
  static constexpr int kMinSample = 2;
  static constexpr int kDof = 4;
  static constexpr const char* kName = "similarity";
  static constexpr double kMinSeparationPx = 1e-3;
  static bool IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx);
  static bool SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx, Eigen::Matrix3d* curr_from_prev);
  static bool FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                              const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                              const double* weights = nullptr);
  static void SquaredResiduals(const Eigen::Matrix3d& curr_from_prev, const Eigen::Matrix2Xd& prev,
                               const Eigen::Matrix2Xd& curr, double* out);
};

/// x_curr = A x_prev + t, A any 2x2 (the paper's model; MATLAB estimateGeometricTransform2D's
/// 'affine').
/// Degenerate sample: the three points are collinear (or coincident) in prev or in curr, i.e.
/// the triangle's height is below kCollinearTolerance times its longest side.
struct AffineModel {
  static constexpr int kMinSample = 3;
  static constexpr int kDof = 6;
  static constexpr const char* kName = "affine";
  static constexpr double kCollinearTolerance = 1e-2;
  static bool IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx);
  static bool SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx, Eigen::Matrix3d* curr_from_prev);
  static bool FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                              const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                              const double* weights = nullptr);
  static void SquaredResiduals(const Eigen::Matrix3d& curr_from_prev, const Eigen::Matrix2Xd& prev,
                               const Eigen::Matrix2Xd& curr, double* out);
};

/// x_curr ~ H x_prev, H(2,2) = 1 (normalised DLT, Hartley & Zisserman 2003, alg. 4.2;
/// MATLAB's 'projective').
/// Degenerate sample: three of the four points collinear in prev or in curr (tolerance as
/// AffineModel), or the orientations of the four triangles disagree between prev and curr (no
/// homography that keeps the points on one side of the horizon maps them; the check of
/// OpenCV's and USAC's sample filters).
struct HomographyModel {
  static constexpr int kMinSample = 4;
  static constexpr int kDof = 8;
  static constexpr const char* kName = "homography";
  static constexpr double kCollinearTolerance = 1e-2;
  static bool IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx);
  static bool SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                           const int* idx, Eigen::Matrix3d* curr_from_prev);
  static bool FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                              const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                              const double* weights = nullptr);
  static void SquaredResiduals(const Eigen::Matrix3d& curr_from_prev, const Eigen::Matrix2Xd& prev,
                               const Eigen::Matrix2Xd& curr, double* out);
};

/// The policy struct of a MotionModel value: MotionModelType<MotionModel::kAffine> is
/// AffineModel.
template <MotionModel M>
struct MotionModelTraits;
#define AEROVO_MOTION_MODEL_TRAITS(e, T) \
  template <>                            \
  struct MotionModelTraits<MotionModel::e> { using type = T; };
AEROVO_MOTION_MODELS(AEROVO_MOTION_MODEL_TRAITS)
#undef AEROVO_MOTION_MODEL_TRAITS
template <MotionModel M>
using MotionModelType = typename MotionModelTraits<M>::type;

/// Run-time dispatch: calls f(Model{}) with the policy struct of `model` (an empty struct, so a
/// generic lambda gets the type as decltype of its argument) and returns what f returns. One
/// switch per call; whatever f runs is compiled for the static type.
template <class F>
decltype(auto) VisitMotionModel(MotionModel model, F&& f) {
  switch (model) {
#define AEROVO_MOTION_MODEL_CASE(e, T) \
  case MotionModel::e:                 \
    return f(T{});
    AEROVO_MOTION_MODELS(AEROVO_MOTION_MODEL_CASE)
#undef AEROVO_MOTION_MODEL_CASE
  }
  return f(AffineModel{});  // Not reached for a valid enumerator (the paper's model otherwise).
}

namespace internal {
template <template <class...> class List, std::size_t... I>
List<MotionModelType<kAllMotionModels[I]>...> ApplyToMotionModels(std::index_sequence<I...>);
}  // namespace internal

/// List<TranslationModel, SimilarityModel, ...> over every policy, in enum order (e.g. the
/// typed tests' ::testing::Types).
template <template <class...> class List>
using ForAllMotionModels = decltype(internal::ApplyToMotionModels<List>(
    std::make_index_sequence<kNumMotionModels>()));

}  // namespace aerovo
