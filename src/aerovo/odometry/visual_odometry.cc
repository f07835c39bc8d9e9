#include "aerovo/odometry/visual_odometry.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"

namespace aerovo {

void Validate(const OdometryOptions& o) {
  Validate(o.surf);
  Validate(o.correspondence);
  options::CheckRanges(o, "odometry");
  const auto fail = [](const std::string& message) { throw InvalidArgument(message); };
  if (!(o.focal_px >= 0.0) || !std::isfinite(o.focal_px)) {
    fail("odometry.focal_px must be finite and >= 0, got " + options::FormatNumber(o.focal_px));
  }
  if (!(o.default_height_m >= 0.0) || !std::isfinite(o.default_height_m)) {
    fail("odometry.default_height_m must be finite and >= 0, got " +
         options::FormatNumber(o.default_height_m));
  }
  if (o.relocalize_min_inliers < MinSampleSize(o.correspondence.model)) {
    fail("odometry.relocalize_min_inliers must be at least the model's minimal sample");
  }
}

const char* ToString(FrameStatus status) {
  switch (status) {
    case FrameStatus::kFirst:
      return "first";
    case FrameStatus::kOk:
      return "ok";
    case FrameStatus::kReacquired:
      return "reacquired";
    case FrameStatus::kBridged:
      return "bridged";
  }
  return "?";
}

const char* ToString(StepFailure failure) {
  switch (failure) {
    case StepFailure::kNone:
      return "";
    case StepFailure::kTooFewFeatures:
      return "too-few-features";
    case StepFailure::kNoTransform:
      return "no-transform";
    case StepFailure::kTooFewInliers:
      return "too-few-inliers";
    case StepFailure::kImplausibleMotion:
      return "implausible-motion";
  }
  return "?";
}

namespace {

// A frame that later frames may be matched against: its features and the trajectory state at
// that frame (so that a match against it re-anchors the pose, undoing any bridged guesses).
struct Reference {
  FeatureSet features;
  int index = -1;
  double gsd = 1.0;
  bool measured = false;  // its pose came from a match (or it is the first frame), not bridged
  PoseChain chain{ScaleMode::kMetric, 1, 1};
};

// Outcome of one correspondence attempt against one reference.
struct Attempt {
  bool success = false;
  Eigen::Matrix3d curr_from_ref = Eigen::Matrix3d::Identity();
  int n_matched = 0;
  int n_inliers = 0;
  int cluster = -1;
  int attempts = 0;
  bool fell_back = false;
  double correspond_ms = 0.0;
  double estimate_ms = 0.0;
};

Eigen::Matrix3d Power(const Eigen::Matrix3d& m, int k) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  for (int i = 0; i < k; ++i) r = m * r;
  return r;
}

}  // namespace

struct VisualOdometry::Impl {
  explicit Impl(const OdometryOptions& o)
      : surf(o.surf),
        guided(StepOptions(o, true)),
        unguided(StepOptions(o, false)),
        relocalise(RelocaliseOptions(o)),
        refine(RefineOptions(o)) {}

  // Keyframe attempts: unguided (no motion model predicts a relocalisation), on all points (a
  // cell fit with fewer than relocalize_min_inliers would reject the keyframe without ever
  // looking at the whole frame), with relocalize_sampler.
  static CorrespondenceOptions RelocaliseOptions(const OdometryOptions& o) {
    CorrespondenceOptions c = WithGuidance(o.correspondence, false);
    c.method = CorrespondenceMethod::kStandard;
    c.sampler = o.relocalize_sampler;
    return c;
  }

  static CorrespondenceOptions RefineOptions(const OdometryOptions& o) {
    CorrespondenceOptions c = o.correspondence;
    c.method = CorrespondenceMethod::kStandard;
    c.guided_matching = true;
    c.match.guided_radius_px = o.refine_radius_px;
    return c;
  }

  // Frame-to-frame steps: a successful cell is refined on all points by the stage itself
  // (ClusteredRansacOptions::refine_final_radius_px), with the odometry's radius, always, and
  // on every point however many (a track adds up every step's error, and SURF, not this pass,
  // sets the frame rate).
  static CorrespondenceOptions StepOptions(const OdometryOptions& o, bool guided) {
    CorrespondenceOptions c = WithGuidance(o.correspondence, guided);
    c.clustered.refine_final_radius_px = o.refine_on_all_points ? o.refine_radius_px : 0.f;
    c.clustered.refine_final_min_shift_px = 0.f;
    c.clustered.refine_final_max_points = 0;
    return c;
  }

  static CorrespondenceOptions WithGuidance(CorrespondenceOptions c, bool guided) {
    c.guided_matching = guided;
    return c;
  }

  Surf surf;
  CorrespondenceStage guided, unguided, relocalise, refine;

  int width = 0, height = 0;
  int next_index = 0;
  PoseChain chain{ScaleMode::kMetric, 1, 1};
  double gsd_prev_frame = 1.0;
  std::optional<double> yaw0_deg;
  // Most recent frame with enough features (the usual reference) and the last frame whose pose
  // was measured, when it is not that one (after a bridged frame with features).
  std::optional<Reference> prev;
  std::optional<Reference> last_good;
  // Every keyframe_interval-th measured frame, the newest max_keyframes kept.
  std::deque<Reference> keyframes;
  int last_keyframe_index = -1000000;
  std::vector<const Reference*> candidates;
  // Motion of the last measured one-frame step (constant-velocity model).
  Eigen::Matrix3d velocity = Eigen::Matrix3d::Identity();
  bool have_velocity = false;

  // Correspondence of `ref` and `curr`; `prior` = predicted curr_from_ref (clustered: used for
  // the crop and, when guided, the search windows; standard guided: the search windows).
  Attempt Correspond(bool use_guided, const FeatureSet& ref, const FeatureSet& curr,
                     const std::optional<Eigen::Matrix3d>& prior, bool keyframe = false) {
    CorrespondenceStage& stage = keyframe ? relocalise : use_guided ? guided : unguided;
    const CorrespondenceResult c = stage.Run(ref, width, height, curr, prior);
    Attempt a;
    a.success = c.success;
    a.curr_from_ref = c.curr_from_prev;
    a.n_matched = static_cast<int>(c.matches.size());
    a.n_inliers = c.num_inliers;
    a.cluster =
        c.cell_row >= 0 ? c.cell_row * stage.options().clustered.grid_cols + c.cell_col : -1;
    a.attempts = c.attempts;
    a.fell_back = c.fell_back;
    a.correspond_ms = c.match_ms;
    a.estimate_ms = c.estimate_ms;
    return a;
  }

  // Refit of an accepted standard result (fall-back, keyframe) on all points, guided tightly
  // by it (see refine_on_all_points); cell results had the stage's own final pass.
  void Refine(const FeatureSet& ref, const FeatureSet& curr, Attempt* a) {
    const CorrespondenceResult c = refine.Standard(ref, curr, a->curr_from_ref);
    a->correspond_ms += c.match_ms;
    a->estimate_ms += c.estimate_ms;
    ++a->attempts;
    if (c.success && c.num_inliers > a->n_inliers) {
      a->curr_from_ref = c.curr_from_prev;
      a->n_matched = static_cast<int>(c.matches.size());
      a->n_inliers = c.num_inliers;
    }
  }
};

VisualOdometry::VisualOdometry(const OdometryOptions& options) : options_(options) {
  Validate(options_);
  impl_ = std::make_unique<Impl>(options_);
}
VisualOdometry::~VisualOdometry() = default;
VisualOdometry::VisualOdometry(VisualOdometry&&) noexcept = default;
VisualOdometry& VisualOdometry::operator=(VisualOdometry&&) noexcept = default;

namespace {

// Checks an estimated step against what a nadir camera can physically do between two frames.
bool Plausible(const OdometryOptions& o, const Eigen::Matrix3d& t, int width, int height) {
  if (!t.allFinite()) return false;
  const Eigen::Vector2d centre(0.5 * (width - 1), 0.5 * (height - 1));
  const Eigen::Vector3d h = t * centre.homogeneous();
  if (!(std::abs(h.z()) > 1e-9)) return false;
  const Eigen::Matrix2d lin = t.topLeftCorner<2, 2>() / t(2, 2);
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(lin);
  const Eigen::Vector2d sv = svd.singularValues();
  if (!(sv(1) > 1e-9) || lin.determinant() <= 0.0) return false;  // reflection or collapse
  const double scale = std::sqrt(sv(0) * sv(1));
  if (std::abs(scale - 1.0) > o.max_scale_change) return false;
  if (sv(0) / sv(1) > o.max_anisotropy) return false;
  const double shift = (h.head<2>() / h.z() - centre).norm();
  return shift <= o.max_shift_fraction * std::max(width, height);
}

}  // namespace

FrameResult VisualOdometry::Process(const GrayImageView& frame, double time_s,
                                    std::optional<double> height_m, std::optional<double> yaw_deg) {
  Stopwatch total;
  Impl& s = *impl_;
  const OdometryOptions& o = options_;
  FrameResult r;
  r.index = s.next_index;
  r.time_s = time_s;
  if (frame.empty()) {
    throw InvalidArgument("VisualOdometry: frame " + std::to_string(r.index) + " is empty");
  }
  if (r.index == 0) {
    s.width = frame.width;
    s.height = frame.height;
  } else if (frame.width != s.width || frame.height != s.height) {
    throw InputError("frame " + std::to_string(r.index) + ": size " + std::to_string(frame.width) +
                     "x" + std::to_string(frame.height) + " differs from the first frame's " +
                     std::to_string(s.width) + "x" + std::to_string(s.height));
  }
  // Ground sampling distance of this frame.
  double gsd = 1.0;
  if (o.focal_px > 0.0) {
    const double h = height_m ? *height_m : o.default_height_m;
    if (!(h > 0.0) || !std::isfinite(h)) {
      throw InputError("frame " + std::to_string(r.index) +
                       ": no valid height above ground (give telemetry with relative altitude "
                       "or --altitude), got " +
                       std::to_string(h) + " m");
    }
    gsd = h / o.focal_px;
  }
  r.gsd_m_per_px = gsd;

  SurfResult features = s.surf.DetectAndDescribe(frame);
  r.detect_ms = features.detect_ms;
  r.describe_ms = features.describe_ms;
  r.n_surf = static_cast<int>(features.features.size());
  const bool usable = r.n_surf >= o.min_features;

  // No usable frame yet (the flight starts dark, blank or textureless): there is nothing to
  // match against, so the first usable frame starts the trajectory where the bridged frames
  // left it (the origin: nothing has moved it). Without this every later frame would be bridged
  // with zero motion for the whole flight.
  const bool no_reference_yet =
      r.index > 0 && usable && !s.prev && !s.last_good && s.keyframes.empty();
  std::optional<double> heading_override;
  if (r.index == 0 || no_reference_yet) s.yaw0_deg = yaw_deg;
  if (o.heading_from_yaw && yaw_deg && s.yaw0_deg && o.scale_mode == ScaleMode::kMetric) {
    heading_override = -(*yaw_deg - *s.yaw0_deg) * M_PI / 180.0;
  }

  if (r.index == 0 || no_reference_yet) {
    s.chain = PoseChain(o.scale_mode, frame.width, frame.height);
    s.chain.Start(gsd);
    s.have_velocity = false;
    r.status = FrameStatus::kFirst;
  } else {
    // Candidate references, the previous usable frame first.
    // Then, if both fail, the keyframes (relocalisation), newest first.
    std::vector<const Reference*>& candidates = s.candidates;
    candidates.clear();
    if (s.prev) candidates.push_back(&*s.prev);
    if (s.last_good && (!s.prev || s.last_good->index != s.prev->index) &&
        r.index - s.last_good->index <= o.max_reacquire_gap) {
      candidates.push_back(&*s.last_good);
    }
    const std::size_t n_local = candidates.size();
    if (o.relocalize) {
      for (auto it = s.keyframes.rbegin(); it != s.keyframes.rend(); ++it) {
        if (std::none_of(candidates.begin(), candidates.begin() + n_local,
                         [&](const Reference* c) { return c->index == it->index; })) {
          candidates.push_back(&*it);
        }
      }
    }
    const int n_candidates = static_cast<int>(candidates.size());
    r.failure = usable ? StepFailure::kNoTransform : StepFailure::kTooFewFeatures;
    const Reference* accepted = nullptr;
    Attempt best;
    // Local candidates: the first acceptable one wins. Keyframes: all are tried and the one with
    // the most inliers wins (no motion prior confirms a relocalisation, so take the strongest).
    Attempt best_keyframe;
    const Reference* best_keyframe_ref = nullptr;
    bool best_keyframe_guided = false;
    for (int c = 0; c < n_candidates && usable && accepted == nullptr; ++c) {
      const Reference& ref = *candidates[c];
      const int gap = r.index - ref.index;
      const bool keyframe = static_cast<std::size_t>(c) >= n_local;
      std::optional<Eigen::Matrix3d> prior;
      if (s.have_velocity && !keyframe) prior = Power(s.velocity, gap);
      const int needed = keyframe ? o.relocalize_min_inliers : o.correspondence.min_inliers;
      // Guided first (cheap, robust to repeated texture), then unguided.
      for (int pass = 0; pass < 2 && (keyframe || accepted == nullptr); ++pass) {
        const bool guided = pass == 0;
        if (guided && (!o.correspondence.guided_matching || !prior)) continue;
        Attempt a = s.Correspond(guided, ref.features, features.features, prior, keyframe);
        if (o.refine_on_all_points && a.success && a.cluster < 0 &&
            o.correspondence.method == CorrespondenceMethod::kClustered) {
          s.Refine(ref.features, features.features, &a);
        }
        r.correspond_ms += a.correspond_ms;
        r.estimate_ms += a.estimate_ms;
        StepFailure why = StepFailure::kNone;
        if (!a.success) {
          why = StepFailure::kNoTransform;
        } else if (a.n_inliers < needed) {
          why = StepFailure::kTooFewInliers;
        } else if (!Plausible(o, a.curr_from_ref, s.width, s.height)) {
          why = StepFailure::kImplausibleMotion;
        }
        if (keyframe && (why != StepFailure::kNone || a.n_inliers <= best_keyframe.n_inliers)) {
          continue;  // keep the failure of the local candidates / the best keyframe so far
        }
        if (keyframe) {
          best_keyframe = a;
          best_keyframe_ref = &ref;
          best_keyframe_guided = guided;
          continue;
        }
        r.failure = why;
        r.n_matched = a.n_matched;
        r.n_inliers = a.n_inliers;
        r.cluster = a.cluster;
        r.attempts += a.attempts;
        r.fell_back = a.fell_back;
        if (why == StepFailure::kNone) {
          accepted = &ref;
          best = a;
          r.guided = guided;
        }
      }
    }
    if (accepted == nullptr && best_keyframe_ref != nullptr) {
      accepted = best_keyframe_ref;
      best = best_keyframe;
      r.guided = best_keyframe_guided;
      r.relocalized = true;
      r.n_matched = best.n_matched;
      r.n_inliers = best.n_inliers;
      r.cluster = best.cluster;
      r.fell_back = best.fell_back;
    }
    if (accepted != nullptr) {
      const int gap = r.index - accepted->index;
      r.status = gap == 1 ? FrameStatus::kOk : FrameStatus::kReacquired;
      r.reference_index = accepted->index;
      r.curr_from_prev = best.curr_from_ref;
      // Re-anchor on the reference's pose (discarding any bridged guesses since).
      s.chain = accepted->chain;
      s.chain.Step(best.curr_from_ref, accepted->gsd, gsd,
                   heading_override ? &*heading_override : nullptr);
      if (gap == 1) {
        s.velocity = best.curr_from_ref;
        s.have_velocity = true;
      }
      r.failure = StepFailure::kNone;
    } else {
      r.status = FrameStatus::kBridged;
      r.reference_index = s.prev ? s.prev->index : -1;
      r.curr_from_prev = s.have_velocity ? s.velocity : Eigen::Matrix3d::Identity();
      s.chain.Step(r.curr_from_prev, s.gsd_prev_frame, gsd,
                   heading_override ? &*heading_override : nullptr);
    }
  }

  // Bookkeeping of the references.
  const bool measured = r.status != FrameStatus::kBridged;
  if (usable) {
    Reference ref;
    ref.features = std::move(features.features);
    ref.index = r.index;
    ref.gsd = gsd;
    ref.measured = measured;
    ref.chain = s.chain;
    if (measured && o.relocalize && r.index - s.last_keyframe_index >= o.keyframe_interval) {
      s.keyframes.push_back(ref);
      s.last_keyframe_index = r.index;
      if (static_cast<int>(s.keyframes.size()) > o.max_keyframes) s.keyframes.pop_front();
    }
    if (measured) {
      s.last_good.reset();  // this frame is both the previous and the last good frame
    } else if (s.prev && s.prev->measured) {
      // Bridged over a usable frame: keep the last measured one for re-acquisition.
      s.last_good = std::move(s.prev);
    }
    s.prev = std::move(ref);
  }
  if (s.last_good && r.index - s.last_good->index >= o.max_reacquire_gap) s.last_good.reset();
  s.gsd_prev_frame = gsd;

  r.world_from_frame = s.chain.world_from_frame();
  r.position_m = s.chain.position_m();
  r.heading_rad = s.chain.heading_rad();
  r.step_scale = LinearScale(r.curr_from_prev);
  ++s.next_index;
  ++stats_.frames;
  if (r.status == FrameStatus::kOk || r.status == FrameStatus::kFirst) ++stats_.ok;
  if (r.status == FrameStatus::kReacquired) ++stats_.reacquired;
  if (r.status == FrameStatus::kBridged) ++stats_.bridged;
  r.total_ms = total.elapsed_ms();
  return r;
}

}  // namespace aerovo
