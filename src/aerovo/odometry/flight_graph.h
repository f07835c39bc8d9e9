// The offline whole-flight optimisation of a run (docs/backend.md): while the flight is
// processed, FlightGraph collects each frame's causal pose (FrameResult, pose_chain.h frames),
// each step as a relative factor of the pose graph (backend/pose_graph.h, backend/pixel_step.h)
// and, for keyframes spaced over the ground, the features needed to match them again; after the
// last frame, Optimize finds pairs of keyframes whose predicted footprints overlap (from the
// causal track), matches and fits each pair (standard RANSAC, seeded per pair from the run's
// seed), verifies the fit (inliers, their spread over the image, agreement with the graph's
// prediction: the gate) and adds the verified ones as relative factors; then OptimizeAll with the
// robust (Cauchy) cost gives every frame's optimised pose. Online (BackendOptions::online,
// AddOnline), the same graph grows per frame: the frame is matched against recent keyframes with
// the same pair fitter and verification, and the last poses are optimised (OptimizeWindow).
//
// Frames: local = the run's local metric frame (pose_chain.h); a frame's ground coordinates and
// the poses `local_from_frame` as in backend/similarity2.h (position of the camera centre's ground
// point in metres, heading = FrameResult::heading_rad, log-scale 0 = the height's scale).
// Scale: the causal track takes each frame's scale from its height (ScaleMode::kMetric), so every
// relative factor measures a log-scale change of 0 with a standard deviation of 1e-3: the graph
// moves and turns frames but keeps the heights' scale, as the causal track does.
// No I/O (the run writes vo_optimized.*: pipeline/run_steps.h).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "aerovo/backend/pose_graph.h"
#include "aerovo/backend/similarity2.h"
#include "aerovo/core/options.h"
#include "aerovo/correspondence/correspondence.h"
#include "aerovo/features/keypoint.h"
#include "aerovo/odometry/place_signature.h"
#include "aerovo/odometry/visual_odometry.h"

namespace aerovo {

/// Options of the offline whole-flight optimisation and the online window (`backend.*` of a run
/// configuration).
/// Lengths are fractions of the footprint's smaller side (the frame's smaller side in pixels
/// times its ground sampling distance), so that they hold at any height and resolution.
struct BackendOptions {
  /// Run the offline optimisation after the last frame (vo_optimized.*, summary.json
  /// "optimized"). Default false: on the simulated lawnmowers it cuts the end error by several
  /// times, but on the real flights of BENCHMARKS.md ("Offline optimisation") it does not lower
  /// the error against GPS (tampa-phantom3's rises); false leaves the run exactly as without a
  /// back-end (no vo_optimized.*).
  bool enable = false;
  /// A measured frame becomes a keyframe (its features kept) when its causal centre is at least
  /// this far from the last keyframe's. Memory: at most path length / (keyframe_spacing x
  /// footprint side) + 1 keyframes of ~0.3 kB per SURF point. Default 0.3 (each point of the
  /// ground is then in about three keyframes along the track).
  double keyframe_spacing = 0.3;
  /// Two keyframes that are not neighbours in the keyframe order are a candidate pair when their
  /// causal centres are at most this far apart. Default 0.8 (footprints overlapping by about a
  /// fifth or more, with room for the causal drift).
  double search_radius = 0.8;
  /// Candidate pairs tried per keyframe at most (its nearest by the causal track). Default 6:
  /// bounds the matching time (one exhaustive match each).
  int max_pairs_per_keyframe = 6;
  /// A pair's fit is kept only with at least this many RANSAC inliers. Default 40 (more than a
  /// step's 12: a pair far apart in time has no motion prior to confirm it).
  int min_inliers = 40;
  /// The inliers' bounding box in the later frame must cover at least this fraction of its
  /// area. Default 0.05 (a fit on one small patch, e.g. a repeated texture, is not kept).
  double min_spread = 0.05;
  /// Gate: the fit's translation may differ from the graph's prediction (the causal track) by
  /// at most gate x the causal path length between the two frames, plus a tenth of the
  /// footprint side; its heading by at most gate_heading_deg. Default 0.05 (the causal drift on
  /// the real flights is 1-2 % of the path: BENCHMARKS.md); a false overlap (two places that
  /// look alike) placing a frame farther from its predicted place is rejected.
  double gate = 0.05;
  /// Gate on the heading, degrees. Default 15.
  double gate_heading_deg = 15.0;
  /// The online window (docs/backend.md, "Online window"): each new frame is also matched
  /// against up to online_keyframes recent keyframes (guided by the graph's prediction, judged
  /// as the offline pairs: min_inliers, min_spread, gate), and the last `window` poses are
  /// optimised per frame (backend::OptimizeWindow, older poses held: final); the live outputs
  /// (pose stream, MAVLink, frames.csv and the track files) carry the windowed estimate.
  /// Default false: BENCHMARKS.md, "Online window".
  bool online = false;
  /// Poses optimised per frame (the newest ones). Default 10.
  int window = 10;
  /// Recent keyframes (other than the step's own reference, within search_radius of the frame
  /// by the causal track) a new frame is matched against. Default 2.
  int online_keyframes = 2;
  /// Loop closures by appearance (docs/backend.md, "Loop closures"): each keyframe's signature
  /// (place_signature.h: a bag of its quantised SURF descriptors) is compared with those of every
  /// older keyframe outside the recent window, so that a revisit is found when the causal track
  /// has drifted too far for the predicted footprints to overlap; the candidates are fitted
  /// unguided and judged by JudgeClosure (min_inliers, min_spread, and the gate as a chi-square
  /// test against the uncertainty chained since the candidate). Offline they
  /// join the footprint pairs; online (backend.online) a verified one re-optimises the whole
  /// graph. Default false: BENCHMARKS.md, "Loop closures".
  bool closures = false;
  /// Closure candidates only among keyframes whose causal centres are at most this far,
  /// fraction of the footprint's smaller side. Default 20 (the gate bounds the correction a
  /// closure may make anyway).
  double closure_search_radius = 20.0;
  /// A keyframe is a closure candidate when its signature's similarity to the new keyframe's is
  /// at least this fraction of the new keyframe's similarity to its previous keyframe (about
  /// 70 % overlap at the default keyframe spacing). Default 0.3.
  double closure_similarity = 0.3;
  /// Closure candidates tried per keyframe at most (the most similar first). Default 2.
  int closure_max_candidates = 2;
  /// The run's GPS fixes as absolute position factors of the offline optimisation (enable),
  /// standard deviation of each fix's horizontal position per axis, metres; 0: none (the graph
  /// keeps the causal track's placement). Only the fixes the run accepted (not rejected by the
  /// plausibility check, not withheld by GPS denial) and only once the run is geo-referenced;
  /// the robust cost of the solve down-weights a fix that disagrees with the images. The
  /// optimised track then takes its shape from the images and its placement (and a common
  /// scale, heading) from all the fixes. Default 0; `aerovo map build` sets 3 (docs/map.md).
  double gps_sigma_m = 0.0;
};

/// Throws InvalidArgument naming the field ("backend.gate must be ...").
void Validate(const BackendOptions& options);

// clang-format off
template <class V>
void VisitFields(BackendOptions& o, V& v) {
  using namespace options;
  v.Field(o.enable, "enable", "Offline whole-flight optimisation after the last frame (vo_optimized.*)", Any());
  v.Field(o.keyframe_spacing, "keyframe_spacing", "Keyframe spacing, fraction of the footprint's smaller side", GreaterThan(0).Finite());
  v.Field(o.search_radius, "search_radius", "Candidate pairs within this distance, fraction of the footprint's smaller side", GreaterThan(0).Finite());
  v.Field(o.max_pairs_per_keyframe, "max_pairs_per_keyframe", "Candidate pairs tried per keyframe at most", Interval(1, 1000));
  v.Field(o.min_inliers, "min_inliers", "RANSAC inliers needed to keep a pair's fit", Interval(3, 1000000));
  v.Field(o.min_spread, "min_spread", "Inliers' bounding box, least fraction of the image area", Interval(0, 1, true, true));
  v.Field(o.gate, "gate", "Largest disagreement of a fit with the track, fraction of the path between the frames", GreaterThan(0).Finite());
  v.Field(o.gate_heading_deg, "gate_heading_deg", "Largest heading disagreement of a fit with the track, degrees", Interval(0, 180, false, true));
  v.Field(o.online, "online", "Online window: match each frame against recent keyframes and optimise the last poses per frame; the live outputs carry the windowed estimate", Any());
  v.Field(o.window, "window", "Online window: poses optimised per frame (older ones are final)", Interval(2, 10000));
  v.Field(o.online_keyframes, "online_keyframes", "Online window: recent keyframes matched per frame", Interval(1, 1000));
  v.Field(o.closures, "closures", "Loop closures by appearance: keyframes compared by their bags of quantised descriptors with older ones outside the window", Any());
  v.Field(o.closure_search_radius, "closure_search_radius", "Loop closures: candidates within this causal distance, fraction of the footprint's smaller side", GreaterThan(0).Finite());
  v.Field(o.closure_similarity, "closure_similarity", "Loop closures: least similarity, relative to the previous keyframe's", GreaterThan(0).Finite());
  v.Field(o.closure_max_candidates, "closure_max_candidates", "Loop closures: candidates tried per keyframe at most", Interval(1, 1000));
  v.Field(o.gps_sigma_m, "gps_sigma_m", "GPS fixes as absolute position factors of the offline optimisation: standard deviation per axis, metres (0: none)", AtLeast(0).Finite());
}
// clang-format on

/// A pair's fitted pixel transform: curr_from_prev maps the earlier frame's pixels to the later
/// one's; inliers_curr_px are the RANSAC inliers in the later frame's pixels.
struct PairFit {
  Eigen::Matrix3d curr_from_prev_px = Eigen::Matrix3d::Identity();
  Eigen::Matrix2Xd inliers_curr_px;
};
/// Matches and fits two keyframes' features; nullopt when no fit. `seed`: the RANSAC seed;
/// `prior`: the predicted curr_from_prev pixel transform (nullopt: none, match unguided).
using PairFitter = std::function<std::optional<PairFit>(
    const FeatureSet& prev, const FeatureSet& curr, std::uint64_t seed,
    const std::optional<Eigen::Matrix3d>& prior)>;
/// The standard method (correspondence.h: all points; guided by the prior when one is given,
/// else unguided) of `options` with the seed of each call, then the refit on all points
/// (CorrespondenceStage::RefitOnAllPoints) when `options` refines fall-backs; frames of width x
/// height pixels.
PairFitter MakeStandardPairFitter(const CorrespondenceOptions& options, int width, int height);

/// The seed of pair (a, b) from the run's seed: SplitMix64 of the three (S. Vigna, "Further
/// scramblings of Marsaglia's xorshift generators", 2017): the same for a pair whatever the
/// order or threads the pairs are tried in.
std::uint64_t PairSeed(std::uint64_t run_seed, int a, int b);

/// Why a pair's fit was not added.
enum class PairVerdict { kAdded, kNoFit, kTooFewInliers, kTooLittleSpread, kGate };

/// The verdict on a fit of frames a (earlier) -> b: `fit` and `predicted` are prev_from_curr in
/// frame a's metres, `path_m` the causal path length between them, `side_m` the footprint's
/// smaller side, `spread` the inliers' bounding-box fraction of the image.
PairVerdict JudgePair(const BackendOptions& options, const backend::Similarity2& fit,
                      const backend::Similarity2& predicted, int n_inliers, double spread,
                      double path_m, double side_m);

/// The verdict on a loop closure by appearance (BackendOptions::closures) of frames a -> b: as
/// JudgePair, but the gate is a chi-square test of the closure's implied correction e = (fit -
/// predicted translation, wrapped heading difference) against the uncertainty accumulated since
/// a: d^2 = e' (chain_cov + fit_cov + D)^-1 e <= 16.27 (chi-square, 3 degrees of freedom, 0.999),
/// where chain_cov is the covariance of (x, y, heading) chained from the steps' factors between
/// a and b (FlightGraph), fit_cov the fit's, and D the drift model of the linear gate: standard
/// deviations (gate x path_m + side_m / 10) / 4.03 per axis and gate_heading_deg / 4.03 (so
/// that with negligible chain and fit covariances the test is JudgePair's bound); all in frame
/// a's metres and radians. A stretch of weak steps (bridged frames) widens it.
PairVerdict JudgeClosure(const BackendOptions& options, const backend::Similarity2& fit,
                         const backend::Similarity2& predicted, int n_inliers, double spread,
                         const Eigen::Matrix3d& chain_cov, const Eigen::Matrix3d& fit_cov,
                         double path_m, double side_m);

/// "added", "no_fit", "too_few_inliers", "too_little_spread", "gate".
const char* ToString(PairVerdict verdict);

/// One candidate pair tried (OptimizedFlight::pairs).
struct TriedPair {
  int a = 0, b = 0;  ///< The two frames (their order given to Add), a < b.
  PairVerdict verdict = PairVerdict::kNoFit;
  int inliers = 0;      ///< RANSAC inliers of the fit (0: no fit).
  double spread = 0.0;  ///< The inliers' bounding box, fraction of the image.
  /// prev_from_curr measured by the fit (log-scale as measured, before the factor sets it to 0)
  /// and predicted by the causal track, in frame a's metres; the fit is the identity without one.
  backend::Similarity2 fit, predicted;
  bool down_weighted = false;  ///< Added, and down-weighted by the robust cost.
  /// A loop-closure candidate found by appearance (BackendOptions::closures), not by the
  /// predicted footprints.
  bool by_appearance = false;
};

/// What the offline optimisation did, and the optimised poses.
struct OptimizedFlight {
  /// Per frame given to Add, in order: the optimised local_from_frame.
  std::vector<backend::Similarity2> local_from_frame;
  int keyframes = 0;
  int pairs_tried = 0;     ///< Candidate pairs matched.
  int pairs_verified = 0;  ///< Added as factors.
  int pairs_rejected = 0;  ///< Tried and not added (no fit, inliers, spread or gate).
  int pairs_gated = 0;     ///< Of those, rejected by the gate.
  int outliers = 0;        ///< Added pairs the robust cost down-weighted (pose_graph.h).
  int absolute = 0;           ///< Absolute factors given to Optimize and added.
  int absolute_outliers = 0;  ///< Of those, down-weighted by the robust cost.
  /// Of the pairs, the loop-closure candidates found by appearance (BackendOptions::closures):
  /// tried, verified (added), rejected by the gate.
  int closures_tried = 0, closures_verified = 0, closures_gated = 0;
  double match_s = 0.0;    ///< Wall time of the pairs' matching and fitting, s.
  double solve_s = 0.0;    ///< Wall time of the graph solve, s.
  int iterations = 0;
  std::vector<TriedPair> pairs;  ///< Every pair tried, in the order tried.
};

/// A frame's pose from the online window (FlightGraph::AddOnline).
struct WindowedPose {
  backend::Similarity2 local_from_frame;  ///< The windowed estimate (log-scale 0).
  /// Marginal covariance of (x [m], y [m], heading [rad], log-scale) given the poses before
  /// the window (held: backend::PoseGraphResult::covariance); valid when has_covariance.
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
  bool has_covariance = false;
  int pairs_tried = 0;     ///< Keyframes this frame was matched against.
  int pairs_verified = 0;  ///< Added as factors.
  int pairs_gated = 0;     ///< Rejected by the gate.
  int window_first = 0;    ///< The window's first pose (the ones before it are final).
  /// Loop closures by appearance (BackendOptions::closures) tried at this frame (when it became
  /// a keyframe), verified (added as factors), rejected by the gate.
  int closures_tried = 0, closures_verified = 0, closures_gated = 0;
  /// A verified closure made the whole graph re-optimised (OptimizeAll) before the window's
  /// solve; its wall time, ms.
  bool full_solve = false;
  double full_solve_ms = 0.0;
};

/// An absolute fix of a frame already in the graph (FlightGraph::AddFix): a position and
/// optionally a heading in the local frame (pose_chain.h), with their covariance. A fix against
/// a geo-referenced map (odometry/map_match.h MapFix) is brought from the run's ENU frame to
/// the local one by the GeoReferencer's rotation (pipeline/stage_map_fix.cc).
struct GraphFix {
  int frame = 0;  ///< The frame's index in the graph (FrameResult::index).
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();  ///< Local frame, m.
  std::optional<double> heading_rad;                     ///< Local frame (FrameResult's), rad.
  /// Covariance of the position, m^2 (symmetric positive definite), and of the heading, rad^2
  /// (> 0 when heading_rad is set).
  Eigen::Matrix2d position_cov_m2 = Eigen::Matrix2d::Identity();
  double heading_var_rad2 = 0.0;
  /// 1-sigma uncertainty of the track's placement that no fix has measured yet (its
  /// geo-reference: GPS that may be far off, or a prior the map's search found hundreds of
  /// metres off), m: added to the gate's P per axis for the graph's first fused fix only (after
  /// it, the fixes anchor the track). 0: the chained uncertainty alone.
  double placement_sigma_m = 0.0;
};

/// What AddFix did.
struct FixOutcome {
  bool fused = false;  ///< Passed the gate and added as an absolute factor (else gated).
  /// The gate's statistic: d^2 = e' (P + R)^-1 e (FlightGraph::AddFix), and its bound.
  double d2 = 0.0, bound = 0.0;
  /// The correction made at the fix's frame: (x, y [m, local], heading [rad]); zero when gated.
  Eigen::Vector3d correction = Eigen::Vector3d::Zero();
  /// The newest frame's estimate after the fix (the live pose), and how far its position moved.
  backend::Similarity2 newest;
  double newest_moved_m = 0.0;
};

/// The frames of a run in order, built as they come (Add), optimised at the end (Optimize).
class FlightGraph {
 public:
  /// Frames of width x height pixels (the ones given to the odometry). `seed`: the random
  /// projections of the keyframe signatures (BackendOptions::closures; place_signature.h).
  /// InvalidArgument for invalid options.
  FlightGraph(const BackendOptions& options, int width, int height, std::uint64_t seed = 0);

  /// Adds the next frame's odometry result (frames in the order processed; r.index must be the
  /// number of frames added so far: InvalidArgument otherwise). Keeps r.features when the frame
  /// becomes a keyframe.
  void Add(const FrameResult& r);

  /// The online window (BackendOptions::online): Add(r), then r's features matched against up
  /// to online_keyframes recent keyframes (newest first; not r's reference, not r itself, within
  /// search_radius by the causal track), each guided by the causal prediction, seeded with
  /// PairSeed and judged by JudgePair; the verified ones become factors; then the last `window`
  /// poses are optimised (OptimizeWindow, with covariance) and their estimates replace the
  /// graph's (the poses before the window keep theirs: final). A new pose starts at the previous
  /// pose's estimate moved by the causal step. With BackendOptions::closures, a frame that
  /// becomes a keyframe is also matched (unguided) against its closure candidates by appearance
  /// among the keyframes before the window; a verified closure is added and the whole graph is
  /// re-optimised (OptimizeAll) before the window's solve, so that the poses between the two
  /// ends of the loop move too (docs/backend.md, "Loop closures"). Returns the frame's windowed
  /// pose.
  /// An empty `fitter` adds the frame's step only (no keyframe matching, no closures): the
  /// "fixes only" window of map_fix.apply without backend.online (docs/backend.md).
  WindowedPose AddOnline(const FrameResult& r, const PairFitter& fitter, std::uint64_t run_seed);

  /// An absolute fix of frame fix.frame (added already; BackendOptions::online, as the window's
  /// poses are re-estimated), judged against the graph's estimate x of that frame and fused
  /// (docs/backend.md, "Absolute fixes"):
  /// - the anchor a is the frame of the last fused fix (the first frame before any): the
  ///   frame's uncertainty since then, P, is the covariance of (x, y, heading) chained from the
  ///   step factors a + 1..frame (as JudgeClosure's chain_cov, rotated into the local frame)
  ///   plus JudgeClosure's drift model over the causal path from a to the frame; R is the fix's;
  /// - the gate: e = fix - x (the heading wrapped; the heading left out without one), d^2 = e'
  ///   (P + R)^-1 e <= the chi-square bound at 0.999 (13.82 for 2 degrees of freedom, 16.27 for
  ///   3); a gated fix changes nothing;
  /// - a fused fix corrects the frame by c = P (P + R)^-1 e (each weighted by its covariance);
  ///   the frames after it (up to the newest) move rigidly with it (turned by c's heading about
  ///   the frame), the frames between a and it by the fraction of the causal path from a,
  ///   so that every later frame (AddOnline chains a new pose from the previous estimate)
  ///   carries the correction; the fix becomes an absolute factor of the graph (Optimize uses
  ///   it), and the poses up to the fix's frame are held from then on (final: the window's
  ///   step factors, which know nothing of the drift the correction undid, would pull them
  ///   back; Optimize frees them, a closure's whole-graph solve online moves only the later
  ///   ones).
  /// InvalidArgument when the frame is not in the graph, the graph is not online, or the fix is
  /// not finite or its covariance not positive definite.
  FixOutcome AddFix(const GraphFix& fix);
  int fixes_fused() const { return fixes_fused_; }
  int fixes_gated() const { return fixes_gated_; }

  /// Forgets the keyframes added so far (their features are released and never matched again):
  /// at a change of the lens model (pipeline/lens_switch.h) the earlier frames' features are
  /// under the old lens, and a match of them against the later frames' would be biased. The
  /// poses and factors stay.
  void DropKeyframes() { keyframes_.clear(); }
  /// The signature of keyframe k (null without BackendOptions::closures).
  const PlaceSignature* signature(int k) const {
    return keyframes_[static_cast<std::size_t>(k)].signature.get();
  }
  int keyframe_frame(int k) const { return keyframes_[static_cast<std::size_t>(k)].frame; }

  int width() const { return width_; }
  int height() const { return height_; }
  int num_frames() const { return static_cast<int>(poses_.size()); }
  int num_keyframes() const { return static_cast<int>(keyframes_.size()); }
  const backend::PoseGraph& graph() const { return graph_; }

  /// The pairs, their verdicts, the solve. `fitter`: how a pair is matched
  /// (MakeStandardPairFitter in a run); `run_seed`: the run's RANSAC seed. `absolute`: fixes
  /// added to the solve beside the pairs (e.g. each frame's GPS position in the local frame,
  /// pipeline/run_steps.h OptimizeFlight), their `pose` the frame's index in the order added;
  /// they take the robust cost as every factor (a bad fix is down-weighted: OptimizedFlight::
  /// absolute_outliers). Throws InvalidArgument when no frame was added, or naming an absolute
  /// factor that is invalid (backend::PoseGraph::AddAbsolute).
  OptimizedFlight Optimize(const PairFitter& fitter, std::uint64_t run_seed,
                           const std::vector<backend::AbsoluteFactor>& absolute = {}) const;

 private:
  struct Keyframe {
    int frame = 0;
    double gsd = 1.0;
    double path_m = 0.0;  // causal path length from the first frame
    std::shared_ptr<const FeatureSet> features;
    std::shared_ptr<const PlaceSignature> signature;  // with BackendOptions::closures
  };
  backend::RelativeFactor StepFactor(const FrameResult& r) const;
  // Keyframe i's candidate partners j > i + 1, nearest first, at most max_pairs_per_keyframe.
  std::vector<int> CandidatesOf(int i) const;
  // Fits and judges the pair (a, b); *f is the factor when kAdded; *record what was found.
  // `guided`: the fitter is given the causal prediction as its prior; `closure`: judged by
  // JudgeClosure (a loop closure by appearance), else by JudgePair.
  PairVerdict TryPair(const Keyframe& a, const Keyframe& b, const PairFitter& fitter,
                      std::uint64_t run_seed, bool guided, backend::RelativeFactor* f,
                      TriedPair* record, bool closure = false) const;
  // The covariance of (x, y, heading) of frame b in frame a's coordinates (a < b; zero when
  // a >= b), chained from the step factors of frames a + 1..b along the causal poses (a step
  // from a frame before a starts from zero).
  Eigen::Matrix3d ChainCovariance(int a, int b) const;
  // AddFix's correction c of frame k spread over the estimates from `anchor` + 1 on.
  void SpreadCorrection(int anchor, int k, const Eigen::Vector3d& c);
  // Keyframe i's closure candidates by appearance: older keyframes j <= i - 2 whose frame is
  // at least `window` frames before i's, within closure_search_radius by the causal track, with
  // a relative similarity of at least closure_similarity; the most similar first (ties: the
  // older first), at most closure_max_candidates.
  std::vector<int> ClosureCandidatesOf(int i) const;
  // The online matches of the newest frame `cur` (AddOnline), added to graph_; the frames
  // matched appended to *tried.
  void MatchRecent(const Keyframe& cur, int reference, const PairFitter& fitter,
                   std::uint64_t run_seed, WindowedPose* out, std::vector<int>* tried);
  // The online closures of the newest keyframe (AddOnline), skipping the frames in `tried`;
  // returns whether one was added to graph_.
  bool MatchClosures(const PairFitter& fitter, std::uint64_t run_seed,
                     const std::vector<int>& tried, WindowedPose* out);
  // Offline: the closure candidates of every keyframe (skipping the pairs in `tried`, keyframe
  // indices), tried, judged, recorded in *out and the verified ones added to *graph.
  void TryClosures(const PairFitter& fitter, std::uint64_t run_seed,
                   const std::vector<std::pair<int, int>>& tried, backend::PoseGraph* graph,
                   OptimizedFlight* out) const;

  BackendOptions options_;
  int width_ = 0, height_ = 0;
  backend::PoseGraph graph_;
  std::vector<backend::Similarity2> poses_;
  std::vector<double> gsd_, path_m_;
  std::vector<int> step_factor_;  // per frame: its step's index in graph_ (-1: the first frame)
  std::vector<Keyframe> keyframes_;
  std::uint64_t seed_ = 0;
  std::optional<DescriptorQuantizer> quantizer_;  // made at the first keyframe (closures)
  std::vector<std::pair<int, int>> online_closures_;  // frame pairs added online (a < b)
  int last_fix_frame_ = 0;                            // AddFix's anchor
  int fixes_fused_ = 0, fixes_gated_ = 0;
};

}  // namespace aerovo
