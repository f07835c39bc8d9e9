// Robust estimation of a frame-to-frame transform from putative correspondences: ONE RANSAC loop
// (Fischler & Bolles 1981) with MSAC scoring (Torr & Zisserman 2000), templated on the model
// (aerovo/estimation/models.h) and the sampler (aerovo/estimation/samplers.h) policies.
// Semantics and defaults follow MATLAB's estimateGeometricTransform2D (the paper's tool):
// MaxNumTrials 1000, Confidence 99 %, MaxDistance 1.5 px, adaptive trial count, least-squares
// refit on the inliers (MATLAB: once; here iterated to convergence, see
// RansacOptions::final_refit_iterations). Optional local optimisation (Chum, Matas, Kittler,
// "Locally optimized RANSAC", DAGM 2003, simplified to iterated least squares on the inliers).
// Optional robust polish of the result (iteratively reweighted least squares with a smooth
// Geman-McClure loss over all correspondences, in the spirit of PoseLib's robust refinement
// after RANSAC), which makes the estimate independent of the RANSAC seed.
//
// Frames and units: prev_px / curr_px are 2xN pixel positions in the previous / current frame;
// the model is curr_from_prev (3x3, maps prev pixels to curr pixels); residuals, thresholds and
// scores are in pixels / pixels^2 of the current frame.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "aerovo/core/error.h"
#include "aerovo/core/options.h"
#include "aerovo/core/timer.h"
#include "aerovo/estimation/models.h"
#include "aerovo/estimation/samplers.h"

namespace aerovo {

/// Options of the robust estimator. Defaults are MATLAB estimateGeometricTransform2D's.
struct RansacOptions {
  /// Upper bound on the number of (non-degenerate) minimal samples scored. Default 1000
  /// (MATLAB MaxNumTrials).
  int max_num_trials = 1000;
  /// Probability, in percent, that at least one all-inlier sample is drawn; sets the adaptive
  /// trial count N = ceil(log(1 - p) / log(1 - w^m)). Default 99 (MATLAB Confidence).
  double confidence_percent = 99.0;
  /// Inlier threshold on the transfer error |T(prev) - curr|, px; also the MSAC truncation.
  /// Default 1.5 px (MATLAB MaxDistance).
  double max_distance_px = 1.5;
  /// Degenerate samples (rejected before scoring, not counted as trials) allowed before giving
  /// up, so that all-degenerate data terminates. Default 10000 (10 x max_num_trials; our
  /// choice, in the spirit of MATLAB's bound on skipped trials).
  int max_degenerate_samples = 10000;
  /// Seed of the sampler: same seed and input, same result.
  std::uint64_t seed = 1;
  /// Local optimisation: whenever a new best model is found, refit it by least squares on its
  /// inliers and keep the refit while the MSAC score improves. Default false (MATLAB has none).
  bool local_optimization = false;
  /// Maximum refits per local optimisation. Default 4 (our choice: LO converges in 2-3).
  int lo_max_iterations = 4;
  /// Least-squares refits of the best model before returning: the first on the best sample's
  /// inliers (always kept, as MATLAB's single refit), each further one on the previous fit's
  /// inliers, kept while the MSAC score improves. 0 returns the minimal-sample model.
  /// Default 3 (MATLAB: 1). Why more than one: when noise is comparable to max_distance_px the
  /// best minimal-sample model misses inliers in the parts of the frame it extrapolates to, and
  /// a single refit inherits that spatial bias (measured on synthetic-flight in
  /// bench_correspondence: 0.12 px corner error after one refit, 0.04 px after convergence).
  int final_refit_iterations = 3;
  /// Robust polish after the refits (not in MATLAB): up to polish_iterations rounds of
  /// iteratively reweighted least squares over EVERY correspondence with Geman-McClure weights
  /// w = (1 + r^2 / s^2)^-2, s = polish_scale_px, stopping when the model moves less than
  /// 1e-4 px over the prev points' bounding box. The polished model is kept when it has at least
  /// the minimal sample of inliers (mask, count and score are those of the returned model).
  /// Why: the refits fit one hard-thresholded inlier set, and on a non-planar scene neighbouring
  /// inlier sets give models 1.8 px apart at the frame corners depending on the seed (tampa-
  /// phantom3, BENCHMARKS.md "Correspondence"); the smooth loss has one minimum near them, so
  /// the result becomes a function of the correspondences alone (seed spread 0.00 px there).
  /// The price: outliers a few s from the model keep a small weight (0.07 at 5 px), which moves
  /// an exact fit by thousandths of a pixel. Default 0 (off: MATLAB's estimator, the paper's).
  int polish_iterations = 0;
  /// Scale s of the polish's loss, px: residuals well below s count fully, a residual of s
  /// counts 1/4, of 3 s 1 %. Default 3 px (twice MaxDistance; our choice: on tampa-phantom3
  /// s = 1.5 px still left a 0.18 px mean seed-to-seed spread, 3 px none).
  double polish_scale_px = 3.0;
};

/// Throws InvalidArgument naming the offending field when `options` are out of range.
void Validate(const RansacOptions& options);
/// The option schema (core/options.h; keys ransac.* in a run configuration).
// clang-format off
template <class V>
void VisitFields(RansacOptions& o, V& v) {
  using namespace options;
  v.Field(o.max_num_trials, "max_num_trials", "Most minimal samples scored (MATLAB MaxNumTrials)", AtLeast(1));
  v.Field(o.confidence_percent, "confidence_percent", "Confidence of the adaptive trial count, % (MATLAB Confidence)", Interval(0, 100, true, true));
  v.Field(o.max_distance_px, "max_distance_px", "Inlier threshold on the transfer error, px (MATLAB MaxDistance)", GreaterThan(0).Finite());
  v.Field(o.max_degenerate_samples, "max_degenerate_samples", "Degenerate samples allowed before giving up", AtLeast(0));
  v.Field(o.seed, "seed", "Seed of the sampler (same seed and input, same result)", Any().Alias("seed"));
  v.Field(o.local_optimization, "local_optimization", "Least-squares local optimisation of every new best model", Any());
  v.Field(o.lo_max_iterations, "lo_max_iterations", "Most refits per local optimisation", AtLeast(1));
  v.Field(o.final_refit_iterations, "final_refit_iterations", "Least-squares refits of the best model (MATLAB: 1)", AtLeast(0));
  v.Field(o.polish_iterations, "polish_iterations", "Robust IRLS polish rounds over all matches (0 = off; 20 makes tracks seed-independent)", AtLeast(0).Alias("polish"));
  v.Field(o.polish_scale_px, "polish_scale_px", "Scale of the polish's Geman-McClure loss, px", GreaterThan(0).Finite());
}
// clang-format on

/// Result of one robust estimation, returned by value.
struct RansacResult {
  /// True when a model was found with at least the model's minimal sample of inliers.
  bool success = false;
  /// Estimated transform (identity when !success).
  Eigen::Matrix3d curr_from_prev = Eigen::Matrix3d::Identity();
  /// One entry per correspondence: 1 if its transfer error under curr_from_prev is below
  /// max_distance_px, else 0 (all 0 when !success).
  std::vector<std::uint8_t> inlier_mask;
  int num_inliers = 0;
  /// Minimal samples scored (degenerate samples excluded).
  int num_trials = 0;
  /// Minimal samples rejected as degenerate.
  int num_degenerate_samples = 0;
  /// MSAC cost of curr_from_prev: sum over all correspondences of min(e^2, max_distance^2),
  /// px^2; lower is better.
  double score = std::numeric_limits<double>::infinity();
  double time_ms = 0.0;
};

/// The adaptive trial count of MATLAB's msac (computeLoopNumber): the number of minimal samples
/// of `sample_size` needed so that, with inlier ratio `inlier_ratio`, at least one is all
/// inliers with probability confidence_percent / 100: ceil(log(1 - p) / log(1 - w^m)).
/// Returns INT32_MAX when w^m is below double epsilon, 0 when w = 1.
int RansacTrialCount(double confidence_percent, double inlier_ratio, int sample_size);

/// Reusable buffers of the RANSAC loop (no allocation per trial; reused across calls).
struct RansacWorkspace {
  std::vector<double> residuals;         // Residuals of the model being scored, px^2.
  std::vector<double> best_residuals;    // Residuals of the best model so far, px^2.
  std::vector<int> inliers;              // Indices of the best model's inliers.
  std::vector<int> all;                  // 0 .. n-1 (the polish fits every correspondence).
  std::vector<double> weights;           // Polish weights, one per correspondence.
  std::vector<double> polish_residuals;  // Residuals of the model being polished, px^2.
};

namespace internal {

// MSAC cost and inlier count of residuals r[0..n). Four independent partial sums: one running
// sum is a serial chain of FP adds (4-cycle latency each, and without -ffast-math the compiler
// may not reassociate it); BM_RansacAffine/10000 went from 2.2 to 0.87 ms with this.
inline double MsacScore(const double* r, int n, double threshold2, int* num_inliers) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int c0 = 0, c1 = 0, c2 = 0, c3 = 0;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += std::min(r[i], threshold2);
    s1 += std::min(r[i + 1], threshold2);
    s2 += std::min(r[i + 2], threshold2);
    s3 += std::min(r[i + 3], threshold2);
    c0 += r[i] < threshold2;
    c1 += r[i + 1] < threshold2;
    c2 += r[i + 2] < threshold2;
    c3 += r[i + 3] < threshold2;
  }
  for (; i < n; ++i) {
    s0 += std::min(r[i], threshold2);
    c0 += r[i] < threshold2;
  }
  *num_inliers = c0 + c1 + c2 + c3;
  return (s0 + s1) + (s2 + s3);
}

inline int CollectInliers(const double* r, int n, double threshold2, std::vector<int>* out) {
  out->clear();
  for (int i = 0; i < n; ++i) {
    if (r[i] < threshold2) out->push_back(i);
  }
  return static_cast<int>(out->size());
}

}  // namespace internal

/// The RANSAC/MSAC loop. `quality` (may be null): one value per correspondence, lower = better
/// (used by quality-aware samplers such as PROSAC). Throws InvalidArgument if prev_px and
/// curr_px differ in size or hold a non-finite value. Fewer correspondences than the minimal
/// sample is not an error: the result has success = false.
template <class Model, class Sampler>
RansacResult RunRansac(const RansacOptions& options, const Eigen::Matrix2Xd& prev_px,
                       const Eigen::Matrix2Xd& curr_px, const float* quality, Sampler& sampler,
                       RansacWorkspace& ws) {
  Stopwatch watch;
  if (prev_px.cols() != curr_px.cols()) {
    throw InvalidArgument("RANSAC: " + std::to_string(prev_px.cols()) + " prev points but " +
                          std::to_string(curr_px.cols()) + " curr points");
  }
  if (!prev_px.allFinite() || !curr_px.allFinite()) {
    throw InvalidArgument("RANSAC: a correspondence has a non-finite pixel coordinate");
  }
  constexpr int m = Model::kMinSample;
  const int n = static_cast<int>(prev_px.cols());
  RansacResult result;
  result.inlier_mask.assign(static_cast<std::size_t>(n), 0);
  if (n < m) {
    result.time_ms = watch.elapsed_ms();
    return result;
  }
  const double t2 = options.max_distance_px * options.max_distance_px;
  ws.residuals.resize(static_cast<std::size_t>(n));
  ws.best_residuals.resize(static_cast<std::size_t>(n));
  ws.inliers.reserve(static_cast<std::size_t>(n));
  sampler.Reset(options.seed, n, m, quality);

  Eigen::Matrix3d model, best_model = Eigen::Matrix3d::Identity();
  double best_score = std::numeric_limits<double>::infinity();
  int best_inliers = 0;
  int trial_limit = options.max_num_trials;
  int sample[m];

  // Least-squares refits on the current best inliers while the MSAC score improves.
  auto local_optimise = [&](int max_iterations) {
    for (int it = 0; it < max_iterations; ++it) {
      const int k = internal::CollectInliers(ws.best_residuals.data(), n, t2, &ws.inliers);
      if (!Model::FitLeastSquares(prev_px, curr_px, ws.inliers.data(), k, &model)) return;
      Model::SquaredResiduals(model, prev_px, curr_px, ws.residuals.data());
      int inl = 0;
      const double score = internal::MsacScore(ws.residuals.data(), n, t2, &inl);
      if (!(score < best_score)) return;
      best_score = score;
      best_inliers = inl;
      best_model = model;
      ws.best_residuals.swap(ws.residuals);
    }
  };

  while (result.num_trials < trial_limit) {
    sampler.Draw(sample);
    if (!Model::SolveMinimal(prev_px, curr_px, sample, &model)) {
      if (++result.num_degenerate_samples > options.max_degenerate_samples) break;
      continue;
    }
    ++result.num_trials;
    Model::SquaredResiduals(model, prev_px, curr_px, ws.residuals.data());
    int inl = 0;
    const double score = internal::MsacScore(ws.residuals.data(), n, t2, &inl);
    if (score < best_score) {
      best_score = score;
      best_inliers = inl;
      best_model = model;
      ws.best_residuals.swap(ws.residuals);
      if (options.local_optimization) local_optimise(options.lo_max_iterations);
      const int needed =
          RansacTrialCount(options.confidence_percent, static_cast<double>(best_inliers) / n, m);
      trial_limit = std::min(trial_limit, needed);
    }
  }

  if (best_score == std::numeric_limits<double>::infinity()) {
    result.time_ms = watch.elapsed_ms();
    return result;
  }
  for (int it = 0; it < options.final_refit_iterations; ++it) {
    // The mask is recomputed after every accepted refit, so it always describes the returned
    // model.
    const int k = internal::CollectInliers(ws.best_residuals.data(), n, t2, &ws.inliers);
    if (!Model::FitLeastSquares(prev_px, curr_px, ws.inliers.data(), k, &model)) break;
    Model::SquaredResiduals(model, prev_px, curr_px, ws.residuals.data());
    int inl = 0;
    const double score = internal::MsacScore(ws.residuals.data(), n, t2, &inl);
    if (inl < m || (it > 0 && !(score < best_score))) break;
    best_model = model;
    best_score = score;
    best_inliers = inl;
    ws.best_residuals.swap(ws.residuals);
  }
  if (options.polish_iterations > 0 && best_inliers >= m) {
    ws.all.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) ws.all[static_cast<std::size_t>(i)] = i;
    ws.weights.resize(static_cast<std::size_t>(n));
    ws.polish_residuals.assign(ws.best_residuals.begin(), ws.best_residuals.end());
    const Eigen::Vector2d lo = prev_px.rowwise().minCoeff(), hi = prev_px.rowwise().maxCoeff();
    const Eigen::Vector2d box[4] = {lo, {hi.x(), lo.y()}, {lo.x(), hi.y()}, hi};
    const double inv_s2 = 1.0 / (options.polish_scale_px * options.polish_scale_px);
    Eigen::Matrix3d current = best_model;
    for (int it = 0; it < options.polish_iterations; ++it) {
      for (int i = 0; i < n; ++i) {
        const double u = 1.0 + ws.polish_residuals[static_cast<std::size_t>(i)] * inv_s2;
        ws.weights[static_cast<std::size_t>(i)] = 1.0 / (u * u);
      }
      if (!Model::FitLeastSquares(prev_px, curr_px, ws.all.data(), n, &model, ws.weights.data())) {
        break;
      }
      double moved2 = 0.0;
      for (const Eigen::Vector2d& c : box) {
        moved2 =
            std::max(moved2, (TransformPoint(model, c) - TransformPoint(current, c)).squaredNorm());
      }
      current = model;
      Model::SquaredResiduals(current, prev_px, curr_px, ws.polish_residuals.data());
      if (!(moved2 >= 1e-8)) break;  // < 1e-4 px (or NaN: the residuals say the rest).
    }
    int inl = 0;
    const double score = internal::MsacScore(ws.polish_residuals.data(), n, t2, &inl);
    if (inl >= m && current.allFinite()) {
      best_model = current;
      best_score = score;
      best_inliers = inl;
      ws.best_residuals.swap(ws.polish_residuals);
    }
  }
  result.curr_from_prev = best_model;
  result.score = best_score;
  result.num_inliers = best_inliers;
  for (int i = 0; i < n; ++i) {
    result.inlier_mask[static_cast<std::size_t>(i)] = ws.best_residuals[i] < t2 ? 1 : 0;
  }
  result.success = best_inliers >= m;
  if (!result.success) {
    result.curr_from_prev.setIdentity();
    std::fill(result.inlier_mask.begin(), result.inlier_mask.end(), 0);
    result.num_inliers = 0;
  }
  result.time_ms = watch.elapsed_ms();
  return result;
}

/// RANSAC estimator for one model and sampler policy; keeps its buffers between calls.
/// Not thread-safe: one instance per thread.
template <class Model, class Sampler = UniformSampler>
class Ransac {
 public:
  /// Throws InvalidArgument if `options` are invalid.
  explicit Ransac(const RansacOptions& options = {}) : options_(options) { Validate(options_); }

  const RansacOptions& options() const { return options_; }

  /// See RunRansac. The sampler is re-seeded with options().seed at every call, so repeated
  /// calls on the same input give the same result.
  RansacResult Estimate(const Eigen::Matrix2Xd& prev_px, const Eigen::Matrix2Xd& curr_px,
                        const float* quality = nullptr) {
    return RunRansac<Model, Sampler>(options_, prev_px, curr_px, quality, sampler_, workspace_);
  }

 private:
  RansacOptions options_;
  Sampler sampler_;
  RansacWorkspace workspace_;
};

/// Run-time dispatch to Ransac<Model, Sampler> (once per call; the loop itself is the
/// template). Validates `options`. `workspace` may be reused across calls and models.
RansacResult EstimateTransform(MotionModel model, SamplerKind sampler, const RansacOptions& options,
                               const Eigen::Matrix2Xd& prev_px, const Eigen::Matrix2Xd& curr_px,
                               const float* quality, RansacWorkspace& workspace);

}  // namespace aerovo
