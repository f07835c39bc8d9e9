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
//   kName                           lower-case name for logs and reports;
//   IsDegenerate(prev, curr, idx)   true when the minimal sample idx[0..kMinSample) cannot
//                                   define a model (coincident or collinear points);
//   SolveMinimal(prev, curr, idx, &T)
//                                   model from a minimal sample; false if degenerate or the
//                                   solution is not finite;
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
#pragma once

#include <Eigen/Core>

namespace aerovo {

/// Run-time choice of the motion model (the RANSAC loop itself is a template on the policy).
enum class MotionModel {
  kTranslation,  ///< 2 DoF: shift only.
  kSimilarity,   ///< 4 DoF: rotation, uniform scale, shift (no reflection).
  kAffine,       ///< 6 DoF: the paper's model and MATLAB's estimateGeometricTransform2D 'affine'.
  kHomography,   ///< 8 DoF: projective ('projective' in MATLAB).
};

/// "translation", "similarity", "affine", "homography".
const char* ToString(MotionModel model);
/// Inverse of ToString; throws InvalidArgument naming the accepted values.
MotionModel ParseMotionModel(const char* name);
/// Minimal sample size of the model (1, 2, 3, 4).
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

/// x_curr = x_prev + t.
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

/// x_curr = A x_prev + t, A any 2x2 (the paper's model).
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

/// x_curr ~ H x_prev, H(2,2) = 1 (normalised DLT, Hartley & Zisserman 2003, alg. 4.2).
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

}  // namespace aerovo
