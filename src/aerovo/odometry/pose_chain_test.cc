#include "aerovo/odometry/pose_chain.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/LU>

#include "aerovo/core/error.h"

namespace aerovo::pose_chain_test {
namespace {

constexpr int kW = 800, kH = 600;
const Eigen::Vector2d kCentre(0.5 * (kW - 1), 0.5 * (kH - 1));

// A nadir camera over a flat ground plane: position in the local frame (m), heading (rad, CCW
// from local +y), ground sampling distance (m/px).
struct Cam {
  Eigen::Vector2d pos;
  double heading;
  double gsd;
};

// ground_from_pixel of a camera: g = pos + gsd * Rot(heading) * FlipY * (p - centre).
Eigen::Matrix3d GroundFromPixel(const Cam& c) {
  Eigen::Matrix2d rot;
  rot << std::cos(c.heading), -std::sin(c.heading), std::sin(c.heading), std::cos(c.heading);
  const Eigen::Matrix2d flip = Eigen::Vector2d(1.0, -1.0).asDiagonal();
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topLeftCorner<2, 2>() = c.gsd * rot * flip;
  m.topRightCorner<2, 1>() = c.pos - c.gsd * rot * flip * kCentre;
  return m;
}

Eigen::Matrix3d CurrFromPrev(const Cam& prev, const Cam& curr) {
  return GroundFromPixel(curr).inverse() * GroundFromPixel(prev);
}

std::vector<Cam> LawnmowerFlight() {
  // 40 steps north, a 180-degree turn over 6 steps, 40 steps south, with varying height.
  std::vector<Cam> cams;
  Eigen::Vector2d p(0, 0);
  double heading = 0.0;
  for (int i = 0; i < 86; ++i) {
    const double gsd = 0.02 + 0.002 * std::sin(0.3 * i);
    cams.push_back({p, heading, gsd});
    double step_heading = 0.0;
    if (i >= 40 && i < 46) step_heading = -M_PI / 6.0;  // turning right (clockwise)
    heading += step_heading;
    // Fly along the image-up direction (local +y rotated by heading), 8 m per step.
    p += 8.0 * Eigen::Vector2d(-std::sin(heading), std::cos(heading));
  }
  return cams;
}

TEST(PoseChain, MetricModeRecoversExactTrajectoryWithVaryingHeight) {
  const std::vector<Cam> cams = LawnmowerFlight();
  PoseChain chain(ScaleMode::kMetric, kW, kH);
  chain.Start(cams[0].gsd);
  for (std::size_t i = 1; i < cams.size(); ++i) {
    chain.Step(CurrFromPrev(cams[i - 1], cams[i]), cams[i - 1].gsd, cams[i].gsd);
    EXPECT_NEAR((chain.position_m() - cams[i].pos).norm(), 0.0, 1e-6) << "frame " << i;
    EXPECT_NEAR(std::remainder(chain.heading_rad() - cams[i].heading, 2 * M_PI), 0.0, 1e-9);
    // local_from_frame maps every pixel to its ground position.
    const Eigen::Matrix3d expected = GroundFromPixel(cams[i]);
    EXPECT_LT((chain.world_from_frame() - expected).cwiseAbs().maxCoeff(), 1e-6);
  }
  // The flight turned back: the last frame is ~8 m x 40 east... check it ended south-going.
  EXPECT_NEAR(std::abs(chain.heading_rad()), M_PI, 1e-9);
}

TEST(PoseChain, AffineChainIsExactAtConstantHeightAndDriftsWithHeightChange) {
  std::vector<Cam> cams = LawnmowerFlight();
  for (Cam& c : cams) c.gsd = 0.02;
  PoseChain chain(ScaleMode::kAffineChain, kW, kH);
  chain.Start(0.02);
  for (std::size_t i = 1; i < cams.size(); ++i) {
    chain.Step(CurrFromPrev(cams[i - 1], cams[i]), 0.02, 0.02);
    EXPECT_NEAR((chain.position_m() - cams[i].pos).norm(), 0.0, 1e-6) << "frame " << i;
    EXPECT_NEAR(chain.chained_scale(), 1.0, 1e-9);
  }
  // Descending from gsd 0.02 to 0.01 over flat ground: the affine chain stays exact (its world
  // is the first frame's pixels, a scaled copy of the ground) and its accumulated scale is the
  // height ratio; metric mode agrees without chaining the scale.
  PoseChain affine(ScaleMode::kAffineChain, kW, kH), metric(ScaleMode::kMetric, kW, kH);
  Cam prev{{0, 0}, 0.0, 0.02};
  affine.Start(prev.gsd);
  metric.Start(prev.gsd);
  for (int i = 1; i <= 10; ++i) {
    const Cam curr{{0.0, 10.0 * i}, 0.0, 0.02 - 0.001 * i};
    affine.Step(CurrFromPrev(prev, curr), prev.gsd, curr.gsd);
    metric.Step(CurrFromPrev(prev, curr), prev.gsd, curr.gsd);
    prev = curr;
  }
  EXPECT_NEAR((metric.position_m() - Eigen::Vector2d(0, 100)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(affine.chained_scale(), 0.5, 1e-9);
  EXPECT_NEAR((affine.position_m() - Eigen::Vector2d(0, 100)).norm(), 0.0, 1e-6);
}

TEST(PoseChain, MetricModeIgnoresTiltInducedStepScale) {
  // The tampa pitfall: each step's affine scale is 1.05 forward (scale about the image centre),
  // chained it explodes; metric mode uses only rotation and the centre's displacement.
  PoseChain affine(ScaleMode::kAffineChain, kW, kH), metric(ScaleMode::kMetric, kW, kH);
  affine.Start(0.02);
  metric.Start(0.02);
  Cam prev{{0, 0}, 0.0, 0.02};
  for (int i = 1; i <= 30; ++i) {
    const Cam curr{{0.0, 8.0 * i}, 0.0, 0.02};
    Eigen::Matrix3d zoom = Eigen::Matrix3d::Identity();
    zoom.topLeftCorner<2, 2>() *= 1.05;
    zoom.topRightCorner<2, 1>() = kCentre - 1.05 * kCentre;
    const Eigen::Matrix3d t = zoom * CurrFromPrev(prev, curr);
    affine.Step(t, 0.02, 0.02);
    metric.Step(t, 0.02, 0.02);
    prev = curr;
  }
  // Metric: the centre's displacement shrinks by 1/1.05 at most per step.
  EXPECT_NEAR(metric.position_m().y(), 240.0, 240.0 * 0.06);
  EXPECT_NEAR(metric.position_m().x(), 0.0, 1e-6);
  EXPECT_LT(affine.chained_scale(), 0.25);
}

TEST(PoseChain, HeadingOverrideAndErrors) {
  PoseChain chain(ScaleMode::kMetric, kW, kH);
  EXPECT_THROW(chain.Step(Eigen::Matrix3d::Identity(), 1, 1), InvalidArgument);
  chain.Start(0.05);
  const double heading = 0.7;
  chain.Step(Eigen::Matrix3d::Identity(), 0.05, 0.05, &heading);
  EXPECT_NEAR(chain.heading_rad(), 0.7, 1e-12);
  EXPECT_THROW(chain.Step(Eigen::Matrix3d::Zero(), 0.05, 0.05), InvalidArgument);
  EXPECT_THROW(chain.Start(0.0), InvalidArgument);
  EXPECT_THROW(PoseChain(ScaleMode::kMetric, 0, 10), InvalidArgument);
  EXPECT_EQ(ParseScaleMode("affine-chain"), ScaleMode::kAffineChain);
  EXPECT_THROW(ParseScaleMode("pixels"), InvalidArgument);
}

TEST(PoseChain, RotationAngleAndScaleOfTransform) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topLeftCorner<2, 2>() << std::cos(0.3), -std::sin(0.3), std::sin(0.3), std::cos(0.3);
  m.topLeftCorner<2, 2>() *= 1.2;
  EXPECT_NEAR(RotationAngleRad(m), 0.3, 1e-12);
  EXPECT_NEAR(LinearScale(m), 1.2, 1e-12);
}

}  // namespace
}  // namespace aerovo::pose_chain_test
