#include "aerovo/odometry/visual_odometry.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "aerovo/camera/lens.h"
#include "aerovo/core/angles.h"
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
  std::shared_ptr<const FeatureSet> features;  // shared with FrameResult::features
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
  std::vector<Match> matches;            // the fit's matches (indices into ref, curr)
  std::vector<std::uint8_t> inlier_mask;  // 1 for the fit's inliers
};

Eigen::Matrix3d Power(const Eigen::Matrix3d& m, int k) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  for (int i = 0; i < k; ++i) r = m * r;
  return r;
}

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

// Why an attempt is not an acceptable step needing `needed` inliers (kNone: it is).
StepFailure Judge(const OdometryOptions& o, const Attempt& a, int needed, int width, int height) {
  if (!a.success) return StepFailure::kNoTransform;
  if (a.n_inliers < needed) return StepFailure::kTooFewInliers;
  if (!Plausible(o, a.curr_from_ref, width, height)) return StepFailure::kImplausibleMotion;
  return StepFailure::kNone;
}

CorrespondenceOptions WithGuidance(CorrespondenceOptions c, bool guided) {
  c.guided_matching = guided;
  return c;
}

// Keyframe attempts: unguided (no motion model predicts a relocalisation), on all points (a
// cell fit with fewer than relocalize_min_inliers would reject the keyframe without ever
// looking at the whole frame), with relocalize_sampler.
CorrespondenceOptions RelocaliseOptions(const OdometryOptions& o) {
  CorrespondenceOptions c = WithGuidance(o.correspondence, false);
  c.method = CorrespondenceMethod::kStandard;
  c.sampler = o.relocalize_sampler;
  return c;
}

}  // namespace

namespace {

// The keypoints of a distorted frame to the ideal pinhole (SetLensUndistortion), in place; the
// ones without a pinhole position are removed with their descriptors (no allocation).
void UndistortKeypoints(const LensUndistortion& lens, FeatureSet* features) {
  std::vector<Keypoint>& kps = features->keypoints;
  const std::size_t dim = static_cast<std::size_t>(features->descriptor_size);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < kps.size(); ++i) {
    double u = 0.0, v = 0.0;
    if (!lens.UndistortPixel(kps[i].x, kps[i].y, &u, &v)) continue;
    if (kept != i) {
      kps[kept] = kps[i];
      std::copy_n(features->descriptor(i), dim, features->descriptor(kept));
    }
    kps[kept].x = static_cast<float>(u);
    kps[kept].y = static_cast<float>(v);
    ++kept;
  }
  kps.resize(kept);
  features->descriptors.resize(kept * dim);
}

// The keypoints of a width x height frame seen with `attitude` to the virtual nadir camera
// (focal length focal_px, principal point at the frame centre), in place: matching, RANSAC,
// references and the chain then see nadir-equivalent frames (attitude.h).
void KeypointsToNadir(const CameraAttitude& attitude, double focal_px, int width, int height,
                      FeatureSet* features) {
  const Eigen::Matrix3d h =
      NadirFromCameraHomography(attitude, focal_px, 0.5 * (width - 1), 0.5 * (height - 1));
  for (Keypoint& k : features->keypoints) {
    const Eigen::Vector3d q = h * Eigen::Vector3d(k.x, k.y, 1.0);
    k.x = static_cast<float>(q.x() / q.z());
    k.y = static_cast<float>(q.y() / q.z());
  }
}

}  // namespace

struct VisualOdometry::Impl {
  // Frame-to-frame steps use o.correspondence as given (its refinement included), guided or
  // not; keyframes the relocalisation's options.
  explicit Impl(const OdometryOptions& o)
      : surf(o.surf),
        guided(WithGuidance(o.correspondence, true)),
        unguided(WithGuidance(o.correspondence, false)),
        relocalise(RelocaliseOptions(o)),
        refit_keyframes(o.correspondence.method == CorrespondenceMethod::kClustered &&
                        o.correspondence.clustered.refine &&
                        o.correspondence.clustered.refine_fallback) {}

  Surf surf;
  std::optional<LensUndistortion> lens;  // SetLensUndistortion: keypoints to the ideal pinhole
  double surf_min_response = 0.0;  // Adaptive SURF's floor for the next frame (0 = its option).
  std::vector<float> surf_cell_min_response;  // ... and its floor per grid cell (empty = none).
  CorrespondenceStage guided, unguided, relocalise;
  // A relocalisation is a standard result: refit on all points like a fall-back
  // (ClusteredRansacOptions::refine_fallback) in a clustered run.
  bool refit_keyframes;

  int width = 0, height = 0;
  int next_index = 0;
  bool share_features = false;  // SetShareFeatures
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

  // Frame `index`'s size: the first frame sets it, every later one must have it (InputError).
  void CheckFrameSize(const GrayImageView& frame, int index) {
    if (index == 0) {
      width = frame.width;
      height = frame.height;
    } else if (frame.width != width || frame.height != height) {
      throw InputError("frame " + std::to_string(index) + ": size " + std::to_string(frame.width) +
                       "x" + std::to_string(frame.height) + " differs from the first frame's " +
                       std::to_string(width) + "x" + std::to_string(height));
    }
  }

  // The features of frame r->index: adaptive SURF (the floor steered by the previous frame,
  // SurfResult::next_min_response and next_cell_min_response), the keypoints to the ideal
  // pinhole (SetLensUndistortion; InputError when the frame is not the lens's size), then, with a
  // focal length and an attitude off nadir, to the virtual nadir camera. Sets r's detect_ms,
  // describe_ms, n_surf, tilt_deg and attitude_corrected.
  SurfResult Detect(const OdometryOptions& o, const GrayImageView& frame,
                    const std::optional<CameraAttitude>& attitude, FrameResult* r) {
    SurfResult features = surf.DetectAndDescribe(frame, surf_min_response, surf_cell_min_response);
    surf_min_response = features.next_min_response;
    surf_cell_min_response.swap(features.next_cell_min_response);
    r->detect_ms = features.detect_ms;
    r->describe_ms = features.describe_ms;
    if (lens) {
      if (frame.width != lens->input().width_px || frame.height != lens->input().height_px) {
        throw InputError(fmt::format("frame {}: size {}x{} differs from the lens's {}x{}", r->index,
                                     frame.width, frame.height, lens->input().width_px,
                                     lens->input().height_px));
      }
      UndistortKeypoints(*lens, &features.features);
    }
    r->n_surf = static_cast<int>(features.features.size());
    if (attitude) {
      r->tilt_deg = TiltFromNadirDeg(*attitude);
      if (o.focal_px > 0.0 && (attitude->roll_deg != 0.0 || attitude->pitch_deg != 0.0)) {
        KeypointsToNadir(*attitude, o.focal_px, frame.width, frame.height, &features.features);
        r->attitude_corrected = true;
      }
    }
    return features;
  }

  // Correspondence of `ref` and `curr`; `prior` = predicted curr_from_ref (clustered: used for
  // the crop and, when guided, the search windows; standard guided: the search windows).
  Attempt Correspond(bool use_guided, const FeatureSet& ref, const FeatureSet& curr,
                     const std::optional<Eigen::Matrix3d>& prior, bool keyframe = false) {
    CorrespondenceStage& stage = keyframe ? relocalise : use_guided ? guided : unguided;
    CorrespondenceResult c = stage.Run(ref, width, height, curr, prior);
    // By the step stage: the refit has the steps' sampler, not relocalize_sampler.
    if (keyframe && refit_keyframes) unguided.RefitOnAllPoints(ref, curr, &c);
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
    a.matches = std::move(c.matches);
    a.inlier_mask = std::move(c.inlier_mask);
    return a;
  }

  // Ground sampling distance of frame r.index (m/px; 1 without a focal length).
  static double GroundSamplingDistance(const OdometryOptions& o, int index,
                                       std::optional<double> height_m) {
    if (!(o.focal_px > 0.0)) return 1.0;
    const double h = height_m ? *height_m : o.default_height_m;
    // At most kMaxHeightAboveGroundM: 1e308 m made positions of 1e303 m and inf, status ok.
    if (!(h > 0.0 && h <= kMaxHeightAboveGroundM)) {
      throw InputError("frame " + std::to_string(index) +
                       ": no valid height above ground (give telemetry with relative altitude "
                       "or --altitude), got " +
                       std::to_string(h) + " m");
    }
    return h / o.focal_px;
  }

  // Candidate references of frame `index` into `candidates`: the previous usable frame, then
  // the last good frame (within max_reacquire_gap), then (relocalize) the keyframes, newest
  // first. Returns how many are local (not keyframes).
  std::size_t CollectCandidates(const OdometryOptions& o, int index) {
    candidates.clear();
    if (prev) candidates.push_back(&*prev);
    if (last_good && (!prev || last_good->index != prev->index) &&
        index - last_good->index <= o.max_reacquire_gap) {
      candidates.push_back(&*last_good);
    }
    const std::size_t n_local = candidates.size();
    if (o.relocalize) {
      for (auto it = keyframes.rbegin(); it != keyframes.rend(); ++it) {
        if (std::none_of(candidates.begin(), candidates.begin() + n_local,
                         [&](const Reference* c) { return c->index == it->index; })) {
          candidates.push_back(&*it);
        }
      }
    }
    return n_local;
  }

  // The local candidates: the first acceptable attempt wins, guided first (cheap, robust to
  // repeated texture), then unguided. r's attempt fields are those of the last attempt.
  const Reference* MatchLocal(const OdometryOptions& o, const FeatureSet& curr,
                              std::size_t n_local, FrameResult* r, Attempt* best) {
    for (std::size_t c = 0; c < n_local; ++c) {
      const Reference& ref = *candidates[c];
      std::optional<Eigen::Matrix3d> prior;
      if (have_velocity) prior = Power(velocity, r->index - ref.index);
      for (int pass = 0; pass < 2; ++pass) {
        const bool use_guided = pass == 0;
        if (use_guided && (!o.correspondence.guided_matching || !prior)) continue;
        const Attempt a = Correspond(use_guided, *ref.features, curr, prior);
        r->correspond_ms += a.correspond_ms;
        r->estimate_ms += a.estimate_ms;
        const StepFailure why = Judge(o, a, o.correspondence.min_inliers, width, height);
        r->failure = why;
        r->n_matched = a.n_matched;
        r->n_inliers = a.n_inliers;
        r->cluster = a.cluster;
        r->attempts += a.attempts;
        r->fell_back = a.fell_back;
        if (why == StepFailure::kNone) {
          *best = a;
          r->guided = use_guided;
          return &ref;
        }
      }
    }
    return nullptr;
  }

  // The keyframes (relocalisation): all are tried, unguided, and the acceptable one with the
  // most inliers wins (no motion prior confirms a relocalisation, so take the strongest).
  const Reference* MatchKeyframes(const OdometryOptions& o, const FeatureSet& curr,
                                  std::size_t n_local, FrameResult* r, Attempt* best) {
    const Reference* best_ref = nullptr;
    Attempt best_keyframe;
    for (std::size_t c = n_local; c < candidates.size(); ++c) {
      const Reference& ref = *candidates[c];
      const Attempt a = Correspond(false, *ref.features, curr, std::nullopt, true);
      r->correspond_ms += a.correspond_ms;
      r->estimate_ms += a.estimate_ms;
      if (Judge(o, a, o.relocalize_min_inliers, width, height) != StepFailure::kNone ||
          a.n_inliers <= best_keyframe.n_inliers) {
        continue;  // keep the failure of the local candidates / the best keyframe so far
      }
      best_keyframe = a;
      best_ref = &ref;
    }
    if (best_ref == nullptr) return nullptr;
    *best = best_keyframe;
    r->guided = false;
    r->relocalized = true;
    r->n_matched = best->n_matched;
    r->n_inliers = best->n_inliers;
    r->cluster = best->cluster;
    r->fell_back = best->fell_back;
    return best_ref;
  }

  // The accepted step's inlier points in frame r (FrameResult::step_inliers_curr_px).
  static void StepInliers(const Attempt& a, const FeatureSet& curr, FrameResult* r) {
    int n = 0;
    for (std::uint8_t m : a.inlier_mask) n += m != 0;
    r->step_inliers_curr_px.resize(2, n);
    int k = 0;
    for (std::size_t i = 0; i < a.matches.size() && i < a.inlier_mask.size(); ++i) {
      if (a.inlier_mask[i] == 0) continue;
      const Keypoint& p = curr.keypoints[static_cast<std::size_t>(a.matches[i].curr_index)];
      r->step_inliers_curr_px.col(k++) = Eigen::Vector2d(p.x, p.y);
    }
  }

  // The step of frame r against the candidate references: accepted (re-anchored on the
  // reference's pose) or bridged with the previous step's motion.
  void Step(const OdometryOptions& o, const FeatureSet& curr, bool usable, double gsd,
            const double* heading_override, FrameResult* r) {
    const std::size_t n_local = CollectCandidates(o, r->index);
    r->failure = usable ? StepFailure::kNoTransform : StepFailure::kTooFewFeatures;
    Attempt best;
    const Reference* accepted = nullptr;
    if (usable) {
      accepted = MatchLocal(o, curr, n_local, r, &best);
      if (accepted == nullptr) accepted = MatchKeyframes(o, curr, n_local, r, &best);
    }
    if (accepted != nullptr) {
      const int gap = r->index - accepted->index;
      r->status = gap == 1 ? FrameStatus::kOk : FrameStatus::kReacquired;
      r->reference_index = accepted->index;
      r->curr_from_prev = best.curr_from_ref;
      if (share_features) StepInliers(best, curr, r);
      // Re-anchor on the reference's pose (discarding any bridged guesses since).
      chain = accepted->chain;
      chain.Step(best.curr_from_ref, accepted->gsd, gsd, heading_override);
      if (gap == 1) {
        velocity = best.curr_from_ref;
        have_velocity = true;
      }
      r->failure = StepFailure::kNone;
    } else {
      r->status = FrameStatus::kBridged;
      r->reference_index = prev ? prev->index : -1;
      r->curr_from_prev = have_velocity ? velocity : Eigen::Matrix3d::Identity();
      chain.Step(r->curr_from_prev, gsd_prev_frame, gsd, heading_override);
    }
  }

  // Bookkeeping of the references after frame r (its features are moved in when usable).
  void UpdateReferences(const OdometryOptions& o, const FrameResult& r, bool usable, double gsd,
                        FeatureSet* features, FrameResult* out) {
    const bool measured = r.status != FrameStatus::kBridged;
    if (usable) {
      Reference ref;
      ref.features = std::make_shared<const FeatureSet>(std::move(*features));
      if (share_features) out->features = ref.features;
      ref.index = r.index;
      ref.gsd = gsd;
      ref.measured = measured;
      ref.chain = chain;
      if (measured && o.relocalize && r.index - last_keyframe_index >= o.keyframe_interval) {
        keyframes.push_back(ref);
        last_keyframe_index = r.index;
        if (static_cast<int>(keyframes.size()) > o.max_keyframes) keyframes.pop_front();
      }
      if (measured) {
        last_good.reset();  // this frame is both the previous and the last good frame
      } else if (prev && prev->measured) {
        // Bridged over a usable frame: keep the last measured one for re-acquisition.
        last_good = std::move(prev);
      }
      prev = std::move(ref);
    }
    if (last_good && r.index - last_good->index >= o.max_reacquire_gap) last_good.reset();
    gsd_prev_frame = gsd;
  }
};

VisualOdometry::VisualOdometry(const OdometryOptions& options) : options_(options) {
  Validate(options_);
  impl_ = std::make_unique<Impl>(options_);
}
void VisualOdometry::SetLensUndistortion(const CameraIntrinsics& lens) {
  impl_->lens.emplace(lens);
}
void VisualOdometry::SetShareFeatures(bool share) { impl_->share_features = share; }
VisualOdometry::~VisualOdometry() = default;
VisualOdometry::VisualOdometry(VisualOdometry&&) noexcept = default;
VisualOdometry& VisualOdometry::operator=(VisualOdometry&&) noexcept = default;

FrameResult VisualOdometry::Process(const GrayImageView& frame, double time_s,
                                    std::optional<double> height_m, std::optional<double> yaw_deg,
                                    std::optional<CameraAttitude> attitude) {
  Stopwatch total;
  Impl& s = *impl_;
  const OdometryOptions& o = options_;
  FrameResult r;
  r.index = s.next_index;
  r.time_s = time_s;
  if (frame.empty()) {
    throw InvalidArgument("VisualOdometry: frame " + std::to_string(r.index) + " is empty");
  }
  // Values that are not finite never reach the track: a NaN yaw (with heading_from_yaw) turned
  // every later position into NaN with status ok; a NaN attitude every keypoint.
  const auto not_finite = [&](const char* what, double v) {
    throw InvalidArgument(fmt::format("VisualOdometry: frame {}: {} = {} is not finite", r.index,
                                      what, v));
  };
  if (!std::isfinite(time_s)) not_finite("time_s", time_s);
  if (yaw_deg && !std::isfinite(*yaw_deg)) not_finite("yaw_deg", *yaw_deg);
  if (attitude && !std::isfinite(attitude->roll_deg)) not_finite("roll_deg", attitude->roll_deg);
  if (attitude && !std::isfinite(attitude->pitch_deg)) {
    not_finite("pitch_deg", attitude->pitch_deg);
  }
  s.CheckFrameSize(frame, r.index);
  const double gsd = Impl::GroundSamplingDistance(o, r.index, height_m);
  r.gsd_m_per_px = gsd;

  SurfResult features = s.Detect(o, frame, attitude, &r);
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
    heading_override = -(*yaw_deg - *s.yaw0_deg) * kDegToRad;
  }

  if (r.index == 0 || no_reference_yet) {
    s.chain = PoseChain(o.scale_mode, frame.width, frame.height);
    s.chain.Start(gsd);
    s.have_velocity = false;
    r.status = FrameStatus::kFirst;
  } else {
    s.Step(o, features.features, usable, gsd, heading_override ? &*heading_override : nullptr,
           &r);
  }
  s.UpdateReferences(o, r, usable, gsd, &features.features, &r);

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
