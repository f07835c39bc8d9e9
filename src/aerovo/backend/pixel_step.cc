#include "aerovo/backend/pixel_step.h"

#include <cmath>
#include <string>

#include <Eigen/LU>

#include "aerovo/core/error.h"

namespace aerovo::backend {

namespace {

void CheckGsd(const char* name, double gsd) {
  if (!(std::isfinite(gsd) && gsd > 0.0)) {
    throw InvalidArgument(std::string(name) + " must be finite and > 0, got " +
                          std::to_string(gsd));
  }
}

// Ground coordinates (metres) of a pixel: x right, y up, origin at the centre.
Eigen::Vector2d GroundOfPixel(const Eigen::Vector2d& p_px, const Eigen::Vector2d& centre_px,
                              double gsd) {
  return gsd * Eigen::Vector2d(p_px.x() - centre_px.x(), centre_px.y() - p_px.y());
}

}  // namespace

Similarity2 PrevFromCurrOfPixelStep(const Eigen::Matrix3d& curr_from_prev_px,
                                    const Eigen::Vector2d& centre_px, double gsd_prev_m_per_px,
                                    double gsd_curr_m_per_px) {
  CheckGsd("gsd_prev_m_per_px", gsd_prev_m_per_px);
  CheckGsd("gsd_curr_m_per_px", gsd_curr_m_per_px);
  if (!curr_from_prev_px.allFinite() || !centre_px.allFinite()) {
    throw InvalidArgument("PrevFromCurrOfPixelStep: the transform or the centre is not finite");
  }
  Eigen::Matrix3d prev_from_curr_px;
  bool invertible = false;
  double det = 0.0;
  curr_from_prev_px.computeInverseAndDetWithCheck(prev_from_curr_px, det, invertible, 1e-12);
  if (!invertible) throw InvalidArgument("PrevFromCurrOfPixelStep: the transform is singular");
  prev_from_curr_px /= prev_from_curr_px(2, 2);
  // In ground coordinates (y flipped): L = (g_p / g_c) F A F, F = diag(1, -1); the centre of
  // frame curr maps to g_p F (A c + a - c).
  const Eigen::Matrix2d a = prev_from_curr_px.topLeftCorner<2, 2>();
  Eigen::Matrix2d f_a_f = a;
  f_a_f(0, 1) = -a(0, 1);
  f_a_f(1, 0) = -a(1, 0);
  const Eigen::Vector2d centre_in_prev_px =
      a * centre_px + prev_from_curr_px.topRightCorner<2, 1>();
  Similarity2 out;
  out.translation_m = GroundOfPixel(centre_in_prev_px, centre_px, gsd_prev_m_per_px);
  // Closest rotation of the linear part (its polar decomposition, for det > 0).
  out.heading_rad = std::atan2(f_a_f(1, 0) - f_a_f(0, 1), f_a_f(0, 0) + f_a_f(1, 1));
  const double lin_det = std::abs(a.determinant());
  if (!(lin_det > 0.0)) throw InvalidArgument("PrevFromCurrOfPixelStep: the transform is singular");
  out.log_scale = std::log(gsd_prev_m_per_px / gsd_curr_m_per_px) + 0.5 * std::log(lin_det);
  return out;
}

Eigen::Matrix3d PixelStepOfPrevFromCurr(const Similarity2& prev_from_curr,
                                        const Eigen::Vector2d& centre_px, double gsd_prev_m_per_px,
                                        double gsd_curr_m_per_px) {
  CheckGsd("gsd_prev_m_per_px", gsd_prev_m_per_px);
  CheckGsd("gsd_curr_m_per_px", gsd_curr_m_per_px);
  if (!prev_from_curr.AllFinite() || !centre_px.allFinite()) {
    throw InvalidArgument("PixelStepOfPrevFromCurr: the step or the centre is not finite");
  }
  // Pixels to ground (x right, y up, about the centre) and back: p_m = g F (p_px - c).
  Eigen::Matrix3d ground_from_px_curr = Eigen::Matrix3d::Identity();
  ground_from_px_curr.topLeftCorner<2, 2>() << gsd_curr_m_per_px, 0.0, 0.0, -gsd_curr_m_per_px;
  ground_from_px_curr.topRightCorner<2, 1>() =
      -(ground_from_px_curr.topLeftCorner<2, 2>() * centre_px);
  Eigen::Matrix3d px_from_ground_prev = Eigen::Matrix3d::Identity();
  px_from_ground_prev.topLeftCorner<2, 2>() << 1.0 / gsd_prev_m_per_px, 0.0, 0.0,
      -1.0 / gsd_prev_m_per_px;
  px_from_ground_prev.topRightCorner<2, 1>() = centre_px;
  const Eigen::Matrix3d prev_from_curr_px =
      px_from_ground_prev * prev_from_curr.Matrix() * ground_from_px_curr;
  return prev_from_curr_px.inverse();
}

Eigen::Matrix4d SimilarityFitInformation(const Eigen::Matrix2Xd& curr_px,
                                         const Similarity2& prev_from_curr,
                                         const Eigen::Vector2d& centre_px, double gsd_prev_m_per_px,
                                         double gsd_curr_m_per_px, double point_sigma_px) {
  CheckGsd("gsd_prev_m_per_px", gsd_prev_m_per_px);
  CheckGsd("gsd_curr_m_per_px", gsd_curr_m_per_px);
  if (!(std::isfinite(point_sigma_px) && point_sigma_px > 0.0)) {
    throw InvalidArgument("point_sigma_px must be finite and > 0, got " +
                          std::to_string(point_sigma_px));
  }
  if (curr_px.cols() < 2) {
    throw InvalidArgument("SimilarityFitInformation: needs at least 2 points, got " +
                          std::to_string(curr_px.cols()));
  }
  if (!curr_px.allFinite() || !centre_px.allFinite() || !prev_from_curr.AllFinite()) {
    throw InvalidArgument("SimilarityFitInformation: a point or the fit is not finite");
  }
  const double scale = prev_from_curr.scale();
  const double sigma2 = point_sigma_px * point_sigma_px *
                        (gsd_prev_m_per_px * gsd_prev_m_per_px +
                         scale * scale * gsd_curr_m_per_px * gsd_curr_m_per_px);
  const Eigen::Matrix2d linear = prev_from_curr.Linear();  // exp(s) R(a)
  Eigen::Matrix<double, 2, 4> j;
  j.leftCols<2>().setIdentity();
  Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
  for (Eigen::Index i = 0; i < curr_px.cols(); ++i) {
    const Eigen::Vector2d q = GroundOfPixel(curr_px.col(i), centre_px, gsd_curr_m_per_px);
    const Eigen::Vector2d m = linear * q;       // d/ds of exp(s) R(a) q
    j.col(2) = Eigen::Vector2d(-m.y(), m.x());  // d/da: the 90-degree rotation of m
    j.col(3) = m;
    jtj.noalias() += j.transpose() * j;
  }
  return jtj / sigma2;
}

}  // namespace aerovo::backend
