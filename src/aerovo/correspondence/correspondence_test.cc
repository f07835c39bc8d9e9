#include "aerovo/correspondence/correspondence.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#if AEROVO_TESTS_HAVE_OPENCV  // 0 in the builds without OpenCV (AEROVO_CORE_ONLY, aarch64)
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif

#include "aerovo/core/angles.h"
#include "aerovo/core/testing.h"
#include "aerovo/estimation/testing.h"
#include "aerovo/features/surf.h"

namespace aerovo::correspondence_test {
namespace {

using testing::kFrameHeight;
using testing::kFrameWidth;

Eigen::Matrix3d Shift(double tu, double tv) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m(0, 2) = tu;
  m(1, 2) = tv;
  return m;
}

// Builds prev/curr feature sets point by point: each prev point gets a random unit descriptor;
// its curr twin (same descriptor) is placed where `curr_of` says, and is left out when that is
// outside the frame (the point left the view).
class SceneBuilder {
 public:
  explicit SceneBuilder(std::uint64_t seed) : rng_(seed) {
    prev_.descriptor_size = curr_.descriptor_size = 64;
  }

  void Add(const Eigen::Vector2d& prev_px, const Eigen::Vector2d& curr_px) {
    std::normal_distribution<float> g(0.f, 1.f);
    std::vector<float> d(64);
    float norm = 0.f;
    for (float& v : d) {
      v = g(rng_);
      norm += v * v;
    }
    for (float& v : d) v /= std::sqrt(norm);
    Keypoint k;
    k.x = static_cast<float>(prev_px.x());
    k.y = static_cast<float>(prev_px.y());
    k.scale = 2.f;
    k.laplacian = 1;
    prev_.keypoints.push_back(k);
    prev_.descriptors.insert(prev_.descriptors.end(), d.begin(), d.end());
    if (curr_px.x() < 0 || curr_px.y() < 0 || curr_px.x() > kFrameWidth - 1 ||
        curr_px.y() > kFrameHeight - 1) {
      return;
    }
    k.x = static_cast<float>(curr_px.x());
    k.y = static_cast<float>(curr_px.y());
    curr_.keypoints.push_back(k);
    curr_.descriptors.insert(curr_.descriptors.end(), d.begin(), d.end());
  }

  // `count` points uniform in [x0, x1) x [y0, y1) shrunk by 2 px (clear of cell edges),
  // moving by `motion`.
  void AddInBox(int count, double x0, double y0, double x1, double y1,
                const Eigen::Matrix3d& motion) {
    std::uniform_real_distribution<double> ux(x0 + 2, x1 - 2), uy(y0 + 2, y1 - 2);
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector2d p = testing::DrawYThenX(ux, uy, rng_);
      Add(p, TransformPoint(motion, p));
    }
  }

  // Same, but the curr twin is at a random place in the frame (a wrong correspondence).
  void AddScrambledInBox(int count, double x0, double y0, double x1, double y1) {
    std::uniform_real_distribution<double> ux(x0 + 2, x1 - 2), uy(y0 + 2, y1 - 2);
    std::uniform_real_distribution<double> fx(0, kFrameWidth - 1), fy(0, kFrameHeight - 1);
    // Braced lists are evaluated left to right ([dcl.init.list]): the same draws everywhere.
    for (int i = 0; i < count; ++i) Add({ux(rng_), uy(rng_)}, {fx(rng_), fy(rng_)});
  }

  // A look-alike of the last prev point in curr (same descriptor) at `curr_px`.
  void AddDecoy(const Eigen::Vector2d& curr_px) {
    Keypoint k = prev_.keypoints.back();
    k.x = static_cast<float>(curr_px.x());
    k.y = static_cast<float>(curr_px.y());
    curr_.keypoints.push_back(k);
    curr_.descriptors.insert(curr_.descriptors.end(), prev_.descriptors.end() - 64,
                             prev_.descriptors.end());
  }

  const FeatureSet& prev() const { return prev_; }
  const FeatureSet& curr() const { return curr_; }

 private:
  std::mt19937_64 rng_;
  FeatureSet prev_, curr_;
};

struct Direction {
  double tu, tv;
  RectI expected_crop;
};

// Content motion (t_u, t_v) of 60 / 45 px in each of the 8 directions and zero: the strip on the
// side the content moves toward is dropped.
std::vector<Direction> Directions() {
  const int w = kFrameWidth, h = kFrameHeight;
  return {
      {0, 0, {0, 0, w, h}},
      {60, 0, {0, 0, w - 60, h}},
      {-60, 0, {60, 0, w - 60, h}},
      {0, 45, {0, 0, w, h - 45}},
      {0, -45, {0, 45, w, h - 45}},
      {60, 45, {0, 0, w - 60, h - 45}},
      {60, -45, {0, 45, w - 60, h - 45}},
      {-60, 45, {60, 0, w - 60, h - 45}},
      {-60, -45, {60, 45, w - 60, h - 45}},
  };
}

void ExpectRectEq(const RectI& a, const RectI& b, const std::string& what) {
  EXPECT_EQ(a.x, b.x) << what;
  EXPECT_EQ(a.y, b.y) << what;
  EXPECT_EQ(a.width, b.width) << what;
  EXPECT_EQ(a.height, b.height) << what;
}

TEST(ClusteredCrop, DropsTheStripsTheContentMovesToward) {
  for (const Direction& d : Directions()) {
    const std::string what = "t = (" + std::to_string(d.tu) + ", " + std::to_string(d.tv) + ")";
    ExpectRectEq(ClusteredCrop(kFrameWidth, kFrameHeight, Shift(d.tu, d.tv)), d.expected_crop,
                 what);
  }
  // Fractional shifts round up; a rotation about the frame centre moves nothing there.
  ExpectRectEq(ClusteredCrop(800, 600, Shift(10.2, -0.5)), RectI{0, 1, 789, 599}, "fractional");
  const double a = 0.01;
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  rot.topLeftCorner<2, 2>() << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
  const Eigen::Vector2d c(399.5, 299.5);
  rot.block<2, 1>(0, 2) = c - rot.topLeftCorner<2, 2>() * c;
  ExpectRectEq(ClusteredCrop(800, 600, rot), RectI{0, 0, 800, 600}, "rotation about centre");
  EXPECT_TRUE(ClusteredCrop(800, 600, Shift(900, 0)).empty());
  EXPECT_THROW(ClusteredCrop(0, 600, Shift(0, 0)), InvalidArgument);
  EXPECT_THROW(ClusteredCrop(800, 600, Shift(NAN, 0)), InvalidArgument);
}

// One motion of CropAndChosenCellForEachMotion: the direction, its label, the cell that should
// be chosen (13 points) and the decoy below the minimum (11 points).
struct MotionCase {
  const Direction& d;
  std::string what;
  Eigen::Matrix3d motion;
  int target, decoy;
};

// The scene of `c`: every cell of the expected crop gets a distinct number of points, plus a few
// points in each strip that should be dropped.
SceneBuilder CellScene(const MotionCase& c, std::uint64_t seed) {
  SceneBuilder scene(seed);
  const RectI& crop = c.d.expected_crop;
  for (int cell = 0; cell < 9; ++cell) {
    const int count = cell == c.target ? 13 : cell == c.decoy ? 11 : 20 + 3 * cell;
    const CellBounds b = ClusterCellBounds(crop, 3, 3, cell / 3, cell % 3);
    scene.AddInBox(count, b.x0, b.y0, b.x1, b.y1, c.motion);
  }
  // Strips outside the crop: few points each, so a wrong crop would change the counts.
  if (crop.x > 0) scene.AddInBox(5, 0, 0, crop.x, kFrameHeight, c.motion);
  if (crop.x + crop.width < kFrameWidth) {
    scene.AddInBox(5, crop.x + crop.width, 0, kFrameWidth, kFrameHeight, c.motion);
  }
  if (crop.y > 0) scene.AddInBox(5, 0, 0, kFrameWidth, crop.y, c.motion);
  if (crop.y + crop.height < kFrameHeight) {
    scene.AddInBox(5, 0, crop.y + crop.height, kFrameWidth, kFrameHeight, c.motion);
  }
  return scene;
}

// The paper's algorithm exactly (no refinement): the crop, the target cell in one attempt, and
// the cell's own fit on its 13 points.
void ExpectPaperCellFit(const SceneBuilder& scene, const MotionCase& c) {
  const std::string& what = c.what;
  const RectI& crop = c.d.expected_crop;
  CorrespondenceOptions paper;  // The paper's algorithm exactly: the cell's own fit.
  paper.clustered.refine = false;
  CorrespondenceStage stage(paper);
  const CorrespondenceResult r =
      stage.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), c.motion);
  ExpectRectEq(r.crop, crop, what);
  EXPECT_FALSE(r.refined);
  ASSERT_TRUE(r.success) << what;
  EXPECT_FALSE(r.fell_back) << what;
  EXPECT_EQ(r.method_used, CorrespondenceMethod::kClustered);
  EXPECT_EQ(r.cell_row, c.target / 3) << what;
  EXPECT_EQ(r.cell_col, c.target % 3) << what;
  EXPECT_EQ(r.attempts, 1) << what;
  EXPECT_EQ(r.cell_point_counts[static_cast<std::size_t>(c.decoy)], 11) << what;
  EXPECT_EQ(r.cell_point_counts[static_cast<std::size_t>(c.target)], 13) << what;
  ASSERT_EQ(r.matches.size(), 13u) << what;
  EXPECT_EQ(r.num_inliers, 13) << what;
  const CellBounds b = ClusterCellBounds(crop, 3, 3, c.target / 3, c.target % 3);
  for (const Match& m : r.matches) {
    const Keypoint& k = scene.prev().keypoints[static_cast<std::size_t>(m.prev_index)];
    EXPECT_TRUE(b.contains(k.x, k.y)) << what;
  }
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, c.motion, kFrameWidth, kFrameHeight), 0.01)
      << what;
  EXPECT_GT(r.match_ms + r.estimate_ms, 0.0);
  EXPECT_GE(r.total_ms, r.match_ms + r.estimate_ms);
}

// A refined run with options `o`: same cell as the paper's, in one attempt, refined.
CorrespondenceResult RefinedRun(const SceneBuilder& scene, const MotionCase& c,
                                const CorrespondenceOptions& o) {
  CorrespondenceStage stage_refined(o);
  const CorrespondenceResult x =
      stage_refined.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), c.motion);
  EXPECT_TRUE(x.success) << c.what;
  EXPECT_TRUE(x.refined) << c.what;
  EXPECT_EQ(x.cell_row * 3 + x.cell_col, c.target) << c.what;
  EXPECT_EQ(x.attempts, 1) << c.what;
  return x;
}

// Refinement without the final pass, in one pass: up to 20 points of every cell are re-matched.
void ExpectSpreadRefinement(const SceneBuilder& scene, const MotionCase& c) {
  const std::string& what = c.what;
  CorrespondenceOptions spread;
  spread.clustered.refine_final_radius_px = 0.f;
  spread.clustered.refine_early_exit = false;
  const CorrespondenceResult rr = RefinedRun(scene, c, spread);
  // 20 points per other cell (all 11 of the decoy), all 13 of the chosen cell; no strip point.
  const std::size_t expected = 7 * 20 + 11 + 13;
  EXPECT_EQ(rr.matches.size(), expected) << what;
  EXPECT_EQ(rr.num_inliers, static_cast<int>(expected)) << what;
  for (const Match& m : rr.matches) {
    const Keypoint& k = scene.prev().keypoints[static_cast<std::size_t>(m.prev_index)];
    EXPECT_TRUE(c.d.expected_crop.contains(k.x, k.y)) << what;
  }
  EXPECT_LT(MaxCornerDisplacementPx(rr.curr_from_prev, c.motion, kFrameWidth, kFrameHeight), 0.01)
      << what;
  EXPECT_FALSE(rr.final_pass) << what;
  EXPECT_LT(rr.refine_shift_px, 0.01) << what;
  EXPECT_FALSE(rr.refine_early_exit) << what;
}

// Default: the motion is exact, so the fit on the first half of the spread points (10 per other
// cell) stays on the cell's: the other half and the final pass are skipped.
void ExpectEarlyExit(const SceneBuilder& scene, const MotionCase& c) {
  const std::string& what = c.what;
  const CorrespondenceResult rs = RefinedRun(scene, c, CorrespondenceOptions{});
  EXPECT_TRUE(rs.refine_early_exit) << what;
  EXPECT_FALSE(rs.final_pass) << what;
  EXPECT_EQ(rs.matches.size(), 7u * 10u + 10u + 13u) << what;
  EXPECT_EQ(rs.num_inliers, static_cast<int>(rs.matches.size())) << what;
  EXPECT_LT(rs.refine_shift_px, 0.01) << what;
  EXPECT_LT(MaxCornerDisplacementPx(rs.curr_from_prev, c.motion, kFrameWidth, kFrameHeight), 0.01)
      << what;
}

// Final pass forced: it matches every prev point (strips included) around the refined
// prediction, i.e. every point that is still in view (the only ones with a curr twin).
void ExpectForcedFinalPass(const SceneBuilder& scene, const MotionCase& c) {
  const std::string& what = c.what;
  CorrespondenceOptions always;
  always.clustered.refine_final_min_shift_px = 0.f;
  const CorrespondenceResult rd = RefinedRun(scene, c, always);
  EXPECT_TRUE(rd.final_pass) << what;
  EXPECT_EQ(rd.matches.size(), scene.curr().size()) << what;
  EXPECT_EQ(rd.num_inliers, static_cast<int>(scene.curr().size())) << what;
  for (const Match& m : rd.matches) {
    const Keypoint& p = scene.prev().keypoints[static_cast<std::size_t>(m.prev_index)];
    const Keypoint& k = scene.curr().keypoints[static_cast<std::size_t>(m.curr_index)];
    EXPECT_LT(
        (TransformPoint(c.motion, Eigen::Vector2d(p.x, p.y)) - Eigen::Vector2d(k.x, k.y)).norm(),
        1e-3)
        << what;
  }
  EXPECT_LT(MaxCornerDisplacementPx(rd.curr_from_prev, c.motion, kFrameWidth, kFrameHeight), 0.01)
      << what;
}

// Most-first takes the fullest cell (count 20 + 3 * 8 = 44 unless it is target/decoy).
void ExpectMostFirstTakesFullest(const SceneBuilder& scene, const MotionCase& c) {
  CorrespondenceOptions most;
  most.clustered.cell_order = CellOrder::kMostFirst;
  CorrespondenceStage stage_most(most);
  const CorrespondenceResult rm =
      stage_most.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), c.motion);
  int fullest = 0;
  for (int cell = 1; cell < 9; ++cell) {
    if (rm.cell_point_counts[cell] > rm.cell_point_counts[fullest]) fullest = cell;
  }
  ASSERT_TRUE(rm.success) << c.what;
  EXPECT_EQ(rm.cell_row * 3 + rm.cell_col, fullest) << c.what;
}

// For each motion: every cell of the expected crop gets a distinct number of points (one with
// 11, below the paper's minimum 12, one with 13 = the fewest eligible), plus points in the strips
// that should be dropped. The motion repeats from n-1 to n.
TEST(ClusteredRansac, CropAndChosenCellForEachMotion) {
  const std::vector<Direction> dirs = Directions();
  for (std::size_t di = 0; di < dirs.size(); ++di) {
    const Direction& d = dirs[di];
    const MotionCase c{d, "t = (" + std::to_string(d.tu) + ", " + std::to_string(d.tv) + ")",
                       Shift(d.tu, d.tv), static_cast<int>(di % 9), static_cast<int>((di + 4) % 9)};
    const SceneBuilder scene = CellScene(c, 100 + di);
    ASSERT_NO_FATAL_FAILURE(ExpectPaperCellFit(scene, c));
    ExpectSpreadRefinement(scene, c);
    ExpectEarlyExit(scene, c);
    ExpectForcedFinalPass(scene, c);
    ASSERT_NO_FATAL_FAILURE(ExpectMostFirstTakesFullest(scene, c));
  }
}

TEST(ClusteredRansac, CellsBelowMinimumAreNeverChosen) {
  // Eight cells with 11 points, one with 30: only the 30-point cell is eligible even though the
  // others have fewer points.
  SceneBuilder scene(7);
  const Eigen::Matrix3d motion = Shift(-20, 15);
  const RectI crop = ClusteredCrop(kFrameWidth, kFrameHeight, motion);
  for (int cell = 0; cell < 9; ++cell) {
    const CellBounds b = ClusterCellBounds(crop, 3, 3, cell / 3, cell % 3);
    scene.AddInBox(cell == 7 ? 30 : 11, b.x0, b.y0, b.x1, b.y1, motion);
  }
  CorrespondenceOptions paper;
  paper.clustered.refine = false;
  CorrespondenceStage stage(paper);
  const CorrespondenceResult r =
      stage.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), motion);
  ASSERT_TRUE(r.success);
  EXPECT_FALSE(r.fell_back);
  EXPECT_EQ(r.cell_row, 2);
  EXPECT_EQ(r.cell_col, 1);
  EXPECT_EQ(r.attempts, 1);
  EXPECT_EQ(r.matches.size(), 30u);

  // With min_points 31 no cell is eligible: straight to the fall-back, one attempt.
  CorrespondenceOptions strict;
  strict.clustered.min_points = 31;
  CorrespondenceStage stage_strict(strict);
  const CorrespondenceResult rs =
      stage_strict.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), motion);
  ASSERT_TRUE(rs.success);
  EXPECT_TRUE(rs.fell_back);
  EXPECT_EQ(rs.method_used, CorrespondenceMethod::kStandard);
  EXPECT_EQ(rs.attempts, 1);
  EXPECT_EQ(rs.cell_row, -1);
  EXPECT_EQ(rs.matches.size(), scene.prev().size());
  EXPECT_LT(MaxCornerDisplacementPx(rs.curr_from_prev, motion, kFrameWidth, kFrameHeight), 0.01);
}

// The previous step moved the content right, this one moves it left-down: every cell's matches
// are wrong (the cells' points were scrambled), only the points in the dropped strip move
// consistently. Clustered RANSAC must try every cell, fail, and fall back to standard RANSAC,
// which recovers the true motion from the strip's points.
TEST(ClusteredRansac, FallsBackToStandardWhenNoCellWorks) {
  SceneBuilder scene(9);
  const Eigen::Matrix3d last = Shift(60, 0);
  const Eigen::Matrix3d motion = Shift(-25, 12);
  const RectI crop = ClusteredCrop(kFrameWidth, kFrameHeight, last);
  ASSERT_EQ(crop.width, kFrameWidth - 60);
  for (int cell = 0; cell < 9; ++cell) {
    const CellBounds b = ClusterCellBounds(crop, 3, 3, cell / 3, cell % 3);
    scene.AddScrambledInBox(14 + cell, b.x0, b.y0, b.x1, b.y1);
  }
  scene.AddInBox(50, crop.x + crop.width, 20, kFrameWidth, kFrameHeight - 20, motion);

  CorrespondenceStage stage;
  const CorrespondenceResult r =
      stage.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), last);
  ASSERT_TRUE(r.success);
  EXPECT_TRUE(r.fell_back);
  EXPECT_EQ(r.method_used, CorrespondenceMethod::kStandard);
  EXPECT_EQ(r.attempts, 10);
  EXPECT_EQ(r.cell_row, -1);
  EXPECT_EQ(r.cell_col, -1);
  EXPECT_EQ(r.num_inliers, 50);
  EXPECT_EQ(r.matches.size(), scene.prev().size());
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, motion, kFrameWidth, kFrameHeight), 0.01);

  // The same scene with only the scrambled cells: nothing works, and the result says so.
  SceneBuilder bad(10);
  for (int cell = 0; cell < 9; ++cell) {
    const CellBounds b = ClusterCellBounds(crop, 3, 3, cell / 3, cell % 3);
    bad.AddScrambledInBox(14, b.x0, b.y0, b.x1, b.y1);
  }
  const CorrespondenceResult rb =
      stage.Clustered(bad.prev(), kFrameWidth, kFrameHeight, bad.curr(), last);
  EXPECT_FALSE(rb.success);
  EXPECT_TRUE(rb.fell_back);
  EXPECT_EQ(rb.attempts, 10);
  EXPECT_EQ(rb.curr_from_prev, Eigen::Matrix3d::Identity());
}

// A cell's transform is exact inside the cell but extrapolates noise to the far corners; the
// refinement re-fits on points spread over the whole crop and lands as close to the truth as
// standard RANSAC (all points: within 0.2 px of it; the default 180 points: within 0.5 px).
TEST(ClusteredRansac, RefinementMatchesStandardAccuracy) {
  SceneBuilder scene(12);
  Eigen::Matrix3d motion;
  motion << 1.02, -0.03, 21.0, 0.025, 0.985, -14.0, 0, 0, 1;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(0, kFrameWidth - 1), uy(0, kFrameHeight - 1);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (int i = 0; i < 600; ++i) {
    const Eigen::Vector2d p = testing::DrawYThenX(ux, uy, rng);
    scene.Add(p, TransformPoint(motion, p) + testing::DrawYThenX(noise, noise, rng));
  }
  CorrespondenceOptions paper, all, spread;
  paper.clustered.refine = false;
  all.clustered.refine_max_points = 0;
  all.clustered.refine_final_radius_px = 0.f;
  spread.clustered.refine_final_radius_px = 0.f;
  CorrespondenceStage cell_only(paper), refining_all(all), refining(spread), defaults, standard;
  const Eigen::Matrix3d still = Eigen::Matrix3d::Identity();
  const auto rp = cell_only.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto ra =
      refining_all.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto rr = refining.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto rd = defaults.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto rs = standard.Standard(scene.prev(), scene.curr());
  ASSERT_TRUE(rp.success && ra.success && rr.success && rd.success && rs.success);
  EXPECT_FALSE(rp.refined);
  EXPECT_TRUE(ra.refined);
  EXPECT_TRUE(rr.refined);
  EXPECT_TRUE(rd.refined);
  EXPECT_GT(ra.num_inliers, 5 * rp.num_inliers);
  EXPECT_LE(rr.matches.size(), 160u + rp.matches.size());
  EXPECT_GT(rr.num_inliers, 150);
  // 0.5 px of noise on one cell's ~70 points: its fit is off by more than 1 px at the far
  // corners, the spread fit moves it by that much, so the default runs the final pass.
  // FRAGILE, by the draw: this scene (seed 5, DrawYThenX) gives 1.92 px; the same seed drawn
  // x before y gives 0.91 px (what aarch64 drew before the draws were ordered: the final pass
  // rightly did not run). Over seeds 0-59 in both draw orders the shift ranges 0.37-2.44 px
  // (median 1.10) and is > 1 px, with the final pass, in 69 of 120 scenes; the gate always agreed
  // with the shift. The seed is kept because the assertions below need a scene that crosses it.
  std::printf("spread refinement moved the cell's fit by %.2f px\n", rd.refine_shift_px);
  EXPECT_TRUE(rd.final_pass);
  EXPECT_GT(rd.refine_shift_px, 1.0);
  // The final pass finds the standard method's evidence: every point, same fit.
  EXPECT_EQ(rd.matches.size(), rs.matches.size());
  EXPECT_EQ(rd.num_inliers, rs.num_inliers);
  EXPECT_LT(MaxCornerDisplacementPx(rd.curr_from_prev, rs.curr_from_prev, 800, 600), 0.05);
  EXPECT_LT(rd.num_comparisons * 3, rs.num_comparisons);
  const double e_cell = MaxCornerDisplacementPx(rp.curr_from_prev, motion, 800, 600);
  const double e_all = MaxCornerDisplacementPx(ra.curr_from_prev, motion, 800, 600);
  const double e_default = MaxCornerDisplacementPx(rr.curr_from_prev, motion, 800, 600);
  const double e_standard = MaxCornerDisplacementPx(rs.curr_from_prev, motion, 800, 600);
  EXPECT_LT(e_standard, 0.3);
  EXPECT_LT(e_all, 0.3);
  EXPECT_LT(e_all, e_cell);
  EXPECT_LT(MaxCornerDisplacementPx(ra.curr_from_prev, rs.curr_from_prev, 800, 600), 0.2);
  EXPECT_LT(e_default, 0.5);
  EXPECT_LT(MaxCornerDisplacementPx(rr.curr_from_prev, rs.curr_from_prev, 800, 600), 0.5);
  std::printf(
      "corner error px: cell %.3f, refined(all) %.3f, refined(180) %.3f, default (final pass) "
      "%.3f, standard %.3f\n",
      e_cell, e_all, e_default, MaxCornerDisplacementPx(rd.curr_from_prev, motion, 800, 600),
      e_standard);
}

TEST(ClusteredRansac, SpreadRefinementKeepsTheCellsMatchesAndMatchesOnlyOtherCells) {
  // 60 points per cell on a 3 x 3 grid over the whole frame (zero motion: no crop), one cell
  // with 30 (the fewest: chosen), all moving by an affine map that keeps every point in view.
  SceneBuilder scene(21);
  Eigen::Matrix3d motion;
  motion << 0.98, 0.01, 4.0, -0.01, 0.98, 8.0, 0, 0, 1;
  const double cw = kFrameWidth / 3.0, ch = kFrameHeight / 3.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      scene.AddInBox(r == 2 && c == 0 ? 30 : 60, c * cw, r * ch, (c + 1) * cw, (r + 1) * ch,
                     motion);
    }
  }
  CorrespondenceOptions paper, spread;
  paper.clustered.refine = false;
  spread.clustered.refine_final_radius_px = 0.f;
  spread.clustered.refine_max_points = 90;  // 10 per cell
  spread.clustered.refine_early_exit = false;
  CorrespondenceStage cell_only(paper), refining(spread);
  const Eigen::Matrix3d still = Eigen::Matrix3d::Identity();
  const auto rp = cell_only.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto rr = refining.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  ASSERT_TRUE(rp.success && rr.success);
  ASSERT_EQ(rp.cell_row, 2);
  ASSERT_EQ(rp.cell_col, 0);
  ASSERT_TRUE(rr.refined);
  // The cell's matches are in the refined set exactly as the cell attempt made them.
  std::map<int, Match> refined_by_prev;
  for (const Match& m : rr.matches) refined_by_prev[m.prev_index] = m;
  ASSERT_EQ(rp.matches.size(), 30u);
  for (const Match& m : rp.matches) {
    ASSERT_EQ(refined_by_prev.count(m.prev_index), 1u) << "cell match of prev " << m.prev_index;
    EXPECT_EQ(refined_by_prev[m.prev_index].curr_index, m.curr_index);
    EXPECT_EQ(refined_by_prev[m.prev_index].ssd, m.ssd);
  }
  // 10 further points from each of the 8 other cells, each with its twin.
  EXPECT_EQ(rr.matches.size(), 30u + 8u * 10u);
  EXPECT_EQ(rr.num_inliers, 110);
  // Only those 80 points were matched again: the refinement's comparisons are those of a
  // guided match of exactly them around the cell's fit.
  std::vector<int> others;
  for (const Match& m : rr.matches) {
    const Keypoint& k = scene.prev().keypoints[static_cast<std::size_t>(m.prev_index)];
    if (!(k.x < cw && k.y >= 2 * ch)) others.push_back(m.prev_index);
  }
  ASSERT_EQ(others.size(), 80u);
  MatchOptions guided = spread.match;
  guided.guided_radius_px = spread.clustered.refine_radius_px;
  Matcher matcher(guided);
  const MatchResult again =
      matcher.Match(scene.prev(), scene.curr(), others, AffinePart(rp.curr_from_prev));
  EXPECT_EQ(rr.num_comparisons, rp.num_comparisons + again.num_comparisons);
  EXPECT_LT(MaxCornerDisplacementPx(rr.curr_from_prev, motion, 800, 600), 1e-3);
}

// The two-layer scene of the tests below: the bottom-left cell (40 points, the fewest: the
// chosen one) moves with NearLayer(), the other cells (80 points each) with FarLayer(), 2.5 px
// further right; both keep every point in view.
Eigen::Matrix3d NearLayer() {
  Eigen::Matrix3d m;
  m << 0.98, 0.01, 4.0, -0.01, 0.98, 8.0, 0, 0, 1;
  return m;
}
Eigen::Matrix3d FarLayer() { return Shift(2.5, 0.0) * NearLayer(); }
void AddTwoLayers(SceneBuilder* scene) {
  const double cw = kFrameWidth / 3.0, ch = kFrameHeight / 3.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const bool chosen = r == 2 && c == 0;
      scene->AddInBox(chosen ? 40 : 80, c * cw, r * ch, (c + 1) * cw, (r + 1) * ch,
                      chosen ? NearLayer() : FarLayer());
    }
  }
}

// The final pass runs when the spread refinement moves the cell's fit by more than
// refine_final_min_shift_px at the corners: here the bottom-left cell (the chosen one: fewest
// points) moves with one affine map and the rest of the frame, a second layer, 2.5 px further
// right, so the cell's fit is 2.5 px off elsewhere.
TEST(ClusteredRansac, FinalPassRunsWhenTheSpreadFitMovesTheCellsFit) {
  SceneBuilder scene(33);
  const Eigen::Matrix3d far_layer = FarLayer();
  AddTwoLayers(&scene);
  const Eigen::Matrix3d still = Eigen::Matrix3d::Identity();
  CorrespondenceOptions defaults, tolerant;
  tolerant.clustered.refine_final_min_shift_px = 5.f;
  CorrespondenceStage stage(defaults), stage_tolerant(tolerant), standard;
  const auto rd = stage.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto rt =
      stage_tolerant.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto rs = standard.Standard(scene.prev(), scene.curr());
  ASSERT_TRUE(rd.success && rt.success && rs.success);
  ASSERT_EQ(rd.cell_row * 3 + rd.cell_col, 6);
  // The spread fit follows the 160 far-layer points (it has more inliers than the cell's fit),
  // 2.5 px from the cell's fit.
  EXPECT_NEAR(rd.refine_shift_px, 2.5, 0.05);
  EXPECT_NEAR(rt.refine_shift_px, 2.5, 0.05);
  EXPECT_TRUE(rd.final_pass);
  EXPECT_FALSE(rt.final_pass);
  // The final pass gives the standard method's answer: the far layer, all 640 of its points.
  EXPECT_EQ(rd.num_inliers, rs.num_inliers);
  EXPECT_EQ(rd.num_inliers, 640);
  EXPECT_LT(MaxCornerDisplacementPx(rd.curr_from_prev, rs.curr_from_prev, 800, 600), 1e-6);
  EXPECT_LT(MaxCornerDisplacementPx(rd.curr_from_prev, far_layer, 800, 600), 1e-3);
  // Without it the spread fit is the same layer's. The tolerant gate accepts the fit on the
  // first half of the spread points (10 per other cell: 80 of the layer's points); the default
  // one does not, so the other half was matched and the fit made on all 160.
  EXPECT_TRUE(rt.refine_early_exit);
  EXPECT_FALSE(rd.refine_early_exit);
  EXPECT_EQ(rt.num_inliers, 80);
  EXPECT_LT(MaxCornerDisplacementPx(rt.curr_from_prev, far_layer, 800, 600), 1e-3);
}

// The final pass matches at most refine_final_max_points prev points, every k-th in
// FeatureSet order: on the two-layer scene (680 points, the final pass runs) with a cap of 100,
// exactly the points floor(j * 680 / 100) are matched again, and the fit on the far layer's
// among them is that layer's motion.
TEST(ClusteredRansac, FinalPassMatchesAtMostRefineFinalMaxPoints) {
  SceneBuilder scene(33);
  const Eigen::Matrix3d far_layer = FarLayer();
  const double cw = kFrameWidth / 3.0, ch = kFrameHeight / 3.0;
  AddTwoLayers(&scene);
  ASSERT_EQ(scene.prev().size(), 680u);
  CorrespondenceOptions capped;
  capped.clustered.refine_final_max_points = 100;
  CorrespondenceStage stage(capped);
  const Eigen::Matrix3d still = Eigen::Matrix3d::Identity();
  const auto r = stage.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  ASSERT_TRUE(r.success);
  ASSERT_TRUE(r.final_pass);
  std::set<int> sampled;
  for (int j = 0; j < 100; ++j) sampled.insert(j * 680 / 100);
  int far_sampled = 0;
  for (int i : sampled) {
    const Keypoint& k = scene.prev().keypoints[static_cast<std::size_t>(i)];
    far_sampled += !(k.x < cw && k.y >= 2 * ch);
  }
  EXPECT_LE(r.matches.size(), 100u);
  for (const Match& m : r.matches) EXPECT_EQ(sampled.count(m.prev_index), 1u) << m.prev_index;
  EXPECT_EQ(r.num_inliers, far_sampled);
  EXPECT_GT(far_sampled, 80);
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, far_layer, 800, 600), 1e-3);
  // Uncapped (0), every point: the far layer's 640.
  capped.clustered.refine_final_max_points = 0;
  CorrespondenceStage all(capped);
  const auto ra = all.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  ASSERT_TRUE(ra.final_pass);
  EXPECT_EQ(ra.num_inliers, 640);
}

// When the first half's fit does not pass the gate, matching the second half and fitting on
// both gives exactly the one-pass refinement: same matches, inlier mask, transform and
// comparisons (the matches of a point do not depend on the others; RANSAC sees the same list
// with the same seed). Same two-layer scene as above, without the final pass.
TEST(ClusteredRansac, EarlyExitSplitGivesTheOnePassResultWhenTheGateFails) {
  SceneBuilder scene(33);
  AddTwoLayers(&scene);
  CorrespondenceOptions split, one_pass;
  split.clustered.refine_final_radius_px = 0.f;
  one_pass.clustered.refine_final_radius_px = 0.f;
  one_pass.clustered.refine_early_exit = false;
  CorrespondenceStage a(split), b(one_pass);
  const Eigen::Matrix3d still = Eigen::Matrix3d::Identity();
  const auto rs = a.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  const auto ro = b.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  ASSERT_TRUE(rs.success && ro.success && rs.refined && ro.refined);
  EXPECT_FALSE(rs.refine_early_exit);
  EXPECT_EQ(rs.curr_from_prev, ro.curr_from_prev);
  EXPECT_EQ(rs.inlier_mask, ro.inlier_mask);
  EXPECT_EQ(rs.num_inliers, 160);
  ASSERT_EQ(rs.matches.size(), ro.matches.size());
  for (std::size_t i = 0; i < rs.matches.size(); ++i) {
    EXPECT_EQ(rs.matches[i].prev_index, ro.matches[i].prev_index);
    EXPECT_EQ(rs.matches[i].curr_index, ro.matches[i].curr_index);
  }
  EXPECT_EQ(rs.num_comparisons, ro.num_comparisons);
  EXPECT_EQ(rs.refine_shift_px, ro.refine_shift_px);
  // A zero gate means "always the final pass": no early exit either.
  CorrespondenceOptions always = split;
  always.clustered.refine_final_min_shift_px = 0.f;
  CorrespondenceStage c(always);
  const auto ra = c.Clustered(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), still);
  EXPECT_FALSE(ra.refine_early_exit);
  EXPECT_EQ(ra.curr_from_prev, ro.curr_from_prev);
}

TEST(StandardCorrespondence, MatchesAllAndFits) {
  SceneBuilder scene(11);
  Eigen::Matrix3d motion;
  motion << 1.01, 0.02, -14.0, -0.015, 0.99, 9.0, 0, 0, 1;
  scene.AddInBox(300, 0, 0, kFrameWidth, kFrameHeight, motion);
  scene.AddScrambledInBox(100, 0, 0, kFrameWidth, kFrameHeight);
  const CorrespondenceResult r = StandardCorrespondence(scene.prev(), scene.curr());
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.method_used, CorrespondenceMethod::kStandard);
  EXPECT_FALSE(r.fell_back);
  EXPECT_EQ(r.attempts, 1);
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, motion, kFrameWidth, kFrameHeight), 0.01);
  // Inliers are exactly the consistent points that stayed in view.
  int consistent = 0;
  for (std::size_t i = 0; i < r.matches.size(); ++i) {
    const bool truth = r.matches[i].prev_index < 300;
    consistent += truth;
    EXPECT_EQ(r.inlier_mask[i] != 0, truth) << i;
  }
  EXPECT_EQ(r.num_inliers, consistent);
  EXPECT_GT(consistent, 250);

  // Run() dispatches on the method; clustered and standard agree on this clean scene, and
  // guided matching with the true prior gives the same transform.
  CorrespondenceOptions o;
  o.method = CorrespondenceMethod::kStandard;
  CorrespondenceStage standard(o);
  const CorrespondenceResult rs =
      standard.Run(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), std::nullopt);
  EXPECT_EQ(rs.curr_from_prev, r.curr_from_prev);
  o.method = CorrespondenceMethod::kClustered;
  o.guided_matching = true;
  CorrespondenceStage clustered(o);
  const CorrespondenceResult rc =
      clustered.Run(scene.prev(), kFrameWidth, kFrameHeight, scene.curr(), motion);
  ASSERT_TRUE(rc.success);
  EXPECT_FALSE(rc.fell_back);
  EXPECT_LT(rc.matches.size(), r.matches.size());
  EXPECT_LT(MaxCornerDisplacementPx(rc.curr_from_prev, motion, kFrameWidth, kFrameHeight), 0.01);
}

TEST(CorrespondenceOptions, ValidateNamesTheField) {
  CorrespondenceOptions o;
  EXPECT_NO_THROW(Validate(o));
  o.clustered.grid_rows = 0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o = {};
  o.min_inliers = 2;  // Below the affine minimal sample.
  try {
    Validate(o);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("min_inliers"), std::string::npos);
  }
  o = {};
  o.ransac.max_distance_px = -1;
  EXPECT_THROW(CorrespondenceStage{o}, InvalidArgument);
  for (float bad : {-0.5f, std::numeric_limits<float>::quiet_NaN()}) {
    o = {};
    o.clustered.refine_final_min_shift_px = bad;
    try {
      Validate(o);
      ADD_FAILURE() << "no throw for " << bad;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("refine_final_min_shift_px"), std::string::npos);
    }
  }
  o = {};
  o.clustered.refine_final_max_points = -1;
  try {
    Validate(o);
    ADD_FAILURE() << "no throw for refine_final_max_points -1";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("refine_final_max_points"), std::string::npos);
  }
}

// ---------------------------------------------------------------- refit on all points

// Repeated texture under a known affine motion (1.5 deg, scale 1.01, shift (12, -7) px): every
// prev point's twin is where the motion puts it, and every other point also has a look-alike
// (same descriptor) 100 px away in curr, so that the exhaustive ratio test rejects it (two
// identical best candidates) while guided matching within a few pixels of the truth meets only
// the twin. All twins stay in the frame.
struct RepeatedTexture {
  FeatureSet prev, curr;
  Eigen::Matrix3d truth;
  int pairs = 0;     // prev points with their twin in curr
  int distinct = 0;  // of which without a look-alike
};

RepeatedTexture MakeRepeatedTexture() {
  RepeatedTexture scene;
  const double a = 1.5 * kDegToRad, s = 1.01;
  scene.truth << s * std::cos(a), -s * std::sin(a), 12.0, s * std::sin(a), s * std::cos(a), -7.0,
      0.0, 0.0, 1.0;
  SceneBuilder b(17);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(40, kFrameWidth - 40), uy(40, kFrameHeight - 40);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector2d p = testing::DrawYThenX(ux, uy, rng);
    const Eigen::Vector2d q = TransformPoint(scene.truth, p);
    b.Add(p, q);
    ++scene.pairs;
    if (i % 2 == 1) {
      b.AddDecoy(q + Eigen::Vector2d(q.x() < kFrameWidth / 2 ? 100.0 : -100.0, 0.0));
    } else {
      ++scene.distinct;
    }
  }
  scene.prev = b.prev();
  scene.curr = b.curr();
  return scene;
}

// CorrespondenceStage::RefitOnAllPoints on an accepted standard result: guided by its fit, the
// refit matches the look-alike points too, fits on every pair (exact positions up to float
// rounding: within 1e-3 px of the truth at the corners), and replaces the result; refitting that
// again finds no more inliers and keeps it.
TEST(RefitOnAllPoints, RecoversRepeatedTextureWithKnownTruth) {
  const RepeatedTexture scene = MakeRepeatedTexture();
  ASSERT_EQ(static_cast<int>(scene.curr.size()), scene.pairs + (scene.pairs - scene.distinct));
  CorrespondenceStage stage;  // refine_final_radius_px = 6 px
  CorrespondenceResult r = stage.Standard(scene.prev, scene.curr);
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.num_inliers, scene.distinct) << "the ratio test drops every look-alike";
  const int attempts = r.attempts;
  EXPECT_TRUE(stage.RefitOnAllPoints(scene.prev, scene.curr, &r));
  EXPECT_TRUE(r.refined);
  EXPECT_TRUE(r.final_pass);
  EXPECT_EQ(r.attempts, attempts + 1);
  EXPECT_EQ(r.num_inliers, scene.pairs);
  EXPECT_EQ(static_cast<int>(r.matches.size()), scene.pairs);
  EXPECT_LT(MaxCornerDisplacementPx(r.curr_from_prev, scene.truth, kFrameWidth, kFrameHeight),
            1e-3);
  const Eigen::Matrix3d kept = r.curr_from_prev;
  EXPECT_FALSE(stage.RefitOnAllPoints(scene.prev, scene.curr, &r)) << "no inlier more to find";
  EXPECT_EQ(r.curr_from_prev, kept);
  EXPECT_EQ(r.num_inliers, scene.pairs);
  CorrespondenceResult failed;  // !success: nothing to refit
  EXPECT_FALSE(stage.RefitOnAllPoints(scene.prev, scene.curr, &failed));
  EXPECT_EQ(failed.attempts, 0);
  CorrespondenceOptions no_final;
  no_final.clustered.refine_final_radius_px = 0.f;
  CorrespondenceStage without_radius(no_final);
  EXPECT_THROW(without_radius.RefitOnAllPoints(scene.prev, scene.curr, &r), InvalidArgument);
}

// ClusteredRansacOptions::refine_fallback: with no eligible cell clustered RANSAC falls back to
// the standard method, and the fall-back's fit is refit on all points (same result as the
// explicit RefitOnAllPoints); without it, or with refine = false, the fall-back is exactly the
// standard method.
TEST(RefitOnAllPoints, RefineFallbackRefitsTheFallBack) {
  const RepeatedTexture scene = MakeRepeatedTexture();
  const Eigen::Matrix3d still = Eigen::Matrix3d::Identity();
  CorrespondenceOptions o;
  o.clustered.min_points = 100000;  // no cell is eligible
  const CorrespondenceResult plain =
      ClusteredCorrespondence(scene.prev, kFrameWidth, kFrameHeight, scene.curr, still, o);
  ASSERT_TRUE(plain.success);
  EXPECT_TRUE(plain.fell_back);
  EXPECT_FALSE(plain.final_pass);
  EXPECT_EQ(plain.num_inliers, scene.distinct);

  o.clustered.refine_fallback = true;
  const CorrespondenceResult refit =
      ClusteredCorrespondence(scene.prev, kFrameWidth, kFrameHeight, scene.curr, still, o);
  ASSERT_TRUE(refit.success);
  EXPECT_TRUE(refit.fell_back);
  EXPECT_TRUE(refit.final_pass);
  EXPECT_TRUE(refit.refined);
  EXPECT_EQ(refit.attempts, plain.attempts + 1);
  EXPECT_EQ(refit.num_inliers, scene.pairs);
  EXPECT_LT(MaxCornerDisplacementPx(refit.curr_from_prev, scene.truth, kFrameWidth, kFrameHeight),
            1e-3);
  CorrespondenceStage stage(o);
  CorrespondenceResult explicit_refit = stage.Standard(scene.prev, scene.curr, still);
  stage.RefitOnAllPoints(scene.prev, scene.curr, &explicit_refit);
  EXPECT_EQ(explicit_refit.curr_from_prev, refit.curr_from_prev);
  EXPECT_EQ(explicit_refit.num_inliers, refit.num_inliers);

  o.clustered.refine = false;  // turns off every refine_* option
  const CorrespondenceResult paper =
      ClusteredCorrespondence(scene.prev, kFrameWidth, kFrameHeight, scene.curr, still, o);
  EXPECT_FALSE(paper.final_pass);
  EXPECT_EQ(paper.num_inliers, scene.distinct);
  EXPECT_EQ(paper.curr_from_prev, plain.curr_from_prev);
}

TEST(RefitOnAllPoints, ValidateNamesBothFieldsWhenTheRefitHasNoRadius) {
  CorrespondenceOptions o;
  o.clustered.refine_fallback = true;
  o.clustered.refine_final_radius_px = 0.f;
  try {
    Validate(o);
    ADD_FAILURE() << "no throw";
  } catch (const InvalidArgument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("refine_fallback"), std::string::npos) << what;
    EXPECT_NE(what.find("refine_final_radius_px"), std::string::npos) << what;
  }
  o.clustered.refine = false;  // no refinement: neither field is used
  EXPECT_NO_THROW(Validate(o));
}

// ---------------------------------------------------------------- real imagery ($AEROVO_SHARED)

#if AEROVO_TESTS_HAVE_OPENCV  // the orthophoto is a JPEG: read with OpenCV
// Two 1920x1080 crops of the Callas orthophoto, the second moved by (72, 18) px: the true
// curr_from_prev is the shift (-72, -18). SURF (MATLAB defaults) on both; standard, clustered
// (paper) and clustered (refined) must all recover the shift within 1 px at the corners, and
// the clustered runs must use one cell of the crop left by the previous step's motion.
TEST(CorrespondenceRealData, CallasShiftedCrops) {
  AEROVO_REQUIRE_SHARED(path, "data/ortho/callas-quarry.jpg");
  cv::Mat bgr = cv::imread(path.string(), cv::IMREAD_COLOR), gray;
  ASSERT_FALSE(bgr.empty()) << path;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  bgr.release();
  const int w = 1920, h = 1080, x0 = 1600, y0 = 1700, dx = 72, dy = 18;
  const cv::Mat a = gray(cv::Rect(x0, y0, w, h)).clone();
  const cv::Mat b = gray(cv::Rect(x0 + dx, y0 + dy, w, h)).clone();
  SurfOptions so;
  so.num_threads = 2;
  Surf surf(so);
  const FeatureSet prev =
      surf.DetectAndDescribe(
              GrayImageView{a.data, a.cols, a.rows, static_cast<std::ptrdiff_t>(a.step[0])})
          .features;
  const FeatureSet curr =
      surf.DetectAndDescribe(
              GrayImageView{b.data, b.cols, b.rows, static_cast<std::ptrdiff_t>(b.step[0])})
          .features;
  ASSERT_GT(prev.size(), 500u);
  const Eigen::Matrix3d truth = Shift(-dx, -dy);

  const CorrespondenceResult rs = StandardCorrespondence(prev, curr);
  ASSERT_TRUE(rs.success);
  EXPECT_LT(MaxCornerDisplacementPx(rs.curr_from_prev, truth, w, h), 0.1);
  EXPECT_GT(rs.num_inliers, 500);

  for (bool refine : {false, true}) {
    CorrespondenceOptions o;
    o.clustered.refine = refine;
    const CorrespondenceResult rc = ClusteredCorrespondence(prev, w, h, curr, truth, o);
    ASSERT_TRUE(rc.success) << "refine " << refine;
    EXPECT_FALSE(rc.fell_back);
    EXPECT_EQ(rc.refined, refine);
    // Content moves left and up: the left 72 px and top 18 px strips are dropped.
    ExpectRectEq(rc.crop, RectI{72, 18, w - 72, h - 18}, "callas crop");
    EXPECT_GE(rc.cell_row, 0);
    EXPECT_LT(MaxCornerDisplacementPx(rc.curr_from_prev, truth, w, h), 1.0) << "refine " << refine;
    EXPECT_LT(MaxCornerDisplacementPx(rc.curr_from_prev, rs.curr_from_prev, w, h), 1.0);
    // The paper's point: far fewer descriptor comparisons than matching everything.
    EXPECT_LT(rc.num_comparisons * 5, rs.num_comparisons) << "refine " << refine;
  }
}
#endif  // AEROVO_TESTS_HAVE_OPENCV

}  // namespace
}  // namespace aerovo::correspondence_test
