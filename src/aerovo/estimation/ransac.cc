#include "aerovo/estimation/ransac.h"

#include <cstdint>
#include <limits>

namespace aerovo {

void Validate(const RansacOptions& o) { options::CheckRanges(o, "ransac"); }

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
