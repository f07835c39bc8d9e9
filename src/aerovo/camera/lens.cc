#include "aerovo/camera/lens.h"

#include <algorithm>
#include <cmath>

namespace aerovo {

namespace {

constexpr double kHalfPi = 1.57079632679489661923;
constexpr int kMaxIterations = 20;
constexpr double kTolerance = 1e-12;  // normalised units (1e-9 px at f = 1000 px)

// Singular values {min, max} of [a b; c d].
std::array<double, 2> SingularValues(double a, double b, double c, double d) {
  const double t = a * a + b * b + c * c + d * d;
  const double det = a * d - b * c;
  const double disc = std::sqrt(std::max(0.0, t * t - 4.0 * det * det));
  return {std::sqrt(std::max(0.0, 0.5 * (t - disc))), std::sqrt(0.5 * (t + disc))};
}

}  // namespace

LensUndistortion::LensUndistortion(const CameraIntrinsics& lens) : input_(lens) {
  Validate(lens);
  output_ = IntrinsicsFromFocalPx(lens.fx_px, lens.width_px, lens.height_px);
  fisheye_ = lens.model == LensModel::kFisheye;
  for (std::size_t i = 0; i < lens.distortion.size() && i < d_.size(); ++i) {
    d_[i] = lens.distortion[i];
  }
  identity_ = !lens.HasDistortion();
}

void LensUndistortion::DistortNormalised(double x, double y, double* xd, double* yd) const {
  if (identity_) {
    *xd = x;
    *yd = y;
    return;
  }
  const double r2 = x * x + y * y;
  if (fisheye_) {
    const double r = std::sqrt(r2);
    if (r < 1e-12) {
      *xd = x;
      *yd = y;
      return;
    }
    const double t = std::atan(r), t2 = t * t;
    const double td = t * (1 + t2 * (d_[0] + t2 * (d_[1] + t2 * (d_[2] + t2 * d_[3]))));
    *xd = x * (td / r);
    *yd = y * (td / r);
    return;
  }
  const double radial = (1 + r2 * (d_[0] + r2 * (d_[1] + r2 * d_[4]))) /
                        (1 + r2 * (d_[5] + r2 * (d_[6] + r2 * d_[7])));
  *xd = x * radial + 2 * d_[2] * x * y + d_[3] * (r2 + 2 * x * x);
  *yd = y * radial + d_[2] * (r2 + 2 * y * y) + 2 * d_[3] * x * y;
}

namespace {

// The pinhole model's distortion of (x, y) and its Jacobian [j00 j01; j10 j11].
void PinholeWithJacobian(const std::array<double, 8>& d, double x, double y, double* xd,
                         double* yd, double j[4]) {
  const double r2 = x * x + y * y;
  const double a = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  const double b = 1 + r2 * (d[5] + r2 * (d[6] + r2 * d[7]));
  const double da = d[0] + r2 * (2 * d[1] + 3 * r2 * d[4]);
  const double db = d[5] + r2 * (2 * d[6] + 3 * r2 * d[7]);
  const double rad = a / b;
  const double drad = (da * b - a * db) / (b * b);  // d rad / d r2
  const double p1 = d[2], p2 = d[3];
  *xd = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  *yd = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  const double cross = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y;
  j[0] = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x;
  j[1] = cross;
  j[2] = cross;
  j[3] = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x;
}

// theta_d(theta) of the fisheye model and its derivative.
void FisheyeTheta(const std::array<double, 8>& d, double t, double* td, double* dtd) {
  const double t2 = t * t;
  *td = t * (1 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))));
  *dtd = 1 + t2 * (3 * d[0] + t2 * (5 * d[1] + t2 * (7 * d[2] + t2 * 9 * d[3])));
}

}  // namespace

bool LensUndistortion::UndistortNormalised(double xd, double yd, double* x, double* y) const {
  if (identity_) {
    *x = xd;
    *y = yd;
    return true;
  }
  if (fisheye_) {
    // Radial: solve theta_d(theta) = |(xd, yd)| for theta (1-D Newton), then r = tan(theta).
    const double rd = std::sqrt(xd * xd + yd * yd);
    if (rd < 1e-12) {
      *x = xd;
      *y = yd;
      return true;
    }
    double t = std::min(rd, 1.5);
    for (int it = 0; it < kMaxIterations; ++it) {
      double td = 0.0, dtd = 0.0;
      FisheyeTheta(d_, t, &td, &dtd);
      const double e = td - rd;
      if (std::abs(e) < kTolerance) {
        if (!(dtd > 0.0) || !(t < kHalfPi) || !(t > 0.0)) return false;
        const double s = std::tan(t) / rd;
        *x = xd * s;
        *y = yd * s;
        return true;
      }
      if (!(dtd > 0.0)) return false;
      t -= e / dtd;
      if (!std::isfinite(t)) return false;
    }
    return false;
  }
  double u = xd, v = yd;
  for (int it = 0; it < kMaxIterations; ++it) {
    double fx = 0.0, fy = 0.0, j[4];
    PinholeWithJacobian(d_, u, v, &fx, &fy, j);
    const double ex = fx - xd, ey = fy - yd;
    const double det = j[0] * j[3] - j[1] * j[2];
    if (ex * ex + ey * ey < kTolerance * kTolerance) {
      if (!(det > 0.0)) return false;  // beyond the model's monotonic range
      *x = u;
      *y = v;
      return true;
    }
    if (!(std::abs(det) > 1e-300)) return false;
    u -= (j[3] * ex - j[1] * ey) / det;
    v -= (-j[2] * ex + j[0] * ey) / det;
    if (!std::isfinite(u) || !std::isfinite(v)) return false;
  }
  return false;
}

bool LensUndistortion::UndistortPixel(double u, double v, double* u_out, double* v_out) const {
  double x = 0.0, y = 0.0;
  if (!UndistortNormalised((u - input_.cx_px) / input_.fx_px, (v - input_.cy_px) / input_.fy_px,
                           &x, &y)) {
    return false;
  }
  *u_out = output_.fx_px * x + output_.cx_px;
  *v_out = output_.fy_px * y + output_.cy_px;
  return true;
}

bool LensUndistortion::DistortPixel(double u_out, double v_out, double* u, double* v) const {
  double xd = 0.0, yd = 0.0;
  DistortNormalised((u_out - output_.cx_px) / output_.fx_px, (v_out - output_.cy_px) / output_.fy_px,
                    &xd, &yd);
  if (!std::isfinite(xd) || !std::isfinite(yd)) return false;
  *u = input_.fx_px * xd + input_.cx_px;
  *v = input_.fy_px * yd + input_.cy_px;
  return true;
}

std::array<double, 2> LensUndistortion::LocalScale(double u_out, double v_out) const {
  const double x = (u_out - output_.cx_px) / output_.fx_px;
  const double y = (v_out - output_.cy_px) / output_.fy_px;
  double j[4] = {1.0, 0.0, 0.0, 1.0};
  if (!identity_) {
    double xd = 0.0, yd = 0.0;
    if (fisheye_) {
      // x_d = g(r) x with g = theta_d / r: J = g I + (g' / r) x x^T.
      const double r = std::sqrt(x * x + y * y);
      if (r > 1e-9) {
        const double t = std::atan(r);
        double td = 0.0, dtd = 0.0;
        FisheyeTheta(d_, t, &td, &dtd);
        const double g = td / r;
        const double dg = (dtd / (1 + r * r) * r - td) / (r * r);
        j[0] = g + dg * x * x / r;
        j[1] = j[2] = dg * x * y / r;
        j[3] = g + dg * y * y / r;
      }
    } else {
      PinholeWithJacobian(d_, x, y, &xd, &yd, j);
    }
  }
  // Pixels: d(distorted px) / d(output px) = diag(fx, fy) J diag(1 / f_out, 1 / f_out).
  const double sx = input_.fx_px / output_.fx_px, sy = input_.fy_px / output_.fy_px;
  return SingularValues(sx * j[0], sx * j[1], sy * j[2], sy * j[3]);
}

double LensUndistortion::MaxScaleChange() const {
  if (identity_ && input_.fx_px == input_.fy_px) return 0.0;
  constexpr int kGrid = 33;
  double worst = 0.0;
  for (int iy = 0; iy < kGrid; ++iy) {
    for (int ix = 0; ix < kGrid; ++ix) {
      const double u = (input_.width_px - 1) * static_cast<double>(ix) / (kGrid - 1);
      const double v = (input_.height_px - 1) * static_cast<double>(iy) / (kGrid - 1);
      double uo = 0.0, vo = 0.0;
      if (!UndistortPixel(u, v, &uo, &vo)) return 1.0;
      const std::array<double, 2> s = LocalScale(uo, vo);
      worst = std::max({worst, std::abs(s[0] - 1.0), std::abs(s[1] - 1.0)});
    }
  }
  return worst;
}

double MaxLensScaleChange(const CameraIntrinsics& lens) {
  return LensUndistortion(lens).MaxScaleChange();
}

namespace {

// Whether `lens` has no ray for distorted pixel (u, v) that it reaches without turning back
// (FirstFoldedPixel).
bool TurnsBackBefore(const LensUndistortion& lens, double u, double v) {
  const CameraIntrinsics& out = lens.output();
  double u0 = 0.0, v0 = 0.0, uo = 0.0, vo = 0.0;
  if (!lens.DistortPixel(out.cx_px, out.cy_px, &u0, &v0)) return true;
  const double du = u - u0, dv = v - v0;
  if (du * du + dv * dv < 1.0) return false;  // the principal point itself
  if (!lens.UndistortPixel(u, v, &uo, &vo)) return true;
  constexpr int kSteps = 64;
  double previous = 0.0;
  for (int i = 1; i <= kSteps; ++i) {
    const double t = static_cast<double>(i) / kSteps;
    double a = 0.0, b = 0.0;
    if (!lens.DistortPixel(out.cx_px + t * (uo - out.cx_px), out.cy_px + t * (vo - out.cy_px), &a,
                           &b)) {
      return true;
    }
    const double along = (a - u0) * du + (b - v0) * dv;
    if (!(along > previous)) return true;
    previous = along;
  }
  return false;
}

}  // namespace

std::optional<std::array<double, 2>> FirstFoldedPixel(const CameraIntrinsics& k) {
  if (k.model != LensModel::kPinhole || !k.HasDistortion()) return std::nullopt;
  const LensUndistortion lens(k);
  constexpr int kGrid = 33;
  constexpr double kCheckedRadius = 0.9;  // of the farthest corner's distance
  double farthest_sq = 0.0;
  for (const double u : {0.0, k.width_px - 1.0}) {
    for (const double v : {0.0, k.height_px - 1.0}) {
      farthest_sq =
          std::max(farthest_sq, (u - k.cx_px) * (u - k.cx_px) + (v - k.cy_px) * (v - k.cy_px));
    }
  }
  const double checked_sq = kCheckedRadius * kCheckedRadius * farthest_sq;
  for (int iy = 0; iy < kGrid; ++iy) {
    for (int ix = 0; ix < kGrid; ++ix) {
      const double u = (k.width_px - 1) * static_cast<double>(ix) / (kGrid - 1);
      const double v = (k.height_px - 1) * static_cast<double>(iy) / (kGrid - 1);
      if ((u - k.cx_px) * (u - k.cx_px) + (v - k.cy_px) * (v - k.cy_px) > checked_sq) continue;
      if (TurnsBackBefore(lens, u, v)) return std::array<double, 2>{u, v};
    }
  }
  return std::nullopt;
}

}  // namespace aerovo
