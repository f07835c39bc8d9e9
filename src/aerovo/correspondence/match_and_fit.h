// One match + RANSAC attempt of the correspondence stage, with the buffers it reuses between
// attempts (the current frame's match candidates, point buffers, RANSAC workspace). Used by the
// standard method, the clustered search and the guided refinement (correspondence.h).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "aerovo/estimation/models.h"
#include "aerovo/estimation/ransac.h"
#include "aerovo/estimation/samplers.h"
#include "aerovo/features/keypoint.h"
#include "aerovo/matching/matcher.h"

namespace aerovo {

struct CorrespondenceOptions;
struct CorrespondenceResult;

/// Not thread-safe: one instance per thread.
class MatchAndFit {
 public:
  /// Keeps the model, sampler, RANSAC options and min_inliers of `options` (valid).
  explicit MatchAndFit(const CorrespondenceOptions& options);

  /// Prepares the current frame once for every attempt on it; the time goes to result->match_ms.
  void Prepare(const FeatureSet& curr, CorrespondenceResult* result);

  /// Matches prev_subset of `prev` (every prev point when empty) against the prepared current
  /// frame with `matcher` (guided around `prior`'s affine part when `guided` and a prior is
  /// given), adds `known` (matches already made, sorted by prev index, of prev points outside
  /// the subset) and runs RANSAC on all of them. Overwrites out's matches, mask, inliers and
  /// transform (identity unless it succeeds), adds its counters and timings. Returns
  /// out->success: RANSAC succeeded with at least min_inliers inliers.
  bool Run(Matcher& matcher, bool guided, const FeatureSet& prev, const std::vector<int>& subset,
           const std::optional<Eigen::Matrix3d>& prior, CorrespondenceResult* out,
           const std::vector<Match>* known = nullptr);

  int min_inliers() const { return min_inliers_; }

 private:
  MotionModel model_;
  SamplerKind sampler_;
  RansacOptions ransac_;
  int min_inliers_;
  MatchCandidates candidates_;
  RansacWorkspace workspace_;
  Eigen::Matrix2Xd prev_px_, curr_px_;
  std::vector<float> quality_;
  std::vector<Match> merged_;
};

}  // namespace aerovo
