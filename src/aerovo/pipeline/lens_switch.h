// The lens self-calibration applied during the run (docs/lenses.md "Self-calibration"): the
// pre-pass (pipeline/lens_prepass.h) runs on its own thread from the first frame on, beside the
// odometry, so the first poses never wait for it. Its estimate is taken at a fixed frame, the
// SWITCH FRAME: the first frame at least kLensSwitchAfterS seconds of stream time after the
// first one (Frame::time_s), or the one after kLensSwitchMaxFrames frames, whichever comes
// first. The loop waits there for the estimate if it is not ready yet, so which frame switches
// never depends on the threads' timing: a run on a file gives the same outputs every time.
//
// A significant estimate then becomes the run's lens, as a calibration file would have been
// from the start, without stopping the pose stream: a new odometry with the lens (undistort
// auto|points|frames) is given again the frames before the switch frame (their processed pixels
// and odometry inputs, kept until then; not again through the sinks), at most
// kLensReplayFramesPerFrame of them per frame processed, while the run goes on under the old
// lens (every frame still gives its pose, and is kept for the replay too). At the first frame
// whose predecessors the new odometry has all processed, the CATCH-UP FRAME, the new odometry
// and undistortion become the run's: that frame's step is measured between two frames under the
// same lens, and the track from it on is the one of a run with the lens from its first frame.
// The replay gains kLensReplayFramesPerFrame - 1 frames per frame, so the catch-up frame comes
// about (switch frame) / (kLensReplayFramesPerFrame - 1) frames after the switch frame, and no
// pose waits for more than 1 + kLensReplayFramesPerFrame frames' odometry (the frame's own and
// the replay's: FrameState::frames_replayed). Both frames follow from frame counts only, never
// from the threads' timing. The live poses (pose stream, MAVLink) sent before the catch-up
// frame were under the ideal pinhole: its position may jump from them; frames.csv marks it
// (status "+lens"), MAVLink's reset_counter grows by one there (docs/autopilot.md), and
// summary.json lens_estimate says where (switch_frame, caught_up_frame, frames_replayed,
// wait_ms). The run's files do not keep those poses (when FilePosesReplaceable): the outputs
// hold them from the first frame on (RunOutputs::HoldForReplay; the pose stream's "pose" lines
// are not held) and at the catch-up frame take the replay's pose of every frame before it
// (RunOutputs::ReleaseHeld, RunTotals::ReplacePoses), the geo-referencing fitted again from
// those, so the files are the ones of a run given the estimate from its first frame. An
// estimate that is not significant changes nothing (the kept frames are dropped, the files
// released with the live poses); a run that ends before its catch-up frame records the
// estimate as not applied and writes the live poses.
//
// A live source cannot be read twice: its pairs are copies of the frames it delivers before the
// switch frame (lens_prepass.h LivePairFeed), a pair started every kLivePairSpacingS of stream
// time (or every kLivePairSpacingFrames frames, whichever comes first) and completed by the next
// frame delivered, matched on the pre-pass's thread as they come; the feed is closed at the switch
// frame; the run does not wait there: the estimate is taken at the first frame from the switch
// frame on at which it is ready (or waited for once kLiveMaxKeptFrames frames are kept), so a
// live pose stream never stops for it. Which frames pair and switch then depends on which the
// live source delivered and when (as everything of a live run).
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/odometry/attitude.h"
#include "aerovo/odometry/visual_odometry.h"
#include "aerovo/pipeline/lens_prepass.h"
#include "aerovo/pipeline/preprocess.h"
#include "aerovo/pipeline/run_steps.h"
#include "aerovo/pipeline/run_types.h"

namespace aerovo::run_steps {

struct RunContext;
struct FrameState;

/// A lens's undistortion (SetUpUndistortion): the whole-frame undistorter (frames path; null:
/// none or the points path, which the odometry does), the path, and the lens's largest local
/// scale change (camera/lens.h MaxLensScaleChange; unset: no lens).
struct LensPath {
  std::unique_ptr<FrameUndistorter> undistorter;
  UndistortionPath undistortion = UndistortionPath::kNone;
  std::optional<double> scale_change;
};

/// Stream seconds from the first frame to the switch frame: photos 0.5-2 s apart switch at their
/// 2nd-5th frame. The pre-pass takes 1.5-2.2 s beside the odometry on a 12 s 720p or 1080p clip
/// and about 6 s at 4K on a busy 2-core machine (BENCHMARKS.md "First pose within a second"):
/// the run waits at the switch frame for what is left. Our choice.
inline constexpr double kLensSwitchAfterS = 2.0;
/// Frames kept for the replay, at most (their processed pixels: 2.1 MP each at most with the
/// default detect_megapixels, about 100 MB for 48): the switch frame comes no later than this
/// (frame 48, 1.6 s into a 30 fps video). Our choice.
inline constexpr int kLensSwitchMaxFrames = 48;
/// Kept frames the new odometry is given per frame processed while it catches up (see the file
/// comment): a pose waits for at most 4 frames' odometry instead of the whole replay (48 frames
/// at 30 fps), and the catch-up frame comes about 24 frames after the switch frame. Our choice:
/// 2 would halve the longest wait's extra work but double the frames processed twice.
inline constexpr int kLensReplayFramesPerFrame = 3;
/// A live source: a pair of the lens pre-pass starts every this many seconds of stream time, or
/// every kLivePairSpacingFrames frames, before the switch frame: kLensPrepassPairs pairs by
/// 1.2 s (or by frame 32), inside both limits above. Our choice.
inline constexpr double kLivePairSpacingS = 0.3;
inline constexpr int kLivePairSpacingFrames = 8;
/// A live source: frames kept for the replay while the estimate is not ready after the switch
/// frame (the run does not wait for it there; see the file comment), at most: beyond, the run
/// waits. Twice kLensSwitchMaxFrames (about 200 MB of 2.1 MP frames). Our choice.
inline constexpr int kLiveMaxKeptFrames = 2 * kLensSwitchMaxFrames;

/// The lens switch of a run (see the file comment); owned by the run (RunContext::lens_switch).
class LensSwitch {
 public:
  /// `task`: the pre-pass, started; `first_time_s`: the first frame's Frame::time_s;
  /// `live_feed`: a live source's pairs, which Keep() fills and the switch closes (the task's
  /// feed), else null; `replace_file_poses`: the run's files take the replay's poses
  /// (FilePosesReplaceable; the caller holds the outputs: RunOutputs::HoldForReplay).
  LensSwitch(std::unique_ptr<LensPrepassTask> task, double first_time_s,
             std::shared_ptr<LivePairFeed> live_feed = nullptr, bool replace_file_poses = false);
  ~LensSwitch();

  /// Before `frame`'s stages (read, not processed yet): at the switch frame, waits for the
  /// estimate (Cancelled on the run's stop flag) and records it in the summary and the log
  /// (TakeEstimate); from there on until the catch-up frame, gives the new odometry up to
  /// kLensReplayFramesPerFrame kept frames (FrameState::frames_replayed) and, at the catch-up
  /// frame, makes the lens the run's (camera, lens_estimate.yaml, the new odometry and its
  /// undistortion) and sets FrameState::lens_switched. Output errors escape (lens_estimate.yaml).
  void BeforeStages(RunContext& run, FrameState& frame);
  /// After `frame`'s stages, before the catch-up frame: keeps its processed pixels
  /// (FrameState::pixels) and odometry inputs for the replay; with a live feed, before the switch
  /// frame, hands over the frame as delivered when it starts or completes a pair.
  void Keep(const FrameState& frame);
  /// At the end of the run: when the switch frame or the catch-up frame never came (a flight
  /// shorter than kLensSwitchAfterS, or stopped), the estimate is recorded as not applied.
  void Finish(RunContext& run);
  /// Nothing left to do: the estimate was taken and, when significant, the run switched to it.
  bool done() const { return phase_ == Phase::kDone; }
  /// The run's files take the replay's poses of the frames before the catch-up frame (see the
  /// file comment): the outputs hold them until then (RunOutputs::HoldForReplay).
  bool replaces_file_poses() const { return replace_file_poses_; }
  /// Whether a run's files can take the replay's poses: not with the online window or the
  /// offline flight graph (backend.enable, map_fix.apply), whose poses and factors are the live
  /// odometry's, nor with a map (its fixes may seed the geo-referencing, stage_map_fix.cc).
  static bool FilePosesReplaceable(const RunContext& run);

 private:
  enum class Phase { kCollecting, kReplaying, kDone };
  // A frame before the catch-up frame as the odometry got it.
  struct Kept {
    GrayImage pixels;
    int frame = -1;  // Frame::index
    double time_s = 0.0;
    double height_m = 0.0;
    std::optional<double> yaw_deg;
    std::optional<CameraAttitude> attitude;
    std::optional<GeoPoint> gps;  // the frame's fix (FrameState::gps), as the georef stage got it
    bool gps_denied = false;      // FrameState::gps_denied
  };
  // A kept frame as the replay estimated it, and what the geo-referencing takes of it.
  struct Replayed {
    ReplayedPose pose;
    std::optional<GeoPoint> gps;
    std::optional<double> yaw_deg;
    bool gps_denied = false;
  };
  // `frame` (read, not processed yet) is the switch frame.
  bool Due(const FrameState& frame) const;
  // At the switch frame: the estimate waited for and recorded; significant, the replay set up.
  void TakeEstimate(RunContext& run, FrameState& frame);
  // Up to kLensReplayFramesPerFrame kept frames given to the new odometry; none left: the
  // catch-up frame (SwitchOver).
  void Advance(RunContext& run, FrameState& frame);
  // The estimate and the new odometry made the run's at `frame`.
  void SwitchOver(RunContext& run, FrameState& frame);
  // At the catch-up frame: the run's files and geo-referencing given the replayed poses
  // (replace_file_poses_), else the geo-referencing restarted if its heading is not fixed yet.
  void ReplaceFilePoses(RunContext& run);
  // A live source: `f` completes the pending pair and/or starts the next one.
  void FeedLivePair(const FrameState& f);

  std::unique_ptr<LensPrepassTask> task_;
  double first_time_s_ = 0.0;
  Phase phase_ = Phase::kCollecting;
  int kept_before_switch_ = 0;  // frames kept before the switch frame (Due)
  std::deque<Kept> kept_;       // frames the new odometry has not been given yet
  std::shared_ptr<LivePairFeed> live_feed_;
  bool live_closed_ = false;          // the live feed closed (the switch frame came)
  std::optional<Frame> pair_start_;  // a live pair's first frame, waiting for the next
  int live_pairs_ = 0;               // pairs started so far
  // From the switch frame to the catch-up frame: the estimate, the odometry under it and its
  // undistortion, the frames given to it so far.
  std::optional<LensPrepass> prepass_;
  double waited_ms_ = 0.0;
  int switch_frame_ = -1;
  std::unique_ptr<VisualOdometry> odometry_;
  LensPath path_;
  int replayed_ = 0;
  bool replace_file_poses_ = false;
  std::vector<Replayed> replayed_poses_;  // replace_file_poses_: every frame replayed so far
};

/// Undistortion of `run`'s lens (RunLens of its camera; none: nothing) on run.odometry (points)
/// or as run.undistorter (frames), per RunConfig::undistort; fills in the summary's
/// undistortion fields (run_setup.cc).
void SetUpUndistortion(RunContext& run);
/// The same for `camera`'s lens on `odometry` (points) or in the returned path (frames), not
/// touching `run` (run_setup.cc); InstallLensPath makes it the run's.
LensPath MakeLensPath(const RunContext& run, const RunCamera& camera, VisualOdometry& odometry);
void InstallLensPath(RunContext& run, LensPath path);

/// The log line of a pre-pass's result (run_setup.cc): `switch_frame` -1 when never applied.
void LogLensPrepass(const RunContext& run, const LensPrepass& prepass, int switch_frame,
                    double waited_ms);

}  // namespace aerovo::run_steps
