// Test-only helpers (not installed: testing.h is excluded): synthetic correspondences with known
// ground truth for the estimation tests and benchmarks.
#pragma once

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "aerovo/estimation/models.h"

namespace aerovo::testing {

constexpr int kFrameWidth = 800;
constexpr int kFrameHeight = 600;

struct SyntheticCorrespondences {
  Eigen::Matrix2Xd prev;
  Eigen::Matrix2Xd curr;
  std::vector<std::uint8_t> is_inlier;  // Ground truth, one per column.
  std::vector<float> quality;           // Fake match SSD: inliers and outliers alike random.
};

/// A 2-vector (x, y) drawn from `dist_x` and `dist_y` with `rng`, y FIRST, then x: a fixed order
/// on every compiler and architecture. C++ leaves the evaluation order of function arguments
/// unspecified: `Eigen::Vector2d(ux(rng), uy(rng))` draws uy first with GCC on x86-64 (it
/// evaluates arguments right to left) but ux first with GCC on aarch64 (and with Clang), so one
/// seed gave other scenes per architecture. y-then-x is the order x86-64 GCC used, so
/// the x86 scenes, and every x86 test's numbers, are the ones recorded before. A braced list
/// `{ux(rng), uy(rng)}` needs no helper: its elements are evaluated left to right
/// ([dcl.init.list]), so it draws x first everywhere.
template <typename DistX, typename DistY, typename Engine>
Eigen::Vector2d DrawYThenX(DistX& dist_x, DistY& dist_y, Engine& rng) {
  const double y = dist_y(rng);
  const double x = dist_x(rng);
  return Eigen::Vector2d(x, y);
}

/// `num_inliers` prev points uniform in the 800x600 frame mapped by `curr_from_prev` plus
/// Gaussian noise of `noise_px` per coordinate, mixed at random positions with `num_outliers`
/// correspondences whose curr point is uniform in the frame and at least 5 px from where the
/// true transform puts it (so that, without noise, the true inlier set is exactly defined).
inline SyntheticCorrespondences MakeCorrespondences(const Eigen::Matrix3d& curr_from_prev,
                                                    int num_inliers, int num_outliers,
                                                    double noise_px, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(0.0, kFrameWidth - 1.0), uy(0.0, kFrameHeight - 1.0);
  std::normal_distribution<double> noise(0.0, noise_px > 0 ? noise_px : 1.0);
  std::uniform_real_distribution<float> q(0.f, 0.04f);
  const int n = num_inliers + num_outliers;
  std::vector<int> slot(static_cast<std::size_t>(n));
  std::iota(slot.begin(), slot.end(), 0);
  std::shuffle(slot.begin(), slot.end(), rng);
  SyntheticCorrespondences s;
  s.prev.resize(2, n);
  s.curr.resize(2, n);
  s.is_inlier.assign(static_cast<std::size_t>(n), 0);
  s.quality.assign(static_cast<std::size_t>(n), 0.f);
  for (int k = 0; k < n; ++k) {
    const int i = slot[static_cast<std::size_t>(k)];
    const Eigen::Vector2d p = DrawYThenX(ux, uy, rng);
    const Eigen::Vector2d truth = TransformPoint(curr_from_prev, p);
    Eigen::Vector2d c;
    if (k < num_inliers) {
      c = truth;
      if (noise_px > 0) c += DrawYThenX(noise, noise, rng);
      s.is_inlier[static_cast<std::size_t>(i)] = 1;
    } else {
      do {
        c = DrawYThenX(ux, uy, rng);
      } while ((c - truth).norm() < 5.0);
    }
    s.prev.col(i) = p;
    s.curr.col(i) = c;
    s.quality[static_cast<std::size_t>(i)] = q(rng);
  }
  return s;
}

}  // namespace aerovo::testing
