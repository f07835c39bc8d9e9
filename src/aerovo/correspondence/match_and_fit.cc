#include "aerovo/correspondence/match_and_fit.h"

#include <algorithm>
#include <utility>

#include "aerovo/core/timer.h"
#include "aerovo/correspondence/correspondence.h"

namespace aerovo {

MatchAndFit::MatchAndFit(const CorrespondenceOptions& options)
    : model_(options.model),
      sampler_(options.sampler),
      ransac_(options.ransac),
      min_inliers_(options.min_inliers) {}

void MatchAndFit::Prepare(const FeatureSet& curr, CorrespondenceResult* result) {
  const Stopwatch prepare;
  candidates_.Reset(curr);
  result->match_ms += prepare.elapsed_ms();
}

bool MatchAndFit::Run(Matcher& matcher, bool guided, const FeatureSet& prev,
                      const std::vector<int>& subset, const std::optional<Eigen::Matrix3d>& prior,
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
  RansacResult r =
      EstimateTransform(model_, sampler_, ransac_, prev_px_, curr_px_, quality_.data(), workspace_);
  out->estimate_ms += watch.elapsed_ms();
  out->ransac_trials += r.num_trials;
  out->matches = std::move(matched.matches);
  out->inlier_mask = std::move(r.inlier_mask);
  out->num_inliers = r.num_inliers;
  out->success = r.success && r.num_inliers >= min_inliers_;
  out->curr_from_prev = out->success ? r.curr_from_prev : Eigen::Matrix3d::Identity();
  return out->success;
}

}  // namespace aerovo
