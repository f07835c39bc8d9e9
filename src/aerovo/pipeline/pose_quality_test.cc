#include "aerovo/pipeline/pose_quality.h"

#include <gtest/gtest.h>

namespace aerovo::pose_quality_test {
namespace {

FrameResult Step(FrameStatus status, int inliers, int matched) {
  FrameResult r;
  r.status = status;
  r.n_inliers = inliers;
  r.n_matched = matched;
  return r;
}

TEST(PoseQuality, BridgedIsMinusOneAndTheOriginIsFull) {
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kBridged, 500, 600)), -1);
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kFirst, 0, 0)), 100);
}

TEST(PoseQuality, MeasuredStepsFromInliersAndTheirShare) {
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kOk, 100, 100)), 100);
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kOk, 400, 400)), 100);  // saturates
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kOk, 100, 200)), 75);   // 1 * (0.5 + 0.25)
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kOk, 50, 50)), 50);     // 0.5 * 1
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kOk, 12, 48)), 8);      // 0.12 * 0.625 = 7.5 -> 8
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kReacquired, 100, 100)), 50);
  // An accepted step is never 0 (0 would read as "no confidence" to an autopilot).
  EXPECT_EQ(PoseQuality(Step(FrameStatus::kOk, 1, 1000)), 1);
  // More inliers never lowers it; a lower share never raises it.
  int last = 0;
  for (int n = 1; n <= 150; ++n) {
    const int q = PoseQuality(Step(FrameStatus::kOk, n, 2 * n));
    EXPECT_GE(q, last) << n;
    last = q;
  }
  EXPECT_GT(PoseQuality(Step(FrameStatus::kOk, 60, 80)), PoseQuality(Step(FrameStatus::kOk, 60, 300)));
}

}  // namespace
}  // namespace aerovo::pose_quality_test
