#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/eval/trajectory_eval.h"

namespace aerovo::trajectory_eval_test {
namespace {

// A curvy 2-D flight (metres): a lawnmower-like sweep with a sinusoidal wobble, 1 s steps.
std::vector<TrajectoryPoint2D> CurvyTrack(int n) {
  std::vector<TrajectoryPoint2D> t;
  for (int i = 0; i < n; ++i) {
    const double s = i * 2.0;
    t.push_back({100.0 + i, 300.0 + s + 40.0 * std::sin(s / 60.0),
                 -150.0 + 80.0 * std::cos(s / 90.0) + 0.3 * s});
  }
  return t;
}

std::vector<TrajectoryPoint2D> Transform(const Similarity2D& t,
                                         const std::vector<TrajectoryPoint2D>& in) {
  std::vector<TrajectoryPoint2D> out;
  for (const auto& p : in) {
    const Eigen::Vector2d q = t.Apply({p.x, p.y});
    out.push_back({p.t, q.x(), q.y()});
  }
  return out;
}

Similarity2D Inverse(const Similarity2D& t) {
  Similarity2D inv;
  inv.angle_rad = -t.angle_rad;
  inv.scale = 1.0 / t.scale;
  inv.translation_m = -(inv.scale * (inv.Rotation() * t.translation_m));
  return inv;
}

TEST(Similarity2D, ApplyAndMatrixAgree) {
  Similarity2D t{kPi / 2, 2.0, {1.0, -3.0}};
  const Eigen::Vector2d p = t.Apply({1.0, 0.0});
  EXPECT_NEAR(p.x(), 1.0, 1e-15);  // (1,0) -> rotated (0,1) -> scaled (0,2) -> (1,-1)
  EXPECT_NEAR(p.y(), -1.0, 1e-15);
  const Eigen::Vector3d h = t.Matrix() * Eigen::Vector3d(4.0, 5.0, 1.0);
  EXPECT_NEAR((h.head<2>() - t.Apply({4.0, 5.0})).norm(), 0.0, 1e-12);
  const Eigen::Vector2d back = Inverse(t).Apply(t.Apply({7.0, -2.0}));
  EXPECT_NEAR((back - Eigen::Vector2d(7.0, -2.0)).norm(), 0.0, 1e-12);
}

TEST(AlignUmeyama2D, RecoversSim2Exactly) {
  const auto enu = CurvyTrack(300);
  for (double angle : {0.7, -2.2, 3.1, -3.1, 0.0}) {
    const Similarity2D enu_from_vo{angle, 1.3, {250.0, -480.0}};
    const auto vo = Transform(Inverse(enu_from_vo), enu);
    const AlignmentResult r = AlignUmeyama2D(vo, enu, AlignmentModel::kSim2);
    EXPECT_EQ(r.model, AlignmentModel::kSim2);
    EXPECT_EQ(r.num_points, 300);
    EXPECT_NEAR(std::remainder(r.enu_from_vo.angle_rad - angle, 2 * kPi), 0.0, 1e-9) << angle;
    EXPECT_NEAR(r.enu_from_vo.scale, 1.3, 1e-9);
    EXPECT_NEAR(r.enu_from_vo.translation_m.x(), 250.0, 1e-9);
    EXPECT_NEAR(r.enu_from_vo.translation_m.y(), -480.0, 1e-9);
    EXPECT_LT(r.rmse_m, 1e-9);
    const TrajectoryErrors e =
        EvaluateTrajectory(vo, enu, {AlignmentModel::kSim2, {10.0, 50.0, 100.0}});
    EXPECT_LT(e.ate_m.max, 1e-9);
    EXPECT_LT(e.end_point_error_m, 1e-9);
    for (const auto& s : e.segments) {
      EXPECT_GT(s.error_m.count, 0);
      EXPECT_LT(s.error_m.max, 1e-9);
      EXPECT_LT(s.drift_percent.max, 1e-9);
    }
  }
}

TEST(AlignUmeyama2D, RecoversSE2ExactlyAndKeepsScale) {
  const auto enu = CurvyTrack(200);
  const Similarity2D enu_from_vo{-1.1, 1.0, {-35.0, 12.5}};
  const auto vo = Transform(Inverse(enu_from_vo), enu);
  const AlignmentResult r = AlignUmeyama2D(vo, enu, AlignmentModel::kSE2);
  EXPECT_NEAR(r.enu_from_vo.angle_rad, -1.1, 1e-9);
  EXPECT_EQ(r.enu_from_vo.scale, 1.0);
  EXPECT_NEAR(r.enu_from_vo.translation_m.x(), -35.0, 1e-9);
  EXPECT_NEAR(r.enu_from_vo.translation_m.y(), 12.5, 1e-9);
  EXPECT_LT(r.rmse_m, 1e-9);

  // A VO track 20 % too small: SE(2) keeps scale 1 and shows the error, Sim(2) removes it.
  const auto small = Transform(Inverse(Similarity2D{-1.1, 1.25, {-35.0, 12.5}}), enu);
  const TrajectoryComparison c = CompareTrajectories(small, enu);
  EXPECT_EQ(c.se2.alignment.model, AlignmentModel::kSE2);
  EXPECT_EQ(c.se2.alignment.enu_from_vo.scale, 1.0);
  EXPECT_NEAR(c.se2.alignment.enu_from_vo.angle_rad, -1.1, 1e-9);  // rotation still right
  EXPECT_GT(c.se2.ate_m.rmse, 10.0);
  EXPECT_NEAR(c.sim2.alignment.enu_from_vo.scale, 1.25, 1e-9);
  EXPECT_LT(c.sim2.ate_m.rmse, 1e-9);
}

TEST(AlignUmeyama2D, ReflectionIsNotAllowed) {
  // A mirrored estimate cannot be aligned by a proper rotation: residuals stay large.
  const auto enu = CurvyTrack(100);
  std::vector<TrajectoryPoint2D> mirrored = enu;
  for (auto& p : mirrored) p.x = -p.x;
  const AlignmentResult r = AlignUmeyama2D(mirrored, enu, AlignmentModel::kSim2);
  EXPECT_GT(r.rmse_m, 10.0);
}

TEST(EvaluateTrajectory, KnownNoiseGivesKnownAte) {
  // Each position is visited twice (a hover) with opposite offsets +n_k and -n_k. The offsets
  // then sum to zero and are uncorrelated with the positions, so the optimal alignment is the
  // true one and the residuals are exactly |n_k|: RMSE/mean/median/max are known in closed
  // form.
  const auto base = CurvyTrack(50);
  const Similarity2D enu_from_vo{0.4, 1.0, {10.0, 20.0}};
  std::vector<TrajectoryPoint2D> vo, enu;
  std::vector<double> mags;
  for (size_t k = 0; k < base.size(); ++k) {
    const double mag = 0.5 + 0.1 * static_cast<double>(k % 7);  // 0.5 .. 1.1 m
    const double dir = 0.37 * static_cast<double>(k);
    const Eigen::Vector2d n = mag * Eigen::Vector2d(std::cos(dir), std::sin(dir));
    const Eigen::Vector2d q = enu_from_vo.Apply({base[k].x, base[k].y});
    for (double sign : {1.0, -1.0}) {
      vo.push_back(base[k]);
      enu.push_back({base[k].t, q.x() + sign * n.x(), q.y() + sign * n.y()});
      mags.push_back(mag);
    }
  }
  double sum = 0.0, sum_sq = 0.0, max = 0.0;
  for (double m : mags) sum += m, sum_sq += m * m, max = std::max(max, m);
  const TrajectoryErrors e = EvaluateTrajectory(vo, enu);
  EXPECT_NEAR(e.alignment.enu_from_vo.angle_rad, 0.4, 1e-9);
  EXPECT_NEAR((e.alignment.enu_from_vo.translation_m - Eigen::Vector2d(10.0, 20.0)).norm(), 0.0,
              1e-9);
  EXPECT_EQ(e.ate_m.count, 100);
  EXPECT_NEAR(e.ate_m.rmse, std::sqrt(sum_sq / mags.size()), 1e-9);
  EXPECT_NEAR(e.ate_m.mean, sum / mags.size(), 1e-9);
  EXPECT_NEAR(e.ate_m.max, max, 1e-9);
  std::vector<double> sorted = mags;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_NEAR(e.ate_m.median, 0.5 * (sorted[49] + sorted[50]), 1e-9);
  EXPECT_NEAR(e.alignment.rmse_m, e.ate_m.rmse, 1e-12);
  for (size_t i = 0; i < mags.size(); ++i) EXPECT_NEAR(e.ate_per_point_m[i], mags[i], 1e-9);
}

TEST(EvaluateTrajectory, GaussianNoiseRmseMatchesSigma) {
  // Isotropic Gaussian noise sigma per axis: E|n|^2 = 2 sigma^2; fitting 3 SE(2) parameters to
  // 2N coordinates leaves RMSE ~ sigma sqrt(2 (2N-3) / (2N)) (seeded, so deterministic).
  const auto base = CurvyTrack(4000);
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 0.8);
  std::vector<TrajectoryPoint2D> enu = base;
  for (auto& p : enu) p.x += noise(rng), p.y += noise(rng);
  const TrajectoryErrors e = EvaluateTrajectory(base, enu);
  const double expected = 0.8 * std::sqrt(2.0 * (8000.0 - 3.0) / 8000.0);
  EXPECT_NEAR(e.ate_m.rmse, expected, 0.03 * expected);
  // Rayleigh distribution of |n|: mean sigma sqrt(pi/2), median sigma sqrt(2 ln 2).
  EXPECT_NEAR(e.ate_m.mean, 0.8 * std::sqrt(kPi / 2), 0.03);
  EXPECT_NEAR(e.ate_m.median, 0.8 * std::sqrt(2 * std::log(2.0)), 0.03);
  EXPECT_NEAR(e.alignment.enu_from_vo.angle_rad, 0.0, 1e-3);
}

TEST(EvaluateTrajectory, ScaleDriftOnStraightLine) {
  // Reference: 200 m due east in 1 m steps; VO 1 % long (x_vo = 1.01 x).
  std::vector<TrajectoryPoint2D> enu, vo;
  for (int i = 0; i <= 200; ++i) {
    enu.push_back({i * 0.1, static_cast<double>(i), 0.0});
    vo.push_back({i * 0.1, 1.01 * i, 0.0});
  }
  TrajectoryEvalOptions o;
  o.segment_lengths_m = {10.0, 100.0, 150.5, 500.0};
  const TrajectoryErrors se2 = EvaluateTrajectory(vo, enu, o);
  EXPECT_NEAR(se2.distance_flown_m, 200.0, 1e-12);
  EXPECT_NEAR(PathLength(enu), 200.0, 1e-12);
  EXPECT_NEAR(se2.alignment.enu_from_vo.angle_rad, 0.0, 1e-12);
  // SE(2) can only shift: aligned x = 1.01 x - 1, error |0.01 (x - 100)|.
  EXPECT_NEAR(se2.alignment.enu_from_vo.translation_m.x(), -1.0, 1e-9);
  EXPECT_NEAR(se2.end_point_error_m, 1.0, 1e-9);
  EXPECT_NEAR(se2.end_point_error_percent, 0.5, 1e-9);
  EXPECT_NEAR(se2.end_point_error_unaligned_m, 2.0, 1e-9);
  EXPECT_NEAR(se2.end_point_error_unaligned_percent, 1.0, 1e-9);
  EXPECT_NEAR(se2.ate_m.max, 1.0, 1e-9);
  EXPECT_NEAR(se2.ate_m.median, 0.5, 1e-9);  // |0.01 (x-100)|, x = 0..200: median of 0..1
  double sum_sq = 0.0;
  for (int i = 0; i <= 200; ++i) sum_sq += std::pow(0.01 * (i - 100), 2);
  EXPECT_NEAR(se2.ate_m.rmse, std::sqrt(sum_sq / 201.0), 1e-9);
  // Every segment of L metres is 1 % too long: error 0.01 L, drift 1 %.
  ASSERT_EQ(se2.segments.size(), 4u);
  EXPECT_EQ(se2.segments[0].length_m, 10.0);
  EXPECT_EQ(se2.segments[0].error_m.count, 191);  // starts 0..190
  EXPECT_NEAR(se2.segments[0].error_m.mean, 0.1, 1e-9);
  EXPECT_NEAR(se2.segments[0].drift_percent.max, 1.0, 1e-9);
  EXPECT_NEAR(se2.segments[0].drift_percent.median, 1.0, 1e-9);
  EXPECT_EQ(se2.segments[1].error_m.count, 101);
  EXPECT_NEAR(se2.segments[1].error_m.rmse, 1.0, 1e-9);
  // 150.5 m: the end is the first point at >= 150.5 m, i.e. 151 m on.
  EXPECT_EQ(se2.segments[2].error_m.count, 50);
  EXPECT_NEAR(se2.segments[2].error_m.max, 1.51, 1e-9);
  EXPECT_NEAR(se2.segments[2].drift_percent.mean, 1.0, 1e-9);
  EXPECT_EQ(se2.segments[3].error_m.count, 0);
  EXPECT_EQ(se2.segments[3].drift_percent.max, 0.0);

  o.model = AlignmentModel::kSim2;
  const TrajectoryErrors sim2 = EvaluateTrajectory(vo, enu, o);
  EXPECT_NEAR(sim2.alignment.enu_from_vo.scale, 1.0 / 1.01, 1e-12);
  EXPECT_LT(sim2.ate_m.max, 1e-9);
  EXPECT_LT(sim2.segments[1].drift_percent.max, 1e-9);
  EXPECT_NEAR(sim2.end_point_error_unaligned_m, 2.0, 1e-9);  // unaligned ignores the model
}

TEST(EvaluateTrajectory, DegenerateInputThrows) {
  const std::vector<TrajectoryPoint2D> none, one = {{0, 1, 2}}, two = {{0, 0, 0}, {1, 5, 0}};
  EXPECT_THROW(AlignUmeyama2D(none, none, AlignmentModel::kSE2), InvalidArgument);
  EXPECT_THROW(AlignUmeyama2D(one, one, AlignmentModel::kSim2), InvalidArgument);
  EXPECT_THROW(EvaluateTrajectory(one, one), InvalidArgument);
  EXPECT_THROW(AlignUmeyama2D(two, one, AlignmentModel::kSE2), InvalidArgument);
  const std::vector<TrajectoryPoint2D> same = {{0, 3, 3}, {1, 3, 3}, {2, 3, 3}};
  const std::vector<TrajectoryPoint2D> line = {{0, 0, 0}, {1, 1, 0}, {2, 2, 0}};
  EXPECT_THROW(AlignUmeyama2D(same, line, AlignmentModel::kSE2), InvalidArgument);
  EXPECT_THROW(AlignUmeyama2D(line, same, AlignmentModel::kSim2), InvalidArgument);
  std::vector<TrajectoryPoint2D> bad = line;
  bad[1].y = std::nan("");
  try {
    AlignUmeyama2D(bad, line, AlignmentModel::kSE2);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("estimate point 1"), std::string::npos) << e.what();
  }
  // Two distinct points are enough for SE(2) and Sim(2).
  const std::vector<TrajectoryPoint2D> two_ref = {{0, 10, 10}, {1, 10, 20}};
  const AlignmentResult r = AlignUmeyama2D(two, two_ref, AlignmentModel::kSim2);
  EXPECT_NEAR(r.enu_from_vo.angle_rad, kPi / 2, 1e-12);
  EXPECT_NEAR(r.enu_from_vo.scale, 2.0, 1e-12);
  EXPECT_LT(r.rmse_m, 1e-12);
  EXPECT_THROW(EvaluateTrajectory(two, two_ref, {AlignmentModel::kSE2, {10.0, -1.0}}),
               InvalidArgument);
}

TEST(SummarizeErrors, KnownValues) {
  const TrajectoryErrorStats even = SummarizeErrors({3.0, 1.0, 2.0, 4.0});
  EXPECT_EQ(even.count, 4);
  EXPECT_DOUBLE_EQ(even.mean, 2.5);
  EXPECT_DOUBLE_EQ(even.median, 2.5);
  EXPECT_DOUBLE_EQ(even.max, 4.0);
  EXPECT_DOUBLE_EQ(even.rmse, std::sqrt(7.5));
  const TrajectoryErrorStats odd = SummarizeErrors({5.0, 0.0, 1.0});
  EXPECT_DOUBLE_EQ(odd.median, 1.0);
  EXPECT_DOUBLE_EQ(odd.mean, 2.0);
  const TrajectoryErrorStats empty = SummarizeErrors({});
  EXPECT_EQ(empty.count, 0);
  EXPECT_EQ(empty.rmse, 0.0);
}

TEST(AssociateByTime, Interpolation) {
  // GPS at 1 Hz moving 10 m/s east; frames at 0.25 s steps from -0.5 s to 4.5 s.
  std::vector<TrajectoryPoint2D> gps, frames;
  for (int i = 0; i <= 4; ++i) gps.push_back({i * 1.0, i * 10.0, 5.0});
  for (int i = -2; i <= 18; ++i) frames.push_back({i * 0.25, 0.0, 0.0});
  const AssociatedTrajectories a = AssociateByTime(frames, gps);
  ASSERT_EQ(a.estimate.size(), 17u);  // t = 0 .. 4 inclusive
  EXPECT_EQ(a.num_unmatched, 4);
  EXPECT_EQ(a.estimate_index.front(), 2);
  for (size_t k = 0; k < a.estimate.size(); ++k) {
    const double t = a.estimate[k].t;
    EXPECT_DOUBLE_EQ(a.reference[k].t, t);
    EXPECT_NEAR(a.reference[k].x, 10.0 * t, 1e-12);
    EXPECT_NEAR(a.reference[k].y, 5.0, 1e-12);
    EXPECT_EQ(a.reference_index[k], std::min(static_cast<int>(std::floor(t)), 4));
  }
  // A fix gap longer than max_gap_s is not bridged.
  std::vector<TrajectoryPoint2D> gappy = {{0, 0, 0}, {1, 10, 0}, {5, 50, 0}};
  const AssociatedTrajectories g = AssociateByTime({{0.5, 0, 0}, {3.0, 0, 0}, {5.0, 0, 0}}, gappy);
  ASSERT_EQ(g.estimate_index, (std::vector<int>{0, 2}));
  EXPECT_NEAR(g.reference[0].x, 5.0, 1e-12);
  EXPECT_NEAR(g.reference[1].x, 50.0, 1e-12);
  EXPECT_EQ(g.num_unmatched, 1);
}

TEST(AssociateByTime, Nearest) {
  const std::vector<TrajectoryPoint2D> gps = {{0, 0, 0}, {1, 10, 0}, {2, 20, 0}, {2, 99, 0}};
  AssociationOptions o;
  o.method = AssociationMethod::kNearest;
  o.max_time_difference_s = 0.2;
  const std::vector<TrajectoryPoint2D> frames = {{1.15, 0, 0}, {0.5, 0, 0}, {-0.1, 0, 0},
                                                 {1.9, 0, 0},  {2.3, 0, 0}, {1.5, 0, 0}};
  const AssociatedTrajectories a = AssociateByTime(frames, gps, o);
  ASSERT_EQ(a.estimate_index, (std::vector<int>{0, 2, 3}));
  EXPECT_EQ(a.reference_index, (std::vector<int>{1, 0, 2}));  // duplicate t = 2: first fix
  EXPECT_DOUBLE_EQ(a.reference[0].t, 1.0);
  EXPECT_DOUBLE_EQ(a.reference[0].x, 10.0);
  EXPECT_DOUBLE_EQ(a.reference[2].x, 20.0);
  EXPECT_EQ(a.num_unmatched, 3);
  // Equidistant from two fixes: the earlier one.
  o.max_time_difference_s = 0.5;
  const AssociatedTrajectories tie = AssociateByTime({{0.5, 0, 0}}, gps, o);
  EXPECT_EQ(tie.reference_index, (std::vector<int>{0}));
}

TEST(AssociateByTime, BadInputThrows) {
  const std::vector<TrajectoryPoint2D> backwards = {{0, 0, 0}, {2, 0, 0}, {1, 0, 0}};
  try {
    AssociateByTime({{0.5, 0, 0}}, backwards);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("point 2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(AssociateByTime({{std::nan(""), 0, 0}}, {{0, 0, 0}}), InvalidArgument);
  AssociationOptions o;
  o.max_gap_s = 0.0;
  EXPECT_THROW(AssociateByTime({}, {}, o), InvalidArgument);
  o = {};
  o.max_time_difference_s = -1.0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  EXPECT_EQ(AssociateByTime({{1, 0, 0}}, {}).num_unmatched, 1);
}

// A lawnmower (4 legs of 200 m, 60 m apart) as GPS, and estimates of it: the same track with
// 0.5 m of noise, its mirror image, the track with x and y swapped and one axis scaled by 0.7
// (latitude and longitude swapped at 45 degrees north: a degree of longitude is cos(45 deg) of
// a degree of latitude), and a straight line mirrored.
TEST(CheckMirrored, TellsAMirroredTrackFromANoisyOne) {
  std::vector<TrajectoryPoint2D> gps, noisy, mirrored, swapped;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (int leg = 0; leg < 4; ++leg) {
    for (int k = 0; k <= 40; ++k) {
      const double along = leg % 2 == 0 ? 5.0 * k : 200.0 - 5.0 * k;
      const TrajectoryPoint2D p{leg * 41.0 + k, along, 60.0 * leg};
      gps.push_back(p);
      noisy.push_back({p.t, p.x + noise(rng), p.y + noise(rng)});
      // Rotated by 30 degrees and mirrored: what no Sim(2) alignment undoes.
      const double c = std::cos(0.5236), sn = std::sin(0.5236);
      mirrored.push_back({p.t, c * p.x + sn * p.y, sn * p.x - c * p.y});
      swapped.push_back({p.t, 0.7 * p.y, p.x});
    }
  }
  const auto good = CheckMirrored(noisy, gps);
  ASSERT_TRUE(good);
  EXPECT_FALSE(good->mirrored);
  EXPECT_NEAR(good->rmse_m, 0.7, 0.15);  // 0.5 m per axis
  EXPECT_GT(good->aspect, 0.2);

  const auto m = CheckMirrored(mirrored, gps);
  ASSERT_TRUE(m);
  EXPECT_TRUE(m->mirrored);
  EXPECT_LT(m->mirrored_rmse_m, 1e-6);
  EXPECT_GT(m->rmse_m, 0.1 * m->spread_m);

  const auto sw = CheckMirrored(swapped, gps);
  ASSERT_TRUE(sw);
  EXPECT_TRUE(sw->mirrored);
  EXPECT_LT(sw->mirrored_rmse_m, 0.5 * sw->rmse_m);

  // A straight line is its own mirror image: never flagged.
  std::vector<TrajectoryPoint2D> line, line_mirrored;
  for (int k = 0; k < 50; ++k) {
    line.push_back({double(k), 4.0 * k, 1.0 * k});
    line_mirrored.push_back({double(k), 4.0 * k, -1.0 * k});
  }
  const auto l = CheckMirrored(line_mirrored, line);
  ASSERT_TRUE(l);
  EXPECT_FALSE(l->mirrored);
  EXPECT_LT(l->aspect, 0.01);
  EXPECT_FALSE(CheckMirrored({{0, 1, 1}, {1, 1, 1}}, {{0, 0, 0}, {1, 1, 1}}));
}

}  // namespace
}  // namespace aerovo::trajectory_eval_test
