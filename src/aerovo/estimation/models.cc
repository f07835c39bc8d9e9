#include "aerovo/estimation/models.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include <Eigen/Dense>

#include "aerovo/core/error.h"

namespace aerovo {
namespace {

// Residual given to points that a homography sends to or beyond the line at infinity: far
// above any threshold, finite so that sums stay finite.
constexpr double kHugeResidualPx2 = 1e30;

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Signed twice-area of (a, b, c); 0 when the triangle is "thin": its height is at most
// `tolerance` times its longest side (covers coincident points too).
double ThinAwareCross(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                      double tolerance) {
  const Eigen::Vector2d ab = b - a, ac = c - a, bc = c - b;
  const double cross = Cross(ab, ac);
  const double longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
  // height = |cross| / longest; thin when height <= tolerance * longest.
  if (std::abs(cross) <= tolerance * longest2) return 0.0;
  return cross;
}

// Weight of the k-th fitted point (all 1 without weights).
inline double WeightAt(const double* weights, int k) {
  return weights == nullptr ? 1.0 : weights[k];
}

// Hartley normalisation: translate the centroid to the origin and scale so that the mean
// distance to it is sqrt(2). Returns false when all points coincide (or all weights are 0).
struct Normalizer {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double scale = 1.0;

  // weights: one per idx entry (nullptr = all 1); weighted centroid and mean distance.
  bool Compute(const Eigen::Matrix2Xd& pts, const int* idx, int n, const double* weights) {
    centroid.setZero();
    double total = 0.0;
    for (int k = 0; k < n; ++k) {
      const double w = WeightAt(weights, k);
      centroid += w * pts.col(idx[k]);
      total += w;
    }
    if (!(total > 0.0)) return false;
    centroid /= total;
    double mean_dist = 0.0;
    for (int k = 0; k < n; ++k)
      mean_dist += WeightAt(weights, k) * (pts.col(idx[k]) - centroid).norm();
    mean_dist /= total;
    if (!(mean_dist > 1e-12)) return false;
    scale = std::sqrt(2.0) / mean_dist;
    return true;
  }
  Eigen::Vector2d Apply(const Eigen::Vector2d& p) const { return scale * (p - centroid); }
  Eigen::Matrix3d Matrix() const {
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    m(0, 0) = m(1, 1) = scale;
    m(0, 2) = -scale * centroid.x();
    m(1, 2) = -scale * centroid.y();
    return m;
  }
  Eigen::Matrix3d InverseMatrix() const {
    Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
    m(0, 0) = m(1, 1) = 1.0 / scale;
    m(0, 2) = centroid.x();
    m(1, 2) = centroid.y();
    return m;
  }
};

// The scatter matrix of normalised points is nearly rank one when the points lie close to a
// line; its eigenvalue ratio is the squared thickness/length ratio of the point cloud.
bool ScatterIsDegenerate(const Eigen::Matrix2d& scatter, double tolerance) {
  const double tr = scatter.trace();
  return !(scatter.determinant() > tolerance * tolerance * tr * tr);
}

bool NormaliseHomography(Eigen::Matrix3d* h) {
  const double h22 = (*h)(2, 2);
  if (!(std::abs(h22) > 1e-10 * h->norm())) return false;
  *h /= h22;
  return h->allFinite();
}

}  // namespace

// ToString and MinSampleSize keep their own switch (not VisitMotionModel, whose fallback is the
// affine model) so that a value outside the enum stays visible: "unknown", 0.
const char* ToString(MotionModel model) {
  switch (model) {
#define AEROVO_MOTION_MODEL_NAME(e, T) \
  case MotionModel::e:                 \
    return T::kName;
    AEROVO_MOTION_MODELS(AEROVO_MOTION_MODEL_NAME)
#undef AEROVO_MOTION_MODEL_NAME
  }
  return "unknown";
}

MotionModel ParseMotionModel(const char* name) {
  const std::string s = name == nullptr ? "" : name;
  std::string expected;
  for (std::size_t k = 0; k < kNumMotionModels; ++k) {
    if (s == ToString(kAllMotionModels[k])) return kAllMotionModels[k];
    expected += k == 0 ? "" : (k + 1 == kNumMotionModels ? " or " : ", ");
    expected += ToString(kAllMotionModels[k]);
  }
  throw InvalidArgument("unknown motion model '" + s + "' (expected " + expected + ")");
}

int MinSampleSize(MotionModel model) {
  switch (model) {
#define AEROVO_MOTION_MODEL_MIN_SAMPLE(e, T) \
  case MotionModel::e:                       \
    return T::kMinSample;
    AEROVO_MOTION_MODELS(AEROVO_MOTION_MODEL_MIN_SAMPLE)
#undef AEROVO_MOTION_MODEL_MIN_SAMPLE
  }
  return 0;
}

double MaxCornerDisplacementPx(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b, int width,
                               int height) {
  const double xs[2] = {0.0, static_cast<double>(width - 1)};
  const double ys[2] = {0.0, static_cast<double>(height - 1)};
  double worst = 0.0;
  for (double x : xs) {
    for (double y : ys) {
      const Eigen::Vector2d p(x, y);
      worst = std::max(worst, (TransformPoint(a, p) - TransformPoint(b, p)).norm());
    }
  }
  return worst;
}

// ---------------------------------------------------------------- translation

bool TranslationModel::IsDegenerate(const Eigen::Matrix2Xd&, const Eigen::Matrix2Xd&, const int*) {
  return false;
}

bool TranslationModel::SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                    const int* idx, Eigen::Matrix3d* curr_from_prev) {
  curr_from_prev->setIdentity();
  curr_from_prev->block<2, 1>(0, 2) = curr.col(idx[0]) - prev.col(idx[0]);
  return curr_from_prev->allFinite();
}

bool TranslationModel::FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                       const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                                       const double* weights) {
  if (n < kMinSample) return false;
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (int k = 0; k < n; ++k) {
    t += WeightAt(weights, k) * (curr.col(idx[k]) - prev.col(idx[k]));
    total += WeightAt(weights, k);
  }
  if (!(total > 0.0)) return false;
  curr_from_prev->setIdentity();
  curr_from_prev->block<2, 1>(0, 2) = t / total;
  return curr_from_prev->allFinite();
}

void TranslationModel::SquaredResiduals(const Eigen::Matrix3d& m, const Eigen::Matrix2Xd& prev,
                                        const Eigen::Matrix2Xd& curr, double* out) {
  const double tx = m(0, 2), ty = m(1, 2);
  const double* p = prev.data();
  const double* c = curr.data();
  const Eigen::Index n = prev.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double dx = p[2 * i] + tx - c[2 * i];
    const double dy = p[2 * i + 1] + ty - c[2 * i + 1];
    out[i] = dx * dx + dy * dy;
  }
}

// ---------------------------------------------------------------- similarity

bool SimilarityModel::IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                   const int* idx) {
  const double min2 = kMinSeparationPx * kMinSeparationPx;
  return !((prev.col(idx[1]) - prev.col(idx[0])).squaredNorm() > min2) ||
         !((curr.col(idx[1]) - curr.col(idx[0])).squaredNorm() > min2);
}

bool SimilarityModel::SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                   const int* idx, Eigen::Matrix3d* curr_from_prev) {
  if (IsDegenerate(prev, curr, idx)) return false;
  // In complex numbers the model is c = z p + t; z = dc / dp.
  const Eigen::Vector2d dp = prev.col(idx[1]) - prev.col(idx[0]);
  const Eigen::Vector2d dc = curr.col(idx[1]) - curr.col(idx[0]);
  const double den = dp.squaredNorm();
  const double a = (dc.x() * dp.x() + dc.y() * dp.y()) / den;
  const double b = (dc.y() * dp.x() - dc.x() * dp.y()) / den;
  Eigen::Matrix3d& m = *curr_from_prev;
  m << a, -b, 0, b, a, 0, 0, 0, 1;
  m.block<2, 1>(0, 2) = curr.col(idx[0]) - m.topLeftCorner<2, 2>() * prev.col(idx[0]);
  return m.allFinite();
}

bool SimilarityModel::FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                      const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                                      const double* weights) {
  if (n < kMinSample) return false;
  // Centring decouples the shift; the remaining one-unknown complex regression
  // z = sum(c' conj(p')) / sum|p'|^2 is scale-invariant, so centring is the whole
  // normalisation it needs.
  Normalizer np, nc;
  if (!np.Compute(prev, idx, n, weights) || !nc.Compute(curr, idx, n, weights)) return false;
  double sa = 0, sb = 0, spp = 0;
  for (int k = 0; k < n; ++k) {
    const double w = WeightAt(weights, k);
    const Eigen::Vector2d p = prev.col(idx[k]) - np.centroid;
    const Eigen::Vector2d c = curr.col(idx[k]) - nc.centroid;
    sa += w * (c.x() * p.x() + c.y() * p.y());
    sb += w * (c.y() * p.x() - c.x() * p.y());
    spp += w * p.squaredNorm();
  }
  if (!(spp > 1e-12)) return false;
  const double a = sa / spp, b = sb / spp;
  Eigen::Matrix3d& m = *curr_from_prev;
  m << a, -b, 0, b, a, 0, 0, 0, 1;
  m.block<2, 1>(0, 2) = nc.centroid - m.topLeftCorner<2, 2>() * np.centroid;
  return m.allFinite();
}

void SimilarityModel::SquaredResiduals(const Eigen::Matrix3d& m, const Eigen::Matrix2Xd& prev,
                                       const Eigen::Matrix2Xd& curr, double* out) {
  const double a = m(0, 0), b = m(1, 0), tx = m(0, 2), ty = m(1, 2);
  const double* p = prev.data();
  const double* c = curr.data();
  const Eigen::Index n = prev.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = p[2 * i], y = p[2 * i + 1];
    const double dx = a * x - b * y + tx - c[2 * i];
    const double dy = b * x + a * y + ty - c[2 * i + 1];
    out[i] = dx * dx + dy * dy;
  }
}

// ---------------------------------------------------------------- affine

bool AffineModel::IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                               const int* idx) {
  return ThinAwareCross(prev.col(idx[0]), prev.col(idx[1]), prev.col(idx[2]),
                        kCollinearTolerance) == 0.0 ||
         ThinAwareCross(curr.col(idx[0]), curr.col(idx[1]), curr.col(idx[2]),
                        kCollinearTolerance) == 0.0;
}

bool AffineModel::SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                               const int* idx, Eigen::Matrix3d* curr_from_prev) {
  if (IsDegenerate(prev, curr, idx)) return false;
  // A [dp1 dp2] = [dc1 dc2] with edge vectors from point 0; t from point 0.
  Eigen::Matrix2d dp, dc;
  dp.col(0) = prev.col(idx[1]) - prev.col(idx[0]);
  dp.col(1) = prev.col(idx[2]) - prev.col(idx[0]);
  dc.col(0) = curr.col(idx[1]) - curr.col(idx[0]);
  dc.col(1) = curr.col(idx[2]) - curr.col(idx[0]);
  const Eigen::Matrix2d a = dc * dp.inverse();
  Eigen::Matrix3d& m = *curr_from_prev;
  m.setIdentity();
  m.topLeftCorner<2, 2>() = a;
  m.block<2, 1>(0, 2) = curr.col(idx[0]) - a * prev.col(idx[0]);
  return m.allFinite();
}

bool AffineModel::FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                  const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                                  const double* weights) {
  if (n < kMinSample) return false;
  // Centring is all the conditioning the affine fit needs: the normal equations of the six
  // unknowns split into A = S_cp S_pp^-1 (2x2) and the shift between the centroids, and both
  // that solution and the degeneracy test (det / trace^2) are invariant to a scaling of the
  // points, so Hartley's scale step (a pass with a square root per point) would only cost time.
  // Two passes: the (weighted) centroids, then the centred second moments.
  double total = 0.0, px = 0.0, py = 0.0, cx = 0.0, cy = 0.0;
  const double* p = prev.data();
  const double* c = curr.data();
  for (int k = 0; k < n; ++k) {
    const double w = WeightAt(weights, k);
    const int i = idx[k];
    total += w;
    px += w * p[2 * i];
    py += w * p[2 * i + 1];
    cx += w * c[2 * i];
    cy += w * c[2 * i + 1];
  }
  if (!(total > 0.0)) return false;
  const Eigen::Vector2d p0(px / total, py / total), c0(cx / total, cy / total);
  double pxx = 0.0, pxy = 0.0, pyy = 0.0, cxx = 0.0, cxy = 0.0, cyy = 0.0;
  double xpx = 0.0, xpy = 0.0, ypx = 0.0, ypy = 0.0;  // S_cp = [xpx xpy; ypx ypy]
  for (int k = 0; k < n; ++k) {
    const double w = WeightAt(weights, k);
    const int i = idx[k];
    const double dpx = p[2 * i] - p0.x(), dpy = p[2 * i + 1] - p0.y();
    const double dcx = c[2 * i] - c0.x(), dcy = c[2 * i + 1] - c0.y();
    const double wpx = w * dpx, wpy = w * dpy, wcx = w * dcx, wcy = w * dcy;
    pxx += wpx * dpx;
    pxy += wpx * dpy;
    pyy += wpy * dpy;
    cxx += wcx * dcx;
    cxy += wcx * dcy;
    cyy += wcy * dcy;
    xpx += wcx * dpx;
    xpy += wcx * dpy;
    ypx += wcy * dpx;
    ypy += wcy * dpy;
  }
  Eigen::Matrix2d spp, scp, scc;
  spp << pxx, pxy, pxy, pyy;
  scc << cxx, cxy, cxy, cyy;
  scp << xpx, xpy, ypx, ypy;
  if (ScatterIsDegenerate(spp, kCollinearTolerance) ||
      ScatterIsDegenerate(scc, kCollinearTolerance)) {
    return false;
  }
  const Eigen::Matrix2d a = scp * spp.inverse();
  Eigen::Matrix3d& m = *curr_from_prev;
  m.setIdentity();
  m.topLeftCorner<2, 2>() = a;
  m.block<2, 1>(0, 2) = c0 - a * p0;
  return m.allFinite();
}

void AffineModel::SquaredResiduals(const Eigen::Matrix3d& m, const Eigen::Matrix2Xd& prev,
                                   const Eigen::Matrix2Xd& curr, double* out) {
  const double a00 = m(0, 0), a01 = m(0, 1), a10 = m(1, 0), a11 = m(1, 1), tx = m(0, 2),
               ty = m(1, 2);
  const double* p = prev.data();
  const double* c = curr.data();
  const Eigen::Index n = prev.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = p[2 * i], y = p[2 * i + 1];
    const double dx = a00 * x + a01 * y + tx - c[2 * i];
    const double dy = a10 * x + a11 * y + ty - c[2 * i + 1];
    out[i] = dx * dx + dy * dy;
  }
}

// ---------------------------------------------------------------- homography

bool HomographyModel::IsDegenerate(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                   const int* idx) {
  static constexpr int kTriples[4][3] = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};
  int positive = 0, negative = 0;
  for (const auto& t : kTriples) {
    const double cp = ThinAwareCross(prev.col(idx[t[0]]), prev.col(idx[t[1]]), prev.col(idx[t[2]]),
                                     kCollinearTolerance);
    const double cc = ThinAwareCross(curr.col(idx[t[0]]), curr.col(idx[t[1]]), curr.col(idx[t[2]]),
                                     kCollinearTolerance);
    if (cp == 0.0 || cc == 0.0) return true;
    (cp * cc > 0 ? positive : negative)++;
  }
  return positive != 0 && negative != 0;
}

bool HomographyModel::SolveMinimal(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                   const int* idx, Eigen::Matrix3d* curr_from_prev) {
  if (IsDegenerate(prev, curr, idx)) return false;
  Normalizer np, nc;
  if (!np.Compute(prev, idx, kMinSample, nullptr) || !nc.Compute(curr, idx, kMinSample, nullptr))
    return false;
  // With both point sets centred at the origin, h22 = 0 would need the centroid to map to
  // infinity, which the non-degenerate sample excludes; so fixing h22 = 1 leaves a square
  // 8x8 system, much cheaper than a null-space SVD.
  Eigen::Matrix<double, 8, 8> a;
  Eigen::Matrix<double, 8, 1> b;
  for (int k = 0; k < kMinSample; ++k) {
    const Eigen::Vector2d p = np.Apply(prev.col(idx[k]));
    const Eigen::Vector2d c = nc.Apply(curr.col(idx[k]));
    a.row(2 * k) << p.x(), p.y(), 1, 0, 0, 0, -c.x() * p.x(), -c.x() * p.y();
    a.row(2 * k + 1) << 0, 0, 0, p.x(), p.y(), 1, -c.y() * p.x(), -c.y() * p.y();
    b(2 * k) = c.x();
    b(2 * k + 1) = c.y();
  }
  const Eigen::Matrix<double, 8, 1> h = a.partialPivLu().solve(b);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  *curr_from_prev = nc.InverseMatrix() * hn * np.Matrix();
  return NormaliseHomography(curr_from_prev);
}

bool HomographyModel::FitLeastSquares(const Eigen::Matrix2Xd& prev, const Eigen::Matrix2Xd& curr,
                                      const int* idx, int n, Eigen::Matrix3d* curr_from_prev,
                                      const double* weights) {
  if (n < kMinSample) return false;
  Normalizer np, nc;
  if (!np.Compute(prev, idx, n, weights) || !nc.Compute(curr, idx, n, weights)) return false;
  // Normalised DLT: the unit h minimising |A h| is the eigenvector of A^T A with the smallest
  // eigenvalue; accumulating the 9x9 A^T A keeps memory constant for any n.
  Eigen::Matrix<double, 9, 9> ata = Eigen::Matrix<double, 9, 9>::Zero();
  Eigen::Matrix2d spp = Eigen::Matrix2d::Zero(), scc = Eigen::Matrix2d::Zero();
  Eigen::Matrix<double, 9, 1> r1, r2;
  for (int k = 0; k < n; ++k) {
    const double w = WeightAt(weights, k);
    const Eigen::Vector2d p = np.Apply(prev.col(idx[k]));
    const Eigen::Vector2d c = nc.Apply(curr.col(idx[k]));
    spp.noalias() += w * p * p.transpose();
    scc.noalias() += w * c * c.transpose();
    r1 << p.x(), p.y(), 1, 0, 0, 0, -c.x() * p.x(), -c.x() * p.y(), -c.x();
    r2 << 0, 0, 0, p.x(), p.y(), 1, -c.y() * p.x(), -c.y() * p.y(), -c.y();
    ata.selfadjointView<Eigen::Lower>().rankUpdate(r1, w);
    ata.selfadjointView<Eigen::Lower>().rankUpdate(r2, w);
  }
  if (ScatterIsDegenerate(spp, kCollinearTolerance) ||
      ScatterIsDegenerate(scc, kCollinearTolerance)) {
    return false;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(ata);
  if (eig.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, 9, 1> h = eig.eigenvectors().col(0);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  *curr_from_prev = nc.InverseMatrix() * hn * np.Matrix();
  return NormaliseHomography(curr_from_prev);
}

void HomographyModel::SquaredResiduals(const Eigen::Matrix3d& m, const Eigen::Matrix2Xd& prev,
                                       const Eigen::Matrix2Xd& curr, double* out) {
  const double h00 = m(0, 0), h01 = m(0, 1), h02 = m(0, 2), h10 = m(1, 0), h11 = m(1, 1),
               h12 = m(1, 2), h20 = m(2, 0), h21 = m(2, 1), h22 = m(2, 2);
  const double* p = prev.data();
  const double* c = curr.data();
  const Eigen::Index n = prev.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = p[2 * i], y = p[2 * i + 1];
    const double w = h20 * x + h21 * y + h22;
    // A nadir camera keeps every visible point in front (w > 0 with H(2,2) = 1); a point sent
    // to or behind the line at infinity cannot be an inlier.
    if (!(w > 1e-12)) {
      out[i] = kHugeResidualPx2;
      continue;
    }
    const double inv_w = 1.0 / w;
    const double dx = (h00 * x + h01 * y + h02) * inv_w - c[2 * i];
    const double dy = (h10 * x + h11 * y + h12) * inv_w - c[2 * i + 1];
    out[i] = dx * dx + dy * dy;
  }
}

}  // namespace aerovo
