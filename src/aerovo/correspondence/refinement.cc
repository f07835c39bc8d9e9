#include "aerovo/correspondence/refinement.h"

#include <cstdint>
#include <utility>

#include "aerovo/correspondence/correspondence.h"
#include "aerovo/correspondence/match_and_fit.h"
#include "aerovo/estimation/models.h"

namespace aerovo {

namespace {

MatchOptions WithRadius(const CorrespondenceOptions& o, float radius_px) {
  MatchOptions m = o.match;
  // 0 disables the final pass; the matcher still needs a valid radius.
  if (radius_px > 0.f) m.guided_radius_px = radius_px;
  return m;
}

// Adds the costs of a pass that worked on its own result to `out`'s.
void AddCosts(const CorrespondenceResult& pass, CorrespondenceResult* out) {
  out->match_ms += pass.match_ms;
  out->estimate_ms += pass.estimate_ms;
  out->num_comparisons += pass.num_comparisons;
  out->ransac_trials += pass.ransac_trials;
}

// One guided pass of the refinement, on its own result *pass (MatchAndFit::Run overwrites it):
// matches the prev points `subset` (empty: every point) with `matcher` around `prior` on `fit`,
// `known` matches taking part as they are (nullptr: none), adds the pass's costs to *out and
// adopts its fit into *out (refined = true) when it succeeds with at least min_inliers inliers.
// With known matches an empty subset skips the pass: a crop holding only the chosen cell has
// nothing else to match.
void RefinePass(MatchAndFit& fit, Matcher& matcher, const FeatureSet& prev,
                const std::vector<int>& subset, const Eigen::Matrix3d& prior,
                const std::vector<Match>* known, int min_inliers, CorrespondenceResult* pass,
                CorrespondenceResult* out) {
  if (known != nullptr && subset.empty()) return;
  fit.Run(matcher, true, prev, subset, prior, pass, known);
  AddCosts(*pass, out);
  if (!pass->success || pass->num_inliers < min_inliers) return;
  out->curr_from_prev = pass->curr_from_prev;
  out->matches = pass->matches;
  out->inlier_mask = pass->inlier_mask;
  out->num_inliers = pass->num_inliers;
  out->refined = true;
}

// Puts the fit of `kept` (transform, matches, mask, inliers, shift) back into *out; the costs
// and flags of *out stay.
void RestoreFit(const CorrespondenceResult& kept, CorrespondenceResult* out) {
  out->curr_from_prev = kept.curr_from_prev;
  out->matches = kept.matches;
  out->inlier_mask = kept.inlier_mask;
  out->num_inliers = kept.num_inliers;
  out->refine_shift_px = kept.refine_shift_px;
}

}  // namespace

GuidedRefinement::GuidedRefinement(const CorrespondenceOptions& options)
    : spread_matcher_(WithRadius(options, options.clustered.refine_radius_px)),
      final_matcher_(WithRadius(options, options.clustered.refine_final_radius_px)) {}

void GuidedRefinement::RefineCell(const CorrespondenceOptions& options, MatchAndFit& fit,
                                  const FeatureSet& prev, int width, int height,
                                  const std::vector<int>& cell_of, CorrespondenceResult* out) {
  const ClusteredRansacOptions& co = options.clustered;
  const int num_cells = co.grid_rows * co.grid_cols;
  const int per_cell = co.refine_max_points == 0
                           ? static_cast<int>(prev.size())
                           : (co.refine_max_points + num_cells - 1) / num_cells;
  // The chosen cell's matches all take part (as they are: its points are not matched again),
  // so that a refined model consistent with the cell finds at least the cell's inliers again:
  // "at least as many inliers" then means "explains the cell's evidence and more", whatever
  // refine_max_points is. The other cells' points are matched around the cell's prediction.
  const int chosen = out->cell_row * co.grid_cols + out->cell_col;
  // With a gate, the early exit splits the spread points in two halves (see refine_early_exit).
  const bool gated = co.refine_final_min_shift_px > 0.f;
  const bool early_exit = co.refine_early_exit && gated;
  const int first_half = early_exit ? (per_cell + 1) / 2 : per_cell;
  SelectSpreadPoints(cell_of, num_cells, chosen, per_cell, first_half);
  const CorrespondenceResult cell = *out;  // restored if a one-pass refinement would keep it
  const Eigen::Matrix3d& cell_fit = cell.curr_from_prev;
  // Each pass works on its own result (see RefinePass).
  const auto refine_pass = [&](Matcher& matcher, const std::vector<int>& subset,
                               const Eigen::Matrix3d& prior, const std::vector<Match>* known,
                               int min_inliers, CorrespondenceResult* pass) {
    RefinePass(fit, matcher, prev, subset, prior, known, min_inliers, pass, out);
  };
  const auto shift = [&] {
    return MaxCornerDisplacementPx(cell_fit, out->curr_from_prev, width, height);
  };
  // The spread fit confirms the cell's across the frame: it stayed within the gate of it, on
  // at least min_inliers inliers more than the cell's (a fit that found no support elsewhere,
  // and so stayed exactly where the cell's was, confirms nothing).
  const auto confirms = [&] {
    return out->refined && out->refine_shift_px <= co.refine_final_min_shift_px &&
           out->num_inliers - cell.num_inliers >= options.min_inliers;
  };
  CorrespondenceResult first;
  refine_pass(spread_matcher_, subset_, cell_fit, &cell.matches, cell.num_inliers, &first);
  if (out->refined) out->refine_shift_px = shift();
  if (early_exit && confirms()) {
    out->refine_early_exit = true;
    return;
  }
  if (!second_half_.empty()) {
    // The first half's matches (the cell's included) join the second's, whether or not the
    // first fit was adopted: the fit is then the one-pass fit over every spread point, and it
    // replaces the cell's (not the first half's) on the same rule.
    const std::vector<Match>& known = first.attempts > 0 ? first.matches : cell.matches;
    CorrespondenceResult second;
    out->refined = false;
    refine_pass(spread_matcher_, second_half_, cell_fit, &known, cell.num_inliers, &second);
    if (out->refined) {
      out->refine_shift_px = shift();
    } else {
      // Not adopted: the cell's fit stays, as after a one-pass refinement (the costs stay).
      RestoreFit(cell, out);
    }
  }
  if (co.refine_final_radius_px <= 0.f) return;
  // A spread fit that confirms the cell's says the model holds across the frame (see
  // refine_final_min_shift_px); one that was not adopted says nothing.
  if (gated && confirms()) return;
  out->final_pass = true;
  // The final fit replaces the spread fit when it has at least as many inliers among the points
  // the pass matched: all of them, or with the cap, those of the sample.
  const int min_inliers = SampleFinalPass(co.refine_final_max_points, prev, *out);
  CorrespondenceResult final_result;
  refine_pass(final_matcher_, subset_, out->curr_from_prev, nullptr, min_inliers, &final_result);
}

void GuidedRefinement::SelectSpreadPoints(const std::vector<int>& cell_of, int num_cells,
                                          int chosen, int per_cell, int first_half) {
  taken_.assign(static_cast<std::size_t>(num_cells), 0);
  subset_.clear();
  second_half_.clear();
  for (std::size_t i = 0; i < cell_of.size(); ++i) {
    const int cell = cell_of[i];
    if (cell < 0 || cell == chosen) continue;
    const int t = taken_[static_cast<std::size_t>(cell)]++;
    if (t < first_half) {
      subset_.push_back(static_cast<int>(i));
    } else if (t < per_cell) {
      second_half_.push_back(static_cast<int>(i));
    }
  }
}

int GuidedRefinement::SampleFinalPass(int max_points, const FeatureSet& prev,
                                      const CorrespondenceResult& fitted) {
  subset_.clear();  // empty: every prev point
  const std::int64_t n = static_cast<std::int64_t>(prev.size());
  const std::int64_t cap = max_points;
  if (!(cap > 0 && n > cap)) return fitted.num_inliers;
  sampled_.assign(prev.size(), 0);
  for (std::int64_t j = 0; j < cap; ++j) {
    subset_.push_back(static_cast<int>(j * n / cap));
    sampled_[static_cast<std::size_t>(subset_.back())] = 1;
  }
  int inliers = 0;
  for (std::size_t k = 0; k < fitted.matches.size(); ++k) {
    inliers += fitted.inlier_mask[k] != 0 &&
               sampled_[static_cast<std::size_t>(fitted.matches[k].prev_index)] != 0;
  }
  return inliers;
}

bool GuidedRefinement::RefitOnAllPoints(MatchAndFit& fit, const FeatureSet& prev,
                                        CorrespondenceResult* out) {
  subset_.clear();  // empty: every prev point
  CorrespondenceResult refit;
  fit.Run(final_matcher_, true, prev, subset_, out->curr_from_prev, &refit);
  AddCosts(refit, out);
  out->attempts += refit.attempts;
  out->final_pass = true;
  if (!refit.success || refit.num_inliers <= out->num_inliers) return false;
  out->curr_from_prev = refit.curr_from_prev;
  out->matches = std::move(refit.matches);
  out->inlier_mask = std::move(refit.inlier_mask);
  out->num_inliers = refit.num_inliers;
  out->refined = true;
  return true;
}

}  // namespace aerovo
