#include "aerovo/pipeline/frame_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo::run_steps {

// ---------------------------------------------------------------------------------------------
// The lists. A new stage or sink: its file, and one line here.

std::vector<StagePtr> MakeStages(const RunContext& run, const std::vector<StagePtr>& extra) {
  std::vector<StagePtr> stages;
  stages.push_back(MakeHeightStage(run));
  stages.push_back(MakeAttitudeStage());
  stages.push_back(MakeFlatFieldStage());
  stages.push_back(MakePreprocessStage());
  stages.push_back(MakeOdometryStage());
  if (WindowRuns(run)) stages.push_back(MakeWindowStage());
  stages.push_back(MakeGpsCheckStage());
  stages.push_back(MakeGeoreferenceStage());
  if (run.map_fixer) stages.push_back(MakeMapFixStage());
  stages.push_back(MakeRecordStage());
  stages.insert(stages.end(), extra.begin(), extra.end());
  return stages;
}

std::vector<SinkPtr> MakeSinks(const RunContext& run, const std::vector<SinkPtr>& extra) {
  std::vector<SinkPtr> sinks;
  if (run.link != nullptr) sinks.push_back(MakeMavlinkSink());
  sinks.push_back(MakeTransformsSink());
  sinks.push_back(MakeSourceCountsSink());
  sinks.push_back(MakePoseStreamSink());
  sinks.push_back(MakeRunFilesSink());
  if (run.config->backend.enable && !WindowRuns(run)) {
    sinks.push_back(MakeFlightGraphSink());  // online, the window stage builds the graph
  }
  sinks.push_back(MakeTotalsSink());
  sinks.push_back(MakeProgressSink());
  if (run.map_fixer) sinks.push_back(MakeMapFixSink());
  sinks.insert(sinks.end(), extra.begin(), extra.end());
  return sinks;
}

// ---------------------------------------------------------------------------------------------
// State

void FrameState::Clear() {
  Frame keep = std::move(frame);
  *this = FrameState();
  frame = std::move(keep);
}

namespace {

GeoRefOptions GeoRefOptionsOf(const RunConfig& config) {
  GeoRefOptions o;
  o.heading_source = config.heading;
  if (config.gps_check.enabled) {
    o.outlier_m = config.gps_check.tolerance_m;
    o.yaw_fixes = config.gps_check.min_chain;
  }
  return o;
}

// The file the signing timestamp is kept in (RunConfig::mavlink_key_timestamp); "" = none.
std::string SigningTimestampFile(const RunConfig& config) {
  if (config.mavlink_key_timestamp == "none") return "";
  if (!config.mavlink_key_timestamp.empty()) return config.mavlink_key_timestamp;
  return config.mavlink_key + ".timestamp";
}

// The --mavlink link (null without): InvalidArgument / InputError naming the URL.
std::unique_ptr<mavlink::AutopilotLink> OpenLink(const RunConfig& config, std::ostream* log) {
  if (config.mavlink.empty()) return nullptr;
  const mavlink::LinkUrl url = mavlink::ParseLinkUrl(config.mavlink);
  mavlink::AutopilotLink::Options o;
  o.sysid = static_cast<uint8_t>(config.mavlink_sysid);
  if (!config.mavlink_key.empty()) {
    o.signing_key = mavlink::ReadSigningKey(config.mavlink_key);
    o.signing_timestamp_file = SigningTimestampFile(config);
  }
  if (!o.signing_timestamp_file.empty()) {
    std::string problem;
    const std::optional<uint64_t> stored =
        mavlink::ReadSigningTimestamp(o.signing_timestamp_file, &problem);
    if (stored) o.signing_initial_timestamp = *stored;
    if (!problem.empty() && log) *log << "warning: " << problem << "\n";
  }
  auto link = std::make_unique<mavlink::AutopilotLink>(mavlink::OpenTransport(url), o);
  if (log) {
    *log << fmt::format("mavlink: {} ({}, sysid {}, compid {}, {} time{}{})\n", url.text,
                        ToString(config.mavlink_message), config.mavlink_sysid, o.compid,
                        ToString(config.mavlink_time), o.signing_key ? ", signed" : "",
                        url.reads_autopilot() ? "; height and attitude from the autopilot" : "");
  }
  return link;
}

// RunConfig::realtime: sleeps until mavlink::MonotonicNowS() reaches `mono_s`, in slices of at
// most 50 ms so that a stop request (SIGINT) ends the wait within them. False when stopped.
bool WaitUntilMonotonic(double mono_s, const std::atomic<bool>* stop) {
  constexpr double kSliceS = 0.05;
  for (;;) {
    if (stop != nullptr && stop->load()) return false;
    const double left_s = mono_s - mavlink::MonotonicNowS();
    if (left_s <= 0.0) return true;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(left_s, kSliceS)));
  }
}

// GPS denial (RunConfig::gps_denied_after_s): from the first frame at or after that time since
// the first frame on, the sample's horizontal position is moved to `f.withheld_gps` and the
// sample keeps no position (has_fix false, latitude and longitude 0), so that no stage can
// read it; the first denied frame is recorded in the totals.
void WithholdPositions(const RunConfig& config, RunState* state, FrameState& f) {
  if (!state->first_frame_time_s) state->first_frame_time_s = f.frame.time_s;
  if (config.gps_denied_after_s < 0.0 ||
      f.frame.time_s - *state->first_frame_time_s < config.gps_denied_after_s) {
    return;
  }
  f.gps_denied = true;
  if (!state->totals.denied_at_s) {
    state->totals.denied_at_s = f.frame.time_s;
    state->totals.denied_from_frame = f.frame.index;
  }
  if (!f.sample) return;
  f.withheld_gps = GpsOf(f.sample);
  f.sample->has_fix = false;
  f.sample->lat_deg = 0.0;
  f.sample->lon_deg = 0.0;
}

}  // namespace

RunState::RunState(const RunConfig& config, bool fix_altitudes_above_sea_level)
    : georef(GeoRefOptionsOf(config), fix_altitudes_above_sea_level), gps_check(config.gps_check) {}

bool FixAltitudesAboveSeaLevel(const RunTelemetry& telemetry) {
  const std::vector<TelemetrySample>& s = telemetry.telemetry().samples();
  return std::all_of(s.begin(), s.end(), [](const TelemetrySample& x) {
    return !x.has_fix || x.abs_alt_m.has_value();
  });
}

// ---------------------------------------------------------------------------------------------
// Reading

ReadResult ReadFrame(FrameSource& source, const RunConfig& config, const RunTelemetry& telemetry,
                     const std::atomic<bool>* stop, int frames_processed, RunState* state,
                     FrameState& f) {
  f.Clear();
  if (stop != nullptr && stop->load()) return ReadResult::kStopped;
  if (config.max_frames > 0 && frames_processed >= config.max_frames) return ReadResult::kEnd;
  f.frame.received_s = std::numeric_limits<double>::quiet_NaN();
  if (!source.Next(f.frame)) return ReadResult::kEnd;
  f.delivered = true;
  // A PrefetchSource stamps the frame when decoded; else it is received now.
  if (!std::isfinite(f.frame.received_s)) f.frame.received_s = SteadySeconds();
  // When the source delivered the frame (a live source's frames arrive as captured; a file's
  // as read), and the frame's own capture time (FrameState::frame_mono_s).
  f.capture_mono_s = mavlink::MonotonicNowS();
  f.capture_unix_s = mavlink::UnixNowS();
  if (source.IsLive()) {
    // Frame::received_s is on the steady clock (CLOCK_MONOTONIC on Linux): back-dated by the
    // time the frame waited in the decode-ahead queue.
    const double waited_s = std::max(0.0, SteadySeconds() - f.frame.received_s);
    const double arrival_mono_s = f.capture_mono_s - waited_s;
    // Its own time (Frame::time_s: a stream's presentation time) placed on the clock by the
    // least delayed frame so far, so that no frame is stamped after it arrived: frames that
    // waited in a stream's start-up buffer keep their spacing.
    RunState::LiveClock& c = state->live_clock;
    const double offset_s = arrival_mono_s - f.frame.time_s;
    if (!c.set || offset_s < c.mono_minus_own_s) c = {true, offset_s};
    f.frame_mono_s = f.frame.time_s + c.mono_minus_own_s;
    f.frame_unix_s = f.frame_mono_s + (f.capture_unix_s - f.capture_mono_s);
  } else {
    RunState::FrameClock& c = state->frame_clock;
    if (!c.set) c = {true, f.frame.time_s, f.capture_mono_s, f.capture_unix_s};
    const double since_first_s = f.frame.time_s - c.first_time_s;
    f.frame_mono_s = c.first_mono_s + since_first_s;
    f.frame_unix_s = c.first_unix_s + since_first_s;
    if (config.realtime) {
      if (!WaitUntilMonotonic(f.frame_mono_s, stop)) return ReadResult::kStopped;
      f.capture_mono_s = mavlink::MonotonicNowS();
      f.capture_unix_s = mavlink::UnixNowS();
    }
  }
  f.sample = telemetry.SampleOf(f.frame);
  WithholdPositions(config, state, f);
  f.gps = GpsOf(f.sample);
  // No sample, or a sample without a GPS fix (a withheld one is a fix).
  if (!f.gps && !f.withheld_gps) ++state->frames_without_fix;
  f.flags = FrameFlags::Parse(f.frame.flags);
  return ReadResult::kFrame;
}

// ---------------------------------------------------------------------------------------------
// The loop

FrameLoop::FrameLoop(const RunInputs& inputs, const RunTelemetry& telemetry,
                     const ImageFolderSource* folder, OdometryOptions vo_options,
                     const std::filesystem::path& out_dir, const RunCallbacks& callbacks,
                     std::ostream* log)
    : inputs_(inputs),
      telemetry_(telemetry),
      folder_(folder),
      vo_options_(std::move(vo_options)),
      out_dir_(out_dir),
      callbacks_(callbacks),
      log_(log),
      link_(OpenLink(inputs.config, log)),
      state_(inputs.config, FixAltitudesAboveSeaLevel(telemetry)) {}

FrameLoop::~FrameLoop() = default;

void FrameLoop::Process(FrameState& frame, const std::atomic<bool>* stop, const Stopwatch& wall,
                        RunSummary* summary) {
  if (!run_) {
    RunSetup setup;
    RunContext& base = setup.base;
    base.config = &inputs_.config;
    base.telemetry = &telemetry_;
    base.callbacks = &callbacks_;
    base.log = log_;
    base.out_dir = out_dir_;
    base.photo_folder = folder_ != nullptr;
    base.link = link_.get();
    base.link_reads_autopilot =
        link_ && mavlink::ParseLinkUrl(inputs_.config.mavlink).reads_autopilot();
    base.stop = stop;
    base.wall = &wall;
    base.maps = maps_;
    base.summary = summary;
    base.state = &state_;
    setup.focal_from_sim = inputs_.focal_from_sim;
    setup.folder = folder_;
    setup.source_live = source_live_;
    setup.vo_options = vo_options_;
    run_ = SetUpRun(std::move(setup), frame);
    stages_ = MakeStages(*run_, callbacks_.stages);
    sinks_ = MakeSinks(*run_, callbacks_.sinks);
  }
  LensSwitch* lens = run_->lens_switch.get();  // the lens estimate (pipeline/lens_switch.h)
  if (lens != nullptr && !lens->done()) lens->BeforeStages(*run_, frame);
  in_frame_steps_ = true;
  for (const StagePtr& stage : stages_) {
    errors_name_frame_ = stage->ErrorsNameTheFrame();
    stage->Process(frame, *run_);
  }
  errors_name_frame_ = true;
  if (lens != nullptr && !lens->done()) lens->Keep(frame);
  for (const SinkPtr& sink : sinks_) sink->Write(frame, *run_);
  in_frame_steps_ = false;
}

RunFailure FrameLoop::FailureOf(RunFailureKind kind, const char* what,
                                const FrameState& frame) const {
  RunFailure f;
  f.kind = kind;
  f.frame = frame.delivered ? frame.frame.index : -1;
  f.message = what;
  // An output file that cannot be written while a frame is written, or an error of the
  // odometry (which does not know the frame): said with the frame's name.
  const bool name_it = in_frame_steps_ && (kind == RunFailureKind::kOutput || !errors_name_frame_);
  if (name_it) f.file = frame.frame.name;
  return f;
}

void FrameLoop::SayWhenAheadOfTheClock(const FrameState& f, const FrameSource& source) {
  // A file read faster than it was filmed: its frames' times run ahead of the clock. Said once,
  // with --mavlink only (the messages carry those times; nothing else reads the clock).
  constexpr double kAheadS = 0.5;
  if (!link_ || !log_ || source.IsLive() || state_.said_ahead_of_clock) return;
  const double ahead_s = f.frame_mono_s - f.capture_mono_s;
  if (ahead_s <= kAheadS) return;
  state_.said_ahead_of_clock = true;
  *log_ << fmt::format(
      "mavlink: the file is processed faster than real time (frame {} at {:.2f} s of the "
      "stream, {:.2f} s ahead of the clock): messages carry the frames' own times, velocities "
      "from their differences\n",
      f.frame.index, f.frame.time_s, ahead_s);
}

LoopEnd FrameLoop::Run(FrameSource& source, const std::atomic<bool>* stop, const Stopwatch& wall,
                       RunSummary* summary) {
  LoopEnd end;
  FrameState frame;
  // Any failure stops the run with the frames before it kept, and summary.json written with
  // the error (WriteSummary), at the first frame too: a run folder never ends with outputs and
  // no summary (an undecodable first photo, no height or no camera for the first frame).
  while (!end.failure && !end.stopped) {
    try {
      const ReadResult read = ReadFrame(source, inputs_.config, telemetry_, stop,
                                        summary->frames_processed, &state_, frame);
      if (read != ReadResult::kFrame) {
        end.stopped = read == ReadResult::kStopped;
        break;
      }
      SayWhenAheadOfTheClock(frame, source);
      Process(frame, stop, wall, summary);
    } catch (const Cancelled&) {  // a stop inside SURF, matching or RANSAC: frame abandoned
      end.stopped = true;
    } catch (const OutputError& e) {  // disk full: every file keeps its last valid content
      end.failure = FailureOf(RunFailureKind::kOutput, e.what(), frame);
    } catch (const InputError& e) {
      end.failure = FailureOf(RunFailureKind::kInput, e.what(), frame);
    }
  }
  if (run_ && run_->lens_switch) {
    try {
      run_->lens_switch->Finish(*run_);
    } catch (const Cancelled&) {  // stopped while waiting for the estimate
      end.stopped = true;
    }
  }
  end.frames_without_fix = state_.frames_without_fix;
  end.first_flagged = state_.first_flagged;
  end.rejected_fixes = RejectedFixes();
  for (const SinkPtr& sink : sinks_) sink->End(end, run_.get());
  for (const SinkPtr& sink : callbacks_.sinks) {
    if (!run_) sink->End(end, nullptr);  // never set up: the callers' sinks still hear the end
  }
  return end;
}

void FrameLoop::Finish() {
  if (run_) run_->outputs->Finish(state_.georef);
}

std::vector<RejectedFix> FrameLoop::RejectedFixes() const {
  std::vector<RejectedFix> out;
  for (const auto& [f, r] : state_.rejected) out.push_back(r);
  return out;
}

}  // namespace aerovo::run_steps
