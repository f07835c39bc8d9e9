// The per-frame loop of `aerovo run` (step 5 of run_steps.h): frames are read (ReadFrame:
// decoding, telemetry fix), the run is set up from the first one (SetUpRun: camera, reduction,
// lens, odometry, outputs), then each frame goes through the stages (MakeStages) and is handed
// to the sinks (MakeSinks). Types: pipeline/frame_state.h. Adding a stage or a sink: one file
// (stage_*.cc / sink_*.cc) and one line in MakeStages / MakeSinks (frame_loop.cc); from outside
// the pipeline, RunCallbacks::stages / sinks.
#pragma once

#include <atomic>
#include <filesystem>
#include <memory>
#include <ostream>
#include <vector>

#include "aerovo/core/timer.h"
#include "aerovo/pipeline/frame_state.h"
#include "aerovo/pipeline/run_steps.h"

namespace aerovo::run_steps {

// ---------------------------------------------------------------------------------------------
// The built-in stages, in the order MakeStages lists them (one file each).

std::unique_ptr<FrameStage> MakeHeightStage(const RunContext& run);  // stage_height.cc
std::unique_ptr<FrameStage> MakeAttitudeStage();                     // stage_attitude.cc
std::unique_ptr<FrameStage> MakeFlatFieldStage();                    // stage_flat_field.cc
std::unique_ptr<FrameStage> MakePreprocessStage();                   // stage_preprocess.cc
std::unique_ptr<FrameStage> MakeOdometryStage();                     // stage_odometry.cc
std::unique_ptr<FrameStage> MakeWindowStage();                       // stage_window.cc
/// The larger standard deviation of w's position (the square root of the larger eigenvalue of
/// its covariance's x/y block), m; 0 without a covariance (stage_window.cc).
double WindowSigmaXyM(const WindowedPose& w);
/// The standard deviation of w's heading, rad; 0 without a covariance (stage_window.cc).
double WindowSigmaHeadingRad(const WindowedPose& w);
/// A jump of the live pose by `jump_m` and a turn of `turn_rad` (its absolute value): a reset
/// with `cause` when either is past the autopilots' gates for the pose's own standard deviations
/// (mavlink::PoseJumpResetThresholdM of WindowSigmaXyM, mavlink::HeadingJumpResetThresholdRad of
/// WindowSigmaHeadingRad; `w` null: no window, the gates' floors), heading_only when only the turn
/// is; else no reset (stage_window.cc).
PoseReset JumpPastGates(double jump_m, double turn_rad, const WindowedPose* w,
                        PoseReset::Cause cause);
/// The window stage's test of a jump of the live pose (FrameState::pose_reset): at a whole-graph
/// solve (w.full_solve) only, the distance between w's position and the causal prediction
/// (`previous_windowed`, the pose given for the previous frame, moved by the causal step from
/// `previous_causal` to `causal`) is larger than mavlink::PoseJumpResetThresholdM of w's
/// position standard deviation (WindowSigmaXyM), or the wrapped difference of their headings
/// larger than mavlink::HeadingJumpResetThresholdRad of w's heading standard deviation
/// (PoseReset::heading_only when only the heading is). Cause kLoopClosure, or kNone.
PoseReset PoseJumped(const WindowedPose& w, const backend::Similarity2& causal,
                const backend::Similarity2& previous_causal,
                const backend::Similarity2& previous_windowed);
/// The frame's source index, time, world_from_frame (full-frame pixels) and causal pose into
/// RunState::flight (run_steps.h FlightRecording), after its result went into the flight graph:
/// the flight graph sink's and the window stage's (sink_flight_graph.cc). Call it with the
/// odometry's causal result (before the window replaces its pose).
void RecordFlightFrame(const FrameState& f, const RunContext& run);
std::unique_ptr<FrameStage> MakeGpsCheckStage();                     // stage_gps_check.cc
std::unique_ptr<FrameStage> MakeGeoreferenceStage();                 // stage_georef.cc
std::unique_ptr<FrameStage> MakeMapFixStage();                       // stage_map_fix.cc
std::unique_ptr<FrameStage> MakeRecordStage();                       // stage_record.cc

// The built-in sinks, in the order MakeSinks lists them (one file each).

std::unique_ptr<FrameSink> MakeMavlinkSink();       // sink_mavlink.cc
std::unique_ptr<FrameSink> MakeTransformsSink();    // sink_transforms.cc
std::unique_ptr<FrameSink> MakeSourceCountsSink();  // sink_source_counts.cc
std::unique_ptr<FrameSink> MakePoseStreamSink();    // sink_pose_stream.cc
std::unique_ptr<FrameSink> MakeRunFilesSink();      // sink_run_files.cc
std::unique_ptr<FrameSink> MakeFlightGraphSink();   // sink_flight_graph.cc
std::unique_ptr<FrameSink> MakeTotalsSink();        // sink_totals.cc
std::unique_ptr<FrameSink> MakeProgressSink();      // sink_progress.cc
/// The map fixer's end (RunContext::map_fixer): map_fixes.csv and summary.json "map_fixes".
std::unique_ptr<FrameSink> MakeMapFixSink();        // stage_map_fix.cc

/// A stage or sink the loop calls, owned by it or by the caller (RunCallbacks).
using StagePtr = std::shared_ptr<FrameStage>;
using SinkPtr = std::shared_ptr<FrameSink>;

/// Every frame's stages: height, attitude, preprocess (reduction, undistortion, dimming),
/// odometry, GPS check, geo-reference, record; then `extra` (RunCallbacks::stages).
std::vector<StagePtr> MakeStages(const RunContext& run, const std::vector<StagePtr>& extra);
/// Every frame's sinks: MAVLink (the vision message as soon as the pose is known),
/// transforms.csv, the height/attitude source counts, the pose stream, the run files (queued
/// for the heading), the flight graph (backend.enable), the totals, the progress callback; then `extra` (RunCallbacks::sinks).
std::vector<SinkPtr> MakeSinks(const RunContext& run, const std::vector<SinkPtr>& extra);

// ---------------------------------------------------------------------------------------------
// Reading and setting up.

/// Whether every fix of `telemetry` has an altitude above sea level (TelemetrySample::abs_alt_m):
/// the run's GeoReferencer then knows the altitude of its origin (odometry/georef.h
/// altitude_known). False for telemetry with heights above the take-off point only (older DJI
/// SRT: BAROMETER, H) or no height (a GPX without <ele>, a CSV without altitude), whose fixes
/// GpsOf gives that height or 0.
bool FixAltitudesAboveSeaLevel(const RunTelemetry& telemetry);

/// Reads the next frame into `frame` (cleared first): nothing once the stop flag is set
/// (kStopped) or max_frames are processed or the source ends (kEnd); else the frame with the
/// time the source delivered it and its own capture time (FrameState::frame_mono_s: a file's
/// presentation time placed by state->frame_clock), its telemetry fix (counted in
/// state->frames_without_fix when it has none) and its flags (kFrame). The source's
/// InputError escapes (frame.delivered stays false).
enum class ReadResult { kFrame, kEnd, kStopped };
ReadResult ReadFrame(FrameSource& source, const RunConfig& config, const RunTelemetry& telemetry,
                     const std::atomic<bool>* stop, int frames_processed, RunState* state,
                     FrameState& frame);

/// What SetUpRun needs besides the first frame.
struct RunSetup {
  RunContext base;              ///< Its "given before the first frame" part filled in.
  bool focal_from_sim = false;  ///< RunInputs::focal_from_sim.
  const ImageFolderSource* folder = nullptr;  ///< The source as a photo folder (or null).
  bool source_live = false;                   ///< The lens pre-pass is skipped (lens_prepass.h).
  OdometryOptions vo_options;                 ///< RunConfig::odometry.
};
/// The run from its first frame `first`: the camera (ResolveRunCamera), the reduction to the
/// pixel budget, the height source (waiting for the link's first height with MAVLink), the
/// odometry, the lens pre-pass started beside it (pipeline/lens_switch.h) and undistortion, the
/// outputs (config.json, ...); fills in the summary's focal, frame size, height source, lens
/// fields and logs them. InputError (no camera,
/// no calibration) or OutputError (config.json cannot be written); the messages name the frame
/// or file.
std::unique_ptr<RunContext> SetUpRun(RunSetup setup, const FrameState& first);

// ---------------------------------------------------------------------------------------------
// The loop.

/// The frames of a run, one by one. A frame the source flagged (Frame::flags) is processed, its
/// status gets "+flag" and RunSummary::frames_flagged counts it.
class FrameLoop {
 public:
  /// `inputs`, `telemetry`, `callbacks` and `folder` (the source as a photo folder, or null)
  /// must outlive the loop. `log` may be null.
  FrameLoop(const RunInputs& inputs, const RunTelemetry& telemetry, const ImageFolderSource* folder,
            OdometryOptions vo_options, const std::filesystem::path& out_dir,
            const RunCallbacks& callbacks, std::ostream* log);
  ~FrameLoop();

  /// Processes `source` until its end, config.max_frames or `stop` (may be null); call once,
  /// then Finish(). Fills in `summary`'s frames_processed, focal, height source and the height
  /// warning (frames_expected: read for the progress callback). Any error of a frame (at the
  /// first frame too: no camera, no height, an undecodable photo) ends the loop with the frames
  /// before it kept: LoopEnd::failure, a RunFailure naming the frame. With --mavlink each
  /// frame's vision message is sent as soon as it is processed (config.mavlink_message),
  /// stamped with the frame's own capture time (FrameState::frame_mono_s). `wall`: the run's
  /// stopwatch, for the progress callback's frames per second.
  LoopEnd Run(FrameSource& source, const std::atomic<bool>* stop, const Stopwatch& wall,
              RunSummary* summary);
  /// Writes the frames still queued and closes the track files (nothing when no frame came).
  void Finish();
  /// The fixes rejected by the plausibility check, by frame (for Summarize).
  std::vector<RejectedFix> RejectedFixes() const;

  /// The MAVLink link (null without --mavlink).
  const mavlink::AutopilotLink* link() const { return link_.get(); }
  mavlink::AutopilotLink* link() { return link_.get(); }
  /// The main source is live (FrameSource::IsLive): the lens self-calibration pre-pass is
  /// skipped (pipeline/lens_prepass.h). Set before Run.
  void set_source_live(bool live) { source_live_ = live; }
  /// The run's reference maps (RunConfig::map; null: none): frames are matched against them
  /// (pipeline/map_fixer.h). Must outlive the loop; set before Run.
  void set_maps(const map::ReferenceMaps* maps) { maps_ = maps; }
  /// Counts of the odometry, null when no frame came.
  const OdometryStats* vo_stats() const {
    return run_ && run_->odometry ? &run_->odometry->stats() : nullptr;
  }
  const GeoReferencer& georef() const { return state_.georef; }
  /// The flight recorded for the offline optimisation (graph null: backend off or no frame).
  const FlightRecording& flight() const { return state_.flight; }
  const RunTotals& totals() const { return state_.totals; }
  /// Rows of frames.csv (RunOutputs::frames_written; 0 before the first frame).
  int frames_written() const { return run_ ? run_->outputs->frames_written() : 0; }
  /// The totals, moved out (for Summarize, at the end).
  RunTotals TakeTotals() { return std::move(state_.totals); }

 private:
  // Sets up the run at the first frame, then the frame's stages and sinks.
  void Process(FrameState& frame, const std::atomic<bool>* stop, const Stopwatch& wall,
               RunSummary* summary);
  // Logs once (with --mavlink) when a file's frame time runs ahead of the clock.
  void SayWhenAheadOfTheClock(const FrameState& frame, const FrameSource& source);
  // The failure of an exception of `kind` with message `what` at `frame`.
  RunFailure FailureOf(RunFailureKind kind, const char* what, const FrameState& frame) const;

  const RunInputs& inputs_;
  const RunTelemetry& telemetry_;
  const ImageFolderSource* folder_ = nullptr;
  OdometryOptions vo_options_;
  std::filesystem::path out_dir_;
  const RunCallbacks& callbacks_;
  std::ostream* log_ = nullptr;
  std::unique_ptr<mavlink::AutopilotLink> link_;  // --mavlink (null: none)
  bool source_live_ = false;
  const map::ReferenceMaps* maps_ = nullptr;
  RunState state_;
  std::unique_ptr<RunContext> run_;  // from the first frame (stages and sinks get it const)
  std::vector<StagePtr> stages_;
  std::vector<SinkPtr> sinks_;
  // Where the frame is (for FailureOf): in a stage or sink (not the reading or the set-up), and
  // whether that step's input errors name the frame.
  bool in_frame_steps_ = false;
  bool errors_name_frame_ = true;
};

}  // namespace aerovo::run_steps
