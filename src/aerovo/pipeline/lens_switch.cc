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
                       std::shared_ptr<LivePairFeed> live_feed)
    : task_(std::move(task)), first_time_s_(first_time_s), live_feed_(std::move(live_feed)) {}

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
                    static_cast<int>(kept_.size()) >= live_pairs_ * kLivePairSpacingFrames);
  if (due) {
    pair_start_ = copy();
    ++live_pairs_;
  }
}

bool LensSwitch::Due(const FrameState& f) const {
  if (done_) return false;
  return f.frame.time_s - first_time_s_ >= kLensSwitchAfterS ||
         static_cast<int>(kept_.size()) >= kLensSwitchMaxFrames;
}

void LensSwitch::Keep(const FrameState& f) {
  if (done_) return;
  if (live_feed_) FeedLivePair(f);
  if (f.pixels.empty()) return;
  Kept k;
  const GrayImageView& v = f.pixels;
  k.pixels = GrayImage(v.width, v.height);
  for (int y = 0; y < v.height; ++y) std::memcpy(k.pixels.row(y), v.row(y), v.width);
  k.time_s = f.frame.time_s;
  k.height_m = f.height_m;
  k.yaw_deg = f.sample ? f.sample->CameraYawDeg() : std::nullopt;
  k.attitude = f.attitude.camera;
  kept_.push_back(std::move(k));
}

void LensSwitch::Replay(RunContext& run, const LensPrepass& prepass) {
  run.camera.calibrated = *prepass.lens;
  WriteCalibration((run.out_dir / kLensEstimateYaml).string(), *prepass.lens,
                   CalibrationFormat::kOpenCv);
  // The run's lens path as SetUpRun would have made it with the estimate from the start.
  run.odometry = std::make_unique<VisualOdometry>(run.vo_options);
  run.odometry->SetShareFeatures(run.config->backend.enable || WindowRuns(run));
  run.undistorter.reset();
  run.undistortion = UndistortionPath::kNone;
  SetUpUndistortion(run);
  // The frames before the switch frame again, under the lens. Their kept pixels are the
  // preprocessing stage's (reduced, brightness scaled): only the undistortion is added.
  const CancelScope cancel(run.stop);
  for (const Kept& k : kept_) {
    GrayImageView view = k.pixels.view();
    if (run.undistorter) view = run.undistorter->Apply(view);
    run.odometry->Process(view, k.time_s, k.height_m, k.yaw_deg, k.attitude);
  }
}

void LensSwitch::Apply(RunContext& run, FrameState& f) {
  if (live_feed_) live_feed_->Close();
  double waited_ms = 0.0;
  const LensPrepass prepass = task_->Get(run.stop, &waited_ms);
  done_ = true;
  nlohmann::json j = ToJson(prepass);
  j["switch_frame"] = f.frame.index;
  j["wait_ms"] = waited_ms;
  j["frames_replayed"] = 0;
  if (prepass.applied) {
    Replay(run, prepass);
    j["frames_replayed"] = static_cast<int>(kept_.size());
    f.lens_switched = true;
  }
  run.summary->lens_estimate = std::move(j);
  kept_.clear();
  kept_.shrink_to_fit();
  LogLensPrepass(run, prepass, f.frame.index, waited_ms);
}

void LensSwitch::Finish(RunContext& run) {
  if (done_) return;
  if (live_feed_) live_feed_->Close();
  double waited_ms = 0.0;
  LensPrepass prepass = task_->Get(run.stop, &waited_ms);
  done_ = true;
  kept_.clear();
  if (prepass.applied) {
    prepass.applied = false;
    prepass.status = LensPrepassStatus::kNotApplied;
    prepass.why += "; not applied: the run ended before its switch frame (" +
                   fmt::format("{:.1f} s into the stream", kLensSwitchAfterS) + ")";
  }
  nlohmann::json j = ToJson(prepass);
  j["switch_frame"] = -1;
  j["wait_ms"] = waited_ms;
  j["frames_replayed"] = 0;
  run.summary->lens_estimate = std::move(j);
  LogLensPrepass(run, prepass, -1, waited_ms);
}

}  // namespace aerovo::run_steps
