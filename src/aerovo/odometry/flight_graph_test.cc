#include "aerovo/odometry/flight_graph.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/sim/random.h"

namespace aerovo::flight_graph_test {
namespace {

using backend::Similarity2;

constexpr int kWidth = 640, kHeight = 480;
constexpr double kGsd = 0.1;  // m/px: a 64 m x 48 m footprint

const Eigen::Vector2d kCentre(0.5 * (kWidth - 1), 0.5 * (kHeight - 1));

// The pixel transform curr_from_prev of a ground-plane step prev_from_curr (backend/similarity2.h
// frames, scale 1, both frames at kGsd): px_prev = c + F R F (px_curr - c) + F t / g, F =
// diag(1, -1) (the inverse of backend/pixel_step.h PrevFromCurrOfPixelStep).
Eigen::Matrix3d CurrFromPrevPx(const Similarity2& prev_from_curr) {
  Eigen::Matrix2d f = Eigen::Matrix2d::Identity();
  f(1, 1) = -1.0;
  const Eigen::Matrix2d l = f * prev_from_curr.Linear() * f;
  Eigen::Matrix3d prev_from_curr_px = Eigen::Matrix3d::Identity();
  prev_from_curr_px.topLeftCorner<2, 2>() = l;
  prev_from_curr_px.topRightCorner<2, 1>() = kCentre + f * prev_from_curr.translation_m / kGsd - l * kCentre;
  return prev_from_curr_px.inverse();
}

// A 7 x 7 grid of points over the frame: the inliers of a well-spread fit.
Eigen::Matrix2Xd SpreadPoints() {
  Eigen::Matrix2Xd p(2, 49);
  for (int i = 0; i < 49; ++i) p.col(i) << 20.0 + 100.0 * (i % 7), 20.0 + 73.0 * (i / 7);
  return p;
}

// The frame index a test FeatureSet stands for (its one keypoint's x): the injected pair fitter
// of these tests knows the frames' true poses by it.
std::shared_ptr<const FeatureSet> FeaturesOf(int frame) {
  auto f = std::make_shared<FeatureSet>();
  Keypoint k;
  k.x = static_cast<float>(frame);
  f->keypoints.push_back(k);
  f->descriptors.assign(64, 0.f);
  return f;
}
int FrameOf(const FeatureSet& f) { return static_cast<int>(f.keypoints.at(0).x); }

// A lawnmower of `legs` legs of `steps` steps of 4 m, 30 m apart (footprints overlapping by 18 m
// across the legs), the image up along the track; the odometry's steps turn by `bias_rad` more
// than the truth each, so the causal track drifts.
struct Flight {
  std::vector<Similarity2> truth;
  std::vector<FrameResult> results;
};
Flight MakeFlight(int legs, int steps, double bias_rad) {
  Flight f;
  for (int leg = 0; leg < legs; ++leg) {
    const double heading = leg % 2 == 0 ? -M_PI / 2 : M_PI / 2;  // east, then west
    for (int s = 0; s < steps; ++s) {
      const double along = leg % 2 == 0 ? 4.0 * s : 4.0 * (steps - 1 - s);
      f.truth.push_back({Eigen::Vector2d(along, -30.0 * leg), heading, 0.0});
    }
  }
  Similarity2 causal = f.truth[0];
  for (std::size_t i = 0; i < f.truth.size(); ++i) {
    FrameResult r;
    r.index = static_cast<int>(i);
    r.gsd_m_per_px = kGsd;
    r.features = FeaturesOf(r.index);
    if (i > 0) {
      Similarity2 step = backend::Between(f.truth[i - 1], f.truth[i]);
      step.heading_rad += bias_rad;
      causal = causal * step;
      r.status = FrameStatus::kOk;
      r.reference_index = r.index - 1;
      r.curr_from_prev = CurrFromPrevPx(step);
      r.step_inliers_curr_px = SpreadPoints();
    }
    r.position_m = causal.translation_m;
    r.heading_rad = causal.heading_rad;
    f.results.push_back(r);
  }
  return f;
}

// A fitter that returns the true transform of every pair, except those in `wrong` (moved by the
// given ground offset in metres: a false overlap) and those in `none` (no fit).
PairFitter TruthFitter(const Flight& f, std::map<std::pair<int, int>, Eigen::Vector2d> wrong = {},
                       std::vector<std::pair<int, int>> none = {}) {
  return [&f, wrong, none](const FeatureSet& prev, const FeatureSet& curr,
                           std::uint64_t,
                           const std::optional<Eigen::Matrix3d>&) -> std::optional<PairFit> {
    const std::pair<int, int> key(FrameOf(prev), FrameOf(curr));
    for (const auto& n : none) {
      if (n == key) return std::nullopt;
    }
    Similarity2 z = backend::Between(f.truth[static_cast<std::size_t>(key.first)],
                                     f.truth[static_cast<std::size_t>(key.second)]);
    if (const auto it = wrong.find(key); it != wrong.end()) z.translation_m += it->second;
    return PairFit{CurrFromPrevPx(z), SpreadPoints()};
  };
}

double EndError(const Flight& f, const std::vector<Similarity2>& poses) {
  return (poses.back().translation_m - f.truth.back().translation_m).norm();
}

FlightGraph Build(const Flight& f, const BackendOptions& o = {}) {
  FlightGraph g(o, kWidth, kHeight);
  for (const FrameResult& r : f.results) g.Add(r);
  return g;
}

TEST(FlightGraph, OverlapsBetweenLegsCutTheEndErrorByMoreThanThreeQuarters) {
  const Flight f = MakeFlight(4, 40, 0.002);
  const FlightGraph g = Build(f);
  // Keyframes every 0.3 x 48 m: every fourth frame (16 m).
  EXPECT_EQ(g.num_keyframes(), 4 * 10);
  const OptimizedFlight o = g.Optimize(TruthFitter(f), 1);
  std::vector<Similarity2> causal;
  for (const FrameResult& r : f.results) causal.push_back({r.position_m, r.heading_rad, 0.0});
  const double before = EndError(f, causal), after = EndError(f, o.local_from_frame);
  EXPECT_GT(before, 10.0);  // 160 steps turning 0.002 rad too much each
  EXPECT_LT(after, 0.25 * before) << before << " m -> " << after << " m";
  RecordProperty("end_error_m", std::to_string(before) + " -> " + std::to_string(after));
  EXPECT_GT(o.pairs_verified, 30);
  EXPECT_EQ(o.pairs_rejected, 0);
  EXPECT_EQ(o.pairs_tried, o.pairs_verified);
}

// The candidate pairs FlightGraph::Optimize tries, in order.
std::vector<std::pair<int, int>> TriedPairs(const FlightGraph& g) {
  std::vector<std::pair<int, int>> tried;
  g.Optimize(
      [&](const FeatureSet& a, const FeatureSet& b, std::uint64_t,
          const std::optional<Eigen::Matrix3d>&) -> std::optional<PairFit> {
        tried.emplace_back(FrameOf(a), FrameOf(b));
        return std::nullopt;
      },
      1);
  return tried;
}

TEST(FlightGraph, TheGateRejectsAFalseOverlapAndTheTrackIsUnchangedByIt) {
  const Flight f = MakeFlight(4, 40, 0.002);
  const FlightGraph g = Build(f);
  // A candidate pair across legs 0 and 1 whose fit puts the later frame 30 m off (a repeated
  // field: perceptual aliasing), where the track says it cannot be.
  std::pair<int, int> pair(-1, -1);
  for (const auto& p : TriedPairs(g)) {
    if (p.first / 40 == 0 && p.second / 40 == 1) pair = p;
  }
  ASSERT_GE(pair.first, 0) << "no candidate pair across the first two legs";
  const OptimizedFlight clean = g.Optimize(TruthFitter(f, {}, {pair}), 1);
  const OptimizedFlight aliased = g.Optimize(TruthFitter(f, {{pair, {30.0, 0.0}}}), 1);
  ASSERT_EQ(aliased.pairs_tried, clean.pairs_tried);
  EXPECT_EQ(clean.pairs_gated, 0);
  EXPECT_EQ(aliased.pairs_gated, 1);
  EXPECT_EQ(aliased.pairs_verified, clean.pairs_verified);
  ASSERT_EQ(aliased.local_from_frame.size(), clean.local_from_frame.size());
  for (std::size_t i = 0; i < clean.local_from_frame.size(); ++i) {
    EXPECT_EQ(aliased.local_from_frame[i].translation_m, clean.local_from_frame[i].translation_m);
  }
  // Without the gate (a huge one) the false overlap goes in, and the robust cost (Cauchy,
  // pose_graph.h) is left to down-weight it: the second line of defence.
  BackendOptions open;
  open.gate = 100.0;
  open.gate_heading_deg = 179.0;
  const OptimizedFlight ungated =
      Build(f, open).Optimize(TruthFitter(f, {{pair, {30.0, 0.0}}}), 1);
  EXPECT_EQ(ungated.pairs_gated, 0);
  EXPECT_EQ(ungated.pairs_verified, clean.pairs_verified + 1);
  EXPECT_GE(ungated.outliers, 1);
  EXPECT_LT((ungated.local_from_frame.back().translation_m -
             clean.local_from_frame.back().translation_m).norm(), 0.05);
}

TEST(FlightGraph, PairSearchTakesOnlyOverlappingNonNeighbourKeyframes) {
  const Flight f = MakeFlight(2, 40, 0.0);
  BackendOptions o;
  o.search_radius = 0.7;  // 33.6 m
  const FlightGraph g = Build(f, o);
  std::vector<std::pair<int, int>> tried;
  tried = TriedPairs(g);
  ASSERT_FALSE(tried.empty());
  for (const auto& [a, b] : tried) {
    const double d = (f.truth[static_cast<std::size_t>(a)].translation_m -
                      f.truth[static_cast<std::size_t>(b)].translation_m).norm();
    EXPECT_LE(d, 33.6 + 1e-9) << a << "-" << b;
    EXPECT_GT(b - a, 4) << "keyframe neighbours are not a pair";
  }
  // Pairs along a leg (keyframes two apart, 32 m) and across the legs (30 m apart).
  int across = 0;
  for (const auto& [a, b] : tried) across += a / 40 != b / 40;
  EXPECT_GT(across, 0);
  EXPECT_LT(across, static_cast<int>(tried.size()));
}

TEST(FlightGraph, JudgePairChecksInliersSpreadAndTheGate) {
  BackendOptions o;
  const Similarity2 pred{Eigen::Vector2d(10.0, 0.0), 0.0, 0.0};
  EXPECT_EQ(JudgePair(o, pred, pred, 100, 0.5, 200.0, 48.0), PairVerdict::kAdded);
  EXPECT_EQ(JudgePair(o, pred, pred, 39, 0.5, 200.0, 48.0), PairVerdict::kTooFewInliers);
  EXPECT_EQ(JudgePair(o, pred, pred, 100, 0.01, 200.0, 48.0), PairVerdict::kTooLittleSpread);
  // Allowed: 0.05 x 200 m + 4.8 m = 14.8 m.
  Similarity2 fit = pred;
  fit.translation_m.x() += 14.0;
  EXPECT_EQ(JudgePair(o, fit, pred, 100, 0.5, 200.0, 48.0), PairVerdict::kAdded);
  fit.translation_m.x() += 1.0;
  EXPECT_EQ(JudgePair(o, fit, pred, 100, 0.5, 200.0, 48.0), PairVerdict::kGate);
  fit = pred;
  fit.heading_rad = 16.0 * kDegToRad;
  EXPECT_EQ(JudgePair(o, fit, pred, 100, 0.5, 200.0, 48.0), PairVerdict::kGate);
}

TEST(FlightGraph, JudgeClosureIsAChiSquareTestOfTheCorrectionAgainstTheChainedUncertainty) {
  BackendOptions o;
  const Similarity2 pred{Eigen::Vector2d(10.0, 0.0), 0.0, 0.0};
  const Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
  EXPECT_EQ(JudgeClosure(o, pred, pred, 100, 0.5, zero, zero, 200.0, 48.0), PairVerdict::kAdded);
  EXPECT_EQ(JudgeClosure(o, pred, pred, 39, 0.5, zero, zero, 200.0, 48.0),
            PairVerdict::kTooFewInliers);
  EXPECT_EQ(JudgeClosure(o, pred, pred, 100, 0.01, zero, zero, 200.0, 48.0),
            PairVerdict::kTooLittleSpread);
  // Negligible chain and fit covariances: JudgePair's bound, 0.05 x 200 m + 4.8 m = 14.8 m.
  Similarity2 fit = pred;
  fit.translation_m.x() += 14.6;
  EXPECT_EQ(JudgeClosure(o, fit, pred, 100, 0.5, zero, zero, 200.0, 48.0), PairVerdict::kAdded);
  fit.translation_m.x() += 0.4;
  EXPECT_EQ(JudgeClosure(o, fit, pred, 100, 0.5, zero, zero, 200.0, 48.0), PairVerdict::kGate);
  // Steps that are uncertain across the track (a bridged stretch: 10 m in y) widen it there
  // only: 30 m off in y passes, 15 m in x still does not.
  Eigen::Matrix3d chain = zero;
  chain(1, 1) = 100.0;
  fit = pred;
  fit.translation_m.y() += 30.0;
  EXPECT_EQ(JudgeClosure(o, fit, pred, 100, 0.5, chain, zero, 200.0, 48.0), PairVerdict::kAdded);
  fit = pred;
  fit.translation_m.x() += 15.0;
  EXPECT_EQ(JudgeClosure(o, fit, pred, 100, 0.5, chain, zero, 200.0, 48.0), PairVerdict::kGate);
  // Heading: 15 degrees at most with negligible covariances.
  fit = pred;
  fit.heading_rad = 14.5 * kDegToRad;
  EXPECT_EQ(JudgeClosure(o, fit, pred, 100, 0.5, zero, zero, 200.0, 48.0), PairVerdict::kAdded);
  fit.heading_rad = 15.5 * kDegToRad;
  EXPECT_EQ(JudgeClosure(o, fit, pred, 100, 0.5, zero, zero, 200.0, 48.0), PairVerdict::kGate);
}

TEST(FlightGraph, PairSeedIsThePairsWhateverTheOrder) {
  EXPECT_EQ(PairSeed(1, 3, 9), PairSeed(1, 9, 3));
  EXPECT_NE(PairSeed(1, 3, 9), PairSeed(2, 3, 9));
  EXPECT_NE(PairSeed(1, 3, 9), PairSeed(1, 3, 10));
}

// The online window over a flight: each frame through AddOnline with `fitter`; the windowed
// pose of every frame as it was output (the live stream's), and the counts.
struct OnlineRun {
  std::vector<Similarity2> live;
  int tried = 0, verified = 0, gated = 0;
};
OnlineRun RunOnline(const Flight& f, const PairFitter& fitter, BackendOptions o = {}) {
  o.online = true;
  FlightGraph g(o, kWidth, kHeight);
  OnlineRun run;
  for (const FrameResult& r : f.results) {
    const WindowedPose w = g.AddOnline(r, fitter, 7);
    run.live.push_back(w.local_from_frame);
    run.tried += w.pairs_tried;
    run.verified += w.pairs_verified;
    run.gated += w.pairs_gated;
    EXPECT_EQ(w.window_first, std::max(0, r.index + 1 - o.window));
    if (r.index > 0) {
      EXPECT_TRUE(w.has_covariance) << r.index;
      EXPECT_GT(w.covariance(0, 0), 0.0);
    }
  }
  return run;
}

double RmsError(const Flight& f, const std::vector<Similarity2>& poses) {
  double sum = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    sum += (poses[i].translation_m - f.truth[i].translation_m).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(poses.size()));
}

TEST(FlightGraph, OnlineWindowMakesADriftingChainBetter) {
  const Flight f = MakeFlight(2, 40, 0.002);
  std::vector<Similarity2> causal;
  for (const FrameResult& r : f.results) causal.push_back({r.position_m, r.heading_rad, 0.0});
  const OnlineRun online = RunOnline(f, TruthFitter(f));
  // Keyframes every fourth frame: from the first keyframe on, up to two per frame (40 m reach).
  EXPECT_GT(online.verified, 100);
  EXPECT_EQ(online.gated, 0);
  EXPECT_EQ(online.tried, online.verified);
  const double before = EndError(f, causal), after = EndError(f, online.live);
  EXPECT_GT(before, 3.0);  // 79 steps turning 0.002 rad too much each
  EXPECT_LT(after, 0.5 * before) << before << " m -> " << after << " m";
  EXPECT_LT(RmsError(f, online.live), 0.6 * RmsError(f, causal));
  RecordProperty("end_error_m", std::to_string(before) + " -> " + std::to_string(after));
  // The same run again gives the same poses (no hidden state, no clock).
  const OnlineRun again = RunOnline(f, TruthFitter(f));
  for (std::size_t i = 0; i < online.live.size(); ++i) {
    ASSERT_EQ(again.live[i].translation_m, online.live[i].translation_m) << i;
    ASSERT_EQ(again.live[i].heading_rad, online.live[i].heading_rad) << i;
  }
}

TEST(FlightGraph, OnlineWindowGatesAFalseMatchAndKeepsTheTrack) {
  const Flight f = MakeFlight(1, 60, 0.002);
  // The pairs the window tries, in order.
  std::vector<std::pair<int, int>> tried;
  const PairFitter truth = TruthFitter(f);
  RunOnline(f, [&](const FeatureSet& a, const FeatureSet& b, std::uint64_t seed,
                   const std::optional<Eigen::Matrix3d>& prior) {
    tried.emplace_back(FrameOf(a), FrameOf(b));
    EXPECT_TRUE(prior.has_value());  // online matching is guided by the prediction
    return truth(a, b, seed, prior);
  });
  ASSERT_GT(tried.size(), 20u);
  const std::pair<int, int> pair = tried[tried.size() / 2];
  // A false match (a repeated field) 20 m off where the track puts the frame.
  const OnlineRun clean = RunOnline(f, TruthFitter(f, {}, {pair}));
  const OnlineRun aliased = RunOnline(f, TruthFitter(f, {{pair, {20.0, 0.0}}}));
  EXPECT_EQ(clean.gated, 0);
  EXPECT_EQ(aliased.gated, 1);
  EXPECT_EQ(aliased.verified, clean.verified);
  for (std::size_t i = 0; i < clean.live.size(); ++i) {
    ASSERT_EQ(aliased.live[i].translation_m, clean.live[i].translation_m) << i;
  }
  BackendOptions off;
  EXPECT_THROW(FlightGraph(off, kWidth, kHeight).AddOnline(f.results[0], truth, 1),
               InvalidArgument);
}

// The "fixes only" window (an empty fitter: steps alone) over a leg drifting by 0.003 rad per
// step, with an absolute fix of frame `fix_frame` (`offset` from the truth, position sigma
// `sigma_m`, heading sigma 0.01 rad) given when frame fix_frame + 5 is the newest (a fix
// arrives a few frames late); the live poses, the outcome, and the estimates just before the
// fix.
struct FixRun {
  std::vector<Similarity2> live, before_fix, after_fix;
  FixOutcome outcome;
  int fused = 0, gated = 0;
};
FixRun RunWithFix(const Flight& f, int fix_frame, double sigma_m, Eigen::Vector2d offset,
                  double placement_sigma_m = 0.0) {
  BackendOptions o;
  o.online = true;
  FlightGraph g(o, kWidth, kHeight);
  FixRun run;
  for (const FrameResult& r : f.results) {
    run.live.push_back(g.AddOnline(r, PairFitter(), 7).local_from_frame);
    if (r.index != fix_frame + 5) continue;
    GraphFix fix;
    fix.frame = fix_frame;
    fix.position_m = f.truth[static_cast<std::size_t>(fix_frame)].translation_m + offset;
    fix.heading_rad = f.truth[static_cast<std::size_t>(fix_frame)].heading_rad;
    fix.position_cov_m2 = sigma_m * sigma_m * Eigen::Matrix2d::Identity();
    fix.heading_var_rad2 = 0.01 * 0.01;
    fix.placement_sigma_m = placement_sigma_m;
    run.before_fix = g.graph().estimates();
    run.outcome = g.AddFix(fix);
    run.after_fix = g.graph().estimates();
    run.live.back() = run.outcome.newest;
  }
  run.fused = g.fixes_fused();
  run.gated = g.fixes_gated();
  return run;
}

TEST(FlightGraph, AFixPullsADriftedChainToTheTruthByItsCovarianceWeight) {
  const Flight f = MakeFlight(1, 60, 0.003);
  const FixRun none = RunWithFix(f, 1000, 0.2, Eigen::Vector2d::Zero());  // never given
  ASSERT_EQ(none.fused + none.gated, 0);
  const double drift_30 = (none.live[30].translation_m - f.truth[30].translation_m).norm();
  EXPECT_GT(drift_30, 3.0);  // 30 steps turning 0.003 rad too much each
  // A tight fix (0.2 m): frame 30 to within 2 sigma of the truth, the frames after it carried
  // with it (the end error a third: the drift after the fix, 5.2 m, is left; the heading is
  // corrected too, else the error at the fix's frame would grow on).
  const FixRun tight = RunWithFix(f, 30, 0.2, Eigen::Vector2d::Zero());
  ASSERT_TRUE(tight.outcome.fused) << tight.outcome.d2;
  EXPECT_EQ(tight.fused, 1);
  EXPECT_LT((tight.after_fix[30].translation_m - f.truth[30].translation_m).norm(), 0.4);
  EXPECT_GT(tight.outcome.newest_moved_m, 3.0);
  const double end_none = EndError(f, none.live), end_tight = EndError(f, tight.live);
  EXPECT_LT(end_tight, 0.4 * end_none) << end_none << " m -> " << end_tight << " m";
  for (int i = 36; i < 60; ++i) {  // after the fix, the live poses stay near the truth
    EXPECT_LT((tight.live[static_cast<std::size_t>(i)].translation_m -
               f.truth[static_cast<std::size_t>(i)].translation_m).norm(),
              0.5 * (none.live[static_cast<std::size_t>(i)].translation_m -
                     f.truth[static_cast<std::size_t>(i)].translation_m).norm())
        << i;
  }
  // A loose fix (10 m, wider than the chain's uncertainty): a part of the way only, about
  // P / (P + R) of it (the correction is P (P + R)^-1 e).
  const FixRun loose = RunWithFix(f, 30, 10.0, Eigen::Vector2d::Zero());
  ASSERT_TRUE(loose.outcome.fused);
  const double e = (loose.before_fix[30].translation_m - f.truth[30].translation_m).norm();
  const double moved = loose.outcome.correction.head<2>().norm();
  EXPECT_GT(moved, 0.02 * e);
  EXPECT_LT(moved, 0.5 * e);
  const double tight_moved = tight.outcome.correction.head<2>().norm();
  EXPECT_GT(tight_moved, 0.9 * e);
  // The same input, the same poses.
  const FixRun again = RunWithFix(f, 30, 0.2, Eigen::Vector2d::Zero());
  for (std::size_t i = 0; i < tight.live.size(); ++i) {
    ASSERT_EQ(again.live[i].translation_m, tight.live[i].translation_m) << i;
  }
}

TEST(FlightGraph, AFixFarOffIsGatedAndChangesNothing) {
  const Flight f = MakeFlight(1, 60, 0.003);
  const FixRun none = RunWithFix(f, 1000, 0.2, Eigen::Vector2d::Zero());
  const FixRun off = RunWithFix(f, 30, 0.2, Eigen::Vector2d(200.0, 0.0));
  EXPECT_FALSE(off.outcome.fused);
  EXPECT_EQ(off.gated, 1);
  EXPECT_EQ(off.fused, 0);
  EXPECT_GT(off.outcome.d2, off.outcome.bound);
  EXPECT_EQ(off.outcome.correction, Eigen::Vector3d::Zero());
  ASSERT_EQ(off.live.size(), none.live.size());
  for (std::size_t i = 0; i < none.live.size(); ++i) {
    ASSERT_EQ(off.live[i].translation_m, none.live[i].translation_m) << i;
    ASSERT_EQ(off.live[i].heading_rad, none.live[i].heading_rad) << i;
  }
  ASSERT_EQ(off.before_fix.size(), off.after_fix.size());
  for (std::size_t i = 0; i < off.before_fix.size(); ++i) {
    ASSERT_EQ(off.before_fix[i].translation_m, off.after_fix[i].translation_m) << i;
  }
  // The graph's first fix with the track's placement uncertainty (a geo-reference 200 m off,
  // the map's wide search's radius of 400 m as 3 sigma): fused, the fixed frame moved onto it.
  const FixRun placed = RunWithFix(f, 30, 0.2, Eigen::Vector2d(200.0, 0.0), 400.0 / 3.0);
  ASSERT_TRUE(placed.outcome.fused) << placed.outcome.d2 << " > " << placed.outcome.bound;
  EXPECT_LT((placed.after_fix[30].translation_m - f.truth[30].translation_m -
             Eigen::Vector2d(200.0, 0.0)).norm(), 0.4);
  // Bad fixes are clear errors.
  BackendOptions o;
  o.online = true;
  FlightGraph g(o, kWidth, kHeight);
  g.AddOnline(f.results[0], PairFitter(), 7);
  GraphFix bad;
  bad.frame = 3;
  EXPECT_THROW(g.AddFix(bad), InvalidArgument);  // not in the graph
  bad.frame = 0;
  bad.position_cov_m2.setZero();
  EXPECT_THROW(g.AddFix(bad), InvalidArgument);
  bad.position_cov_m2.setIdentity();
  bad.placement_sigma_m = -1.0;
  EXPECT_THROW(g.AddFix(bad), InvalidArgument);
  FlightGraph offline(BackendOptions{}, kWidth, kHeight);
  offline.Add(f.results[0]);
  EXPECT_THROW(offline.AddFix(GraphFix{}), InvalidArgument);
}

TEST(FlightGraph, DroppedKeyframesAreNotMatchedAgain) {
  const Flight f = MakeFlight(1, 40, 0.0);
  BackendOptions o;
  o.online = true;
  FlightGraph g(o, kWidth, kHeight);
  std::vector<std::pair<int, int>> tried;
  const PairFitter record = [&](const FeatureSet& a, const FeatureSet& b, std::uint64_t,
                                const std::optional<Eigen::Matrix3d>&) -> std::optional<PairFit> {
    tried.emplace_back(FrameOf(a), FrameOf(b));
    return std::nullopt;
  };
  for (int i = 0; i < 20; ++i) g.AddOnline(f.results[static_cast<std::size_t>(i)], record, 1);
  EXPECT_EQ(g.num_keyframes(), 5);  // frames 0, 4, 8, 12, 16
  g.DropKeyframes();                // a lens switch at frame 20
  EXPECT_EQ(g.num_keyframes(), 0);
  tried.clear();
  for (int i = 20; i < 40; ++i) g.AddOnline(f.results[static_cast<std::size_t>(i)], record, 1);
  EXPECT_EQ(g.num_frames(), 40);
  EXPECT_EQ(g.num_keyframes(), 5);  // frames 20, 24, ...
  ASSERT_FALSE(tried.empty());
  for (const auto& [a, b] : tried) EXPECT_GE(a, 20) << a << "-" << b;
}


// ---------------------------------------------------------------------------------------------
// Loop closures by appearance (BackendOptions::closures) on a synthetic ground of landmarks with
// known descriptors: every frame's features are the landmarks its true footprint sees, with a
// little noise, so that descriptor similarity follows the true overlap whatever the causal
// track says.

// Landmarks on a 2.5 m grid (jittered up to 0.8 m) over [x0, x1] x [y0, y1] metres, each with
// a random unit descriptor of 64 values. With period_m > 0 the ground repeats every period_m
// along x (rows of identical roofs: perceptual aliasing).
struct Ground {
  std::vector<Eigen::Vector2d> points;
  std::vector<float> descriptors;  // 64 per point
};
Ground MakeGround(double x0, double x1, double y0, double y1, double period_m) {
  constexpr double kCell = 2.5;
  const int period_cells = period_m > 0.0 ? static_cast<int>(std::lround(period_m / kCell)) : 0;
  Ground g;
  for (int iy = 0; iy * kCell <= y1 - y0; ++iy) {
    for (int ix = 0; ix * kCell <= x1 - x0; ++ix) {
      const int key_x = period_cells > 0 ? ix % period_cells : ix;
      sim::Rng rng(sim::SubSeed(11, static_cast<std::uint64_t>(iy) * 100003u +
                                        static_cast<std::uint64_t>(key_x)));
      g.points.emplace_back(x0 + kCell * ix + rng.Uniform(-0.8, 0.8),
                            y0 + kCell * iy + rng.Uniform(-0.8, 0.8));
      double n2 = 0.0;
      const std::size_t at = g.descriptors.size();
      for (int k = 0; k < 64; ++k) {
        const double v = rng.Normal();
        g.descriptors.push_back(static_cast<float>(v));
        n2 += v * v;
      }
      for (int k = 0; k < 64; ++k) g.descriptors[at + k] /= static_cast<float>(std::sqrt(n2));
    }
  }
  return g;
}

// The features frame `index` at the true pose `truth` sees: each landmark in the frame, at its
// pixel (0.3 px noise), its descriptor with noise 0.01 per value, re-normalised.
std::shared_ptr<const FeatureSet> FeaturesSeen(const Ground& g, const Similarity2& truth,
                                               int index) {
  auto f = std::make_shared<FeatureSet>();
  sim::Rng rng(sim::SubSeed(23, static_cast<std::uint64_t>(index)));
  const Similarity2 frame_from_local = truth.Inverse();
  // frame_from_local.Apply in plain scalars (the same sums): every landmark of the ground is
  // mapped for every frame, and an Eigen expression per point is slow in the sanitizer build.
  const Eigen::Matrix2d m = frame_from_local.Linear();
  const double m00 = m(0, 0), m01 = m(0, 1), m10 = m(1, 0), m11 = m(1, 1);
  const double tx = frame_from_local.translation_m.x(), ty = frame_from_local.translation_m.y();
  for (std::size_t i = 0; i < g.points.size(); ++i) {
    const double px = g.points[i].x(), py = g.points[i].y();
    const Eigen::Vector2d q((m00 * px + m01 * py) + tx, (m10 * px + m11 * py) + ty);
    Keypoint k;
    k.x = static_cast<float>(kCentre.x() + q.x() / kGsd + 0.3 * rng.Normal());
    k.y = static_cast<float>(kCentre.y() - q.y() / kGsd + 0.3 * rng.Normal());
    if (k.x < 0.f || k.y < 0.f || k.x > kWidth - 1 || k.y > kHeight - 1) continue;
    k.scale = 2.f;
    k.response = 1.f;
    k.laplacian = 1;
    f->keypoints.push_back(k);
    double n2 = 0.0;
    const std::size_t at = f->descriptors.size();
    for (int d = 0; d < 64; ++d) {
      const double v = g.descriptors[i * 64 + d] + 0.01 * rng.Normal();
      f->descriptors.push_back(static_cast<float>(v));
      n2 += v * v;
    }
    for (int d = 0; d < 64; ++d) f->descriptors[at + d] /= static_cast<float>(std::sqrt(n2));
  }
  return f;
}

// The flight over `g` through the true poses `truth`, whose causal track (the odometry's) is
// `causal`: each frame's step measures the causal step, its features those of the true pose.
Flight FlightOver(const Ground& g, std::vector<Similarity2> truth,
                  const std::vector<Similarity2>& causal) {
  Flight f;
  f.truth = std::move(truth);
  for (std::size_t i = 0; i < f.truth.size(); ++i) {
    FrameResult r;
    r.index = static_cast<int>(i);
    r.gsd_m_per_px = kGsd;
    r.features = FeaturesSeen(g, f.truth[i], r.index);
    if (i > 0) {
      r.status = FrameStatus::kOk;
      r.reference_index = r.index - 1;
      r.curr_from_prev = CurrFromPrevPx(backend::Between(causal[i - 1], causal[i]));
      r.step_inliers_curr_px = SpreadPoints();
    }
    r.position_m = causal[i].translation_m;
    r.heading_rad = causal[i].heading_rad;
    f.results.push_back(r);
  }
  return f;
}

// A square loop of 4 x 88 steps of 4 m (352 m sides, 1408 m), the image up along the track,
// back over the first frame; the causal track drifts by (-0.1, 0.1) m per step (50 m at the
// end, 3.5 % of the path: more than the footprint search radius, within the gate).
Flight MakeDriftingLoop(const Ground& g) {
  constexpr int kSide = 88;
  std::vector<Similarity2> truth, causal;
  for (int k = 0; k <= 4 * kSide; ++k) {
    const int side = (k / kSide) % 4, s = k % kSide;
    const double d = 4.0 * s, l = 4.0 * kSide;
    const Eigen::Vector2d p = side == 0   ? Eigen::Vector2d(d, 0.0)
                              : side == 1 ? Eigen::Vector2d(l, d)
                              : side == 2 ? Eigen::Vector2d(l - d, l)
                                          : Eigen::Vector2d(0.0, l - d);
    truth.push_back({p, side * M_PI / 2 - M_PI / 2, 0.0});
    causal.push_back({p + 0.1 * k * Eigen::Vector2d(-1.0, 1.0), truth.back().heading_rad, 0.0});
  }
  return FlightOver(g, truth, causal);
}

// A fitter that returns the true transform of every pair (frames known by their features).
PairFitter TrueFitterOf(const Flight& f) {
  std::map<const FeatureSet*, int> frame;
  for (const FrameResult& r : f.results) frame[r.features.get()] = r.index;
  return [&f, frame](const FeatureSet& prev, const FeatureSet& curr, std::uint64_t,
                     const std::optional<Eigen::Matrix3d>&) -> std::optional<PairFit> {
    const Similarity2 z = backend::Between(f.truth[static_cast<std::size_t>(frame.at(&prev))],
                                           f.truth[static_cast<std::size_t>(frame.at(&curr))]);
    return PairFit{CurrFromPrevPx(z), SpreadPoints()};
  };
}

// The pairs (frames) FlightGraph::Optimize tries, in order, on a flight over a Ground.
std::vector<std::pair<int, int>> TriedFramePairs(const Flight& f, const FlightGraph& g) {
  std::map<const FeatureSet*, int> frame;
  for (const FrameResult& r : f.results) frame[r.features.get()] = r.index;
  std::vector<std::pair<int, int>> tried;
  g.Optimize(
      [&](const FeatureSet& a, const FeatureSet& b, std::uint64_t,
          const std::optional<Eigen::Matrix3d>&) -> std::optional<PairFit> {
        tried.emplace_back(frame.at(&a), frame.at(&b));
        return std::nullopt;
      },
      1);
  return tried;
}

std::vector<Similarity2> CausalOf(const Flight& f) {
  std::vector<Similarity2> causal;
  for (const FrameResult& r : f.results) causal.push_back({r.position_m, r.heading_rad, 0.0});
  return causal;
}

TEST(LoopClosures, AppearanceFindsTheRevisitTheDriftedFootprintsMiss) {
  const Ground ground = MakeGround(-40.0, 392.0, -40.0, 392.0, 0.0);
  const Flight f = MakeDriftingLoop(ground);
  const PairFitter fitter = TrueFitterOf(f);
  BackendOptions o;
  const FlightGraph plain = Build(f, o);
  // The footprint search alone pairs nothing across the loop's start and end.
  for (const auto& [a, b] : TriedFramePairs(f, plain)) {
    EXPECT_FALSE(a < 44 && b > 308) << a << "-" << b << " is a footprint pair";
  }
  const OptimizedFlight without = plain.Optimize(fitter, 1);
  o.closures = true;
  const OptimizedFlight with = Build(f, o).Optimize(fitter, 1);
  EXPECT_EQ(without.closures_tried, 0);
  EXPECT_GE(with.closures_verified, 3);
  EXPECT_EQ(with.closures_gated, 0);
  int across = 0;
  for (const TriedPair& p : with.pairs) {
    across += p.by_appearance && p.verdict == PairVerdict::kAdded && p.a < 44 && p.b > 308;
  }
  EXPECT_GE(across, 2) << "no closure across the loop's start and end";
  const double causal_end = EndError(f, CausalOf(f));
  const double before = EndError(f, without.local_from_frame);
  const double after = EndError(f, with.local_from_frame);
  EXPECT_GT(causal_end, 45.0);
  // The footprint pairs along the sides and at the corners halve the end error at best.
  EXPECT_GT(before, 20.0);
  EXPECT_LT(after, 0.01 * before) << before << " m -> " << after << " m";
  EXPECT_LT(RmsError(f, with.local_from_frame), 0.2 * RmsError(f, without.local_from_frame));
  RecordProperty("end_error_m", std::to_string(before) + " -> " + std::to_string(after));

  // Online: the closure reaches far behind the window; the whole graph is re-optimised.
  o.online = true;
  FlightGraph g(o, kWidth, kHeight);
  WindowedPose last;
  int full_solves = 0, verified = 0;
  for (const FrameResult& r : f.results) {
    last = g.AddOnline(r, fitter, 1);
    full_solves += last.full_solve;
    verified += last.closures_verified;
  }
  EXPECT_GE(verified, 1);
  EXPECT_GE(full_solves, 1);
  const double live_end = (last.local_from_frame.translation_m - f.truth.back().translation_m).norm();
  EXPECT_LT(live_end, 0.1 * causal_end) << causal_end << " m -> " << live_end << " m";
  EXPECT_LT(RmsError(f, g.graph().estimates()), 0.1 * RmsError(f, CausalOf(f)));
  RecordProperty("online_end_error_m", std::to_string(causal_end) + " -> " + std::to_string(live_end));
}

// A line of `steps` steps of 4 m east over `g`, the image up along the track; the odometry's
// steps turn by 0.001 rad more than the truth each.
Flight MakeLine(const Ground& g, int steps) {
  std::vector<Similarity2> truth, causal;
  Similarity2 c;
  for (int k = 0; k <= steps; ++k) {
    truth.push_back({Eigen::Vector2d(4.0 * k, 0.0), -M_PI / 2, 0.0});
    if (k == 0) {
      c = truth[0];
    } else {
      Similarity2 step = backend::Between(truth[k - 1], truth[k]);
      step.heading_rad += 0.001;
      c = c * step;
    }
    causal.push_back(c);
  }
  return FlightOver(g, truth, causal);
}

// The run's pair fitter (the odometry's correspondence options with its relocalisation
// sampler, as pipeline/run_steps.h PairCorrespondenceOptions) with `threads` matching threads.
PairFitter RealFitter(int threads) {
  const OdometryOptions odometry;
  CorrespondenceOptions c = odometry.correspondence;
  c.sampler = odometry.relocalize_sampler;
  c.match.num_threads = threads;
  return MakeStandardPairFitter(c, kWidth, kHeight);
}

TEST(LoopClosures, TheGateRejectsARepeatedFieldThatVerifiesGeometrically) {
  // A field repeating every 100 m along the line (rows of identical roofs): a frame 100 m on
  // looks exactly like an earlier one, and the real matcher and RANSAC fit it with many inliers
  // spread over the frame; only the gate can tell, since the track puts it 100 m away.
  const Ground ground = MakeGround(-40.0, 380.0, -40.0, 40.0, 100.0);
  const Flight f = MakeLine(ground, 80);
  BackendOptions o;
  const OptimizedFlight plain = Build(f, o).Optimize(RealFitter(1), 3);
  o.closures = true;
  const OptimizedFlight aliased = Build(f, o).Optimize(RealFitter(1), 3);
  EXPECT_EQ(plain.closures_tried, 0);
  EXPECT_GE(aliased.closures_tried, 5);
  EXPECT_EQ(aliased.closures_verified, 0);
  int verified_geometrically = 0;
  for (const TriedPair& p : aliased.pairs) {
    if (!p.by_appearance) continue;
    const double offset_m = (p.fit.translation_m - p.predicted.translation_m).norm();
    if (p.verdict == PairVerdict::kGate && p.inliers >= o.min_inliers &&
        p.spread >= o.min_spread) {
      ++verified_geometrically;
      EXPECT_GT(offset_m, 80.0) << p.a << "-" << p.b;  // the fit: one period off the track
    }
  }
  EXPECT_GE(verified_geometrically, 5);
  EXPECT_GT(plain.pairs_verified, 10);  // the footprint pairs (the true overlaps) are kept
  EXPECT_EQ(aliased.pairs_verified, plain.pairs_verified);
  // The track is the one without closures.
  ASSERT_EQ(aliased.local_from_frame.size(), plain.local_from_frame.size());
  for (std::size_t i = 0; i < plain.local_from_frame.size(); ++i) {
    ASSERT_LT((aliased.local_from_frame[i].translation_m - plain.local_from_frame[i].translation_m)
                  .norm(), 1e-9) << i;
    ASSERT_NEAR(aliased.local_from_frame[i].heading_rad, plain.local_from_frame[i].heading_rad,
                1e-12) << i;
  }
  // Without the gate (a huge one) the false closures go in and bend the track by decimetres
  // although the robust cost (Cauchy) down-weights them: the check above would see it.
  BackendOptions open = o;
  open.gate = 100.0;
  open.gate_heading_deg = 179.0;
  const OptimizedFlight ungated = Build(f, open).Optimize(RealFitter(1), 3);
  EXPECT_GE(ungated.closures_verified, 5);
  double moved_m = 0.0;
  for (std::size_t i = 0; i < plain.local_from_frame.size(); ++i) {
    moved_m = std::max(moved_m, (ungated.local_from_frame[i].translation_m -
                                 plain.local_from_frame[i].translation_m).norm());
  }
  EXPECT_GE(ungated.outliers, 5);  // the robust cost down-weights them, but not to nothing
  EXPECT_GT(moved_m, 0.1);
  // Online too: the live track is the one without closures.
  BackendOptions on;
  on.online = true;
  FlightGraph a(on, kWidth, kHeight, 3);
  on.closures = true;
  FlightGraph b(on, kWidth, kHeight, 3);
  int gated = 0, verified = 0;
  const PairFitter fitter = RealFitter(1);
  for (const FrameResult& r : f.results) {
    const WindowedPose wa = a.AddOnline(r, fitter, 3), wb = b.AddOnline(r, fitter, 3);
    gated += wb.closures_gated;
    verified += wb.closures_verified;
    ASSERT_LT((wa.local_from_frame.translation_m - wb.local_from_frame.translation_m).norm(), 1e-9)
        << r.index;
  }
  EXPECT_GE(gated, 5);
  EXPECT_EQ(verified, 0);
}

TEST(LoopClosures, TheSameSeedGivesTheSameResultWithOneOrTwoThreads) {
  const Ground ground = MakeGround(-40.0, 380.0, -40.0, 40.0, 100.0);
  const Flight f = MakeLine(ground, 80);
  BackendOptions o;
  o.closures = true;
  const FlightGraph g = Build(f, o);
  const OptimizedFlight one = g.Optimize(RealFitter(1), 5);
  const OptimizedFlight two = g.Optimize(RealFitter(2), 5);
  ASSERT_GT(one.closures_tried, 0);
  ASSERT_EQ(one.pairs.size(), two.pairs.size());
  for (std::size_t k = 0; k < one.pairs.size(); ++k) {
    EXPECT_EQ(one.pairs[k].a, two.pairs[k].a);
    EXPECT_EQ(one.pairs[k].b, two.pairs[k].b);
    EXPECT_EQ(one.pairs[k].verdict, two.pairs[k].verdict);
    EXPECT_EQ(one.pairs[k].inliers, two.pairs[k].inliers);
    EXPECT_EQ(one.pairs[k].fit.translation_m, two.pairs[k].fit.translation_m);
  }
  for (std::size_t i = 0; i < one.local_from_frame.size(); ++i) {
    ASSERT_EQ(one.local_from_frame[i].translation_m, two.local_from_frame[i].translation_m) << i;
  }
  // The signatures depend on the seed and on nothing else.
  const FlightGraph again = Build(f, o);
  ASSERT_EQ(again.num_keyframes(), g.num_keyframes());
  for (int k = 0; k < g.num_keyframes(); ++k) {
    EXPECT_EQ(again.signature(k)->words, g.signature(k)->words);
    EXPECT_EQ(again.signature(k)->weights, g.signature(k)->weights);
  }
}

TEST(FlightGraph, BadOptionsAndFramesAreClearErrors) {
  BackendOptions o;
  o.gate = -1.0;
  try {
    FlightGraph g(o, kWidth, kHeight);
    FAIL() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("backend.gate"), std::string::npos) << e.what();
  }
  FlightGraph g(BackendOptions{}, kWidth, kHeight);
  FrameResult r;
  r.index = 3;
  EXPECT_THROW(g.Add(r), InvalidArgument);
  EXPECT_THROW(g.Optimize(TruthFitter(Flight{}), 1), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::flight_graph_test
