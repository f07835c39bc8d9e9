#include "aerovo/estimation/ransac.h"

#include <cstdint>
#include <limits>

namespace aerovo {

void Validate(const RansacOptions& o) {
  if (o.max_num_trials < 1) {
    throw InvalidArgument("RansacOptions.max_num_trials must be >= 1, got " +
                          std::to_string(o.max_num_trials));
  }
  if (!(o.confidence_percent > 0.0 && o.confidence_percent < 100.0)) {
    throw InvalidArgument("RansacOptions.confidence_percent must be in (0, 100), got " +
                          std::to_string(o.confidence_percent));
  }
  if (!(o.max_distance_px > 0.0) || !std::isfinite(o.max_distance_px)) {
    throw InvalidArgument("RansacOptions.max_distance_px must be finite and > 0, got " +
                          std::to_string(o.max_distance_px));
  }
  if (o.max_degenerate_samples < 0) {
    throw InvalidArgument("RansacOptions.max_degenerate_samples must be >= 0, got " +
                          std::to_string(o.max_degenerate_samples));
  }
  if (o.final_refit_iterations < 0) {
    throw InvalidArgument("RansacOptions.final_refit_iterations must be >= 0, got " +
                          std::to_string(o.final_refit_iterations));
  }
  if (o.polish_iterations < 0) {
    throw InvalidArgument("RansacOptions.polish_iterations must be >= 0, got " +
                          std::to_string(o.polish_iterations));
  }
  if (!(o.polish_scale_px > 0.0) || !std::isfinite(o.polish_scale_px)) {
    throw InvalidArgument("RansacOptions.polish_scale_px must be finite and > 0, got " +
                          std::to_string(o.polish_scale_px));
  }
  if (o.lo_max_iterations < 1) {
    throw InvalidArgument("RansacOptions.lo_max_iterations must be >= 1, got " +
                          std::to_string(o.lo_max_iterations));
  }
}

int RansacTrialCount(double confidence_percent, double inlier_ratio, int sample_size) {
  const double all_inlier = std::pow(inlier_ratio, sample_size);
  if (all_inlier < std::numeric_limits<double>::epsilon()) {
    return std::numeric_limits<std::int32_t>::max();
  }
  if (all_inlier >= 1.0) return 0;
  const double n =
      std::ceil(std::log(1.0 - 0.01 * confidence_percent) / std::log(1.0 - all_inlier));
  if (n >= static_cast<double>(std::numeric_limits<std::int32_t>::max())) {
    return std::numeric_limits<std::int32_t>::max();
  }
  return static_cast<int>(n);
}

RansacResult EstimateTransform(MotionModel model, SamplerKind sampler, const RansacOptions& options,
                               const Eigen::Matrix2Xd& prev_px, const Eigen::Matrix2Xd& curr_px,
                               const float* quality, RansacWorkspace& workspace) {
  Validate(options);
  return VisitMotionModel(model, [&](auto m) {
    return VisitSampler(sampler, [&](auto& s) {
      return RunRansac<decltype(m)>(options, prev_px, curr_px, quality, s, workspace);
    });
  });
}

}  // namespace aerovo
