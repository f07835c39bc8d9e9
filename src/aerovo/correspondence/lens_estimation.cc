#include "aerovo/correspondence/lens_estimation.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>
#include <string>

#include <Eigen/Eigenvalues>

#include "aerovo/core/error.h"
#include "aerovo/core/statistics.h"
#include "aerovo/estimation/models.h"
#include "aerovo/estimation/ransac.h"
#include "aerovo/estimation/samplers.h"

namespace aerovo {

const char* ToString(RadialFamily family) {
  return family == RadialFamily::kFisheyeK1 ? "fisheye" : "pinhole";
}

void Validate(const LensEstimationOptions& o) {
  const auto fail = [](const std::string& what) {
    throw InvalidArgument("lens estimation: " + what);
  };
  if (!(o.focal_px > 0.0) || !std::isfinite(o.focal_px)) fail("focal_px must be > 0");
  if (!std::isfinite(o.cx_px) || !std::isfinite(o.cy_px)) fail("cx_px, cy_px must be finite");
  if (o.width_px <= 0 || o.height_px <= 0) fail("width_px and height_px must be > 0");
  if (!(o.widen_fraction > 0.0 && o.widen_fraction < 1.0)) fail("widen_fraction must be in (0, 1)");
  if (!(o.loss_scale_px > 0.0) || !std::isfinite(o.loss_scale_px)) fail("loss_scale_px must be > 0");
  if (o.min_inliers < 8) fail("min_inliers must be >= 8");
  if (o.min_pairs < 1) fail("min_pairs must be >= 1");
  if (o.grid_points < 3) fail("grid_points must be >= 3");
  if (!(o.fisheye_k_min < o.fisheye_k_max) || !(o.brown_k_min < o.brown_k_max)) {
    fail("each k range must have min < max");
  }
  if (!(o.min_cost_drop >= 0.0 && o.min_cost_drop < 1.0)) fail("min_cost_drop must be in [0, 1)");
  if (!(o.min_pair_fraction >= 0.0 && o.min_pair_fraction <= 1.0)) {
    fail("min_pair_fraction must be in [0, 1]");
  }
  if (!(o.min_pair_drop >= 0.0 && o.min_pair_drop < 1.0)) fail("min_pair_drop must be in [0, 1)");
}

namespace {

// printf-style formatting into a std::string (this module does not link fmt).
std::string Format(const char* format, ...) {
  char buffer[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  return buffer;
}

// Rays at most this far off axis (89 degrees): a nadir camera's ground is in front of it.
constexpr double kMaxTheta = 1.5533430342749532;
const double kMaxBrownRadius = std::tan(kMaxTheta);

// The largest u on which g(u) = u + k u^3 is increasing, capped at u_cap.
double MonotonicLimit(double k, double u_cap) {
  if (k >= 0.0) return u_cap;
  return std::min(u_cap, 1.0 / std::sqrt(-3.0 * k));
}

double UCap(RadialFamily family) {
  return family == RadialFamily::kFisheyeK1 ? kMaxTheta : kMaxBrownRadius;
}

// Solves u + k u^3 = d for u in [0, limit] (g increasing there); false when g(limit) < d.
bool SolveRadius(double k, double d, double limit, double* u) {
  if (d <= 0.0) {
    *u = 0.0;
    return d == 0.0;
  }
  const auto g = [k, d](double x) { return x + k * x * x * x - d; };
  if (g(limit) < 0.0) return false;
  double lo = 0.0, hi = limit;
  double x = std::min(d, limit);
  for (int it = 0; it < 60; ++it) {
    const double gx = g(x);
    if (std::abs(gx) <= 1e-12 * std::max(1.0, d)) break;
    if (gx < 0.0) lo = x; else hi = x;
    const double dg = 1.0 + 3.0 * k * x * x;
    double next = dg > 0.0 ? x - gx / dg : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    x = next;
  }
  *u = x;
  return true;
}

}  // namespace

bool RayOfDistorted(RadialFamily family, double k, double xd, double yd, Eigen::Vector3d* ray) {
  const double rd = std::hypot(xd, yd);
  double u = 0.0;
  if (!SolveRadius(k, rd, MonotonicLimit(k, UCap(family)), &u)) return false;
  if (family == RadialFamily::kFisheyeK1) {
    const double theta = u;
    if (rd == 0.0) {
      *ray = Eigen::Vector3d(0.0, 0.0, 1.0);
      return true;
    }
    const double s = std::sin(theta) / rd;
    *ray = Eigen::Vector3d(xd * s, yd * s, std::cos(theta));
    return true;
  }
  const double scale = rd > 0.0 ? u / rd : 1.0;  // r_u / r_d
  *ray = Eigen::Vector3d(xd * scale, yd * scale, 1.0).normalized();
  return true;
}

namespace {

// DistortedOfRay in plain scalars (the cost's per-point loop calls it): the ray (rx, ry, rz) to
// the normalised distorted point (*u, *v).
bool DistortedOfRayXY(RadialFamily family, double k, double rx, double ry, double rz, double* u,
                      double* v) {
  const double rho = std::hypot(rx, ry);
  if (family == RadialFamily::kFisheyeK1) {
    const double theta = std::atan2(rho, rz);
    const double td = theta * (1.0 + k * theta * theta);
    if (rho == 0.0) {
      *u = *v = 0.0;
      return rz > 0.0;
    }
    const double f = td / rho;
    *u = rx * f;
    *v = ry * f;
    return true;
  }
  if (!(rz > 0.0)) return false;
  const double x = rx / rz, y = ry / rz;
  const double f = 1.0 + k * (x * x + y * y);
  *u = x * f;
  *v = y * f;
  return true;
}

}  // namespace

bool DistortedOfRay(RadialFamily family, double k, const Eigen::Vector3d& ray,
                    Eigen::Vector2d* xd) {
  double u = 0.0, v = 0.0;
  if (!DistortedOfRayXY(family, k, ray.x(), ray.y(), ray.z(), &u, &v)) return false;
  *xd = Eigen::Vector2d(u, v);
  return true;
}

namespace {

// Pixels per radian of ray angle at a ray `theta` off axis (geometric mean of the radial and
// tangential scales), in units of the focal length.
double PixelScale(RadialFamily family, double k, double theta) {
  if (theta < 1e-9) return 1.0;
  if (family == RadialFamily::kFisheyeK1) {
    const double radial = 1.0 + 3.0 * k * theta * theta;
    const double tangential = theta * (1.0 + k * theta * theta) / std::sin(theta);
    return std::sqrt(std::max(radial * tangential, 1e-12));
  }
  const double r = std::tan(theta);
  const double radial = (1.0 + 3.0 * k * r * r) * (1.0 + r * r);
  const double tangential = r * (1.0 + k * r * r) / std::sin(theta);
  return std::sqrt(std::max(radial * tangential, 1e-12));
}

// One pair's inliers in normalised distorted coordinates, and the buffers of its cost.
struct PairData {
  std::vector<Eigen::Vector2d> prev, curr;
  // Buffers reused between evaluations.
  std::vector<Eigen::Vector3d> prev_ray, curr_ray;
  std::vector<double> scale, weight, residual_px;
  std::vector<char> valid;
};

struct CostSettings {
  double focal_px = 0.0;
  double s2 = 1.0;          // loss scale squared, px^2
  double outlier_px = 0.0;  // residual charged to a point the model cannot map (the widening)
};

double Cauchy(double e2, double s2) { return s2 * std::log1p(e2 / s2); }

// The Cauchy cost of one pair under (family, k); residuals (px) left in d.residual_px.
double PairCost(RadialFamily family, double k, const CostSettings& cs, PairData& d) {
  const std::size_t n = d.prev.size();
  d.prev_ray.resize(n);
  d.curr_ray.resize(n);
  d.scale.resize(n);
  d.weight.resize(n);
  d.residual_px.assign(n, cs.outlier_px);
  d.valid.assign(n, 0);
  int valid = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!RayOfDistorted(family, k, d.prev[i].x(), d.prev[i].y(), &d.prev_ray[i]) ||
        !RayOfDistorted(family, k, d.curr[i].x(), d.curr[i].y(), &d.curr_ray[i])) {
      continue;
    }
    const Eigen::Vector3d& q = d.curr_ray[i];
    const double theta = std::atan2(std::hypot(q.x(), q.y()), q.z());
    d.scale[i] = cs.focal_px * PixelScale(family, k, theta);
    d.weight[i] = d.scale[i] * d.scale[i];
    d.valid[i] = 1;
    ++valid;
  }
  const double outlier_cost = Cauchy(cs.outlier_px * cs.outlier_px, cs.s2);
  if (valid < 8) return outlier_cost * static_cast<double>(n);
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 9, 9> m;
  // H r in plain scalars, summed in the order of the Eigen product it replaces on x86-64 and
  // aarch64 (rows 0 and 1 as one packet of two doubles, row 2 as Eigen's unrolled sum), so that
  // the estimates stay those of the Eigen expression.
  double hc[9];  // h's coefficients, row-major
  const auto apply = [&hc](const Eigen::Vector3d& r, double* y) {
    const double r0 = r.x(), r1 = r.y(), r2 = r.z();
    y[0] = hc[0] * r0 + hc[1] * r1 + hc[2] * r2;
    y[1] = hc[3] * r0 + hc[4] * r1 + hc[5] * r2;
    y[2] = hc[6] * r0 + (hc[7] * r1 + hc[8] * r2);
  };
  for (int iteration = 0; iteration < 6; ++iteration) {
    // Weighted DLT on the rays: q x (H r) = 0, three rows a per point, m = sum w a a'. Only the
    // lower triangle is accumulated (the eigen-solver reads no other), element (row, col) as
    // (w a_row) a_col, in plain scalars: the per-point loop is the estimate's cost, and as
    // Eigen expressions it was a chain of out-of-line calls in an unoptimised or instrumented
    // build (the sanitizer stage of scripts/test.sh).
    double acc[9][9] = {};
    for (std::size_t i = 0; i < n; ++i) {
      if (!d.valid[i]) continue;
      const Eigen::Vector3d& r = d.prev_ray[i];
      const Eigen::Vector3d& q = d.curr_ray[i];
      const double rv[3] = {r.x(), r.y(), r.z()};
      const double qx[3][3] = {{0.0, -q.z(), q.y()}, {q.z(), 0.0, -q.x()}, {-q.y(), q.x(), 0.0}};
      const double w = d.weight[i];
      for (int j = 0; j < 3; ++j) {
        double a[9], wa[9];
        for (int row = 0; row < 3; ++row) {
          for (int c = 0; c < 3; ++c) a[3 * row + c] = qx[j][row] * rv[c];
        }
        for (int k = 0; k < 9; ++k) wa[k] = w * a[k];
        for (int row = 0; row < 9; ++row) {
          for (int col = 0; col <= row; ++col) acc[row][col] += a[col] * wa[row];
        }
      }
    }
    for (int row = 0; row < 9; ++row) {
      for (int col = 0; col <= row; ++col) m(row, col) = m(col, row) = acc[row][col];
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(m);
    const Eigen::Matrix<double, 9, 1> v = eig.eigenvectors().col(0);
    for (int row = 0; row < 3; ++row) {
      for (int c = 0; c < 3; ++c) h(row, c) = v(3 * row + c);
    }
    for (int row = 0; row < 3; ++row) {
      for (int c = 0; c < 3; ++c) hc[3 * row + c] = h(row, c);
    }
    double sign = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!d.valid[i]) continue;
      double y[3];
      apply(d.prev_ray[i], y);
      const Eigen::Vector3d& q = d.curr_ray[i];
      sign += q.x() * y[0] + q.y() * y[1] + q.z() * y[2];
    }
    if (sign < 0.0) {
      h = -h;
      for (double& c : hc) c = -c;
    }
    // Residuals in the distorted image, then the weights of the next round.
    for (std::size_t i = 0; i < n; ++i) {
      if (!d.valid[i]) continue;
      double y[3];
      apply(d.prev_ray[i], y);
      const Eigen::Vector3d& q = d.curr_ray[i];
      double e = cs.outlier_px, u = 0.0, v = 0.0;
      if (q.x() * y[0] + q.y() * y[1] + q.z() * y[2] > 0.0 &&
          DistortedOfRayXY(family, k, y[0], y[1], y[2], &u, &v)) {
        const double du = u - d.curr[i].x(), dv = v - d.curr[i].y();
        e = std::min(cs.outlier_px, cs.focal_px * std::sqrt(du * du + dv * dv));
      }
      d.residual_px[i] = e;
      const double yn2 = std::max(y[0] * y[0] + y[1] * y[1] + y[2] * y[2], 1e-24);
      d.weight[i] = d.scale[i] * d.scale[i] / yn2 / (1.0 + e * e / cs.s2);
    }
  }
  double cost = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    cost += d.valid[i] ? Cauchy(d.residual_px[i] * d.residual_px[i], cs.s2) : outlier_cost;
  }
  return cost;
}

// The smallest k in [lo, hi] for which every point (normalised distorted radius up to d_max)
// has its inverse (SolveRadius succeeds).
double LowerBoundOfK(RadialFamily family, double d_max, double lo, double hi) {
  const auto ok = [&](double k) {
    double u = 0.0;
    return SolveRadius(k, d_max, MonotonicLimit(k, UCap(family)), &u);
  };
  if (ok(lo)) return lo;
  if (!ok(hi)) return hi;
  double a = lo, b = hi;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (a + b);
    if (ok(mid)) b = mid; else a = mid;
  }
  return std::min(hi, b + 1e-4 * (hi - lo));
}

// Minimises f over [a, b] by golden section (40 steps: the bracket shrinks by 4e-9).
template <class F>
double GoldenMinimum(F&& f, double a, double b) {
  constexpr double kInvPhi = 0.6180339887498949;
  double c = b - kInvPhi * (b - a), d = a + kInvPhi * (b - a);
  double fc = f(c), fd = f(d);
  for (int it = 0; it < 40; ++it) {
    if (fc <= fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - kInvPhi * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + kInvPhi * (b - a);
      fd = f(d);
    }
  }
  return fc <= fd ? c : d;
}

double TotalCost(RadialFamily family, double k, const CostSettings& cs,
                 std::vector<PairData>& data) {
  double c = 0.0;
  for (PairData& d : data) c += PairCost(family, k, cs, d);
  return c;
}

// sqrt of the median squared residual over every pair (after a cost evaluation).
double MedianResidual(const std::vector<PairData>& data) {
  std::vector<double> e;
  for (const PairData& d : data) e.insert(e.end(), d.residual_px.begin(), d.residual_px.end());
  return Median(std::move(e));
}

// Step 1 of EstimateRadialDistortion: the inliers of a widened RANSAC homography on the raw
// pixels (k = 0) of each pair with enough of them, in normalised distorted coordinates.
// d_max: the largest normalised radius of any kept point; points_used: their count.
std::vector<PairData> CollectInliers(const std::vector<LensPair>& pairs,
                                     const LensEstimationOptions& o, const CostSettings& cs,
                                     double* d_max, int* points_used) {
  std::vector<PairData> data;
  RansacWorkspace workspace;
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const LensPair& pair = pairs[p];
    if (pair.prev_px.cols() != pair.curr_px.cols()) {
      throw InvalidArgument(Format("lens estimation: pair %zu has %ld prev and %ld curr points", p,
                                   static_cast<long>(pair.prev_px.cols()),
                                   static_cast<long>(pair.curr_px.cols())));
    }
    if (pair.prev_px.cols() < o.min_inliers) continue;
    RansacOptions ro;
    ro.max_distance_px = cs.outlier_px;
    ro.seed = o.seed + p;
    ro.max_num_trials = 2000;
    const RansacResult r = EstimateTransform(MotionModel::kHomography, SamplerKind::kUniform, ro,
                                             pair.prev_px, pair.curr_px, nullptr, workspace);
    if (!r.success || r.num_inliers < o.min_inliers) continue;
    PairData d;
    for (Eigen::Index i = 0; i < pair.prev_px.cols(); ++i) {
      if (!r.inlier_mask[static_cast<std::size_t>(i)]) continue;
      const Eigen::Vector2d a((pair.prev_px(0, i) - o.cx_px) / o.focal_px,
                              (pair.prev_px(1, i) - o.cy_px) / o.focal_px);
      const Eigen::Vector2d b((pair.curr_px(0, i) - o.cx_px) / o.focal_px,
                              (pair.curr_px(1, i) - o.cy_px) / o.focal_px);
      *d_max = std::max({*d_max, a.norm(), b.norm()});
      d.prev.push_back(a);
      d.curr.push_back(b);
    }
    *points_used += static_cast<int>(d.prev.size());
    data.push_back(std::move(d));
  }
  return data;
}

// The uncertainty of fit->k (see LensFamilyFit::sigma_k): the spread of the per-pair minima and
// the Laplace estimate from the total cost's curvature at k over [lo, hi] (the searched range,
// grid of g points); dof: the residual degrees of freedom.
void EstimateUncertainty(double lo, double hi, int g, double dof, const CostSettings& cs,
                         std::vector<PairData>& data, LensFamilyFit* fit) {
  fit->sigma_k_pairs = RobustStandardError(fit->pair_k);
  const double step = std::max(1e-5, (hi - lo) / (g - 1) / 8.0);
  const double cp = TotalCost(fit->family, std::min(hi, fit->k + step), cs, data);
  const double cm = TotalCost(fit->family, std::max(lo, fit->k - step), cs, data);
  const double curvature = (cp - 2.0 * fit->cost + cm) / (step * step);
  fit->sigma_k_curvature = curvature > 0.0 ? std::sqrt(2.0 * fit->cost / dof / curvature)
                                           : std::numeric_limits<double>::infinity();
  fit->sigma_k = std::max(fit->sigma_k_pairs, fit->sigma_k_curvature);
}

// Step 3 of EstimateRadialDistortion for one family: a grid over the range the data allows
// (every point of normalised radius up to d_max has its inverse), golden section around the best
// grid point for the total and for each pair, and the uncertainty. pinhole_pair: each pair's cost
// at the ideal pinhole; dof: the residual degrees of freedom. False when the range is empty.
bool FitFamily(RadialFamily family, const LensEstimationOptions& o, const CostSettings& cs,
               double d_max, double dof, const std::vector<double>& pinhole_pair,
               std::vector<PairData>& data, LensFamilyFit* fit) {
  const int num_pairs = static_cast<int>(data.size());
  fit->family = family;
  const double lo0 = family == RadialFamily::kFisheyeK1 ? o.fisheye_k_min : o.brown_k_min;
  const double hi = family == RadialFamily::kFisheyeK1 ? o.fisheye_k_max : o.brown_k_max;
  const double lo = LowerBoundOfK(family, d_max, lo0, hi);
  fit->k_min = lo;
  fit->k_max = hi;
  if (!(lo < hi)) return false;
  const int g = o.grid_points;
  std::vector<double> grid(g);
  std::vector<std::vector<double>> pair_cost(num_pairs, std::vector<double>(g));
  std::vector<double> total(g, 0.0);
  for (int j = 0; j < g; ++j) {
    grid[j] = lo + (hi - lo) * j / (g - 1);
    for (int p = 0; p < num_pairs; ++p) {
      pair_cost[p][j] = PairCost(family, grid[j], cs, data[p]);
      total[j] += pair_cost[p][j];
    }
  }
  const auto bracket = [&](const std::vector<double>& c) {
    const int j = static_cast<int>(std::min_element(c.begin(), c.end()) - c.begin());
    return std::make_pair(grid[std::max(j - 1, 0)], grid[std::min(j + 1, g - 1)]);
  };
  const auto [a, b] = bracket(total);
  fit->k = GoldenMinimum([&](double k) { return TotalCost(family, k, cs, data); }, a, b);
  fit->cost = TotalCost(family, fit->k, cs, data);
  for (int p = 0; p < num_pairs; ++p) {
    const auto [pa, pb] = bracket(pair_cost[p]);
    fit->pair_k.push_back(
        GoldenMinimum([&](double k) { return PairCost(family, k, cs, data[p]); }, pa, pb));
    const double at_k = PairCost(family, fit->k, cs, data[p]);
    if (at_k <= (1.0 - o.min_pair_drop) * pinhole_pair[p]) ++fit->pairs_improved;
  }
  EstimateUncertainty(lo, hi, g, dof, cs, data, fit);
  return true;
}

// Step 4 of EstimateRadialDistortion: out->significant and out->why from the chosen family's
// figures (out->cost_drop, pairs_improved, k, sigma_k) and the decision thresholds of `o`.
void Decide(const LensEstimationOptions& o, int num_pairs, LensEstimate* out) {
  const int needed =
      static_cast<int>(std::ceil(o.min_pair_fraction * static_cast<double>(num_pairs) - 1e-9));
  const bool drop_ok = out->cost_drop >= o.min_cost_drop;
  const bool pairs_ok = out->pairs_improved >= needed;
  const bool away_from_pinhole =
      out->family != RadialFamily::kBrownK1 || std::abs(out->k) > 3.0 * out->sigma_k;
  out->significant = drop_ok && pairs_ok && away_from_pinhole;
  const std::string figures = Format(
      "%s k1 = %.4f +- %.4f: cost %.0f%% below the ideal pinhole's (median residual %.2f "
      "-> %.2f px), %d of %d pairs improved by >= %.0f%%",
      ToString(out->family), out->k, out->sigma_k, 100.0 * out->cost_drop,
      out->median_residual_pinhole_px, out->median_residual_px, out->pairs_improved, num_pairs,
      100.0 * o.min_pair_drop);
  if (out->significant) {
    out->why = "significant: " + figures;
  } else if (!drop_ok) {
    out->why =
        Format("not significant (the cost drops by less than %.0f%%): ", 100.0 * o.min_cost_drop) +
        figures;
  } else if (!pairs_ok) {
    out->why = Format("not significant (fewer than %d pairs improved): ", needed) + figures;
  } else {
    out->why = "not significant (k1 within 3 sigma of 0): " + figures;
  }
}

}  // namespace

LensEstimate EstimateRadialDistortion(const std::vector<LensPair>& pairs,
                                      const LensEstimationOptions& o) {
  Validate(o);
  LensEstimate out;
  const double diag = std::hypot(o.width_px, o.height_px);
  CostSettings cs;
  cs.focal_px = o.focal_px;
  cs.s2 = o.loss_scale_px * o.loss_scale_px;
  cs.outlier_px = o.widen_fraction * diag;
  // 1. Inliers of a widened RANSAC homography on the raw pixels (k = 0).
  double d_max = 0.0;
  std::vector<PairData> data = CollectInliers(pairs, o, cs, &d_max, &out.points_used);
  out.pairs_used = static_cast<int>(data.size());
  if (out.pairs_used < o.min_pairs) {
    out.why = Format("%d usable frame pairs (at least %d with %d RANSAC inliers needed)",
                     out.pairs_used, o.min_pairs, o.min_inliers);
    out.points_used = 0;
    return out;
  }
  out.valid = true;
  const int num_pairs = out.pairs_used;
  // 2. The ideal pinhole's cost, per pair and in total.
  std::vector<double> pinhole_pair(num_pairs);
  for (int p = 0; p < num_pairs; ++p) {
    pinhole_pair[p] = PairCost(RadialFamily::kBrownK1, 0.0, cs, data[p]);
    out.cost_pinhole += pinhole_pair[p];
  }
  out.median_residual_pinhole_px = MedianResidual(data);
  // Residual degrees of freedom for the curvature's noise estimate.
  double dof = -1.0;
  for (const PairData& d : data) dof += 2.0 * static_cast<double>(d.prev.size()) - 8.0;
  dof = std::max(dof, 1.0);

  // 3. Each family: grid, golden section, per-pair minima, uncertainty.
  for (RadialFamily family : {RadialFamily::kFisheyeK1, RadialFamily::kBrownK1}) {
    LensFamilyFit fit;
    if (FitFamily(family, o, cs, d_max, dof, pinhole_pair, data, &fit)) {
      out.fits.push_back(std::move(fit));
    }
  }
  if (out.fits.empty()) {
    out.valid = false;
    out.why = "no lens family can map every matched point";
    return out;
  }
  // 4. The family of the lower cost, and the decision.
  const LensFamilyFit& best = *std::min_element(
      out.fits.begin(), out.fits.end(),
      [](const LensFamilyFit& x, const LensFamilyFit& y) { return x.cost < y.cost; });
  out.family = best.family;
  out.k = best.k;
  out.sigma_k = best.sigma_k;
  out.cost = best.cost;
  out.pair_k = best.pair_k;
  out.pairs_improved = best.pairs_improved;
  out.cost_drop = out.cost_pinhole > 0.0 ? 1.0 - out.cost / out.cost_pinhole : 0.0;
  (void)TotalCost(out.family, out.k, cs, data);
  out.median_residual_px = MedianResidual(data);
  Decide(o, num_pairs, &out);
  return out;
}

}  // namespace aerovo
