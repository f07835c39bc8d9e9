// The one "quality" of a pose, 0-100, shared by every live output: the JSONL pose stream
// (--poses-jsonl) and MAVLink ODOMETRY's `quality` field (whose convention it follows: 0 = no
// confidence, 100 = full, -1 = the pose is not measured).
#pragma once

#include "aerovo/odometry/visual_odometry.h"

namespace aerovo {

/// Inliers at which the support term saturates. Our choice: the step's fit rests on the
/// inliers, and beyond about 100 well-spread points more of them change the fit's error little
/// (its standard error falls as 1/sqrt(n)); below it confidence falls in proportion.
inline constexpr int kPoseQualityFullInliers = 100;

/// The quality of a frame's pose, in [-1, 100]:
/// - -1 for a bridged frame (the step failed; the pose is the previous motion extrapolated);
/// - 100 for the first frame (the origin, exact by definition);
/// - for a measured step (ok, reacquired): round(100 * support * agreement), at least 1, with
///   support = min(1, n_inliers / kPoseQualityFullInliers) and agreement = 0.5 + 0.5 *
///   n_inliers / n_matched (the share of the putative matches the fit explains: 1 when all
///   agree, 0.5 when almost none do); a reacquired step (a gap before it) counts half.
/// Only counts of `result` are used (n_inliers, n_matched, status): the same number for the
/// same frame in every output.
int PoseQuality(const FrameResult& result);

}  // namespace aerovo
