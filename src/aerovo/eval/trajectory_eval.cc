#include "aerovo/eval/trajectory_eval.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {
namespace {

Eigen::Vector2d Xy(const TrajectoryPoint2D& p) { return {p.x, p.y}; }

void CheckFinite(const std::vector<TrajectoryPoint2D>& points, const char* fn, const char* name) {
  for (size_t i = 0; i < points.size(); ++i) {
    const TrajectoryPoint2D& p = points[i];
    if (!std::isfinite(p.t) || !std::isfinite(p.x) || !std::isfinite(p.y)) {
      throw InvalidArgument(std::string(fn) + ": " + name + " point " + std::to_string(i) +
                            " is not finite (t " + std::to_string(p.t) + ", x " +
                            std::to_string(p.x) + ", y " + std::to_string(p.y) + ")");
    }
  }
}

void CheckPairs(const std::vector<TrajectoryPoint2D>& estimate,
                const std::vector<TrajectoryPoint2D>& reference, const char* fn) {
  if (estimate.size() != reference.size()) {
    throw InvalidArgument(std::string(fn) + ": estimate has " + std::to_string(estimate.size()) +
                          " points but reference has " + std::to_string(reference.size()) +
                          " (pairs are matched by index)");
  }
  if (estimate.size() < 2) {
    throw InvalidArgument(std::string(fn) + ": need at least 2 point pairs, got " +
                          std::to_string(estimate.size()));
  }
  CheckFinite(estimate, fn, "estimate");
  CheckFinite(reference, fn, "reference");
}

}  // namespace

Eigen::Matrix2d Similarity2D::Rotation() const {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

Eigen::Vector2d Similarity2D::Apply(const Eigen::Vector2d& p) const {
  return scale * (Rotation() * p) + translation_m;
}

Eigen::Matrix3d Similarity2D::Matrix() const {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topLeftCorner<2, 2>() = scale * Rotation();
  m.topRightCorner<2, 1>() = translation_m;
  return m;
}

AlignmentResult AlignUmeyama2D(const std::vector<TrajectoryPoint2D>& estimate,
                               const std::vector<TrajectoryPoint2D>& reference,
                               AlignmentModel model) {
  CheckPairs(estimate, reference, "AlignUmeyama2D");
  const size_t n = estimate.size();
  Eigen::Vector2d mu_e = Eigen::Vector2d::Zero(), mu_r = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mu_e += Xy(estimate[i]);
    mu_r += Xy(reference[i]);
  }
  mu_e /= static_cast<double>(n);
  mu_r /= static_cast<double>(n);
  // Two-pass (centred) sums: GPS-scale coordinates (km) with cm residuals would lose digits
  // in one-pass moment formulas.
  double dot = 0.0, cross = 0.0, var_e = 0.0, var_r = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d e = Xy(estimate[i]) - mu_e;
    const Eigen::Vector2d r = Xy(reference[i]) - mu_r;
    dot += e.dot(r);
    cross += e.x() * r.y() - e.y() * r.x();
    var_e += e.squaredNorm();
    var_r += r.squaredNorm();
  }
  const double spread_floor = 1e-24 * static_cast<double>(n) * (1.0 + mu_e.squaredNorm());
  if (!(var_e > spread_floor)) {
    throw InvalidArgument("AlignUmeyama2D: all " + std::to_string(n) +
                          " estimate points coincide; rotation and scale are undefined");
  }
  const double correlation = std::hypot(dot, cross);
  if (!(correlation > 1e-12 * std::sqrt(var_e * var_r))) {
    throw InvalidArgument(
        "AlignUmeyama2D: estimate and reference point sets are uncorrelated (or the reference "
        "points coincide); the rotation is undefined");
  }
  AlignmentResult result;
  result.model = model;
  result.num_points = static_cast<int>(n);
  Similarity2D& t = result.enu_from_vo;
  t.angle_rad = std::atan2(cross, dot);
  t.scale = model == AlignmentModel::kSim2 ? correlation / var_e : 1.0;
  t.translation_m = mu_r - t.scale * (t.Rotation() * mu_e);
  double sum_sq = 0.0;
  for (size_t i = 0; i < n; ++i) {
    sum_sq += (Xy(reference[i]) - t.Apply(Xy(estimate[i]))).squaredNorm();
  }
  result.rmse_m = std::sqrt(sum_sq / static_cast<double>(n));
  return result;
}

TrajectoryErrorStats SummarizeErrors(std::vector<double> errors) {
  TrajectoryErrorStats s;
  s.count = static_cast<int>(errors.size());
  if (errors.empty()) return s;
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.max = std::max(s.max, e);
  }
  const double n = static_cast<double>(errors.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  const size_t mid = errors.size() / 2;
  std::nth_element(errors.begin(), errors.begin() + mid, errors.end());
  s.median = errors[mid];
  if (errors.size() % 2 == 0) {
    s.median = 0.5 * (s.median + *std::max_element(errors.begin(), errors.begin() + mid));
  }
  return s;
}

void Validate(const TrajectoryEvalOptions& options) {
  for (size_t i = 0; i < options.segment_lengths_m.size(); ++i) {
    const double l = options.segment_lengths_m[i];
    if (!(l > 0.0) || !std::isfinite(l)) {
      throw InvalidArgument("TrajectoryEvalOptions.segment_lengths_m[" + std::to_string(i) +
                            "] = " + std::to_string(l) + " must be a finite length > 0 m");
    }
  }
}

double PathLength(const std::vector<TrajectoryPoint2D>& trajectory) {
  double length = 0.0;
  for (size_t i = 1; i < trajectory.size(); ++i) {
    length +=
        std::hypot(trajectory[i].x - trajectory[i - 1].x, trajectory[i].y - trajectory[i - 1].y);
  }
  return length;
}

TrajectoryErrors EvaluateTrajectory(const std::vector<TrajectoryPoint2D>& estimate,
                                    const std::vector<TrajectoryPoint2D>& reference,
                                    const TrajectoryEvalOptions& options) {
  Validate(options);
  TrajectoryErrors out;
  out.alignment = AlignUmeyama2D(estimate, reference, options.model);
  const Similarity2D& t = out.alignment.enu_from_vo;
  const size_t n = estimate.size();

  out.ate_per_point_m.resize(n);
  for (size_t i = 0; i < n; ++i) {
    out.ate_per_point_m[i] = (Xy(reference[i]) - t.Apply(Xy(estimate[i]))).norm();
  }
  out.ate_m = SummarizeErrors(out.ate_per_point_m);

  // Cumulative reference path length, shared by the distance flown and the segments.
  std::vector<double> cum(n, 0.0);
  for (size_t i = 1; i < n; ++i) {
    cum[i] = cum[i - 1] + (Xy(reference[i]) - Xy(reference[i - 1])).norm();
  }
  out.distance_flown_m = cum[n - 1];
  const auto percent = [&](double e) {
    return out.distance_flown_m > 0.0 ? 100.0 * e / out.distance_flown_m : 0.0;
  };
  out.end_point_error_m = out.ate_per_point_m[n - 1];
  out.end_point_error_percent = percent(out.end_point_error_m);
  out.end_point_error_unaligned_m = (Xy(reference[n - 1]) - Xy(estimate[n - 1])).norm();
  out.end_point_error_unaligned_percent = percent(out.end_point_error_unaligned_m);

  const Eigen::Matrix2d linear = t.scale * t.Rotation();
  std::vector<double> seg_err, seg_drift;
  seg_err.reserve(n);
  seg_drift.reserve(n);
  for (double length : options.segment_lengths_m) {
    seg_err.clear();
    seg_drift.clear();
    size_t j = 0;
    for (size_t i = 0; i < n; ++i) {
      // The end index is monotone in the start index because cum is non-decreasing.
      j = std::max(j, i + 1);
      while (j < n && cum[j] - cum[i] < length) ++j;
      if (j >= n) break;
      const Eigen::Vector2d d_est = linear * (Xy(estimate[j]) - Xy(estimate[i]));
      const Eigen::Vector2d d_ref = Xy(reference[j]) - Xy(reference[i]);
      const double e = (d_est - d_ref).norm();
      seg_err.push_back(e);
      seg_drift.push_back(100.0 * e / (cum[j] - cum[i]));
    }
    SegmentErrors s;
    s.length_m = length;
    s.error_m = SummarizeErrors(seg_err);
    s.drift_percent = SummarizeErrors(seg_drift);
    out.segments.push_back(s);
  }
  return out;
}

TrajectoryComparison CompareTrajectories(const std::vector<TrajectoryPoint2D>& estimate,
                                         const std::vector<TrajectoryPoint2D>& reference,
                                         const TrajectoryEvalOptions& options) {
  TrajectoryEvalOptions o = options;
  TrajectoryComparison c;
  o.model = AlignmentModel::kSE2;
  c.se2 = EvaluateTrajectory(estimate, reference, o);
  o.model = AlignmentModel::kSim2;
  c.sim2 = EvaluateTrajectory(estimate, reference, o);
  return c;
}

void Validate(const AssociationOptions& options) {
  if (!(options.max_time_difference_s >= 0.0) || !std::isfinite(options.max_time_difference_s)) {
    throw InvalidArgument("AssociationOptions.max_time_difference_s = " +
                          std::to_string(options.max_time_difference_s) +
                          " must be a finite time >= 0 s");
  }
  if (!(options.max_gap_s > 0.0) || !std::isfinite(options.max_gap_s)) {
    throw InvalidArgument("AssociationOptions.max_gap_s = " + std::to_string(options.max_gap_s) +
                          " must be a finite time > 0 s");
  }
}

AssociatedTrajectories AssociateByTime(const std::vector<TrajectoryPoint2D>& estimate,
                                       const std::vector<TrajectoryPoint2D>& reference,
                                       const AssociationOptions& options) {
  Validate(options);
  CheckFinite(estimate, "AssociateByTime", "estimate");
  CheckFinite(reference, "AssociateByTime", "reference");
  for (size_t i = 1; i < reference.size(); ++i) {
    if (reference[i].t < reference[i - 1].t) {
      throw InvalidArgument("AssociateByTime: reference times must not decrease: point " +
                            std::to_string(i) + " has t " + std::to_string(reference[i].t) +
                            " s after t " + std::to_string(reference[i - 1].t) + " s");
    }
  }
  AssociatedTrajectories out;
  const auto by_time = [](const TrajectoryPoint2D& p, double t) { return p.t < t; };
  for (size_t i = 0; i < estimate.size(); ++i) {
    const double t = estimate[i].t;
    const size_t k = static_cast<size_t>(
        std::lower_bound(reference.begin(), reference.end(), t, by_time) - reference.begin());
    bool matched = false;
    TrajectoryPoint2D ref;
    int ref_index = -1;
    if (options.method == AssociationMethod::kNearest) {
      // Candidates: the first fix at or after t, and the last one before it; ties go to the
      // earlier fix.
      size_t best = reference.size();
      if (k > 0) best = k - 1;
      if (k < reference.size() &&
          (best == reference.size() || reference[k].t - t < t - reference[best].t)) {
        best = k;
      }
      if (best < reference.size() &&
          std::abs(reference[best].t - t) <= options.max_time_difference_s) {
        matched = true;
        ref = reference[best];
        ref_index = static_cast<int>(best);
      }
    } else if (k < reference.size() && reference[k].t == t) {
      matched = true;
      ref = reference[k];
      ref_index = static_cast<int>(k);
    } else if (k > 0 && k < reference.size() &&
               reference[k].t - reference[k - 1].t <= options.max_gap_s) {
      const TrajectoryPoint2D& a = reference[k - 1];
      const TrajectoryPoint2D& b = reference[k];
      const double w = (t - a.t) / (b.t - a.t);
      matched = true;
      ref = {t, a.x + w * (b.x - a.x), a.y + w * (b.y - a.y)};
      ref_index = static_cast<int>(k - 1);
    }
    if (matched) {
      out.estimate.push_back(estimate[i]);
      out.reference.push_back(ref);
      out.estimate_index.push_back(static_cast<int>(i));
      out.reference_index.push_back(ref_index);
    } else {
      ++out.num_unmatched;
    }
  }
  return out;
}

std::optional<MirrorCheck> CheckMirrored(const std::vector<TrajectoryPoint2D>& estimate,
                                         const std::vector<TrajectoryPoint2D>& reference) {
  CheckPairs(estimate, reference, "CheckMirrored");
  std::vector<TrajectoryPoint2D> reflected = estimate;
  for (TrajectoryPoint2D& p : reflected) p.y = -p.y;
  MirrorCheck c;
  try {
    c.rmse_m = AlignUmeyama2D(estimate, reference, AlignmentModel::kSim2).rmse_m;
    c.mirrored_rmse_m = AlignUmeyama2D(reflected, reference, AlignmentModel::kSim2).rmse_m;
  } catch (const InvalidArgument&) {
    return std::nullopt;
  }
  Eigen::Vector2d mu = Eigen::Vector2d::Zero();
  for (const TrajectoryPoint2D& r : reference) mu += Xy(r);
  mu /= static_cast<double>(reference.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const TrajectoryPoint2D& r : reference) {
    const Eigen::Vector2d d = Xy(r) - mu;
    cov += d * d.transpose();
  }
  cov /= static_cast<double>(reference.size());
  c.spread_m = std::sqrt(cov.trace());
  // Eigenvalues of the symmetric 2x2 covariance, in closed form.
  const double half_trace = 0.5 * cov.trace();
  const double disc = std::sqrt(std::max(
      0.0, 0.25 * (cov(0, 0) - cov(1, 1)) * (cov(0, 0) - cov(1, 1)) + cov(0, 1) * cov(0, 1)));
  const double major = half_trace + disc, minor = std::max(0.0, half_trace - disc);
  c.aspect = major > 0.0 ? std::sqrt(minor / major) : 0.0;
  c.mirrored = c.mirrored_rmse_m < 0.5 * c.rmse_m && c.rmse_m > 0.1 * c.spread_m && c.aspect >= 0.2;
  return c;
}

}  // namespace aerovo
