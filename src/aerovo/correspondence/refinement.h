// Guided refinement of a clustered RANSAC result (step 6 of correspondence.h, an aerovo
// addition; options: the refine* fields of ClusteredRansacOptions):
// - RefineCell: a successful cell's fit seeds the guided matching of points spread over the
//   other cells (with an early exit after half of them), then, unless that spread fit confirms
//   the cell's, a final pass over every prev point (at most refine_final_max_points);
// - RefitOnAllPoints: an accepted fit on all points (a fall-back's, or the odometry's
//   relocalisation on a keyframe) seeds the guided matching of every prev point within
//   refine_final_radius_px, and the refit replaces it when it has more inliers
//   (refine_fallback).
// Pixel frame of features/keypoint.h; transforms are curr_from_prev.
#pragma once

#include <vector>

#include "aerovo/features/keypoint.h"
#include "aerovo/matching/matcher.h"

namespace aerovo {

struct CorrespondenceOptions;
struct CorrespondenceResult;
class MatchAndFit;

/// The refinement's matchers and buffers (no allocation in steady state but the copy of the
/// cell's result). Not thread-safe: one instance per thread.
class GuidedRefinement {
 public:
  /// `options` valid (Validate); only its match options and refine radii are kept.
  explicit GuidedRefinement(const CorrespondenceOptions& options);

  /// Refines the successful cell result *out (cell_row, cell_col set) of clustered RANSAC with
  /// `options` (the ones given to the constructor): matches on `fit`, which is prepared with the
  /// current frame. cell_of[i] is the cell of prev point i (-1 outside the crop); the prev frame
  /// is width x height px. Sets refined, final_pass, refine_shift_px, refine_early_exit and,
  /// when a refined fit is adopted, out's transform, matches, mask and inliers; adds the costs.
  void RefineCell(const CorrespondenceOptions& options, MatchAndFit& fit, const FeatureSet& prev,
                  int width, int height, const std::vector<int>& cell_of,
                  CorrespondenceResult* out);

  /// Refit of the successful result *out on every prev point: guided matching within
  /// refine_final_radius_px (> 0) of out->curr_from_prev and RANSAC on `fit` (prepared with the
  /// current frame). The refit replaces out's transform, matches, mask and inliers when it
  /// succeeds with more inliers (then refined = true); final_pass = true; its costs are added
  /// and it counts as one attempt. Returns whether it replaced the fit.
  bool RefitOnAllPoints(MatchAndFit& fit, const FeatureSet& prev, CorrespondenceResult* out);

 private:
  // The spread points, in FeatureSet order: the first first_half of each cell but `chosen`
  // into subset_, its next per_cell - first_half into second_half_.
  void SelectSpreadPoints(const std::vector<int>& cell_of, int num_cells, int chosen,
                          int per_cell, int first_half);
  // Fills subset_ with the prev points of the final pass (empty: every point; with more than
  // max_points > 0 of them, point floor(j * n / max_points) for j = 0 .. max_points - 1) and
  // returns the inliers of `fitted` among them: what the final fit must match.
  int SampleFinalPass(int max_points, const FeatureSet& prev, const CorrespondenceResult& fitted);

  Matcher spread_matcher_;  // options.match with guided_radius_px = refine_radius_px.
  Matcher final_matcher_;   // options.match with guided_radius_px = refine_final_radius_px.
  std::vector<int> subset_, second_half_, taken_;
  std::vector<char> sampled_;  // prev points of the capped final pass
};

}  // namespace aerovo
