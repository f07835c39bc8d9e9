// The per-frame loop (frame_loop.h) on frames generated in memory: every frame processed and
// written, max_frames and the stop flag, a failure keeping the frames before it, and stages and
// sinks added by a caller (RunCallbacks) alone, called in order for every frame.
#include "aerovo/pipeline/frame_loop.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/core/timer.h"
#include "aerovo/pipeline/frame_state.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo::run_steps::frame_loop_test {
namespace {

namespace fs = std::filesystem;

using ::aerovo::testing::ReadText;

fs::path TempDir(const std::string& name) {
  return ::aerovo::testing::FreshTempDir("aerovo_frame_loop", name);
}

// Rows of a CSV file after its header.
int CsvRows(const fs::path& p) {
  std::istringstream in(ReadText(p));
  std::string line;
  int n = 0;
  while (std::getline(in, line)) ++n;
  return n - 1;
}

// ---------------------------------------------------------------------------------------------
// 5. The frame loop

// Frames cut from one smooth random texture, each `shift_px` further right; the frame
// `odd_index` (if >= 0) has another size, the frame `blank_index` (if >= 0) is uniform grey (no
// feature: the odometry bridges it).
class ShiftedCrops : public FrameSource {
 public:
  ShiftedCrops(int count, int shift_px, int odd_index = -1, int blank_index = -1)
      : count_(count), shift_px_(shift_px), odd_index_(odd_index), blank_index_(blank_index) {
    cv::Mat noise(kH + 64, kW + 64 + count * shift_px, CV_32F);
    cv::RNG rng(7);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.5);
    cv::normalize(noise, noise, 0.0, 255.0, cv::NORM_MINMAX);
    noise.convertTo(texture_, CV_8U);
  }
  bool Next(Frame& frame) override {
    if (next_ >= count_) return false;
    const int w = next_ == odd_index_ ? kW / 2 : kW;
    const cv::Mat crop = texture_(cv::Rect(32 + next_ * shift_px_, 32, w, kH));
    frame.gray = GrayImage(w, kH);
    for (int y = 0; y < kH; ++y) std::copy_n(crop.ptr<std::uint8_t>(y), w, frame.gray.row(y));
    if (next_ == blank_index_) {
      for (int y = 0; y < kH; ++y) std::fill_n(frame.gray.row(y), w, std::uint8_t{128});
    }
    frame.index = next_;
    frame.time_s = 0.1 * next_;
    frame.name = "crop" + std::to_string(next_);
    ++next_;
    return true;
  }
  std::string Describe() const override { return "shifted crops"; }
  int ExpectedFrameCount() const override { return count_; }

  static constexpr int kW = 320, kH = 240;

 private:
  int count_, shift_px_, odd_index_, blank_index_;
  int next_ = 0;
  cv::Mat texture_;
};

RunInputs LoopInputs(const fs::path& out) {
  RunInputs in;
  in.config.out = out.string();
  in.config.altitude_m = 50.0;
  in.config.focal_px = 400.0;
  return in;
}

TEST(FrameLoop, ProcessesEveryFrame) {
  const fs::path dir = TempDir("loop");
  const RunInputs inputs = LoopInputs(dir);
  const RunTelemetry telemetry;
  RunCallbacks cb;
  std::vector<int> progress;
  cb.progress = [&](int done, int expected, double) {
    progress.push_back(done);
    EXPECT_EQ(expected, 6);
  };
  std::ostringstream log;
  FrameLoop loop(inputs, telemetry, nullptr, OdometryOptions(), dir, cb, &log);
  ShiftedCrops source(6, 6);
  RunSummary s;
  s.frames_expected = source.ExpectedFrameCount();
  const LoopEnd end = loop.Run(source, nullptr, Stopwatch(), &s);
  loop.Finish();
  EXPECT_FALSE(end.stopped);
  EXPECT_FALSE(end.failure.has_value());
  EXPECT_EQ(end.frames_without_fix, 6);
  EXPECT_EQ(s.frames_processed, 6);
  EXPECT_EQ(progress, (std::vector<int>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(s.focal_px, 400.0);
  EXPECT_EQ(s.focal_source, "flag");
  EXPECT_EQ(s.height_source, "flag");
  EXPECT_EQ(log.str(),
            "camera: 320x240 px, focal 400.0 px (flag), height from flag\ncamera: focal length "
            "400.0 px (given)\n");
  ASSERT_NE(loop.vo_stats(), nullptr);
  EXPECT_EQ(loop.vo_stats()->ok, 6);
  EXPECT_EQ(loop.totals().measured_steps, 5);
  // 6 px per frame at 50 m and 400 px: 0.75 m per step.
  EXPECT_NEAR(loop.totals().path_length_m, 5 * 0.75, 0.05);
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 6);
  EXPECT_EQ(CsvRows(dir / "transforms.csv"), 6);
  fs::remove_all(dir);
}

TEST(FrameLoop, StopsAtMaxFramesAndOnTheStopFlag) {
  const fs::path dir = TempDir("loop_stop");
  RunInputs inputs = LoopInputs(dir);
  inputs.config.max_frames = 3;
  const RunTelemetry telemetry;
  const RunCallbacks cb;
  {
    FrameLoop loop(inputs, telemetry, nullptr, OdometryOptions(), dir, cb, nullptr);
    ShiftedCrops source(6, 6);
    RunSummary s;
    const LoopEnd end = loop.Run(source, nullptr, Stopwatch(), &s);
    loop.Finish();
    EXPECT_FALSE(end.stopped);
    EXPECT_EQ(s.frames_processed, 3);
    EXPECT_EQ(CsvRows(dir / "frames.csv"), 3);
  }
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    FrameLoop loop(inputs, telemetry, nullptr, OdometryOptions(), dir, cb, nullptr);
    ShiftedCrops source(6, 6);
    RunSummary s;
    const std::atomic<bool> stop{true};
    const LoopEnd end = loop.Run(source, &stop, Stopwatch(), &s);
    loop.Finish();
    EXPECT_TRUE(end.stopped);
    EXPECT_EQ(s.frames_processed, 0);
    EXPECT_EQ(loop.vo_stats(), nullptr);
    EXPECT_FALSE(fs::exists(dir / "frames.csv"));
  }
  fs::remove_all(dir);
}

TEST(FrameLoop, KeepsTheFramesBeforeAnInputError) {
  const fs::path dir = TempDir("loop_error");
  const RunInputs inputs = LoopInputs(dir);
  const RunTelemetry telemetry;
  const RunCallbacks cb;
  FrameLoop loop(inputs, telemetry, nullptr, OdometryOptions(), dir, cb, nullptr);
  ShiftedCrops source(6, 6, 3);  // crop3 has another size
  RunSummary s;
  const LoopEnd end = loop.Run(source, nullptr, Stopwatch(), &s);
  loop.Finish();
  EXPECT_EQ(s.frames_processed, 3);
  ASSERT_TRUE(end.failure.has_value());
  EXPECT_EQ(end.failure->kind, RunFailureKind::kInput);
  EXPECT_EQ(end.failure->frame, 3);
  EXPECT_EQ(end.failure->file, "crop3");  // the odometry's error does not name the frame
  EXPECT_EQ(end.failure->Text().rfind("crop3: ", 0), 0u) << end.failure->Text();
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 3);

  // A missing height at the first frame ends the loop the same way (no frame processed), so that
  // RunFlight writes summary.json with the error (before: thrown past the summary).
  ShiftedCrops first_odd(3, 6);
  RunInputs no_height = LoopInputs(dir);
  no_height.config.altitude_m = 0.0;
  FrameLoop unknown(no_height, telemetry, nullptr, OdometryOptions(), dir, cb, nullptr);
  RunSummary u;
  const LoopEnd none = unknown.Run(first_odd, nullptr, Stopwatch(), &u);
  EXPECT_EQ(u.frames_processed, 0);
  EXPECT_FALSE(none.stopped);
  ASSERT_TRUE(none.failure.has_value());
  EXPECT_EQ(none.failure->frame, 0);
  EXPECT_EQ(none.failure->file, "");  // the height's error names the frame itself
  EXPECT_EQ(none.failure->Text().rfind("crop0: no height above ground", 0), 0u)
      << none.failure->Text();
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// Stages and sinks added by a caller: this file alone, no edit of the pipeline.

// Every call, in order: "stage <index> <status>", "sink <index> <frames processed>",
// "end <kind> <frame> <file>" (or "end ok").
using CallLog = std::vector<std::string>;

// After the built-in stages: sees the odometry's result. Throws an InputError at `throw_at`.
class LoggingStage : public FrameStage {
 public:
  LoggingStage(CallLog* log, int throw_at = -1) : log_(log), throw_at_(throw_at) {}
  const char* name() const override { return "test_logging"; }
  void Process(FrameState& f, const RunContext& run) override {
    (void)run;
    log_->push_back("stage " + std::to_string(f.frame.index) + " " + ToString(f.result.status));
    if (f.frame.index == throw_at_) throw InputError(f.frame.name + ": refused by the test stage");
  }

 private:
  CallLog* log_;
  int throw_at_;
};

// After the built-in sinks: the frame is counted (frames_processed) and in frames.csv or queued.
class LoggingSink : public FrameSink {
 public:
  explicit LoggingSink(CallLog* log) : log_(log) {}
  const char* name() const override { return "test_logging"; }
  void Write(FrameState& f, const RunContext& run) override {
    log_->push_back("sink " + std::to_string(f.frame.index) + " " +
                    std::to_string(run.summary->frames_processed));
  }
  void End(const LoopEnd& end, const RunContext* run) override {
    EXPECT_NE(run, nullptr);
    log_->push_back(end.failure ? std::string("end ") + ToString(end.failure->kind) + " " +
                                      std::to_string(end.failure->frame) + " " + end.failure->file
                                : std::string("end ok"));
  }

 private:
  CallLog* log_;
};

RunConfig FlightConfig(const fs::path& out) {
  RunConfig c;
  c.input = "shifted-crops";
  c.out = out.string();
  c.altitude_m = 50.0;
  c.focal_px = 400.0;
  c.quiet = true;
  return c;
}

TEST(FrameLoop, CallersStagesAndSinksSeeEveryFrameInOrderBridgedAndFailedOnes) {
  const fs::path dir = TempDir("extra");
  CallLog calls;
  RunCallbacks cb;
  cb.stages.push_back(std::make_shared<LoggingStage>(&calls));
  cb.sinks.push_back(std::make_shared<LoggingSink>(&calls));
  // Frame 2 uniform grey (bridged), frame 5 of another size (the odometry refuses it).
  try {
    RunFlight(FlightConfig(dir), std::make_unique<ShiftedCrops>(6, 6, 5, 2), cb);
    ADD_FAILURE() << "frame 5 must stop the run";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("crop5: ", 0), 0u) << e.what();
  }
  const CallLog expected = {"stage 0 first",   "sink 0 1", "stage 1 ok",       "sink 1 2",
                            "stage 2 bridged", "sink 2 3", calls.at(6),        "sink 3 4",
                            calls.at(8),       "sink 4 5", "end input 5 crop5"};
  EXPECT_EQ(calls, expected);
  // Frames 3 and 4 follow the bridged one: measured again (ok or reacquired), never skipped.
  EXPECT_EQ(calls.at(6).rfind("stage 3 ", 0), 0u);
  EXPECT_EQ(calls.at(8).rfind("stage 4 ", 0), 0u);
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 5);
  const nlohmann::json summary = nlohmann::json::parse(ReadText(dir / "summary.json"));
  EXPECT_EQ(summary.at("frames_processed"), 5);
  EXPECT_EQ(summary.at("frames_bridged"), 1);
  EXPECT_EQ(summary.at("error").get<std::string>().rfind("crop5: ", 0), 0u);
  fs::remove_all(dir);
}

TEST(FrameLoop, ACallersStageThatThrowsEndsTheRunAtItsFrame) {
  const fs::path dir = TempDir("extra_throws");
  CallLog calls;
  RunCallbacks cb;
  cb.stages.push_back(std::make_shared<LoggingStage>(&calls, 3));
  cb.sinks.push_back(std::make_shared<LoggingSink>(&calls));
  try {
    RunFlight(FlightConfig(dir), std::make_unique<ShiftedCrops>(6, 6), cb);
    ADD_FAILURE() << "the test stage must stop the run";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("crop3: refused by the test stage (the run stopped "
                                          "there: the 3 frames processed before are in",
                                          0),
              0u)
        << e.what();
  }
  const CallLog expected = {"stage 0 first", "sink 0 1", "stage 1 ok", "sink 1 2",
                            "stage 2 ok",    "sink 2 3", "stage 3 ok", "end input 3 "};
  EXPECT_EQ(calls, expected);
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 3);
  fs::remove_all(dir);
}

// A live source: ShiftedCrops delivered as a camera would, each frame stamped as received
// `waited_s` before it is read.
class LiveCrops : public ShiftedCrops {
 public:
  LiveCrops(int count, double waited_s) : ShiftedCrops(count, 6), waited_s_(waited_s) {}
  bool Next(Frame& frame) override {
    if (!ShiftedCrops::Next(frame)) return false;
    frame.received_s = SteadySeconds() - waited_s_;
    return true;
  }
  bool IsLive() const override { return true; }

 private:
  double waited_s_;
};

// The run's geo-referencing knows its altitude only from fixes above sea level: telemetry with
// heights above the take-off point only (or none) gives tracks without an altitude.
TEST(FrameLoop, OnlyFixesAboveSeaLevelGiveTheTrackAnAltitude) {
  const auto fix = [](double t, std::optional<double> abs_alt) {
    TelemetrySample s;
    s.time_s = t;
    s.has_fix = true;
    s.lat_deg = 45.0;
    s.lon_deg = 7.0;
    s.rel_alt_m = 50.0;
    s.abs_alt_m = abs_alt;
    return s;
  };
  TelemetrySample no_fix;  // a record without a position does not count
  no_fix.time_s = 2.0;
  no_fix.has_fix = false;
  const RunTelemetry amsl(Telemetry({fix(0.0, 300.0), fix(1.0, 301.0), no_fix}), false, "t");
  const RunTelemetry relative(Telemetry({fix(0.0, 300.0), fix(1.0, std::nullopt)}), false, "t");
  EXPECT_TRUE(FixAltitudesAboveSeaLevel(amsl));
  EXPECT_FALSE(FixAltitudesAboveSeaLevel(relative));
  EXPECT_TRUE(FixAltitudesAboveSeaLevel(RunTelemetry()));
  const RunConfig config;
  EXPECT_FALSE(
      RunState(config, FixAltitudesAboveSeaLevel(relative)).georef.fix_altitudes_above_sea_level());
  EXPECT_TRUE(RunState(config).georef.fix_altitudes_above_sea_level());
}

TEST(FrameLoop, AFilesFramesCarryTheirPresentationTimesALiveFrameItsArrival) {
  const RunInputs in = LoopInputs(TempDir("times"));
  const RunTelemetry telemetry;
  RunState state(in.config);
  FrameState f;
  // A file read as fast as it comes (the crops are 0.1 s apart in the stream): the frames' own
  // times are 0.1 s apart on both clocks, from when the first was read (within 1 us, the
  // messages' resolution; a Unix time in double seconds resolves 0.24 us).
  ShiftedCrops file(4, 6);
  std::vector<FrameState> got;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(ReadFrame(file, in.config, telemetry, nullptr, i, &state, f), ReadResult::kFrame);
    got.push_back(f);
    got.back().frame = Frame();
  }
  EXPECT_NEAR(got[0].frame_mono_s, got[0].capture_mono_s, 1e-9);
  EXPECT_NEAR(got[0].frame_unix_s, got[0].capture_unix_s, 1e-9);
  for (int i = 1; i < 4; ++i) {
    EXPECT_NEAR(got[i].frame_mono_s - got[0].frame_mono_s, 0.1 * i, 1e-6) << i;
    EXPECT_NEAR(got[i].frame_unix_s - got[0].frame_unix_s, 0.1 * i, 1e-6) << i;
    // Read back to back: far less than 0.1 s apart on the clock, which the height and attitude
    // of the autopilot are matched to.
    EXPECT_LT(got[i].capture_mono_s - got[i - 1].capture_mono_s, 0.05) << i;
  }
  // A live frame: when its source delivered it, 0.2 s before the loop read it.
  RunState live_state(in.config);
  LiveCrops live(1, 0.2);
  ASSERT_EQ(ReadFrame(live, in.config, telemetry, nullptr, 0, &live_state, f), ReadResult::kFrame);
  EXPECT_NEAR(f.capture_mono_s - f.frame_mono_s, 0.2, 0.01);
  EXPECT_NEAR(f.capture_unix_s - f.frame_unix_s, 0.2, 0.01);
  fs::remove_all(in.config.out);
}

// A stream's start-up burst: frames 0.1 s apart in the stream (Frame::time_s, LiveFrameTimes)
// delivered 1 ms apart, then at their pace.
class BurstCrops : public ShiftedCrops {
 public:
  BurstCrops() : ShiftedCrops(6, 6), t0_(SteadySeconds() - 1.0) {}  // all arrived before read
  bool Next(Frame& frame) override {
    if (!ShiftedCrops::Next(frame)) return false;
    const int i = frame.index;
    frame.received_s = t0_ + (i < 3 ? 0.001 * i : 0.1 * i - 0.198);  // 0, 1, 2 ms, then 0.102...
    return true;
  }
  bool IsLive() const override { return true; }

 private:
  double t0_;
};

TEST(FrameLoop, ALiveFramesOwnTimeIsPlacedByTheLeastDelayedFrame) {
  const RunInputs in = LoopInputs(TempDir("burst"));
  const RunTelemetry telemetry;
  RunState state(in.config);
  FrameState f;
  BurstCrops live;
  std::vector<FrameState> got;
  for (int i = 0; i < 6; ++i) {
    ASSERT_EQ(ReadFrame(live, in.config, telemetry, nullptr, i, &state, f), ReadResult::kFrame);
    got.push_back(f);
    got.back().frame = Frame();
  }
  for (int i = 1; i < 6; ++i) {
    EXPECT_GT(got[i].frame_mono_s, got[i - 1].frame_mono_s) << i;  // strictly increasing
    EXPECT_NEAR(got[i].frame_unix_s - got[i].frame_mono_s,
                got[i].capture_unix_s - got[i].capture_mono_s, 1e-6) << i;
  }
  // Frame 1 arrived 99 ms early for its own time: stamped at its arrival, never after it; from
  // then on the frames keep their own spacing (0.1 s), although frame 3 arrived 100 ms after 2.
  EXPECT_NEAR(got[1].frame_mono_s - got[0].frame_mono_s, 0.001, 2e-4);
  EXPECT_NEAR(got[2].frame_mono_s - got[1].frame_mono_s, 0.001, 2e-4);
  for (int i = 3; i < 6; ++i) {
    EXPECT_NEAR(got[i].frame_mono_s - got[i - 1].frame_mono_s, 0.1, 2e-4) << i;
  }
  fs::remove_all(in.config.out);
}

TEST(FrameLoop, RealtimeDeliversAFilesFramesNoEarlierThanTheirOwnTimes) {
  RunInputs in = LoopInputs(TempDir("realtime"));
  in.config.realtime = true;
  const RunTelemetry telemetry;
  RunState state(in.config);
  FrameState f;
  // The crops are 0.1 s apart in the stream: each is delivered at or after its own time on the
  // clock, so the messages' times are never ahead of it (within 0.5 s after it: a loaded
  // machine's sleep).
  ShiftedCrops file(4, 6);
  std::vector<FrameState> got;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(ReadFrame(file, in.config, telemetry, nullptr, i, &state, f), ReadResult::kFrame);
    got.push_back(f);
    got.back().frame = Frame();
  }
  for (int i = 1; i < 4; ++i) {
    EXPECT_NEAR(got[i].frame_mono_s - got[0].frame_mono_s, 0.1 * i, 1e-6) << i;
    EXPECT_GE(got[i].capture_mono_s, got[i].frame_mono_s) << i;
    EXPECT_LT(got[i].capture_mono_s - got[i].frame_mono_s, 0.5) << i;
  }
  // A stop request ends the wait for a frame 100 s ahead within its 50 ms slices.
  class FarApart : public ShiftedCrops {
   public:
    FarApart() : ShiftedCrops(2, 6) {}
    bool Next(Frame& frame) override {
      if (!ShiftedCrops::Next(frame)) return false;
      frame.time_s = 100.0 * frame.index;
      return true;
    }
  } far;
  RunState far_state(in.config);
  std::atomic<bool> stop{false};
  ASSERT_EQ(ReadFrame(far, in.config, telemetry, &stop, 0, &far_state, f), ReadResult::kFrame);
  const double t0 = SteadySeconds();
  std::thread stopper([&stop] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop = true;
  });
  EXPECT_EQ(ReadFrame(far, in.config, telemetry, &stop, 1, &far_state, f), ReadResult::kStopped);
  stopper.join();
  EXPECT_LT(SteadySeconds() - t0, 5.0);
  fs::remove_all(in.config.out);
}

TEST(FrameLoop, StagesAndSinksAreListedInTheirOrder) {
  const RunConfig config;
  RunContext run;  // no link
  run.config = &config;
  CallLog calls;
  const std::vector<StagePtr> stages = MakeStages(run, {std::make_shared<LoggingStage>(&calls)});
  std::vector<std::string> names;
  for (const StagePtr& s : stages) names.emplace_back(s->name());
  EXPECT_EQ(names,
            (std::vector<std::string>{"height", "attitude", "flat_field", "preprocess", "odometry",
                                      "gps_check", "georeference", "record", "test_logging"}));
  names.clear();
  for (const SinkPtr& s : MakeSinks(run, {std::make_shared<LoggingSink>(&calls)})) {
    names.emplace_back(s->name());
  }
  // No MAVLink sink without a link.
  EXPECT_EQ(names, (std::vector<std::string>{"transforms", "source_counts", "pose_stream",
                                             "run_files", "totals", "progress", "test_logging"}));
}

}  // namespace
}  // namespace aerovo::run_steps::frame_loop_test
