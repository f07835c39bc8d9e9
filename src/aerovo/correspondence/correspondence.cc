#include "aerovo/correspondence/correspondence.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"

namespace aerovo {

void Validate(const CorrespondenceOptions& o) {
  Validate(o.match);
  Validate(o.ransac);
  options::CheckRanges(o.clustered, "clustered");
  options::CheckRanges(o, "correspondence");
  const int m = MinSampleSize(o.model);
  if (o.min_inliers < m) {
    throw InvalidArgument("correspondence.min_inliers must be at least the minimal sample of the " +
                          std::string(ToString(o.model)) + " model (" + std::to_string(m) +
                          "), got " + std::to_string(o.min_inliers));
  }
}

RectI ClusteredCrop(int width, int height, const Eigen::Matrix3d& last_curr_from_prev) {
  if (width <= 0 || height <= 0) {
    throw InvalidArgument("ClusteredCrop: frame size must be positive, got " +
                          std::to_string(width) + " x " + std::to_string(height));
  }
  if (!last_curr_from_prev.allFinite()) {
    throw InvalidArgument("ClusteredCrop: the previous step's transform has non-finite entries");
  }
  const Eigen::Vector2d centre(0.5 * (width - 1), 0.5 * (height - 1));
  const Eigen::Vector2d moved = TransformPoint(last_curr_from_prev, centre);
  const double tu = moved.x() - centre.x();
  const double tv = moved.y() - centre.y();
  if (!std::isfinite(tu) || !std::isfinite(tv)) return RectI{0, 0, 0, 0};
  // Rounding up drops every point that the repeated motion would push out of the frame; a
  // sub-millipixel shift is numerical noise of a zero motion, not a strip.
  auto strip = [](double t, int size) {
    const double a = std::abs(t);
    if (a < 1e-3) return 0;
    return a >= size ? size : static_cast<int>(std::ceil(a));
  };
  const int su = strip(tu, width);
  const int sv = strip(tv, height);
  RectI crop{0, 0, width - su, height - sv};
  if (tu < 0) crop.x = su;  // Content moves left: the left strip leaves the view.
  if (tv < 0) crop.y = sv;  // Content moves up: the top strip leaves the view.
  if (crop.empty()) return RectI{crop.x, crop.y, 0, 0};
  return crop;
}

CellBounds ClusterCellBounds(const RectI& crop, int rows, int cols, int row, int col) {
  const double cw = static_cast<double>(crop.width) / cols;
  const double ch = static_cast<double>(crop.height) / rows;
  CellBounds b;
  b.x0 = crop.x + col * cw;
  b.x1 = col + 1 == cols ? crop.x + crop.width : crop.x + (col + 1) * cw;
  b.y0 = crop.y + row * ch;
  b.y1 = row + 1 == rows ? crop.y + crop.height : crop.y + (row + 1) * ch;
  return b;
}

namespace {

MatchOptions WithRadius(const CorrespondenceOptions& o, float radius_px) {
  MatchOptions m = o.match;
  // 0 disables the final pass; the matcher still needs a valid radius.
  if (radius_px > 0.f) m.guided_radius_px = radius_px;
  return m;
}

}  // namespace

CorrespondenceStage::CorrespondenceStage(const CorrespondenceOptions& options)
    : options_((Validate(options), options)),
      matcher_(options.match),
      refine_matcher_(WithRadius(options, options.clustered.refine_radius_px)),
      final_matcher_(WithRadius(options, options.clustered.refine_final_radius_px)) {}

CorrespondenceResult CorrespondenceStage::Run(
    const FeatureSet& prev, int prev_width, int prev_height, const FeatureSet& curr,
    const std::optional<Eigen::Matrix3d>& last_curr_from_prev) {
  if (options_.method == CorrespondenceMethod::kStandard) {
    CorrespondenceResult r = Standard(prev, curr, last_curr_from_prev);
    if (prev_width > 0 && prev_height > 0) r.crop = RectI{0, 0, prev_width, prev_height};
    return r;
  }
  return Clustered(prev, prev_width, prev_height, curr,
                   last_curr_from_prev.value_or(Eigen::Matrix3d::Identity()));
}

bool CorrespondenceStage::Attempt(Matcher& matcher, bool guided, const FeatureSet& prev,
                                  const std::vector<int>& subset,
                                  const std::optional<Eigen::Matrix3d>& prior,
                                  CorrespondenceResult* out, const std::vector<Match>* known) {
  Stopwatch watch;
  const FeatureSet& curr = candidates_.features();
  std::optional<Eigen::Matrix<double, 2, 3>> prior_affine;
  if (guided && prior) prior_affine = AffinePart(*prior);
  MatchResult matched = matcher.Match(prev, candidates_, subset, prior_affine);
  if (known != nullptr && !known->empty()) {
    // Both lists are sorted by prev index and hold different prev points.
    merged_.resize(matched.matches.size() + known->size());
    std::merge(matched.matches.begin(), matched.matches.end(), known->begin(), known->end(),
               merged_.begin(),
               [](const Match& a, const Match& b) { return a.prev_index < b.prev_index; });
    matched.matches.swap(merged_);
  }
  out->match_ms += watch.elapsed_ms();
  out->num_comparisons += matched.num_comparisons;
  ++out->attempts;

  watch.restart();
  const int n = static_cast<int>(matched.matches.size());
  prev_px_.resize(2, n);
  curr_px_.resize(2, n);
  quality_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const Match& m = matched.matches[static_cast<std::size_t>(i)];
    const Keypoint& p = prev.keypoints[static_cast<std::size_t>(m.prev_index)];
    const Keypoint& c = curr.keypoints[static_cast<std::size_t>(m.curr_index)];
    prev_px_(0, i) = p.x;
    prev_px_(1, i) = p.y;
    curr_px_(0, i) = c.x;
    curr_px_(1, i) = c.y;
    quality_[static_cast<std::size_t>(i)] = m.ssd;
  }
  RansacResult r = EstimateTransform(options_.model, options_.sampler, options_.ransac, prev_px_,
                                     curr_px_, quality_.data(), workspace_);
  out->estimate_ms += watch.elapsed_ms();
  out->ransac_trials += r.num_trials;
  out->matches = std::move(matched.matches);
  out->inlier_mask = std::move(r.inlier_mask);
  out->num_inliers = r.num_inliers;
  out->success = r.success && r.num_inliers >= options_.min_inliers;
  out->curr_from_prev = out->success ? r.curr_from_prev : Eigen::Matrix3d::Identity();
  return out->success;
}

void CorrespondenceStage::Refine(const FeatureSet& prev, int width, int height,
                                 const std::vector<int>& cell_of, CorrespondenceResult* out) {
  const ClusteredRansacOptions& co = options_.clustered;
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
  std::vector<int> taken(static_cast<std::size_t>(num_cells), 0);
  subset_.clear();
  second_half_.clear();
  for (std::size_t i = 0; i < cell_of.size(); ++i) {
    const int cell = cell_of[i];
    if (cell < 0 || cell == chosen) continue;
    const int t = taken[static_cast<std::size_t>(cell)]++;
    if (t < first_half) {
      subset_.push_back(static_cast<int>(i));
    } else if (t < per_cell) {
      second_half_.push_back(static_cast<int>(i));
    }
  }
  const CorrespondenceResult cell = *out;  // restored if a one-pass refinement would keep it
  const Eigen::Matrix3d& cell_fit = cell.curr_from_prev;
  // Each pass works on its own result (Attempt overwrites it), whose cost is added to `out` and
  // which replaces `out`'s fit when it succeeds with at least `min_inliers` inliers.
  const auto refine_pass = [&](Matcher& matcher, const std::vector<int>& subset,
                               const Eigen::Matrix3d& prior, const std::vector<Match>* known,
                               int min_inliers, CorrespondenceResult* pass) {
    // An empty subset means every point: a crop holding only the chosen cell has nothing else
    // to match.
    if (known != nullptr && subset.empty()) return;
    Attempt(matcher, true, prev, subset, prior, pass, known);
    out->match_ms += pass->match_ms;
    out->estimate_ms += pass->estimate_ms;
    out->num_comparisons += pass->num_comparisons;
    out->ransac_trials += pass->ransac_trials;
    if (!pass->success || pass->num_inliers < min_inliers) return;
    out->curr_from_prev = pass->curr_from_prev;
    out->matches = pass->matches;
    out->inlier_mask = pass->inlier_mask;
    out->num_inliers = pass->num_inliers;
    out->refined = true;
  };
  const auto shift = [&] {
    return MaxCornerDisplacementPx(cell_fit, out->curr_from_prev, width, height);
  };
  // The spread fit confirms the cell's across the frame: it stayed within the gate of it, on
  // at least min_inliers inliers more than the cell's (a fit that found no support elsewhere,
  // and so stayed exactly where the cell's was, confirms nothing).
  const auto confirms = [&] {
    return out->refined && out->refine_shift_px <= co.refine_final_min_shift_px &&
           out->num_inliers - cell.num_inliers >= options_.min_inliers;
  };
  CorrespondenceResult first;
  refine_pass(refine_matcher_, subset_, cell_fit, &cell.matches, cell.num_inliers, &first);
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
    refine_pass(refine_matcher_, second_half_, cell_fit, &known, cell.num_inliers, &second);
    if (out->refined) {
      out->refine_shift_px = shift();
    } else {
      // Not adopted: the cell's fit stays, as after a one-pass refinement (the costs stay).
      out->curr_from_prev = cell_fit;
      out->matches = cell.matches;
      out->inlier_mask = cell.inlier_mask;
      out->num_inliers = cell.num_inliers;
      out->refine_shift_px = cell.refine_shift_px;
    }
  }
  if (co.refine_final_radius_px <= 0.f) return;
  // A spread fit that confirms the cell's says the model holds across the frame (see
  // refine_final_min_shift_px); one that was not adopted says nothing.
  if (gated && confirms()) return;
  out->final_pass = true;
  subset_.clear();  // empty: every prev point
  const std::int64_t n = static_cast<std::int64_t>(prev.size());
  const std::int64_t cap = co.refine_final_max_points;
  // The final fit replaces the spread fit when it has at least as many inliers among the points
  // the pass matched: all of them, or with the cap, those of the sample.
  int min_inliers = out->num_inliers;
  if (cap > 0 && n > cap) {
    sampled_.assign(prev.size(), 0);
    for (std::int64_t j = 0; j < cap; ++j) {
      subset_.push_back(static_cast<int>(j * n / cap));
      sampled_[static_cast<std::size_t>(subset_.back())] = 1;
    }
    min_inliers = 0;
    for (std::size_t k = 0; k < out->matches.size(); ++k) {
      min_inliers += out->inlier_mask[k] != 0 &&
                     sampled_[static_cast<std::size_t>(out->matches[k].prev_index)] != 0;
    }
  }
  CorrespondenceResult final_result;
  refine_pass(final_matcher_, subset_, out->curr_from_prev, nullptr, min_inliers, &final_result);
}

CorrespondenceResult CorrespondenceStage::Standard(const FeatureSet& prev, const FeatureSet& curr,
                                                   const std::optional<Eigen::Matrix3d>& prior) {
  Stopwatch total;
  CorrespondenceResult result;
  result.method_used = CorrespondenceMethod::kStandard;
  const Stopwatch prepare;
  candidates_.Reset(curr);
  result.match_ms += prepare.elapsed_ms();
  subset_.clear();
  Attempt(matcher_, options_.guided_matching, prev, subset_, prior, &result);
  result.total_ms = total.elapsed_ms();
  return result;
}

CorrespondenceResult CorrespondenceStage::Clustered(const FeatureSet& prev, int prev_width,
                                                    int prev_height, const FeatureSet& curr,
                                                    const Eigen::Matrix3d& last_curr_from_prev) {
  Stopwatch total;
  const ClusteredRansacOptions& co = options_.clustered;
  CorrespondenceResult result;
  result.method_used = CorrespondenceMethod::kClustered;
  // Clustered RANSAC matches curr up to grid_rows * grid_cols + 2 times: prepare it once.
  const Stopwatch prepare;
  candidates_.Reset(curr);
  result.match_ms += prepare.elapsed_ms();
  result.crop = co.crop ? ClusteredCrop(prev_width, prev_height, last_curr_from_prev)
                        : ClusteredCrop(prev_width, prev_height, Eigen::Matrix3d::Identity());
  const RectI crop = result.crop;
  const int rows = co.grid_rows, cols = co.grid_cols;
  result.cell_point_counts.assign(static_cast<std::size_t>(rows * cols), 0);

  // Cell of every prev point (-1 outside the crop).
  std::vector<int>& cell_of = cell_of_;
  cell_of.assign(prev.size(), -1);
  if (!crop.empty()) {
    // A point's column is the number of inner cell edges at or left of it, with the edges
    // computed as ClusterCellBounds computes them: the two agree on every edge, and two
    // comparisons per axis cost less than the divisions they replace (the loop runs over
    // every prev point of every pair).
    const double cw = static_cast<double>(crop.width) / cols;
    const double ch = static_cast<double>(crop.height) / rows;
    edges_x_.resize(static_cast<std::size_t>(cols - 1));
    edges_y_.resize(static_cast<std::size_t>(rows - 1));
    for (int k = 1; k < cols; ++k) edges_x_[static_cast<std::size_t>(k - 1)] = crop.x + k * cw;
    for (int k = 1; k < rows; ++k) edges_y_[static_cast<std::size_t>(k - 1)] = crop.y + k * ch;
    const double x0 = crop.x, x1 = static_cast<double>(crop.x) + crop.width;
    const double y0 = crop.y, y1 = static_cast<double>(crop.y) + crop.height;
    const double* ex = edges_x_.data();
    const double* ey = edges_y_.data();
    const int nex = cols - 1, ney = rows - 1;
    const Keypoint* kps = prev.keypoints.data();
    int* out_cell = cell_of.data();
    int* counts = result.cell_point_counts.data();
    const int n = static_cast<int>(prev.size());
    for (int i = 0; i < n; ++i) {
      const double x = kps[i].x, y = kps[i].y;
      if (!(x >= x0 && x < x1 && y >= y0 && y < y1)) continue;  // RectI::contains
      int c = 0, r = 0;
      for (int e = 0; e < nex; ++e) c += x >= ex[e] ? 1 : 0;
      for (int e = 0; e < ney; ++e) r += y >= ey[e] ? 1 : 0;
      out_cell[i] = r * cols + c;
      ++counts[r * cols + c];
    }
  }
  std::vector<int> order;
  for (int cell = 0; cell < rows * cols; ++cell) {
    if (result.cell_point_counts[static_cast<std::size_t>(cell)] >= co.min_points) {
      order.push_back(cell);
    }
  }
  const auto& counts = result.cell_point_counts;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return co.cell_order == CellOrder::kFewestFirst ? counts[a] < counts[b] : counts[a] > counts[b];
  });

  for (int cell : order) {
    subset_.clear();
    for (std::size_t i = 0; i < cell_of.size(); ++i) {
      if (cell_of[i] == cell) subset_.push_back(static_cast<int>(i));
    }
    if (Attempt(matcher_, options_.guided_matching, prev, subset_, last_curr_from_prev, &result)) {
      result.cell_row = cell / cols;
      result.cell_col = cell % cols;
      if (co.refine) Refine(prev, prev_width, prev_height, cell_of, &result);
      result.total_ms = total.elapsed_ms();
      return result;
    }
  }

  // The linear-motion assumption failed for this step (the paper): standard RANSAC on all.
  result.fell_back = true;
  result.method_used = CorrespondenceMethod::kStandard;
  subset_.clear();
  Attempt(matcher_, options_.guided_matching, prev, subset_, last_curr_from_prev, &result);
  result.total_ms = total.elapsed_ms();
  return result;
}

CorrespondenceResult StandardCorrespondence(const FeatureSet& prev, const FeatureSet& curr,
                                            const CorrespondenceOptions& options,
                                            const std::optional<Eigen::Matrix3d>& prior) {
  CorrespondenceStage stage(options);
  return stage.Standard(prev, curr, prior);
}

CorrespondenceResult ClusteredCorrespondence(const FeatureSet& prev, int prev_width,
                                             int prev_height, const FeatureSet& curr,
                                             const Eigen::Matrix3d& last_curr_from_prev,
                                             const CorrespondenceOptions& options) {
  CorrespondenceStage stage(options);
  return stage.Clustered(prev, prev_width, prev_height, curr, last_curr_from_prev);
}

}  // namespace aerovo
