#include "aerovo/pipeline/lens_switch.h"

#include <cstring>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/cancel.h"
#include "aerovo/pipeline/frame_state.h"

namespace aerovo::run_steps {

LensSwitch::LensSwitch(std::unique_ptr<LensPrepassTask> task, double first_time_s,
                       std::shared_ptr<LivePairFeed> live_feed, bool replace_file_poses)
    : task_(std::move(task)),
      first_time_s_(first_time_s),
      live_feed_(std::move(live_feed)),
      replace_file_poses_(replace_file_poses) {}

bool LensSwitch::FilePosesReplaceable(const RunContext& run) {
  return !run.config->backend.enable && !WindowRuns(run) && run.maps == nullptr;
}

LensSwitch::~LensSwitch() {
  if (live_feed_) live_feed_->Close();  // the task's thread ends; task_ waits for it
}

void LensSwitch::FeedLivePair(const FrameState& f) {
  if (f.frame.gray.empty()) return;
  const auto copy = [&f] {
    Frame c;
    c.gray = GrayImage(f.frame.gray.width(), f.frame.gray.height());
    std::memcpy(c.gray.data(), f.frame.gray.data(),
                static_cast<std::size_t>(f.frame.gray.width()) * f.frame.gray.height());
    c.index = f.frame.index;
    c.time_s = f.frame.time_s;
    c.name = f.frame.name;
    return c;
  };
  if (pair_start_) {
    live_feed_->Push(std::move(*pair_start_), copy());
    pair_start_.reset();
  }
  const bool due = live_pairs_ < kLensPrepassPairs &&
                   (f.frame.time_s - first_time_s_ >= live_pairs_ * kLivePairSpacingS ||
                    kept_before_switch_ >= live_pairs_ * kLivePairSpacingFrames);
  if (due) {
    pair_start_ = copy();
    ++live_pairs_;
  }
}

bool LensSwitch::Due(const FrameState& f) const {
  return f.frame.time_s - first_time_s_ >= kLensSwitchAfterS ||
         kept_before_switch_ >= kLensSwitchMaxFrames;
}

void LensSwitch::Keep(const FrameState& f) {
  if (phase_ == Phase::kDone) return;
  if (phase_ == Phase::kCollecting && live_feed_ && !live_closed_) FeedLivePair(f);
  if (f.pixels.empty()) return;
  if (phase_ == Phase::kCollecting) ++kept_before_switch_;
  Kept k;
  const GrayImageView& v = f.pixels;
  k.pixels = GrayImage(v.width, v.height);
  for (int y = 0; y < v.height; ++y) std::memcpy(k.pixels.row(y), v.row(y), v.width);
  k.frame = f.frame.index;
  k.gps = f.gps;
  k.gps_denied = f.gps_denied;
  k.time_s = f.frame.time_s;
  k.height_m = f.height_m;
  k.yaw_deg = f.sample ? f.sample->CameraYawDeg() : std::nullopt;
  k.attitude = f.attitude.camera;
  kept_.push_back(std::move(k));
}

void LensSwitch::BeforeStages(RunContext& run, FrameState& f) {
  if (phase_ == Phase::kCollecting) {
    if (!Due(f)) return;
    if (live_feed_) {
      // A live source never waits for the estimate (which frame switches depends on the
      // frames it delivered anyway): its pairs end here, the estimate is taken at the first
      // frame it is ready at, or waited for once kLiveMaxKeptFrames frames are kept.
      live_feed_->Close();
      live_closed_ = true;
      if (!task_->Ready() && static_cast<int>(kept_.size()) < kLiveMaxKeptFrames) return;
    }
    TakeEstimate(run, f);
  }
  if (phase_ == Phase::kReplaying) Advance(run, f);
}

void LensSwitch::TakeEstimate(RunContext& run, FrameState& f) {
  if (live_feed_) live_feed_->Close();
  prepass_ = task_->Get(run.stop, &waited_ms_);
  switch_frame_ = f.frame.index;
  nlohmann::json j = ToJson(*prepass_);
  j["switch_frame"] = switch_frame_;
  j["wait_ms"] = waited_ms_;
  j["frames_replayed"] = 0;
  j["caught_up_frame"] = -1;  // until then, the run's lens is the old one
  run.summary->lens_estimate = std::move(j);
  if (!prepass_->applied) {
    phase_ = Phase::kDone;
    kept_.clear();
    kept_.shrink_to_fit();
    run.outputs->ReleaseHeld({});  // the files keep the live poses
    LogLensPrepass(run, *prepass_, f.frame.index, waited_ms_);
    return;
  }
  // The run's lens path as SetUpRun would have made it with the estimate from the start.
  RunCamera camera = run.camera;
  camera.calibrated = *prepass_->lens;
  odometry_ = std::make_unique<VisualOdometry>(run.vo_options);
  odometry_->SetShareFeatures(run.config->backend.enable || WindowRuns(run));
  path_ = MakeLensPath(run, camera, *odometry_);
  phase_ = Phase::kReplaying;
  if (run.log) {
    *run.log << fmt::format(
        "lens: the estimate is significant at frame {}: the {} frames before it are given again "
        "to an odometry under the lens, {} per frame, while the run goes on under the old lens\n",
        f.frame.index, kept_.size(), kLensReplayFramesPerFrame);
  }
}

void LensSwitch::Advance(RunContext& run, FrameState& f) {
  // The kept pixels are the preprocessing stage's (reduced, brightness scaled) under the old
  // lens (none): only the new lens's undistortion is added.
  const CancelScope cancel(run.stop);
  for (int n = 0; n < kLensReplayFramesPerFrame && !kept_.empty(); ++n) {
    const Kept& k = kept_.front();
    GrayImageView view = k.pixels.view();
    if (path_.undistorter) view = path_.undistorter->Apply(view);
    FrameResult r = odometry_->Process(view, k.time_s, k.height_m, k.yaw_deg, k.attitude);
    if (replace_file_poses_) {
      r.features.reset();
      r.step_inliers_curr_px.resize(2, 0);
      Replayed& out = replayed_poses_.emplace_back();
      out.pose.frame = k.frame;
      out.pose.world_from_full = run.reducer
                                     ? Eigen::Matrix3d(r.world_from_frame * run.reduced_from_full)
                                     : r.world_from_frame;
      out.pose.result = std::move(r);
      out.gps = k.gps;
      out.yaw_deg = k.yaw_deg;
      out.gps_denied = k.gps_denied;
    }
    kept_.pop_front();
    ++replayed_;
    ++f.frames_replayed;
  }
  if (kept_.empty()) SwitchOver(run, f);
}

void LensSwitch::SwitchOver(RunContext& run, FrameState& f) {
  run.camera.calibrated = *prepass_->lens;
  WriteCalibration((run.out_dir / kLensEstimateYaml).string(), *prepass_->lens,
                   CalibrationFormat::kOpenCv);
  run.odometry = std::move(odometry_);
  InstallLensPath(run, std::move(path_));
  ReplaceFilePoses(run);
  f.lens_switched = true;
  phase_ = Phase::kDone;
  kept_.shrink_to_fit();
  nlohmann::json& j = run.summary->lens_estimate;
  j["caught_up_frame"] = f.frame.index;
  j["frames_replayed"] = replayed_;
  j["file_poses_replaced"] = replace_file_poses_;
  LogLensPrepass(run, *prepass_, f.frame.index, waited_ms_);
}

void LensSwitch::ReplaceFilePoses(RunContext& run) {
  GeoReferencer& georef = run.state->georef;
  if (!replace_file_poses_) {
    // The poses before were under the ideal pinhole (a wrong scale with a wide lens): a
    // heading not fixed yet is fixed from the segment under the lens, which starts here.
    if (!georef.ready()) georef.Restart();
    return;
  }
  // The geo-referencing as the frames before would have given it under the lens: their
  // replayed positions, their fixes that still stand (not rejected by the GPS check, nor
  // superseded since: RunState::rejected) and their camera yaw fed in order to a new one; at
  // the first denied frame, fixed with what it has (stage_georef.cc OnDenial).
  GeoReferencer rebuilt(georef.options(), georef.fix_altitudes_above_sea_level());
  bool denial_seen = false;
  std::vector<ReplayedPose> poses;
  poses.reserve(replayed_poses_.size());
  for (Replayed& r : replayed_poses_) {
    const bool stands = r.gps && run.state->rejected.count(r.pose.frame) == 0;
    rebuilt.Observe(r.pose.result.position_m, stands ? r.gps : std::nullopt, r.yaw_deg);
    if (r.gps_denied && !denial_seen) {
      denial_seen = true;
      if (!rebuilt.ready() && rebuilt.has_enu()) rebuilt.FixWithAvailable();
    }
    poses.push_back(std::move(r.pose));
  }
  replayed_poses_.clear();
  replayed_poses_.shrink_to_fit();
  georef = std::move(rebuilt);
  run.outputs->ReleaseHeld(poses);
  run.state->totals.ReplacePoses(poses);
}

void LensSwitch::Finish(RunContext& run) {
  if (phase_ == Phase::kDone) return;
  if (live_feed_) live_feed_->Close();
  LensPrepass prepass;
  if (phase_ == Phase::kCollecting) prepass = task_->Get(run.stop, &waited_ms_);
  else prepass = *prepass_;
  const bool replaying = phase_ == Phase::kReplaying;
  phase_ = Phase::kDone;
  kept_.clear();
  odometry_.reset();
  replayed_poses_.clear();
  run.outputs->ReleaseHeld({});  // never caught up: the files keep the live poses
  if (prepass.applied) {
    prepass.applied = false;
    prepass.status = LensPrepassStatus::kNotApplied;
    prepass.why += replaying ? fmt::format("; not applied: the run ended before the replay from "
                                           "its switch frame {} caught up",
                                           switch_frame_)
                             : "; not applied: the run ended before its switch frame (" +
                                   fmt::format("{:.1f} s into the stream", kLensSwitchAfterS) +
                                   ")";
  }
  nlohmann::json j = ToJson(prepass);
  j["switch_frame"] = replaying ? switch_frame_ : -1;
  j["wait_ms"] = waited_ms_;
  j["frames_replayed"] = 0;
  j["caught_up_frame"] = -1;
  run.summary->lens_estimate = std::move(j);
  LogLensPrepass(run, prepass, -1, waited_ms_);
}

}  // namespace aerovo::run_steps
