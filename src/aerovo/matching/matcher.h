// Descriptor matching between the features of two frames (prev = frame n-1, curr = frame n),
// with MATLAB matchFeatures semantics by default (docs/method.md, "Matching defaults").
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "aerovo/core/options.h"
#include "aerovo/features/keypoint.h"

namespace aerovo {

namespace matching_detail {
class KdForest;
}  // namespace matching_detail

/// How the best and second-best candidates of a query are found (without a motion prior; with
/// one, Matcher::Match always uses the guided grid, whatever this says).
enum class MatchAlgorithm {
  /// Every candidate compared (blocked SIMD): exact, the reference.
  kExhaustive,
  /// Randomized k-d forest over the current frame's descriptors (Silpa-Anan & Hartley 2008;
  /// Muja & Lowe 2009): approximate top-2 search with a budget of examined points; the
  /// decisions on the top-2 found are the exhaustive ones (exact SSD, threshold, ratio).
  kKdForest,
};

/// The algorithm named "exhaustive" or "kdtree" (the CLI's and the run configuration's names);
/// throws InvalidArgument for any other name.
MatchAlgorithm ParseMatchAlgorithm(const std::string& name);
/// "exhaustive" / "kdtree" (the names ParseMatchAlgorithm accepts).
const char* ToString(MatchAlgorithm algorithm);

/// Options of the matching stage. Defaults are MATLAB matchFeatures' defaults (the paper's).
struct MatchOptions {
  /// Ratio test on squared distances: accept the best candidate only if
  /// ssd_best <= max_ratio * ssd_second. Default 0.6 (MATLAB MaxRatio, ratio of SSDs).
  float max_ratio = 0.6f;
  /// Reject matches whose SSD exceeds this percentage of the largest possible SSD between two
  /// L2-normalised descriptors (4). Default 1.0 % => SSD <= 0.04 (MATLAB MatchThreshold).
  float match_threshold_percent = 1.0f;
  /// Keep only mutual best matches (MATLAB Unique). Default false.
  bool unique = false;
  /// Never compare points whose Laplacian signs differ (SURF's free speed-up). Default true.
  bool check_laplacian = true;
  /// Guided matching: with a motion prior (see Matcher::Match), only candidates within this
  /// radius (pixels) of the predicted position are compared. Default 40 px.
  float guided_radius_px = 40.f;
  /// Threads; 1 = single-threaded, 0 = all cores.
  int num_threads = 1;
  /// With exactly one comparable candidate the ratio test cannot be applied (there is no
  /// second-best). true: accept it if it passes match_threshold_percent; false: reject it.
  /// Default true: the case is common with a motion prior (small disc) and after the Laplacian
  /// split, where the prior or the sign has already removed the look-alikes, and the absolute
  /// test alone is strict (SSD <= 0.04, i.e. cosine >= 0.98 between unit descriptors);
  /// rejecting would throw away the best-constrained matches. The ratio test is a test of
  /// distinctiveness against other candidates, so with none there is nothing to fail.
  bool accept_single_candidate = true;
  /// Use the AVX2+FMA kernels when the CPU has them (checked at run time); false forces the
  /// SSE4.2 kernels (for tests and benchmarks). Default true. Results are identical up to
  /// float rounding of near-ties.
  bool use_avx2 = true;
  /// Search of the top-2 without a motion prior. Default kExhaustive (exact, MATLAB's
  /// Exhaustive method). kKdForest pays off from a few thousand points per frame (slower
  /// below, where the SIMD exhaustive path is hard to beat; BENCHMARKS.md, "Approximate
  /// matching") at the price of a recall below 100 %: a query may miss its best
  /// or second-best candidate, and then be rejected, or accepted on a too-optimistic ratio.
  MatchAlgorithm algorithm = MatchAlgorithm::kExhaustive;
  /// kKdForest: randomized trees per Laplacian group, searched together. Default 4, FLANN's
  /// default (Muja & Lowe's library; recall and time per tree count: BENCHMARKS.md,
  /// "Approximate matching"). Range [1, 64].
  int kd_trees = 4;
  /// kKdForest: distinct candidate points examined per query (all trees together; every tree's
  /// first leaf is always examined and the last leaf is finished, so a few more may be).
  /// 0, or >= the number of curr points: exact search (the exhaustive path is used). Default
  /// 64 (recall against budget: bench_matching BM_KdForest, BM_RealOrtho; BENCHMARKS.md,
  /// "Approximate matching"). With 4 trees of 16-point leaves the first leaves alone hold ~50
  /// points, so budgets below that change nothing.
  int kd_max_checks = 64;
  /// kKdForest: seed of the trees' random choices; same seed and data, same trees and
  /// matches (whatever num_threads). Default 1.
  std::uint64_t kd_seed = 1;
};

/// Throws InvalidArgument naming the offending field when out of range.
void Validate(const MatchOptions& options);
/// The option schema (core/options.h; keys match.* in a run configuration).
// clang-format off
template <class V>
void VisitFields(MatchOptions& o, V& v) {
  using namespace options;
  v.Field(o.max_ratio, "max_ratio", "Ratio test on squared distances (MATLAB MaxRatio)", Interval(0, 1, true, false));
  v.Field(o.match_threshold_percent, "match_threshold_percent", "Largest SSD, % of the largest possible (MATLAB MatchThreshold)", Interval(0, 100, true, false));
  v.Field(o.unique, "unique", "Keep only mutual best matches (MATLAB Unique)", Any());
  v.Field(o.check_laplacian, "check_laplacian", "Never compare points whose Laplacian signs differ", Any());
  v.Field(o.guided_radius_px, "guided_radius_px", "Guided matching: search radius around the prediction, px", GreaterThan(0).Finite());
  v.Field(o.num_threads, "num_threads", "Matching threads (0 = all cores)", Interval(0, kMaxOptionThreads));
  v.Field(o.accept_single_candidate, "accept_single_candidate", "Accept a lone candidate on the absolute threshold alone", Any());
  v.Field(o.use_avx2, "use_avx2", "AVX2+FMA kernels when the CPU has them (false: SSE4.2)", Any());
  v.Field(o.algorithm, "algorithm", "Matching without a motion prior: exhaustive (exact) or kdtree (approximate)", Any().Alias("matcher"));
  v.Field(o.kd_trees, "kd_trees", "kdtree: randomized trees per Laplacian group", Interval(1, 64));
  v.Field(o.kd_max_checks, "kd_max_checks", "kdtree: candidates examined per query (0 = exact)", Interval(0, 1000000));
  v.Field(o.kd_seed, "kd_seed", "kdtree: seed of the trees' random choices", Any());
}
// clang-format on
template <>
struct options::EnumTraits<MatchAlgorithm>
    : options::EnumList<MatchAlgorithm, ToString, MatchAlgorithm::kExhaustive,
                        MatchAlgorithm::kKdForest> {};

/// One correspondence: prev.keypoints[prev_index] <-> curr.keypoints[curr_index].
struct Match {
  int prev_index = -1;
  int curr_index = -1;
  float ssd = 0.f;  ///< Squared L2 distance between the two descriptors.
};

struct MatchResult {
  std::vector<Match> matches;
  std::int64_t num_comparisons = 0;  ///< Descriptor distances evaluated.
  double time_ms = 0.0;
};

/// The current frame's side of matching, prepared once and reused by every Match call against
/// that frame (clustered RANSAC matches one frame several times: cells, refinement, final pass):
/// squared descriptor norms, with descriptors and positions checked finite. Refers to the
/// FeatureSet given to Reset without copying it: it must outlive this object's use and stay
/// unchanged in between.
class MatchCandidates {
 public:
  MatchCandidates();
  /// Same as Reset(features).
  explicit MatchCandidates(const FeatureSet& features);
  ~MatchCandidates();
  MatchCandidates(MatchCandidates&&) noexcept;
  MatchCandidates& operator=(MatchCandidates&&) noexcept;
  /// Prepares for `features`, reusing this object's buffers. Throws InvalidArgument on
  /// descriptors.size() inconsistent with keypoints or a non-finite descriptor or position.
  void Reset(const FeatureSet& features);
  /// Reset has been called.
  bool ready() const { return features_ != nullptr; }
  /// Precondition: ready().
  const FeatureSet& features() const { return *features_; }
  /// Squared L2 norm of every descriptor, by index.
  const std::vector<float>& squared_norms() const { return norms_; }

  /// Internal: the positions bucketed in a uniform grid per Laplacian sign, built on the first
  /// guided Match against this frame and reused by the next ones (defined in matcher.cc). Not
  /// safe to build from two threads at once: share a MatchCandidates between threads only
  /// after a first guided Match, or give each thread its own.
  struct Grid;
  const Grid& grid() const;
  /// Internal: the randomized k-d forest over the descriptors per Laplacian group (sign groups
  /// if check_laplacian, else one group), built on the first kKdForest Match against this frame
  /// and reused by the next ones with the same (trees, seed, check_laplacian). Same thread
  /// rule as grid().
  const matching_detail::KdForest& kd_forest(int trees, std::uint64_t seed,
                                             bool check_laplacian) const;

 private:
  const FeatureSet* features_ = nullptr;
  std::vector<float> norms_;
  std::unique_ptr<Grid> grid_;
  mutable bool grid_built_ = false;
  mutable std::unique_ptr<matching_detail::KdForest> forest_;
  mutable bool forest_laplacian_ = true;
};

/// Exhaustive (optionally guided) matcher. Reuses its buffers between calls (no allocation in
/// steady state other than the returned match vector). Not thread-safe: use one instance per
/// thread (it parallelises internally when num_threads != 1 and the work is large enough).
///
/// Paths (all give the same result): exhaustive, blocked SIMD over candidates packed per
/// Laplacian sign; exhaustive with few queries (a prev_subset much smaller than curr), which
/// packs the queries and streams curr in place; guided, a uniform grid over curr positions
/// (built once per MatchCandidates) gives each query its candidates in the disc, compared in
/// place (no copy of the rows). Approximate (MatchAlgorithm::kKdForest, no prior): a
/// randomized k-d forest (built once per MatchCandidates) finds each query's top-2 within a
/// budget of examined points; the decisions are then the exhaustive ones on that top-2, and
/// unique's reverse pass searches a forest over the queries (built per call) the same way.
/// A point with Laplacian 0 (unknown) forms its own group, compared only with other 0 points.
class Matcher {
 public:
  explicit Matcher(const MatchOptions& options = {});
  ~Matcher();
  Matcher(Matcher&&) noexcept;
  Matcher& operator=(Matcher&&) noexcept;

  const MatchOptions& options() const;

  /// Matches prev (restricted to `prev_subset` indices if non-empty) against all of curr.
  /// `curr_from_prev_prior`, if given, is a 2x3 affine predicting curr pixel positions from prev
  /// pixel positions: only curr points within guided_radius_px of the prediction are compared.
  /// Preconditions: equal descriptor sizes; descriptors L2-normalised (SSDs are computed on the
  /// stored values; the threshold's base 4 assumes unit vectors).
  ///
  /// Semantics, for each query point p (MATLAB matchFeatures, Exhaustive, SSD):
  /// - the candidates of p are the curr points it is compared with: same Laplacian sign (if
  ///   check_laplacian; the second-best is therefore also a same-sign point) and, with a prior,
  ///   within guided_radius_px of the predicted position;
  /// - best / second-best are the two smallest SSDs among the candidates (ties: lower index);
  /// - accepted iff ssd_best <= match_threshold_percent / 100 * 4 and
  ///   ssd_best <= max_ratio * ssd_second with ssd_second > 0 (two identical best candidates are
  ///   ambiguous); with a single candidate see accept_single_candidate;
  /// - unique: additionally p must be the best (ties: lower index) among the query points that
  ///   are candidates of that curr point in the reverse direction (same sign, same disc).
  /// Output sorted by prev_index (each prev point at most once); prev_subset may be unsorted and
  /// contain duplicates (dropped). Ranking is done in float32 blocks, accept/reject decisions
  /// and Match::ssd use the SSD recomputed in double. Deterministic: the result does not depend
  /// on num_threads or the SIMD kernel (except float-rounding near-ties in ranking).
  /// With algorithm = kKdForest and no prior, best / second-best are the two smallest SSDs among
  /// the candidates the forest examined (a subset of the candidates above; all of them when
  /// the Laplacian group has at most kd_max_checks points); with unique, p must likewise be the
  /// best of the queries examined by the reverse search (a forest over the query set, built per
  /// call, same options; exhaustive when the query set has at most kd_max_checks points). Same
  /// kd_seed, same result, whatever num_threads.
  /// Throws InvalidArgument on different descriptor sizes, descriptors.size() inconsistent with
  /// keypoints, non-finite descriptors / positions / prior, or prev_subset indices out of range.
  MatchResult Match(
      const FeatureSet& prev, const FeatureSet& curr, const std::vector<int>& prev_subset = {},
      const std::optional<Eigen::Matrix<double, 2, 3>>& curr_from_prev_prior = std::nullopt);
  /// The same, against candidates prepared once (MatchCandidates) for several calls.
  MatchResult Match(
      const FeatureSet& prev, const MatchCandidates& curr, const std::vector<int>& prev_subset = {},
      const std::optional<Eigen::Matrix<double, 2, 3>>& curr_from_prev_prior = std::nullopt);

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace aerovo
