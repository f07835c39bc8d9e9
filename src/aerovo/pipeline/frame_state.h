// What the per-frame loop of `aerovo run` (pipeline/frame_loop.h) passes around:
//   - RunContext: the run, set up once from its first frame (camera, frame reduction, lens
//     undistortion, odometry, outputs) and not changed after, but for the lens self-calibration's
//     switch frame (pipeline/lens_switch.h: the lens, odometry and undistortion replaced); it points to the run's state
//     (RunState: geo-referencing, GPS check, totals) and summary, which the frames change;
//   - FrameState: one frame as a value, filled in by the stages in order (telemetry fix,
//     height, attitude, pixels, odometry result, GPS check, output record);
//   - FrameStage: one step of a frame (stage_*.cc), FrameSink: one consumer of a finished frame
//     (sink_*.cc). The loop calls every stage, then every sink, for each frame; an exception
//     from any of them ends the run at that frame (the loop's one error boundary makes it a
//     RunFailure).
#pragma once

#include <atomic>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <ostream>
#include <string>

#include <Eigen/Core>

#include "aerovo/core/image.h"
#include "aerovo/core/timer.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/telemetry/telemetry.h"
#include "aerovo/mavlink/gps_input.h"
#include "aerovo/mavlink/link.h"
#include "aerovo/odometry/flight_graph.h"
#include "aerovo/odometry/georef.h"
#include "aerovo/odometry/gps_check.h"
#include "aerovo/odometry/visual_odometry.h"
#include "aerovo/pipeline/lens_switch.h"
#include "aerovo/pipeline/preprocess.h"
#include "aerovo/pipeline/run_steps.h"
#include "aerovo/pipeline/run_types.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo::map {
class ReferenceMaps;
}

namespace aerovo::run_steps {

class MapFixer;

/// The GPS plausibility check's verdict on a frame's fix (odometry/gps_check.h).
enum class FixCheck {
  kNoFix,     ///< The frame has no fix.
  kAccepted,  ///< The fix is used (geo-referencing, comparison with GPS).
  kRejected,  ///< Left out; FrameState::fix_rejection says why.
};

/// One frame on its way through the stages. The loop clears it (but for the decoding buffer)
/// before each frame; each stage fills in its part, in the order of MakeStages.
/// A jump of the live pose that aerovo sends as a reset (MAVLink reset_counter + 1; docs/
/// autopilot.md "A pose that jumps"): what made it, and whether its heading alone was past the
/// autopilots' gate (mavlink::HeadingJumpResetThresholdRad; the position within its own).
struct PoseReset {
  enum class Cause { kNone, kLoopClosure, kMapFix };
  Cause cause = Cause::kNone;
  bool heading_only = false;
  explicit operator bool() const { return cause != Cause::kNone; }
};

struct FrameState {
  // Read (ReadFrame): the frame as the source delivered it and its telemetry fix.
  Frame frame;
  bool delivered = false;  ///< `frame` is this iteration's (else a decoding failed).
  /// When the source delivered it, mavlink::MonotonicNowS, s: the instant the autopilot's
  /// samples (height, attitude) are matched to, on the link's clock.
  double capture_mono_s = 0.0;
  double capture_unix_s = 0.0;  ///< The same on the Unix clock, s.
  /// The frame's own capture time, s, on CLOCK_MONOTONIC and CLOCK_REALTIME (the MAVLink
  /// messages' timestamps and the time differences of their velocities): a file's frame
  /// (video, photos) at its presentation time Frame::time_s, counted from the first frame's,
  /// which is placed when it was read (RunState::frame_clock); a live frame at its own time
  /// (Frame::time_s: a stream's presentation time), placed by the least delayed frame so far
  /// (RunState::live_clock): never after its source delivered it (Frame::received_s, on the
  /// reader thread of a PrefetchSource). Velocities and deltas use the differences of
  /// Frame::time_s, which a live stream's start-up burst does not compress.
  double frame_mono_s = 0.0;
  double frame_unix_s = 0.0;
  std::optional<TelemetrySample> sample;  ///< Its telemetry fix (none: no telemetry or no match).
  std::optional<GeoPoint> gps;            ///< GpsOf(sample).
  /// GPS denial (RunConfig::gps_denied_after_s) from this frame on: `sample` has no position
  /// (has_fix false), `gps` is empty, and the fix it had is here, for the comparison with GPS
  /// only (frames.csv gps_* with gps_flag "withheld", RunTotals): no stage reads it.
  bool gps_denied = false;
  std::optional<GeoPoint> withheld_gps;
  FrameFlags flags;                       ///< Frame::flags, typed.
  // Height (stage_height.cc).
  double height_m = 0.0;  ///< Height above ground, metres.
  FrameHeightSource height_source = FrameHeightSource::kNone;
  // Attitude (stage_attitude.cc).
  std::optional<mavlink::AutopilotAttitude> autopilot_attitude;  ///< The link's, near capture.
  FrameAttitude attitude;
  // Flat field (stage_flat_field.cc): the frame with the sensor's static pattern removed, when
  // it is; then preprocessing (stage_preprocess.cc, from these pixels when set, else from
  // `frame`): the pixels given to the odometry (a view into the frame or a stage's buffer,
  // valid until the next frame).
  GrayImageView pixels;
  // Odometry (stage_odometry.cc).
  FrameResult result;
  // Online window (stage_window.cc, backend.online): the frame's windowed pose (the result's
  // position and heading are its).
  std::optional<WindowedPose> window;
  // GPS check (stage_gps_check.cc).
  FixCheck fix = FixCheck::kNoFix;
  std::string fix_rejection;  ///< GpsFixVerdict::kind when kRejected.
  // Record (stage_record.cc): the frame as the outputs write it; `latency_ms` set by the pose
  // stream sink when the frame is handed to the outputs (capture to then, ms).
  PendingFrame output;
  float latency_ms = 0.0f;
  /// The lens estimate was applied at this frame (pipeline/lens_switch.h): its position may
  /// jump from the frames before (frames.csv status "+lens", MAVLink reset_counter + 1).
  bool lens_switched = false;
  /// Frames the lens switch's new odometry was given again before this frame's stages, besides
  /// this frame's own odometry (pipeline/lens_switch.h: at most kLensReplayFramesPerFrame).
  int frames_replayed = 0;
  /// The live pose jumped past the autopilots' gates (a loop closure's whole-graph solve,
  /// stage_window.cc; a fused fix, stage_map_fix.cc): MAVLink reset_counter + 1.
  PoseReset pose_reset;
  /// An absolute position of this frame with its accuracy found by another stage (a fix against
  /// a map): the MAVLink sink sends it as GPS_INPUT (RunConfig::mavlink_gps_input) instead of
  /// the geo-referenced odometry pose. Unset: the odometry pose is sent.
  std::optional<mavlink::GeoFix> absolute_fix;
  /// map_fix.apply: a fix taken at this frame (stage_map_fix.cc) was fused into the pose graph
  /// or rejected by its gate (FlightGraph::AddFix; frames.csv status "+map_fix",
  /// "+map_gated"); the frame it was matched at, and how far it moved this frame's pose, m.
  enum class MapFixTaken { kNone, kFused, kGated };
  MapFixTaken map_fix = MapFixTaken::kNone;
  /// The run's geo-reference was seeded at this frame from a map's fix (stage_map_fix.cc Seed):
  /// that fix's position variance, m² (its covariance's trace plus its residual squared, the
  /// floor the graph puts on a fix: map_fixes.csv sigma_m² + residual_m²), an upper bound of its
  /// variance along the worse axis. The GPS_INPUT accuracy restarts from it (sink_mavlink.cc).
  std::optional<double> map_seed_var_m2;
  int map_fix_frame = -1;
  double map_fix_moved_m = 0.0;

  /// Back to an empty state, keeping `frame`'s pixel buffer for the next decoding.
  void Clear();
};

/// What the frames change for the whole run (owned by the FrameLoop, shared by the stages and
/// sinks through RunContext::state).
struct RunState {
  /// `fix_altitudes_above_sea_level`: GeoReferencer's (FixAltitudesAboveSeaLevel of the run's
  /// telemetry).
  explicit RunState(const RunConfig& config, bool fix_altitudes_above_sea_level = true);
  GeoReferencer georef;
  GpsFixChecker gps_check;  ///< Fixes (stage_gps_check.cc) and the heights' relative altitudes.
  RunTotals totals{true};
  std::map<int, RejectedFix> rejected;  ///< Frame -> its rejected fix.
  int frames_without_fix = 0;
  std::optional<double> first_frame_time_s;  ///< Frame::time_s of the first frame read.
  /// GPS denial: the georef stage has handled the first denied frame (fixed the heading with the
  /// fixes before, or said that it could not).
  bool denial_seen = false;
  /// The first frame flagged with each flag (FrameFlags names), for the summary's warning.
  std::map<std::string, std::string> first_flagged;
  /// Where a file's presentation times are placed on the clocks (FrameState::frame_mono_s):
  /// the first frame's Frame::time_s and when it was read.
  struct FrameClock {
    bool set = false;
    double first_time_s = 0.0, first_mono_s = 0.0, first_unix_s = 0.0;
  } frame_clock;
  /// Where a live frame's own time (Frame::time_s) is placed on CLOCK_MONOTONIC: the smallest
  /// arrival - own time so far (the least delayed frame).
  struct LiveClock {
    bool set = false;
    double mono_minus_own_s = 0.0;
  } live_clock;
  bool said_ahead_of_clock = false;  ///< "processed faster than real time" logged.
  /// backend.enable: every frame's pose, step and keyframe features for the offline
  /// optimisation after the last frame (sink_flight_graph.cc; graph null before the first frame).
  FlightRecording flight;
};

/// A run as set up from its first frame: what every frame goes through. The FrameLoop makes it
/// once (SetUpRun, run_setup.cc) and hands it to the stages and sinks as const: its pointers do
/// not change (but at the lens switch frame, between two frames: `lens_switch`), the objects behind `odometry`, `outputs`, `reducer`, `undistorter`, `link`,
/// `state` and `summary` do (they carry the run's history).
struct RunContext {
  // Given before the first frame.
  const RunConfig* config = nullptr;
  const RunTelemetry* telemetry = nullptr;
  const RunCallbacks* callbacks = nullptr;
  std::ostream* log = nullptr;  ///< May be null.
  std::filesystem::path out_dir;
  bool photo_folder = false;                ///< The source is a photo folder (ImageFolderSource).
  mavlink::AutopilotLink* link = nullptr;   ///< --mavlink (null: none).
  bool link_reads_autopilot = false;        ///< udpin/serial: height and attitude in.
  const std::atomic<bool>* stop = nullptr;  ///< May be null.
  const Stopwatch* wall = nullptr;          ///< The run's stopwatch (frames per second).
  /// RunConfig::map opened (null: none); read by the map fixer's thread only, until its Finish.
  const map::ReferenceMaps* maps = nullptr;
  RunSummary* summary = nullptr;
  RunState* state = nullptr;
  // From the first frame.
  RunCamera camera;                 ///< Of the frames as delivered.
  /// The camera's attitude estimated from the flight when significant (RunConfig::
  /// attitude_estimation, pipeline/lens_prepass.h): every frame's, when nothing else gives it.
  std::optional<CameraAttitude> estimated_attitude;
  int width_px = 0, height_px = 0;  ///< The frames as delivered.
  HeightSource height_source = HeightSource::kTelemetry;
  OdometryOptions vo_options;             ///< focal_px: of the processed (reduced) frames.
  std::unique_ptr<FrameReducer> reducer;  ///< Frames above the pixel budget; null: none.
  Eigen::Matrix3d reduced_from_full = Eigen::Matrix3d::Identity();
  std::unique_ptr<FrameUndistorter> undistorter;  ///< Whole frames remapped; null: none.
  UndistortionPath undistortion = UndistortionPath::kNone;
  std::unique_ptr<VisualOdometry> odometry;
  std::unique_ptr<RunOutputs> outputs;
  /// The lens self-calibration beside the odometry (null: skipped); the FrameLoop calls it
  /// around the stages and it replaces `camera.calibrated`, `odometry`, `undistorter` and
  /// `undistortion` at its switch frame, the one change of a RunContext after the first frame.
  std::unique_ptr<LensSwitch> lens_switch;
  /// With `maps`: the fixes against them on their own thread (pipeline/map_fixer.h; the map-fix
  /// stage hands it frames, the map-fix sink's End finishes it).
  std::shared_ptr<MapFixer> map_fixer;
};

/// The online window stage runs (stage_window.cc): with backend.online, and with map_fix.apply
/// and a map, so that the fixes are fused into the window's graph (stage_map_fix.cc; without
/// backend.online the window is "fixes only": the frames' steps, no keyframe matching).
inline bool WindowRuns(const RunContext& run) {
  return run.config->backend.online || (run.maps != nullptr && run.config->map_fix.apply);
}

/// One step of every frame (height, attitude, preprocessing, odometry, ...): reads what the
/// stages before it put in `frame`, adds its part. Throws to end the run at this frame:
/// InputError (the frame cannot be used), OutputError, Cancelled (the stop flag).
class FrameStage {
 public:
  virtual ~FrameStage() = default;
  /// For messages and tests, e.g. "height".
  virtual const char* name() const = 0;
  virtual void Process(FrameState& frame, const RunContext& run) = 0;
  /// Its InputError messages name the frame already; false: the run's failure is given the
  /// frame's name as its file (RunFailure::file), as for the odometry's.
  virtual bool ErrorsNameTheFrame() const { return true; }
};

/// A consumer of every frame the stages finished (the run files, the pose streams, MAVLink,
/// the totals, the progress callback), in the order of MakeSinks. Write may take what it needs
/// out of `frame` (the sinks after it see it moved from). An OutputError from Write is the
/// frame's: the run's failure names the frame (RunFailure::file).
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual const char* name() const = 0;
  virtual void Write(FrameState& frame, const RunContext& run) = 0;
  /// Once, when the loop ends (`end.failure`: the frame and error that ended it, if any);
  /// `run` is null when no frame was set up. Nothing by default.
  virtual void End(const LoopEnd& end, const RunContext* run) {
    (void)end;
    (void)run;
  }
};

}  // namespace aerovo::run_steps
