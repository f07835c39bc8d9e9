#include "aerovo/odometry/flight_graph.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "aerovo/backend/pixel_step.h"
#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"

namespace aerovo {

namespace {

using backend::Similarity2;

// Noise of one matched point per axis, px: SURF's localisation on the RANSAC inliers (within
// the 1.5 px threshold of RansacOptions).
constexpr double kPointSigmaPx = 1.0;
// What a fit's information leaves out (pixel_step.h: a plane, independent point errors): a
// translation error of kModelFraction of the measured displacement plus kFloorPx pixels, and a
// heading error of kHeadingSigmaRad, added to the fit's covariance. Our choice: the causal
// tracks drift by 1-2 % of the path (BENCHMARKS.md), which a chain of steps whose covariance is
// the fit's alone (millimetres) would call impossible, and the robust cost would then ignore
// every true overlap as an outlier.
constexpr double kModelFraction = 0.01;
constexpr double kFloorPx = 0.5;
constexpr double kHeadingSigmaRad = 0.002;
// The log-scale of every relative factor: 0 with this standard deviation (file comment).
constexpr double kLogScaleSigma = 1e-3;
// A bridged step (no measurement, the constant-velocity guess): its translation is known to its
// own length plus half a footprint side, its heading to 0.3 rad.
constexpr double kBridgedHeadingSigmaRad = 0.3;
// The gate's floor, fraction of the footprint side; and the largest log-scale disagreement.
constexpr double kGateFloorFraction = 0.1;
constexpr double kGateLogScale = 0.2;
// The closures' chi-square gate (JudgeClosure): 3 degrees of freedom at 0.999, and its square
// root, the linear gate's bound in standard deviations of the drift model.
constexpr double kClosureGateChi2 = 16.27;
constexpr double kClosureGateSigmas = 4.034;
// AddFix's gate: chi-square at 0.999 with 2 (position) and 3 (position and heading) degrees of
// freedom.
constexpr double kFixGateChi2Position = 13.82;
constexpr double kFixGateChi2WithHeading = 16.27;
// Random projections per descriptor word of the keyframe signatures (place_signature.h): 2^16
// words, so that two unrelated frames of ~1000 points share few words by chance (about
// 1000^2 / 2^16 = 15 of 1000) while a ground point seen twice keeps its word about half the time.
constexpr int kSignatureBits = 16;

// The information of covariance `cov` with the log-scale row and column replaced by the
// log-scale's own (kLogScaleSigma, uncorrelated).
Eigen::Matrix4d InformationOf(Eigen::Matrix4d cov) {
  cov.row(3).setZero();
  cov.col(3).setZero();
  cov(3, 3) = kLogScaleSigma * kLogScaleSigma;
  cov = 0.5 * (cov + cov.transpose());
  Eigen::Matrix4d info = cov.ldlt().solve(Eigen::Matrix4d::Identity());
  return 0.5 * (info + info.transpose());
}

// The information of a fitted pair: the fit's covariance (pixel_step.h) plus the model's.
Eigen::Matrix4d FitInformation(const Eigen::Matrix2Xd& inliers_curr_px, const Similarity2& z,
                               const Eigen::Vector2d& centre_px, double gsd_prev,
                               double gsd_curr) {
  const Eigen::Matrix4d fit_info = backend::SimilarityFitInformation(
      inliers_curr_px, z, centre_px, gsd_prev, gsd_curr, kPointSigmaPx);
  Eigen::Matrix4d cov = fit_info.ldlt().solve(Eigen::Matrix4d::Identity());
  const double st = kModelFraction * z.translation_m.norm() + kFloorPx * gsd_prev;
  cov(0, 0) += st * st;
  cov(1, 1) += st * st;
  cov(2, 2) += kHeadingSigmaRad * kHeadingSigmaRad;
  return InformationOf(cov);
}

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// The inliers' bounding box, fraction of a width x height image.
double SpreadOf(const Eigen::Matrix2Xd& p, int width, int height) {
  if (p.cols() < 2) return 0.0;
  const Eigen::Vector2d lo = p.rowwise().minCoeff(), hi = p.rowwise().maxCoeff();
  return (hi - lo).prod() / (static_cast<double>(width) * height);
}

}  // namespace

void Validate(const BackendOptions& o) { options::CheckRanges(o, "backend"); }

std::uint64_t PairSeed(std::uint64_t run_seed, int a, int b) {
  const std::uint64_t lo = static_cast<std::uint64_t>(std::min(a, b));
  const std::uint64_t hi = static_cast<std::uint64_t>(std::max(a, b));
  return SplitMix64(SplitMix64(SplitMix64(run_seed) ^ lo) ^ hi);
}

PairFitter MakeStandardPairFitter(const CorrespondenceOptions& options, int width, int height) {
  CorrespondenceOptions c = options;
  c.method = CorrespondenceMethod::kStandard;
  c.guided_matching = false;
  Validate(c);
  const bool refit = c.clustered.refine && c.clustered.refine_fallback &&
                     c.clustered.refine_final_radius_px > 0.f;
  return [c, refit, width, height](const FeatureSet& prev, const FeatureSet& curr,
                                   std::uint64_t seed,
                                   const std::optional<Eigen::Matrix3d>& prior)
             -> std::optional<PairFit> {
    CorrespondenceOptions seeded = c;
    seeded.ransac.seed = seed;
    seeded.guided_matching = prior.has_value();
    CorrespondenceStage stage(seeded);
    CorrespondenceResult r = stage.Run(prev, width, height, curr, prior);
    if (refit) stage.RefitOnAllPoints(prev, curr, &r);
    if (!r.success) return std::nullopt;
    PairFit fit;
    fit.curr_from_prev_px = r.curr_from_prev;
    fit.inliers_curr_px.resize(2, r.num_inliers);
    Eigen::Index k = 0;
    for (std::size_t i = 0; i < r.matches.size() && k < r.num_inliers; ++i) {
      if (r.inlier_mask[i] == 0) continue;
      const Keypoint& p = curr.keypoints[static_cast<std::size_t>(r.matches[i].curr_index)];
      fit.inliers_curr_px.col(k++) = Eigen::Vector2d(p.x, p.y);
    }
    fit.inliers_curr_px.conservativeResize(2, k);
    return fit;
  };
}

const char* ToString(PairVerdict verdict) {
  switch (verdict) {
    case PairVerdict::kAdded: return "added";
    case PairVerdict::kNoFit: return "no_fit";
    case PairVerdict::kTooFewInliers: return "too_few_inliers";
    case PairVerdict::kTooLittleSpread: return "too_little_spread";
    case PairVerdict::kGate: return "gate";
  }
  return "unknown";
}

PairVerdict JudgePair(const BackendOptions& o, const Similarity2& fit, const Similarity2& predicted,
                      int n_inliers, double spread, double path_m, double side_m) {
  if (n_inliers < o.min_inliers) return PairVerdict::kTooFewInliers;
  if (spread < o.min_spread) return PairVerdict::kTooLittleSpread;
  const double allowed_m = o.gate * path_m + kGateFloorFraction * side_m;
  const double heading_deg =
      std::abs(backend::WrapAngleRad(fit.heading_rad - predicted.heading_rad)) * kRadToDeg;
  if (!((fit.translation_m - predicted.translation_m).norm() <= allowed_m) ||
      !(heading_deg <= o.gate_heading_deg) ||
      !(std::abs(fit.log_scale - predicted.log_scale) <= kGateLogScale)) {
    return PairVerdict::kGate;
  }
  return PairVerdict::kAdded;
}

PairVerdict JudgeClosure(const BackendOptions& o, const Similarity2& fit,
                         const Similarity2& predicted, int n_inliers, double spread,
                         const Eigen::Matrix3d& chain_cov, const Eigen::Matrix3d& fit_cov,
                         double path_m, double side_m) {
  if (n_inliers < o.min_inliers) return PairVerdict::kTooFewInliers;
  if (spread < o.min_spread) return PairVerdict::kTooLittleSpread;
  const double st = (o.gate * path_m + kGateFloorFraction * side_m) / kClosureGateSigmas;
  const double sh = o.gate_heading_deg * kDegToRad / kClosureGateSigmas;
  Eigen::Matrix3d cov = chain_cov + fit_cov;
  cov.diagonal() += Eigen::Vector3d(st * st, st * st, sh * sh);
  Eigen::Vector3d e;
  e << fit.translation_m - predicted.translation_m,
      backend::WrapAngleRad(fit.heading_rad - predicted.heading_rad);
  const double d2 = e.dot(cov.ldlt().solve(e));
  if (!(d2 <= kClosureGateChi2) ||
      !(std::abs(fit.log_scale - predicted.log_scale) <= kGateLogScale)) {
    return PairVerdict::kGate;
  }
  return PairVerdict::kAdded;
}

FlightGraph::FlightGraph(const BackendOptions& options, int width, int height,
                         std::uint64_t seed)
    : options_(options), width_(width), height_(height), seed_(seed) {
  Validate(options_);
  if (width <= 0 || height <= 0) {
    throw InvalidArgument("FlightGraph: the frame size must be positive, got " +
                          std::to_string(width) + "x" + std::to_string(height));
  }
}

backend::RelativeFactor FlightGraph::StepFactor(const FrameResult& r) const {
  const Eigen::Vector2d centre(0.5 * (width_ - 1), 0.5 * (height_ - 1));
  const Similarity2 pose{r.position_m, r.heading_rad, 0.0};
  backend::RelativeFactor f;
  f.curr = r.index;
  const bool measured = (r.status == FrameStatus::kOk || r.status == FrameStatus::kReacquired) &&
                        r.reference_index >= 0 && r.reference_index < r.index &&
                        r.step_inliers_curr_px.cols() >= 2;
  if (measured) {
    f.prev = r.reference_index;
    const double gsd_prev = gsd_[static_cast<std::size_t>(f.prev)];
    f.prev_from_curr =
        backend::PrevFromCurrOfPixelStep(r.curr_from_prev, centre, gsd_prev, r.gsd_m_per_px);
    f.information = FitInformation(r.step_inliers_curr_px, f.prev_from_curr, centre, gsd_prev,
                                   r.gsd_m_per_px);
    f.prev_from_curr.log_scale = 0.0;
    return f;
  }
  // Bridged (or a restart after unusable frames): the causal guess, weakly.
  f.prev = r.index - 1;
  f.prev_from_curr = backend::Between(poses_.back(), pose);
  f.prev_from_curr.log_scale = 0.0;
  const double st = f.prev_from_curr.translation_m.norm() +
                    0.5 * r.gsd_m_per_px * std::min(width_, height_);
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();
  cov.diagonal() << st * st, st * st, kBridgedHeadingSigmaRad * kBridgedHeadingSigmaRad, 0.0;
  f.information = InformationOf(cov);
  return f;
}

void FlightGraph::Add(const FrameResult& r) {
  if (r.index != num_frames()) {
    throw InvalidArgument("FlightGraph::Add: frame " + std::to_string(r.index) +
                          " given after " + std::to_string(num_frames()) + " frames");
  }
  const Similarity2 pose{r.position_m, r.heading_rad, 0.0};
  const double path = poses_.empty()
                          ? 0.0
                          : path_m_.back() + (pose.translation_m - poses_.back().translation_m).norm();
  if (r.index > 0) {
    const backend::RelativeFactor f = StepFactor(r);
    // Online, the estimates before this frame may have moved from the causal poses: the new
    // pose starts at the previous estimate moved by the causal step.
    graph_.AddPose(options_.online ? graph_.estimates().back() *
                                         backend::Between(poses_.back(), pose)
                                   : pose);
    step_factor_.push_back(graph_.AddRelative(f));
  } else {
    graph_.AddPose(pose);
    step_factor_.push_back(-1);
  }
  poses_.push_back(pose);
  gsd_.push_back(r.gsd_m_per_px);
  path_m_.push_back(path);
  const bool measured = r.status != FrameStatus::kBridged;
  if (!measured || r.features == nullptr) return;
  const double side_m = r.gsd_m_per_px * std::min(width_, height_);
  if (!keyframes_.empty()) {
    const Eigen::Vector2d last = poses_[static_cast<std::size_t>(keyframes_.back().frame)].translation_m;
    if ((pose.translation_m - last).norm() < options_.keyframe_spacing * side_m) return;
  }
  std::shared_ptr<const PlaceSignature> signature;
  if (options_.closures) {
    if (!quantizer_) quantizer_.emplace(*r.features, kSignatureBits, seed_);
    if (r.features->descriptor_size == quantizer_->descriptor_size()) {
      signature = std::make_shared<const PlaceSignature>(SignatureOf(*quantizer_, *r.features));
    }
  }
  keyframes_.push_back({r.index, r.gsd_m_per_px, path, r.features, std::move(signature)});
}

std::vector<int> FlightGraph::ClosureCandidatesOf(int i) const {
  std::vector<int> out;
  if (i < 2) return out;
  const Keyframe& a = keyframes_[static_cast<std::size_t>(i)];
  const Keyframe& before = keyframes_[static_cast<std::size_t>(i - 1)];
  if (!a.signature || !before.signature) return out;
  const double reference = Similarity(*a.signature, *before.signature);
  if (!(reference > 0.0)) return out;
  const Eigen::Vector2d& ca = poses_[static_cast<std::size_t>(a.frame)].translation_m;
  std::vector<std::pair<double, int>> similar;
  for (int j = 0; j <= i - 2; ++j) {
    const Keyframe& b = keyframes_[static_cast<std::size_t>(j)];
    if (b.frame > a.frame - options_.window) break;  // keyframes in frame order
    if (!b.signature) continue;
    const double side_m = std::min(a.gsd, b.gsd) * std::min(width_, height_);
    const double d = (poses_[static_cast<std::size_t>(b.frame)].translation_m - ca).norm();
    if (d > options_.closure_search_radius * side_m) continue;
    const double score = Similarity(*a.signature, *b.signature) / reference;
    if (score >= options_.closure_similarity) similar.emplace_back(-score, j);
  }
  std::sort(similar.begin(), similar.end());
  for (const auto& [negative_score, j] : similar) {
    if (static_cast<int>(out.size()) >= options_.closure_max_candidates) break;
    out.push_back(j);
  }
  return out;
}

std::vector<int> FlightGraph::CandidatesOf(int i) const {
  const Keyframe& a = keyframes_[static_cast<std::size_t>(i)];
  const Eigen::Vector2d& ca = poses_[static_cast<std::size_t>(a.frame)].translation_m;
  std::vector<std::pair<double, int>> near;
  for (int j = i + 2; j < num_keyframes(); ++j) {
    const Keyframe& b = keyframes_[static_cast<std::size_t>(j)];
    const double side_m = std::min(a.gsd, b.gsd) * std::min(width_, height_);
    const double d = (poses_[static_cast<std::size_t>(b.frame)].translation_m - ca).norm();
    if (d <= options_.search_radius * side_m) near.emplace_back(d, j);
  }
  std::sort(near.begin(), near.end());
  std::vector<int> out;
  for (const auto& [d, j] : near) {
    if (static_cast<int>(out.size()) >= options_.max_pairs_per_keyframe) break;
    out.push_back(j);
  }
  return out;
}

Eigen::Matrix3d FlightGraph::ChainCovariance(int a, int b) const {
  if (a >= b) return Eigen::Matrix3d::Zero();
  std::vector<Eigen::Matrix3d> cov(static_cast<std::size_t>(b - a + 1), Eigen::Matrix3d::Zero());
  const Similarity2 a_from_local = poses_[static_cast<std::size_t>(a)].Inverse();
  for (int k = a + 1; k <= b; ++k) {
    const backend::RelativeFactor& f =
        graph_.relative_factors()[static_cast<std::size_t>(step_factor_[static_cast<std::size_t>(k)])];
    const Eigen::Matrix3d q =
        f.information.ldlt().solve(Eigen::Matrix4d::Identity()).topLeftCorner<3, 3>();
    // The step's start in frame a's coordinates (a_from_prev), and its translation there.
    const int p = std::max(f.prev, a);
    const Similarity2 a_from_prev = a_from_local * poses_[static_cast<std::size_t>(p)];
    const Eigen::Vector2d d = a_from_prev.Linear() * f.prev_from_curr.translation_m;
    Eigen::Matrix3d j1 = Eigen::Matrix3d::Identity(), j2 = Eigen::Matrix3d::Identity();
    j1(0, 2) = -d.y();
    j1(1, 2) = d.x();
    j2.topLeftCorner<2, 2>() = a_from_prev.Linear();
    const Eigen::Matrix3d& before = cov[static_cast<std::size_t>(p - a)];
    cov[static_cast<std::size_t>(k - a)] = j1 * before * j1.transpose() + j2 * q * j2.transpose();
  }
  return cov.back();
}

PairVerdict FlightGraph::TryPair(const Keyframe& a, const Keyframe& b, const PairFitter& fitter,
                                 std::uint64_t run_seed, bool guided,
                                 backend::RelativeFactor* f, TriedPair* record,
                                 bool closure) const {
  record->a = a.frame;
  record->b = b.frame;
  record->predicted = backend::Between(poses_[static_cast<std::size_t>(a.frame)],
                                       poses_[static_cast<std::size_t>(b.frame)]);
  const Eigen::Vector2d centre(0.5 * (width_ - 1), 0.5 * (height_ - 1));
  std::optional<Eigen::Matrix3d> prior;
  if (guided) prior = backend::PixelStepOfPrevFromCurr(record->predicted, centre, a.gsd, b.gsd);
  const std::optional<PairFit> fit =
      fitter(*a.features, *b.features, PairSeed(run_seed, a.frame, b.frame), prior);
  if (fit) record->inliers = static_cast<int>(fit->inliers_curr_px.cols());
  if (!fit || fit->inliers_curr_px.cols() < 2) return PairVerdict::kNoFit;
  try {
    f->prev = a.frame;
    f->curr = b.frame;
    f->prev_from_curr =
        backend::PrevFromCurrOfPixelStep(fit->curr_from_prev_px, centre, a.gsd, b.gsd);
    record->fit = f->prev_from_curr;
    record->spread = SpreadOf(fit->inliers_curr_px, width_, height_);
    const int n = static_cast<int>(fit->inliers_curr_px.cols());
    const double path_m = b.path_m - a.path_m;
    const double side_m = std::min(a.gsd, b.gsd) * std::min(width_, height_);
    f->information = FitInformation(fit->inliers_curr_px, f->prev_from_curr, centre, a.gsd, b.gsd);
    const PairVerdict verdict =
        closure ? JudgeClosure(options_, f->prev_from_curr, record->predicted, n, record->spread,
                               ChainCovariance(a.frame, b.frame),
                               f->information.ldlt().solve(Eigen::Matrix4d::Identity())
                                   .topLeftCorner<3, 3>(),
                               path_m, side_m)
                : JudgePair(options_, f->prev_from_curr, record->predicted, n, record->spread,
                            path_m, side_m);
    if (verdict != PairVerdict::kAdded) return verdict;
    f->prev_from_curr.log_scale = 0.0;
    return verdict;
  } catch (const InvalidArgument&) {  // a singular or degenerate fit
    return PairVerdict::kNoFit;
  }
}

void FlightGraph::MatchRecent(const Keyframe& cur, int reference, const PairFitter& fitter,
                              std::uint64_t run_seed, WindowedPose* out,
                              std::vector<int>* tried) {
  const Eigen::Vector2d& c = poses_[static_cast<std::size_t>(cur.frame)].translation_m;
  for (int k = num_keyframes() - 1; k >= 0 && out->pairs_tried < options_.online_keyframes; --k) {
    const Keyframe& kf = keyframes_[static_cast<std::size_t>(k)];
    if (kf.frame >= cur.frame || kf.frame == reference) continue;
    const double side_m = std::min(kf.gsd, cur.gsd) * std::min(width_, height_);
    const double d = (poses_[static_cast<std::size_t>(kf.frame)].translation_m - c).norm();
    if (d > options_.search_radius * side_m) break;  // older keyframes are farther still
    ++out->pairs_tried;
    tried->push_back(kf.frame);
    backend::RelativeFactor f;
    TriedPair record;
    const PairVerdict verdict = TryPair(kf, cur, fitter, run_seed, true, &f, &record);
    if (verdict == PairVerdict::kAdded) {
      graph_.AddRelative(f);
      ++out->pairs_verified;
    } else if (verdict == PairVerdict::kGate) {
      ++out->pairs_gated;
    }
  }
}

bool FlightGraph::MatchClosures(const PairFitter& fitter, std::uint64_t run_seed,
                                const std::vector<int>& tried, WindowedPose* out) {
  const int i = num_keyframes() - 1;
  const Keyframe& cur = keyframes_[static_cast<std::size_t>(i)];
  bool added = false;
  for (const int j : ClosureCandidatesOf(i)) {
    const Keyframe& kf = keyframes_[static_cast<std::size_t>(j)];
    if (std::find(tried.begin(), tried.end(), kf.frame) != tried.end()) continue;
    ++out->closures_tried;
    backend::RelativeFactor f;
    TriedPair record;
    const PairVerdict verdict = TryPair(kf, cur, fitter, run_seed, false, &f, &record, true);
    if (verdict == PairVerdict::kAdded) {
      graph_.AddRelative(f);
      online_closures_.emplace_back(kf.frame, cur.frame);
      ++out->closures_verified;
      added = true;
    } else if (verdict == PairVerdict::kGate) {
      ++out->closures_gated;
    }
  }
  return added;
}

WindowedPose FlightGraph::AddOnline(const FrameResult& r, const PairFitter& fitter,
                                    std::uint64_t run_seed) {
  if (!options_.online) throw InvalidArgument("FlightGraph::AddOnline: backend.online is off");
  Add(r);
  WindowedPose out;
  const int n = num_frames();
  std::vector<int> tried;
  if (fitter && r.features != nullptr && r.status != FrameStatus::kBridged && n > 1) {
    MatchRecent({r.index, r.gsd_m_per_px, path_m_.back(), r.features, nullptr}, r.reference_index,
                fitter, run_seed, &out, &tried);
  }
  if (fitter && options_.closures && !keyframes_.empty() && keyframes_.back().frame == r.index &&
      MatchClosures(fitter, run_seed, tried, &out)) {
    // A closure reaches far behind the window: the poses between its ends must move too, which
    // the window (older poses held) cannot do; the whole graph is solved (docs/backend.md).
    const Stopwatch full_time;
    graph_.SetEstimates(backend::OptimizeAll(graph_, backend::PoseGraphOptions{}).local_from_frame);
    out.full_solve = true;
    out.full_solve_ms = full_time.elapsed_ms();
  }
  out.window_first = std::max(0, n - options_.window);
  out.local_from_frame = graph_.estimates().back();
  if (n < 2) return out;
  backend::PoseGraphOptions solve;
  solve.covariance = true;
  const backend::PoseGraphResult result =
      backend::OptimizeWindow(graph_, out.window_first, n - 1, solve);
  for (int i = out.window_first; i < n; ++i) {
    graph_.SetEstimate(i, result.local_from_frame[static_cast<std::size_t>(i)]);
  }
  out.local_from_frame = result.local_from_frame.back();
  if (!result.covariance.empty() && result.covariance.back().allFinite()) {
    out.covariance = result.covariance.back();
    out.has_covariance = true;
  }
  return out;
}

void FlightGraph::TryClosures(const PairFitter& fitter, std::uint64_t run_seed,
                              const std::vector<std::pair<int, int>>& tried,
                              backend::PoseGraph* graph, OptimizedFlight* out) const {
  for (int i = 0; i < num_keyframes(); ++i) {
    const Keyframe& b = keyframes_[static_cast<std::size_t>(i)];
    for (const int j : ClosureCandidatesOf(i)) {
      const Keyframe& a = keyframes_[static_cast<std::size_t>(j)];
      const std::pair<int, int> frames(a.frame, b.frame);
      if (std::find(tried.begin(), tried.end(), std::make_pair(j, i)) != tried.end() ||
          std::find(online_closures_.begin(), online_closures_.end(), frames) !=
              online_closures_.end()) {
        continue;  // a footprint pair, or a closure already in the graph
      }
      ++out->pairs_tried;
      ++out->closures_tried;
      backend::RelativeFactor f;
      TriedPair record;
      record.verdict = TryPair(a, b, fitter, run_seed, false, &f, &record, true);
      record.by_appearance = true;
      out->pairs.push_back(record);
      if (record.verdict == PairVerdict::kAdded) {
        graph->AddRelative(f);
        ++out->pairs_verified;
        ++out->closures_verified;
      } else {
        ++out->pairs_rejected;
        if (record.verdict == PairVerdict::kGate) {
          ++out->pairs_gated;
          ++out->closures_gated;
        }
      }
    }
  }
}

OptimizedFlight FlightGraph::Optimize(const PairFitter& fitter, std::uint64_t run_seed,
                                      const std::vector<backend::AbsoluteFactor>& absolute) const {
  if (poses_.empty()) throw InvalidArgument("FlightGraph::Optimize: no frame was added");
  OptimizedFlight out;
  out.keyframes = num_keyframes();
  out.local_from_frame = poses_;
  backend::PoseGraph graph = graph_;
  for (int i = 0; i < graph.num_poses(); ++i) graph.SetHeld(i, false);  // AddFix's, online only
  const std::size_t base_factors = graph.relative_factors().size();
  const std::size_t base_absolute = graph.absolute_factors().size();
  for (const backend::AbsoluteFactor& f : absolute) graph.AddAbsolute(f);
  out.absolute = static_cast<int>(absolute.size());
  const Stopwatch match_time;
  std::vector<std::pair<int, int>> tried;  // keyframe indices, as tried
  for (int i = 0; i < num_keyframes(); ++i) {
    for (const int j : CandidatesOf(i)) {
      const std::pair<int, int> frames(keyframes_[static_cast<std::size_t>(i)].frame,
                                       keyframes_[static_cast<std::size_t>(j)].frame);
      if (std::find(online_closures_.begin(), online_closures_.end(), frames) !=
          online_closures_.end()) {
        continue;  // already a factor of the graph (an online closure)
      }
      tried.emplace_back(i, j);
      ++out.pairs_tried;
      backend::RelativeFactor f;
      TriedPair record;
      const PairVerdict verdict = TryPair(keyframes_[static_cast<std::size_t>(i)],
                                          keyframes_[static_cast<std::size_t>(j)], fitter,
                                          run_seed, false, &f, &record);
      record.verdict = verdict;
      out.pairs.push_back(record);
      if (verdict == PairVerdict::kAdded) {
        graph.AddRelative(f);
        ++out.pairs_verified;
      } else {
        ++out.pairs_rejected;
        if (verdict == PairVerdict::kGate) ++out.pairs_gated;
      }
    }
  }
  if (options_.closures) TryClosures(fitter, run_seed, tried, &graph, &out);
  out.match_s = match_time.elapsed_ms() / 1000.0;
  if (graph.num_poses() < 2) return out;
  const Stopwatch solve_time;
  const backend::PoseGraphResult result = backend::OptimizeAll(graph, backend::PoseGraphOptions{});
  out.solve_s = solve_time.elapsed_ms() / 1000.0;
  out.iterations = result.iterations;
  out.local_from_frame = result.local_from_frame;
  std::size_t k = base_factors;
  for (TriedPair& p : out.pairs) {
    if (p.verdict != PairVerdict::kAdded || k >= result.relative.size()) continue;
    p.down_weighted = result.relative[k++].outlier;
    out.outliers += p.down_weighted ? 1 : 0;
  }
  for (std::size_t a = base_absolute; a < result.absolute.size(); ++a) {
    out.absolute_outliers += result.absolute[a].outlier ? 1 : 0;
  }
  return out;
}

void FlightGraph::SpreadCorrection(int anchor, int k, const Eigen::Vector3d& c) {
  const Similarity2 at_k = graph_.estimates()[static_cast<std::size_t>(k)];
  const Eigen::Rotation2Dd turn(c.z());
  const double start = path_m_[static_cast<std::size_t>(anchor)];
  const double span = path_m_[static_cast<std::size_t>(k)] - start;
  for (int j = anchor + 1; j < num_frames(); ++j) {
    Similarity2 p = graph_.estimates()[static_cast<std::size_t>(j)];
    if (j < k) {  // between the anchor and the fix: the fraction of the path from the anchor
      const double w = span > 0.0 ? (path_m_[static_cast<std::size_t>(j)] - start) / span : 1.0;
      p.translation_m += w * c.head<2>();
      p.heading_rad = backend::WrapAngleRad(p.heading_rad + w * c.z());
    } else {  // the fix's frame and the later ones: rigidly, turned about the fix's frame
      p.translation_m = at_k.translation_m + c.head<2>() +
                        turn * (p.translation_m - at_k.translation_m);
      p.heading_rad = backend::WrapAngleRad(p.heading_rad + c.z());
    }
    graph_.SetEstimate(j, p);
  }
}

FixOutcome FlightGraph::AddFix(const GraphFix& fix) {
  const int k = fix.frame, n = num_frames();
  if (!options_.online) throw InvalidArgument("FlightGraph::AddFix: backend.online is off");
  if (k < 0 || k >= n) {
    throw InvalidArgument("FlightGraph::AddFix: frame " + std::to_string(k) +
                          " is not in the graph (" + std::to_string(n) + " frames)");
  }
  const bool heading = fix.heading_rad.has_value();
  if (!fix.position_m.allFinite() || !fix.position_cov_m2.allFinite() ||
      !(fix.placement_sigma_m >= 0.0) || !std::isfinite(fix.placement_sigma_m) ||
      (heading && (!std::isfinite(*fix.heading_rad) || !(fix.heading_var_rad2 > 0.0))) ||
      !(fix.position_cov_m2.determinant() > 0.0) || !(fix.position_cov_m2(0, 0) > 0.0)) {
    throw InvalidArgument("FlightGraph::AddFix: the fix of frame " + std::to_string(k) +
                          " is not finite, its covariance is not positive definite or its "
                          "placement sigma is negative");
  }
  const int a = std::min(last_fix_frame_, k);
  // P: the frame's uncertainty since the anchor, in the local frame.
  Eigen::Matrix3d p = ChainCovariance(a, k);
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  rot.topLeftCorner<2, 2>() = poses_[static_cast<std::size_t>(a)].Linear() /
                              std::exp(poses_[static_cast<std::size_t>(a)].log_scale);
  p = rot * p * rot.transpose();
  const double side_m = gsd_[static_cast<std::size_t>(k)] * std::min(width_, height_);
  const double path_m = path_m_[static_cast<std::size_t>(k)] - path_m_[static_cast<std::size_t>(a)];
  const double st = (options_.gate * path_m + kGateFloorFraction * side_m) / kClosureGateSigmas;
  const double sh = options_.gate_heading_deg * kDegToRad / kClosureGateSigmas;
  p.diagonal() += Eigen::Vector3d(st * st, st * st, sh * sh);
  if (fixes_fused_ == 0 && fix.placement_sigma_m > 0.0) {
    p.topLeftCorner<2, 2>().diagonal().array() += fix.placement_sigma_m * fix.placement_sigma_m;
  }
  Eigen::Matrix3d r = Eigen::Matrix3d::Zero();
  r.topLeftCorner<2, 2>() = 0.5 * (fix.position_cov_m2 + fix.position_cov_m2.transpose());
  r(2, 2) = heading ? fix.heading_var_rad2 : 0.0;
  const Similarity2 x = graph_.estimates()[static_cast<std::size_t>(k)];
  Eigen::Vector3d e;
  e << fix.position_m - x.translation_m,
      heading ? backend::WrapAngleRad(*fix.heading_rad - x.heading_rad) : 0.0;
  // se = S^-1 e over the measured components (S = P + R; the heading's row left out without
  // one: its component of e and se is then 0).
  Eigen::Vector3d se = Eigen::Vector3d::Zero();
  if (heading) {
    se = (p + r).ldlt().solve(e);
  } else {
    se.head<2>() = (p + r).topLeftCorner<2, 2>().ldlt().solve(Eigen::Vector2d(e.head<2>()));
  }
  FixOutcome out;
  out.d2 = e.dot(se);
  out.bound = heading ? kFixGateChi2WithHeading : kFixGateChi2Position;
  out.newest = graph_.estimates().back();
  if (!(out.d2 <= out.bound)) {
    ++fixes_gated_;
    return out;
  }
  // The correction of every component (the heading's too, through its correlation with the
  // position, when the fix has no heading): P[:, measured] S^-1 e.
  out.correction = p * se;
  SpreadCorrection(a, k, out.correction);
  backend::AbsoluteFactor f;
  f.pose = k;
  f.local_from_frame = Similarity2{fix.position_m, heading ? *fix.heading_rad : 0.0, 0.0};
  f.has_heading = heading;
  f.information.topLeftCorner<2, 2>() = r.topLeftCorner<2, 2>().inverse();
  if (heading) f.information(2, 2) = 1.0 / fix.heading_var_rad2;
  graph_.AddAbsolute(f);
  // The frames up to the fix's are final: a window's solve, whose steps know nothing of the
  // drift the correction undid, must not pull them back (Optimize solves them again).
  for (int j = 0; j <= k; ++j) graph_.SetHeld(j, true);
  last_fix_frame_ = k;
  ++fixes_fused_;
  out.fused = true;
  out.newest_moved_m = (graph_.estimates().back().translation_m - out.newest.translation_m).norm();
  out.newest = graph_.estimates().back();
  return out;
}

}  // namespace aerovo
