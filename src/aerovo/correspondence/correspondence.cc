#include "aerovo/correspondence/correspondence.h"

#include <cmath>
#include <string>

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
  // Cross-field rules (each names both fields).
  const ClusteredRansacOptions& c = o.clustered;
  if (c.refine && c.refine_fallback && c.refine_final_radius_px <= 0.f) {
    throw InvalidArgument(
        "clustered.refine_fallback refits within clustered.refine_final_radius_px, which is 0 "
        "(no final pass): set clustered.refine_fallback = false or "
        "clustered.refine_final_radius_px > 0");
  }
}

CorrespondenceStage::CorrespondenceStage(const CorrespondenceOptions& options)
    : options_((Validate(options), options)),
      matcher_(options.match),
      fit_(options),
      refinement_(options) {}

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

CorrespondenceResult CorrespondenceStage::Standard(const FeatureSet& prev, const FeatureSet& curr,
                                                   const std::optional<Eigen::Matrix3d>& prior) {
  Stopwatch total;
  CorrespondenceResult result;
  result.method_used = CorrespondenceMethod::kStandard;
  fit_.Prepare(curr, &result);
  subset_.clear();
  fit_.Run(matcher_, options_.guided_matching, prev, subset_, prior, &result);
  result.total_ms = total.elapsed_ms();
  return result;
}

bool CorrespondenceStage::RefitOnAllPoints(const FeatureSet& prev, const FeatureSet& curr,
                                           CorrespondenceResult* result) {
  if (!(options_.clustered.refine_final_radius_px > 0.f)) {
    throw InvalidArgument(
        "CorrespondenceStage::RefitOnAllPoints: ClusteredRansacOptions.refine_final_radius_px "
        "is 0 (the refit's radius)");
  }
  if (!result->success) return false;
  Stopwatch total;
  fit_.Prepare(curr, result);
  const bool replaced = refinement_.RefitOnAllPoints(fit_, prev, result);
  result->total_ms += total.elapsed_ms();
  return replaced;
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
