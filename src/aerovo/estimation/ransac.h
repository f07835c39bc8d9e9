// Robust estimation of a frame-to-frame transform from putative correspondences: ONE RANSAC loop
// (Fischler & Bolles 1981), templated on four policies:
//   Model      the motion model (aerovo/estimation/models.h): minimal solver, least squares,
//              residuals;
//   Sampler    the minimal-sample generator (aerovo/estimation/samplers.h);
//   Scorer     the cost of a model from its squared residuals (MsacScorer by default: MSAC,
//              Torr & Zisserman 2000), lower = better;
//   Optimizer  what is done to a model beyond its minimal sample (LeastSquaresOptimizer by
//              default): Local() whenever the loop finds a new best model (local optimisation,
//              PoseLib's refine_model), Final() once on the best model after the loop (the final
//              refit and the robust polish).
// Semantics and defaults follow MATLAB's estimateGeometricTransform2D (the paper's tool):
// MaxNumTrials 1000, Confidence 99 %, MaxDistance 1.5 px, adaptive trial count, least-squares
// refit on the inliers (MATLAB: once; here iterated to convergence, see
// RansacOptions::final_refit_iterations). Optional local optimisation (Chum, Matas, Kittler,
// "Locally optimized RANSAC", DAGM 2003, simplified to iterated least squares on the inliers).
// Optional robust polish of the result (iteratively reweighted least squares with a smooth
// Geman-McClure loss over all correspondences, in the spirit of PoseLib's robust refinement
// after RANSAC), which makes the estimate independent of the RANSAC seed.
//
// The loop (RunRansac) owns only the trial count and the bookkeeping: draw a sample, solve it
// (a false from Model::SolveMinimal is a degenerate sample), score it, and on a new best model
// call Optimizer::Local and shrink the adaptive trial count; after the loop Optimizer::Final,
// then the result (inlier mask of the returned model's residuals). A new scorer or optimiser is
// a new policy type, not an edit of the loop.
//
// Policy contracts (static members, inlined: no virtual call, no allocation per trial):
//   Scorer::Cost(r2, n, threshold2, &num_inliers) -> double
//       cost of the squared residuals r2[0..n) (px^2), lower = better; +inf or NaN marks an
//       unusable model (never better than anything, so never accepted). num_inliers =
//       #{i : r2[i] < threshold2}: the inlier definition is the loop's (max_distance_px),
//       whatever the scorer.
//   Optimizer::Local(state), Optimizer::Final(state)   (state: RansacState<Model, Scorer>)
//       replace state's best model through state.Score and state.Accept, which keep the model,
//       its cost, its inlier count and its residuals (ws.best_residuals) consistent. Local runs
//       inside the loop: it uses the workspace's buffers (no allocation) and should accept only
//       a lower cost, since the later trials are compared with state.best_score. Final runs
//       once and may accept any model: the result is a success when the final model has at
//       least Model::kMinSample inliers, and reports that model's mask, count and cost.
// Where the steps live: the final refit and the polish are steps of the default optimiser's
// Final (driven by RansacOptions as before); they and the local optimisation are free
// function templates (RefitWhileCostImproves, FinalRefit, GemanMcClurePolish) that another
// optimiser can compose differently (ransac_test.cc has examples).
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

#include "aerovo/core/cancel.h"
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
  /// a single refit inherits that spatial bias (BENCHMARKS.md, "Estimator defaults").
  int final_refit_iterations = 3;
  /// Robust polish after the refits (not in MATLAB): up to polish_iterations rounds of
  /// iteratively reweighted least squares over EVERY correspondence with Geman-McClure weights
  /// w = (1 + r^2 / s^2)^-2, s = polish_scale_px, stopping when the model moves less than
  /// 1e-4 px over the prev points' bounding box. The polished model is kept when it has at least
  /// the minimal sample of inliers (mask, count and score are those of the returned model).
  /// Why: the refits fit one hard-thresholded inlier set, and on a non-planar scene neighbouring
  /// inlier sets give models that differ at the frame corners depending on the seed; the smooth
  /// loss has one minimum near them, so the result becomes a function of the correspondences
  /// alone (BENCHMARKS.md, "Estimator defaults"). The price: outliers a few s from the model
  /// keep a small weight (0.07 at 5 px). Default 0 (off: MATLAB's estimator, the paper's).
  int polish_iterations = 0;
  /// Scale s of the polish's loss, px: residuals well below s count fully, a residual of s
  /// counts 1/4, of 3 s 1 %. Default 3 px (twice MaxDistance; BENCHMARKS.md, "Estimator defaults").
  double polish_scale_px = 3.0;
};

/// Throws InvalidArgument naming the offending field when `options` are out of range.
void Validate(const RansacOptions& options);
/// The option schema (core/options.h; keys ransac.* in a run configuration).
// clang-format off
template <class V>
void VisitFields(RansacOptions& o, V& v) {
  using namespace options;
  v.Field(o.max_num_trials, "max_num_trials", "Most minimal samples scored (MATLAB MaxNumTrials)", Interval(1, 10000000));
  v.Field(o.confidence_percent, "confidence_percent", "Confidence of the adaptive trial count, % (MATLAB Confidence)", Interval(0, 100, true, true));
  v.Field(o.max_distance_px, "max_distance_px", "Inlier threshold on the transfer error, px (MATLAB MaxDistance)", GreaterThan(0).Finite());
  v.Field(o.max_degenerate_samples, "max_degenerate_samples", "Degenerate samples allowed before giving up", Interval(0, 10000000));
  v.Field(o.seed, "seed", "Seed of the sampler (same seed and input, same result)", Any().Alias("seed"));
  v.Field(o.local_optimization, "local_optimization", "Least-squares local optimisation of every new best model", Any());
  v.Field(o.lo_max_iterations, "lo_max_iterations", "Most refits per local optimisation", Interval(1, 1000));
  v.Field(o.final_refit_iterations, "final_refit_iterations", "Least-squares refits of the best model (MATLAB: 1)", Interval(0, 1000));
  v.Field(o.polish_iterations, "polish_iterations", "Robust IRLS polish rounds over all matches (0 = off; 20 makes tracks seed-independent)", Interval(0, 1000).Alias("polish"));
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
  /// Scorer cost of curr_from_prev (RunRansac's Scorer policy; by default MSAC: sum over all
  /// correspondences of min(e^2, max_distance^2), px^2); lower is better.
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

// ------------------------------------------------------------------------------------ scorers

/// MSAC (Torr & Zisserman 2000, MATLAB's estimateGeometricTransform2D): cost = sum over all
/// correspondences of min(e^2, threshold^2), px^2.
struct MsacScorer {
  // Four independent partial sums: one running sum is a serial chain of FP adds (4-cycle
  // latency each, and without -ffast-math the compiler may not reassociate it); BENCHMARKS.md,
  // "Estimator defaults".
  static double Cost(const double* r, int n, double threshold2, int* num_inliers) {
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
};

// ---------------------------------------------------------------------------- the loop's state

/// The best model so far and what the policies share during one RunRansac call: the input, the
/// options, the workspace. The best model's residuals are always ws.best_residuals.
template <class ModelT, class ScorerT>
struct RansacState {
  using Model = ModelT;
  using Scorer = ScorerT;

  RansacState(const RansacOptions& options, const Eigen::Matrix2Xd& prev_px,
              const Eigen::Matrix2Xd& curr_px, RansacWorkspace& ws)
      : options(options),
        prev_px(prev_px),
        curr_px(curr_px),
        ws(ws),
        n(static_cast<int>(prev_px.cols())),
        threshold2(options.max_distance_px * options.max_distance_px) {}

  /// Residuals of `model` into residuals[0..n) (px^2) and their cost; *num_inliers as Scorer.
  double Score(const Eigen::Matrix3d& model, double* residuals, int* num_inliers) const {
    Model::SquaredResiduals(model, prev_px, curr_px, residuals);
    return Scorer::Cost(residuals, n, threshold2, num_inliers);
  }

  /// Makes `model` the best; `residuals` (a workspace buffer holding its residuals, e.g.
  /// ws.residuals) is swapped with ws.best_residuals.
  void Accept(const Eigen::Matrix3d& model, double cost, int num_inliers,
              std::vector<double>& residuals) {
    best_model = model;
    best_score = cost;
    best_inliers = num_inliers;
    ws.best_residuals.swap(residuals);
  }

  /// Indices of the best model's inliers into ws.inliers; returns their number.
  int CollectBestInliers() {
    const double* r = ws.best_residuals.data();
    std::vector<int>& out = ws.inliers;
    out.clear();
    for (int i = 0; i < n; ++i) {
      if (r[i] < threshold2) out.push_back(i);
    }
    return static_cast<int>(out.size());
  }

  const RansacOptions& options;
  const Eigen::Matrix2Xd& prev_px;
  const Eigen::Matrix2Xd& curr_px;
  RansacWorkspace& ws;
  const int n;              // Number of correspondences.
  const double threshold2;  // max_distance_px^2.
  Eigen::Matrix3d best_model = Eigen::Matrix3d::Identity();
  double best_score = std::numeric_limits<double>::infinity();  // Scorer cost; inf: no model.
  int best_inliers = 0;
};

// ------------------------------------------------------------------- optimisation building blocks

/// Least-squares refit of the best model on its inliers, then on the refit's inliers, ... at
/// most max_iterations times, each kept only while the cost decreases (local optimisation).
template <class State>
void RefitWhileCostImproves(State& s, int max_iterations) {
  Eigen::Matrix3d model;
  for (int it = 0; it < max_iterations; ++it) {
    const int k = s.CollectBestInliers();
    if (!State::Model::FitLeastSquares(s.prev_px, s.curr_px, s.ws.inliers.data(), k, &model)) {
      return;
    }
    int inl = 0;
    const double score = s.Score(model, s.ws.residuals.data(), &inl);
    if (!(score < s.best_score)) return;
    s.Accept(model, score, inl, s.ws.residuals);
  }
}

/// The refits of RansacOptions::final_refit_iterations: the first least-squares fit on the best
/// model's inliers is kept whatever its cost (MATLAB's single refit), each further one while the
/// cost decreases; none is kept with fewer than Model::kMinSample inliers.
template <class State>
void FinalRefit(State& s, int iterations) {
  Eigen::Matrix3d model;
  for (int it = 0; it < iterations; ++it) {
    // The mask is recomputed after every accepted refit, so it always describes the returned
    // model.
    const int k = s.CollectBestInliers();
    if (!State::Model::FitLeastSquares(s.prev_px, s.curr_px, s.ws.inliers.data(), k, &model)) {
      return;
    }
    int inl = 0;
    const double score = s.Score(model, s.ws.residuals.data(), &inl);
    if (inl < State::Model::kMinSample || (it > 0 && !(score < s.best_score))) return;
    s.Accept(model, score, inl, s.ws.residuals);
  }
}

/// The robust polish of RansacOptions::polish_iterations / polish_scale_px: iteratively
/// reweighted least squares over every correspondence with Geman-McClure weights, from the
/// best model; the polished model replaces it when it is finite and has at least
/// Model::kMinSample inliers (whatever its cost).
template <class State>
void GemanMcClurePolish(State& s, int iterations, double scale_px) {
  using Model = typename State::Model;
  const int n = s.n;
  RansacWorkspace& ws = s.ws;
  ws.all.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) ws.all[static_cast<std::size_t>(i)] = i;
  ws.weights.resize(static_cast<std::size_t>(n));
  ws.polish_residuals.assign(ws.best_residuals.begin(), ws.best_residuals.end());
  const Eigen::Vector2d lo = s.prev_px.rowwise().minCoeff(), hi = s.prev_px.rowwise().maxCoeff();
  const Eigen::Vector2d box[4] = {lo, {hi.x(), lo.y()}, {lo.x(), hi.y()}, hi};
  const double inv_s2 = 1.0 / (scale_px * scale_px);
  Eigen::Matrix3d model, current = s.best_model;
  for (int it = 0; it < iterations; ++it) {
    for (int i = 0; i < n; ++i) {
      const double u = 1.0 + ws.polish_residuals[static_cast<std::size_t>(i)] * inv_s2;
      ws.weights[static_cast<std::size_t>(i)] = 1.0 / (u * u);
    }
    if (!Model::FitLeastSquares(s.prev_px, s.curr_px, ws.all.data(), n, &model,
                                ws.weights.data())) {
      break;
    }
    double moved2 = 0.0;
    for (const Eigen::Vector2d& c : box) {
      moved2 =
          std::max(moved2, (TransformPoint(model, c) - TransformPoint(current, c)).squaredNorm());
    }
    current = model;
    Model::SquaredResiduals(current, s.prev_px, s.curr_px, ws.polish_residuals.data());
    if (!(moved2 >= 1e-8)) break;  // < 1e-4 px (or NaN: the residuals say the rest).
  }
  int inl = 0;
  const double score =
      State::Scorer::Cost(ws.polish_residuals.data(), n, s.threshold2, &inl);
  if (inl >= Model::kMinSample && current.allFinite()) {
    s.Accept(current, score, inl, ws.polish_residuals);
  }
}

// --------------------------------------------------------------------------------- optimisers

/// The default optimiser, driven by RansacOptions: Local = the local optimisation
/// (local_optimization, lo_max_iterations); Final = the final refits (final_refit_iterations)
/// then the robust polish (polish_iterations, polish_scale_px).
struct LeastSquaresOptimizer {
  template <class State>
  static void Local(State& s) {
    if (s.options.local_optimization) RefitWhileCostImproves(s, s.options.lo_max_iterations);
  }
  template <class State>
  static void Final(State& s) {
    FinalRefit(s, s.options.final_refit_iterations);
    if (s.options.polish_iterations > 0 && s.best_inliers >= State::Model::kMinSample) {
      GemanMcClurePolish(s, s.options.polish_iterations, s.options.polish_scale_px);
    }
  }
};

/// The RANSAC loop. `quality` (may be null): one value per correspondence, lower = better
/// (used by quality-aware samplers such as PROSAC). Throws InvalidArgument if prev_px and
/// curr_px differ in size or hold a non-finite value. Fewer correspondences than the minimal
/// sample is not an error: the result has success = false. `options` are not validated here
/// (Ransac and EstimateTransform do it).
template <class Model, class Sampler, class Scorer = MsacScorer,
          class Optimizer = LeastSquaresOptimizer>
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
  ws.residuals.resize(static_cast<std::size_t>(n));
  ws.best_residuals.resize(static_cast<std::size_t>(n));
  ws.inliers.reserve(static_cast<std::size_t>(n));
  sampler.Reset(options.seed, n, m, quality);
  RansacState<Model, Scorer> state(options, prev_px, curr_px, ws);

  Eigen::Matrix3d model;
  int trial_limit = options.max_num_trials;
  int sample[m];
  while (result.num_trials < trial_limit) {
    // A stop request (core/cancel.h) ends the frame; every 16 trials, one atomic load.
    if ((result.num_trials & 15) == 0) ThrowIfCancelled("RANSAC");
    sampler.Draw(sample);
    if (!Model::SolveMinimal(prev_px, curr_px, sample, &model)) {
      if (++result.num_degenerate_samples > options.max_degenerate_samples) break;
      continue;
    }
    ++result.num_trials;
    int inl = 0;
    const double score = state.Score(model, ws.residuals.data(), &inl);
    if (score < state.best_score) {
      state.Accept(model, score, inl, ws.residuals);
      Optimizer::Local(state);
      const int needed = RansacTrialCount(options.confidence_percent,
                                          static_cast<double>(state.best_inliers) / n, m);
      trial_limit = std::min(trial_limit, needed);
    }
  }
  if (state.best_score == std::numeric_limits<double>::infinity()) {  // No model found.
    result.time_ms = watch.elapsed_ms();
    return result;
  }
  Optimizer::Final(state);

  result.success = state.best_inliers >= m;
  if (result.success) {
    result.curr_from_prev = state.best_model;
    result.score = state.best_score;
    result.num_inliers = state.best_inliers;
    const double t2 = state.threshold2;
    for (int i = 0; i < n; ++i) {
      result.inlier_mask[static_cast<std::size_t>(i)] = ws.best_residuals[i] < t2 ? 1 : 0;
    }
  } else {
    result.score = state.best_score;
  }
  result.time_ms = watch.elapsed_ms();
  return result;
}

/// RANSAC estimator for one set of policies (see RunRansac); keeps its buffers between calls.
/// Not thread-safe: one instance per thread.
template <class Model, class Sampler = UniformSampler, class Scorer = MsacScorer,
          class Optimizer = LeastSquaresOptimizer>
class Ransac {
 public:
  /// Throws InvalidArgument if `options` are invalid.
  explicit Ransac(const RansacOptions& options = {}) : options_(options) { Validate(options_); }

  const RansacOptions& options() const { return options_; }

  /// See RunRansac. The sampler is re-seeded with options().seed at every call, so repeated
  /// calls on the same input give the same result.
  RansacResult Estimate(const Eigen::Matrix2Xd& prev_px, const Eigen::Matrix2Xd& curr_px,
                        const float* quality = nullptr) {
    return RunRansac<Model, Sampler, Scorer, Optimizer>(options_, prev_px, curr_px, quality,
                                                        sampler_, workspace_);
  }

 private:
  RansacOptions options_;
  Sampler sampler_;
  RansacWorkspace workspace_;
};

/// Run-time dispatch to RunRansac<Model, Sampler> with the default scorer and optimiser (once per
/// call, through VisitMotionModel and VisitSampler; the loop itself is the template). Validates
/// `options`. `workspace` may be reused across calls and models.
RansacResult EstimateTransform(MotionModel model, SamplerKind sampler, const RansacOptions& options,
                               const Eigen::Matrix2Xd& prev_px, const Eigen::Matrix2Xd& curr_px,
                               const float* quality, RansacWorkspace& workspace);

}  // namespace aerovo
