#include "aerovo/pipeline/pose_quality.h"

#include <algorithm>
#include <cmath>

namespace aerovo {

int PoseQuality(const FrameResult& r) {
  switch (r.status) {
    case FrameStatus::kBridged:
      return -1;
    case FrameStatus::kFirst:
      return 100;
    case FrameStatus::kOk:
    case FrameStatus::kReacquired:
      break;
  }
  const int inliers = std::max(0, r.n_inliers);
  const int matched = std::max(inliers, r.n_matched);
  const double support = std::min(1.0, static_cast<double>(inliers) / kPoseQualityFullInliers);
  const double agreement = matched > 0 ? 0.5 + 0.5 * static_cast<double>(inliers) / matched : 0.5;
  double q = 100.0 * support * agreement;
  if (r.status == FrameStatus::kReacquired) q *= 0.5;
  return std::clamp(static_cast<int>(std::lround(q)), 1, 100);
}

}  // namespace aerovo
