// The lens self-calibration applied during the run (docs/lenses.md "Self-calibration"): the
// pre-pass (pipeline/lens_prepass.h) runs on its own thread from the first frame on, beside the
// odometry, so the first poses never wait for it. Its estimate is taken at a fixed frame, the
// SWITCH FRAME: the first frame at least kLensSwitchAfterS seconds of stream time after the
// first one (Frame::time_s), or the one after kLensSwitchMaxFrames frames, whichever comes
// first. The loop waits there for the estimate if it is not ready yet, so which frame switches
// never depends on the threads' timing: a run on a file gives the same outputs every time.
//
// A significant estimate is then the run's lens from the switch frame on, as a calibration file
// would have been from the start: a new odometry with the lens (undistort auto|points|frames)
// is given again the frames before the switch frame (their processed pixels and odometry inputs
// are kept until then; not again through the sinks), so the switch frame's step is measured
// between two frames under the same lens and the track from the switch frame on is the one of a
// run with the lens from its first frame. The poses sent and written before the switch frame
// were under the ideal pinhole: the switch frame's position may jump from them; frames.csv marks
// it (status "+lens"), MAVLink's reset_counter grows by one there (docs/autopilot.md), and
// summary.json lens_estimate says where (switch_frame, frames_replayed, wait_ms). An estimate
// that is not significant changes nothing (the kept frames are dropped).
//
// A live source cannot be read twice: its pairs are copies of the frames it delivers before the
// switch frame (lens_prepass.h LivePairFeed), a pair started every kLivePairSpacingS of stream
// time (or every kLivePairSpacingFrames frames, whichever comes first) and completed by the next
// frame delivered, matched on the pre-pass's thread as they come; the feed is closed at the switch
// frame, where the run waits only for the pairs not matched yet and the estimate. Which frames
// pair then depends on which the live source delivered (as everything of a live run).
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/odometry/attitude.h"
#include "aerovo/pipeline/lens_prepass.h"

namespace aerovo::run_steps {

struct RunContext;
struct FrameState;

/// Stream seconds from the first frame to the switch frame: photos 0.5-2 s apart switch at their
/// 2nd-5th frame. The pre-pass takes 1.5-2.2 s beside the odometry on a 12 s 720p or 1080p clip
/// and about 6 s at 4K on a busy 2-core machine (BENCHMARKS.md "First pose within a second"):
/// the run waits at the switch frame for what is left. Our choice.
inline constexpr double kLensSwitchAfterS = 2.0;
/// Frames kept for the replay, at most (their processed pixels: 2.1 MP each at most with the
/// default detect_megapixels, about 100 MB for 48): the switch frame comes no later than this
/// (frame 48, 1.6 s into a 30 fps video). Our choice.
inline constexpr int kLensSwitchMaxFrames = 48;
/// A live source: a pair of the lens pre-pass starts every this many seconds of stream time, or
/// every kLivePairSpacingFrames frames, before the switch frame: kLensPrepassPairs pairs by
/// 1.2 s (or by frame 32), inside both limits above. Our choice.
inline constexpr double kLivePairSpacingS = 0.3;
inline constexpr int kLivePairSpacingFrames = 8;

/// The lens switch of a run (see the file comment); owned by the run (RunContext::lens_switch).
class LensSwitch {
 public:
  /// `task`: the pre-pass, started; `first_time_s`: the first frame's Frame::time_s;
  /// `live_feed`: a live source's pairs, which Keep() fills and the switch closes (the task's
  /// feed), else null.
  LensSwitch(std::unique_ptr<LensPrepassTask> task, double first_time_s,
             std::shared_ptr<LivePairFeed> live_feed = nullptr);
  ~LensSwitch();

  /// `frame` (read, not processed yet) is the switch frame.
  bool Due(const FrameState& frame) const;
  /// Keeps `frame`'s processed pixels (FrameState::pixels) and odometry inputs, after its stages
  /// ran (frames before the switch frame; nothing after it); with a live feed, hands over the
  /// frame as delivered when it starts or completes a pair.
  void Keep(const FrameState& frame);
  /// At the switch frame, before its stages: waits for the estimate (Cancelled on the run's stop
  /// flag), records it in the summary and the log and, when significant, applies it (camera,
  /// lens_estimate.yaml, a new odometry with its undistortion, the kept frames replayed) and sets
  /// FrameState::lens_switched. Output errors escape (lens_estimate.yaml).
  void Apply(RunContext& run, FrameState& frame);
  /// At the end of the run: when the switch frame never came (a flight shorter than
  /// kLensSwitchAfterS, or stopped), the estimate is recorded as not applied.
  void Finish(RunContext& run);
  /// The estimate was taken (at the switch frame or at Finish).
  bool done() const { return done_; }

 private:
  // A frame before the switch frame as the odometry got it.
  struct Kept {
    GrayImage pixels;
    double time_s = 0.0;
    double height_m = 0.0;
    std::optional<double> yaw_deg;
    std::optional<CameraAttitude> attitude;
  };
  // The estimate applied to `run` and the kept frames given to its new odometry.
  void Replay(RunContext& run, const LensPrepass& prepass);
  // A live source: `f` completes the pending pair and/or starts the next one.
  void FeedLivePair(const FrameState& f);

  std::unique_ptr<LensPrepassTask> task_;
  double first_time_s_ = 0.0;
  std::vector<Kept> kept_;
  bool done_ = false;
  std::shared_ptr<LivePairFeed> live_feed_;
  std::optional<Frame> pair_start_;  // a live pair's first frame, waiting for the next
  int live_pairs_ = 0;               // pairs started so far
};

/// Undistortion of `run`'s lens (RunLens of its camera; none: nothing) on run.odometry (points)
/// or as run.undistorter (frames), per RunConfig::undistort; fills in the summary's
/// undistortion fields (run_setup.cc).
void SetUpUndistortion(RunContext& run);

/// The log line of a pre-pass's result (run_setup.cc): `switch_frame` -1 when never applied.
void LogLensPrepass(const RunContext& run, const LensPrepass& prepass, int switch_frame,
                    double waited_ms);

}  // namespace aerovo::run_steps
