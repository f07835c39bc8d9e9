#include "aerovo/odometry/attitude_estimation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/statistics.h"
#include "aerovo/estimation/models.h"
#include "aerovo/estimation/ransac.h"
#include "aerovo/estimation/samplers.h"

namespace aerovo {
namespace {

// The inliers of one pair, normalised coordinates ((x - cx) / f, (y - cy) / f).
struct PairPoints {
  std::vector<Eigen::Vector2d> prev, curr;
};

// A point's residual cost when the candidate attitude turns its ray to the horizon: that of a
// residual of 100 loss scales (see AttitudeEstimationOptions::max_tilt_deg).
constexpr double kHorizonResidualScales = 100.0;
// Rays closer than 5 degrees to the horizon after the rotation: the smallest cosine of the
// virtual ray's angle from nadir.
const double kMinNadirCos = std::sin(5.0 * kDegToRad);

// The cost of one pair under the rotation `m` (nadir_from_camera on rays; the points are
// normalised coordinates (x - cx) / f): the Cauchy loss of the current frame's pixel residuals
// (normalised residual times `focal_px`) after the best similarity between the nadir-mapped
// points (3 reweighted least-squares fits). `residuals`, when not null, receives each point's
// residual, px.
double PairCost(const PairPoints& pair, const Eigen::Matrix3d& m, double focal_px, double s,
                std::vector<double>* residuals) {
  // Plain scalars, not Eigen expressions or std::complex products, in the per-point loops: the
  // same operations in the same order (so the same results), without the out-of-line calls that
  // an unoptimised or instrumented build (the sanitizer stage of scripts/test.sh) makes of them.
  const std::size_t n = pair.prev.size();
  thread_local std::vector<double> tl_pr, tl_pi, tl_cr, tl_ci, tl_w;
  thread_local std::vector<unsigned char> tl_ok;
  std::vector<double>&pr = tl_pr, &pi = tl_pi, &cr = tl_cr, &ci = tl_ci, &w = tl_w;
  std::vector<unsigned char>& ok = tl_ok;
  pr.resize(n);
  pi.resize(n);
  cr.resize(n);
  ci.resize(n);
  w.assign(n, 1.0);
  ok.assign(n, 1);
  const double m00 = m(0, 0), m01 = m(0, 1), m02 = m(0, 2), m10 = m(1, 0), m11 = m(1, 1),
               m12 = m(1, 2), m20 = m(2, 0), m21 = m(2, 1), m22 = m(2, 2);
  // The ray m (x, y, 1) of a normalised point, mapped to the plane z = 1 (false: within 5
  // degrees of the horizon or above it).
  const auto map = [&](const Eigen::Vector2d& v, double* out_r, double* out_i) {
    const double x = v.x(), y = v.y();
    const double rx = m00 * x + m01 * y + m02, ry = m10 * x + m11 * y + m12,
                 rz = m20 * x + m21 * y + m22;
    if (!(rz > kMinNadirCos * std::sqrt(rx * rx + ry * ry + rz * rz))) return false;
    *out_r = rx / rz;
    *out_i = ry / rz;
    return true;
  };
  for (std::size_t i = 0; i < n; ++i) {
    ok[i] = map(pair.prev[i], &pr[i], &pi[i]) && map(pair.curr[i], &cr[i], &ci[i]);
  }
  const double s2 = s * s;
  const double horizon_cost = s2 * std::log1p(kHorizonResidualScales * kHorizonResidualScales);
  double cost = 0.0;
  if (residuals) residuals->assign(n, kHorizonResidualScales * s);
  for (int iteration = 0; iteration < 3; ++iteration) {
    // Weighted least squares c = a p + b (a complex: rotation and scale).
    double sw = 0.0, mpr = 0.0, mpi = 0.0, mcr = 0.0, mci = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!ok[i]) continue;
      sw += w[i];
      mpr += w[i] * pr[i];
      mpi += w[i] * pi[i];
      mcr += w[i] * cr[i];
      mci += w[i] * ci[i];
    }
    if (!(sw > 0.0)) return horizon_cost * static_cast<double>(n);
    mpr /= sw;
    mpi /= sw;
    mcr /= sw;
    mci /= sw;
    // num = sum w (c - mc) conj(p - mp), den = sum w |p - mp|^2.
    double num_r = 0.0, num_i = 0.0, den = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!ok[i]) continue;
      const double dr = pr[i] - mpr, di = pi[i] - mpi;
      const double xr = w[i] * (cr[i] - mcr), xi = w[i] * (ci[i] - mci);
      num_r += xr * dr + xi * di;
      num_i += xi * dr - xr * di;
      den += w[i] * (dr * dr + di * di);
    }
    if (!(den > 0.0)) return horizon_cost * static_cast<double>(n);
    const double ar = num_r / den, ai = num_i / den;
    const double br = mcr - (ar * mpr - ai * mpi), bi = mci - (ar * mpi + ai * mpr);
    // Residuals in the current frame's pixels, Cauchy weights and cost.
    cost = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      double e2 = std::numeric_limits<double>::infinity();
      if (ok[i]) {
        // q = a p + b, back to the camera's plane: m' (q, 1).
        const double qr = (ar * pr[i] - ai * pi[i]) + br, qi = (ar * pi[i] + ai * pr[i]) + bi;
        const double bx = m00 * qr + m10 * qi + m20, by = m01 * qr + m11 * qi + m21,
                     bz = m02 * qr + m12 * qi + m22;
        if (bz > 0.0) {
          const double ex = bx / bz - pair.curr[i].x(), ey = by / bz - pair.curr[i].y();
          e2 = (ex * ex + ey * ey) * focal_px * focal_px;
        }
      }
      if (!std::isfinite(e2)) {
        cost += horizon_cost;
        w[i] = 0.0;
        continue;
      }
      cost += s2 * std::log1p(e2 / s2);
      w[i] = 1.0 / (1.0 + e2 / s2);
      if (residuals) (*residuals)[i] = std::sqrt(e2);
    }
  }
  return cost;
}

struct Evaluator {
  const AttitudeEstimationOptions& o;
  const std::vector<PairPoints>& pairs;

  // The cost of pair `only` (or of every pair when only < 0) at attitude `a`.
  double Cost(const CameraAttitude& a, int only, std::vector<double>* pair_costs = nullptr,
              std::vector<double>* residuals = nullptr) const {
    // nadir_from_camera on rays: K^-1 H K of the pixel homography (odometry/attitude.h).
    Eigen::Matrix3d k;
    k << o.focal_px, 0, o.cx_px, 0, o.focal_px, o.cy_px, 0, 0, 1;
    const Eigen::Matrix3d m =
        k.inverse() * NadirFromCameraHomography(a, o.focal_px, o.cx_px, o.cy_px) * k;
    double total = 0.0;
    if (pair_costs) pair_costs->clear();
    if (residuals) residuals->clear();
    std::vector<double> r;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      if (only >= 0 && static_cast<int>(k) != only) continue;
      const double c = PairCost(pairs[k], m, o.focal_px, o.loss_scale_px, residuals ? &r : nullptr);
      if (pair_costs) pair_costs->push_back(c);
      if (residuals) residuals->insert(residuals->end(), r.begin(), r.end());
      total += c;
    }
    return total;
  }

  // The minimiser of Cost(., only): a grid of step grid_step_deg over the range (or, with
  // `around`, over one coarse step around it), then three grids of a quarter of the previous
  // step around the best point (ties: the first in roll-major order, so the result is
  // deterministic).
  CameraAttitude Minimise(int only, const CameraAttitude* around = nullptr) const {
    CameraAttitude best = around ? *around : CameraAttitude{0.0, 0.0};
    double best_cost = Cost(best, only);
    const double range = o.max_tilt_deg;
    double step = around ? o.grid_step_deg / 4.0 : o.grid_step_deg;
    double half_width = around ? o.grid_step_deg : range;
    CameraAttitude centre = best;
    for (int level = around ? 1 : 0; level < 4; ++level) {
      const int n = static_cast<int>(std::floor(half_width / step + 1e-9));
      for (int i = -n; i <= n; ++i) {
        for (int j = -n; j <= n; ++j) {
          const CameraAttitude a{centre.roll_deg + i * step, centre.pitch_deg + j * step};
          if (std::abs(a.roll_deg) > range + 1e-9 || std::abs(a.pitch_deg) > range + 1e-9) {
            continue;
          }
          const double c = Cost(a, only);
          if (c < best_cost) {
            best_cost = c;
            best = a;
          }
        }
      }
      centre = best;
      half_width = step;
      step /= 4.0;
    }
    return best;
  }
};

// The inliers of a RANSAC homography of each pair with enough of them and enough motion.
std::vector<PairPoints> CollectInliers(const std::vector<LensPair>& pairs,
                                       const AttitudeEstimationOptions& o, int* points_used) {
  std::vector<PairPoints> data;
  RansacWorkspace workspace;
  const double diagonal = std::hypot(o.width_px, o.height_px);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const LensPair& pair = pairs[k];
    if (pair.prev_px.cols() != pair.curr_px.cols()) {
      throw InvalidArgument(fmt::format("attitude estimation: pair {} has {} prev and {} curr points",
                                        k, pair.prev_px.cols(), pair.curr_px.cols()));
    }
    if (pair.prev_px.cols() < o.min_inliers) continue;
    RansacOptions ro;
    ro.max_distance_px = o.inlier_fraction * diagonal;
    ro.seed = o.seed + k;
    ro.max_num_trials = 2000;
    const RansacResult r = EstimateTransform(MotionModel::kHomography, SamplerKind::kUniform, ro,
                                             pair.prev_px, pair.curr_px, nullptr, workspace);
    if (!r.success || r.num_inliers < o.min_inliers) continue;
    PairPoints d;
    std::vector<double> motion;
    for (Eigen::Index i = 0; i < pair.prev_px.cols(); ++i) {
      if (!r.inlier_mask[static_cast<std::size_t>(i)]) continue;
      d.prev.emplace_back((pair.prev_px(0, i) - o.cx_px) / o.focal_px,
                          (pair.prev_px(1, i) - o.cy_px) / o.focal_px);
      d.curr.emplace_back((pair.curr_px(0, i) - o.cx_px) / o.focal_px,
                          (pair.curr_px(1, i) - o.cy_px) / o.focal_px);
      motion.push_back((pair.curr_px.col(i) - pair.prev_px.col(i)).norm());
    }
    if (Median(motion) < o.min_motion_fraction * diagonal) continue;
    *points_used += static_cast<int>(d.prev.size());
    data.push_back(std::move(d));
  }
  return data;
}

// The decision of AttitudeEstimationOptions on `e` (valid), in e->significant and e->why.
void Decide(const AttitudeEstimationOptions& o, AttitudeEstimate* e) {
  const double sigma = std::hypot(e->sigma_roll_deg, e->sigma_pitch_deg);
  const auto tilt = [&] {
    return fmt::format("roll {:.2f}, pitch {:.2f} deg ({:.2f} from nadir, sigma {:.2f})",
                       e->attitude.roll_deg, e->attitude.pitch_deg, e->tilt_deg, sigma);
  };
  const int needed = static_cast<int>(std::ceil(o.min_pair_fraction * e->pairs_used - 1e-9));
  if (e->tilt_deg < o.min_tilt_deg) {
    e->why = fmt::format("the camera is nadir within {:.1f} deg: {}", o.min_tilt_deg, tilt());
  } else if (e->tilt_deg < 3.0 * sigma) {
    e->why = fmt::format("the tilt is not 3 sigma from nadir: {}", tilt());
  } else if (e->cost_drop < o.min_cost_drop) {
    e->why = fmt::format("the tilt removes {:.1f} % of the nadir cost (needs {:.1f} %): {}",
                         100.0 * e->cost_drop, 100.0 * o.min_cost_drop, tilt());
  } else if (e->pairs_improved < needed) {
    e->why = fmt::format("only {} of {} pairs agree: {}", e->pairs_improved, e->pairs_used, tilt());
  } else {
    e->significant = true;
    e->why = fmt::format("a tilted camera: {}; the tilt removes {:.1f} % of the nadir cost over {} "
                         "pairs ({} agree)",
                         tilt(), 100.0 * e->cost_drop, e->pairs_used, e->pairs_improved);
  }
}

}  // namespace

void Validate(const AttitudeEstimationOptions& o) {
  const auto fail = [](const char* field, double value) {
    throw InvalidArgument(fmt::format("attitude estimation: {} = {} is out of range", field, value));
  };
  if (!(o.focal_px > 0.0) || !std::isfinite(o.focal_px)) fail("focal_px", o.focal_px);
  if (!std::isfinite(o.cx_px)) fail("cx_px", o.cx_px);
  if (!std::isfinite(o.cy_px)) fail("cy_px", o.cy_px);
  if (o.width_px <= 0) fail("width_px", o.width_px);
  if (o.height_px <= 0) fail("height_px", o.height_px);
  if (!(o.inlier_fraction > 0.0 && o.inlier_fraction < 1.0)) {
    fail("inlier_fraction", o.inlier_fraction);
  }
  if (!(o.loss_scale_px > 0.0) || !std::isfinite(o.loss_scale_px)) {
    fail("loss_scale_px", o.loss_scale_px);
  }
  if (o.min_inliers < 4) fail("min_inliers", o.min_inliers);
  if (!(o.min_motion_fraction >= 0.0 && o.min_motion_fraction < 1.0)) {
    fail("min_motion_fraction", o.min_motion_fraction);
  }
  if (o.min_pairs < 1) fail("min_pairs", o.min_pairs);
  if (!(o.max_tilt_deg > 0.0 && o.max_tilt_deg <= 60.0)) fail("max_tilt_deg", o.max_tilt_deg);
  if (!(o.grid_step_deg > 0.0 && o.grid_step_deg <= o.max_tilt_deg)) {
    fail("grid_step_deg", o.grid_step_deg);
  }
  if (!(o.min_tilt_deg >= 0.0) || !std::isfinite(o.min_tilt_deg)) {
    fail("min_tilt_deg", o.min_tilt_deg);
  }
  if (!(o.min_cost_drop >= 0.0 && o.min_cost_drop < 1.0)) fail("min_cost_drop", o.min_cost_drop);
  if (!(o.min_pair_fraction >= 0.0 && o.min_pair_fraction <= 1.0)) {
    fail("min_pair_fraction", o.min_pair_fraction);
  }
  if (!(o.min_pair_drop >= 0.0 && o.min_pair_drop < 1.0)) fail("min_pair_drop", o.min_pair_drop);
}

AttitudeEstimate EstimateCameraAttitude(const std::vector<LensPair>& pairs,
                                        const AttitudeEstimationOptions& o) {
  Validate(o);
  AttitudeEstimate e;
  const std::vector<PairPoints> data = CollectInliers(pairs, o, &e.points_used);
  e.pairs_used = static_cast<int>(data.size());
  if (e.pairs_used < o.min_pairs) {
    e.why = fmt::format("{} of {} pairs have {} homography inliers and move (needs {} pairs)",
                        e.pairs_used, pairs.size(), o.min_inliers, o.min_pairs);
    return e;
  }
  e.valid = true;
  const Evaluator ev{o, data};
  e.attitude = ev.Minimise(-1);
  e.tilt_deg = TiltFromNadirDeg(e.attitude);
  std::vector<double> nadir_pairs, estimate_pairs, residuals;
  e.cost_nadir = ev.Cost({0.0, 0.0}, -1, &nadir_pairs, &residuals);
  e.median_residual_nadir_px = Median(residuals);
  e.cost = ev.Cost(e.attitude, -1, &estimate_pairs, &residuals);
  e.median_residual_px = Median(residuals);
  e.cost_drop = e.cost_nadir > 0.0 ? 1.0 - e.cost / e.cost_nadir : 0.0;
  std::vector<double> rolls, pitches;
  for (int k = 0; k < e.pairs_used; ++k) {
    const std::size_t i = static_cast<std::size_t>(k);
    if (estimate_pairs[i] <= (1.0 - o.min_pair_drop) * nadir_pairs[i]) ++e.pairs_improved;
    e.pair_attitude.push_back(ev.Minimise(k, &e.attitude));
    rolls.push_back(e.pair_attitude.back().roll_deg);
    pitches.push_back(e.pair_attitude.back().pitch_deg);
  }
  e.sigma_roll_deg = RobustStandardError(rolls);
  e.sigma_pitch_deg = RobustStandardError(pitches);
  Decide(o, &e);
  return e;
}

}  // namespace aerovo
