// The live outputs of `aerovo run` (docs/options.md, --poses-jsonl): the JSONL pose stream on
// stdout with nothing else there (--poses-jsonl -), its geographic follow-up lines when the heading
// waits for GPS, the capture-to-send latency in frames.csv and summary.json, and a live source
// faster than the processing: the newest frame is taken, older ones dropped and counted.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "aerovo/core/options.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/mavlink/messages.h"
#include "aerovo/pipeline/demo.h"
#include "aerovo/pipeline/experiment.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/run_reader.h"
#include "aerovo/sim/simulator.h"

#include "e2e_testing.h"

namespace aerovo::pose_stream_test {
namespace {

namespace fs = std::filesystem;

using e2e::ReadText;
using ::aerovo::testing::Lines;


// A small simulated flight (video, SRT with GPS, height and yaw), made once.
const SimulatedFlight& Flight() {
  static const SimulatedFlight flight = [] {
    const fs::path dir =
        fs::temp_directory_path() / ("aerovo_pose_stream_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ExperimentSimulation sim = DemoSimulation(true);
    sim.sim.flight.legs = 1;
    sim.sim.flight.leg_length_m = 60.0;
    sim.sim.fps = 5.0;  // 30 frames, the first GPS segment (30 m) after 15
    return SimulateExperimentFlight(sim, dir / "sim");
  }();
  return flight;
}

#ifdef AEROVO_CLI_PATH

struct Cli {
  int status = -1;
  std::string out, err;
};

// Runs the CLI with stdout and stderr captured apart.
Cli RunCli(const std::string& args, const fs::path& err_file) {
  const testing::CommandOutput c = testing::RunCommand(std::string(AEROVO_CLI_PATH) + " " + args +
                                                        " 2> '" + err_file.string() + "'");
  return {c.status, c.out, ReadText(err_file)};
}

std::string RunArgs(const SimulatedFlight& f, const fs::path& out) {
  return "run " + f.run.input + " --telemetry " + f.run.telemetry + " --focal-px " +
         options::FormatNumber(f.run.focal_px) + " --threads 1 --no-report -o '" + out.string() +
         "'";
}

// Every stdout line a JSON object; the pose lines one per frames.csv row, in order, with every
// field; the parsed lines into `lines_out`.
void CheckStream(const Cli& r, const fs::path& out, std::vector<nlohmann::json>* lines_out) {
  std::vector<nlohmann::json>& lines = *lines_out;
  lines.clear();
  for (const std::string& line : Lines(r.out)) {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(line);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not JSON on stdout: '" << line << "': " << e.what();
      continue;
    }
    EXPECT_TRUE(j.is_object()) << line;
    lines.push_back(j);
  }
  const auto rows = e2e::ReadCsvRows(out / "frames.csv");
  std::size_t pose = 0;
  for (const nlohmann::json& j : lines) {
    ASSERT_TRUE(j.contains("type")) << j;
    if (j["type"] != "pose") continue;
    ASSERT_LT(pose, rows.size());
    for (const char* k : {"index", "time_s", "x_m", "y_m", "z_m", "heading_deg", "status",
                          "quality", "latency_ms"}) {
      EXPECT_TRUE(j.contains(k)) << k << " missing in " << j;
    }
    EXPECT_EQ(j["index"].get<int>(), std::stoi(rows[pose].at("frame")));
    EXPECT_EQ(j["status"].get<std::string>(), rows[pose].at("status"));
    EXPECT_NEAR(j["time_s"].get<double>(), std::stod(rows[pose].at("time_s")), 1e-6);
    const int q = j["quality"].get<int>();
    EXPECT_TRUE(q == -1 || (q >= 1 && q <= 100)) << q;
    EXPECT_EQ(q == -1, rows[pose].at("status").rfind("bridged", 0) == 0) << j;
    EXPECT_GT(j["z_m"].get<double>(), 10.0) << "z_m is the height above ground";
    EXPECT_GE(j["latency_ms"].get<double>(), 0.0);
    // The latency of the stream is the one in frames.csv.
    EXPECT_NEAR(j["latency_ms"].get<double>(), std::stod(rows[pose].at("latency_ms")), 1e-3);
    ++pose;
  }
  EXPECT_EQ(pose, rows.size()) << "one pose line per frame";
}

TEST(PoseStream, JsonLinesOnStdoutAndNothingElse) {
  const SimulatedFlight& f = Flight();
  const fs::path out = f.dir.parent_path() / "jsonl-yaw";
  const Cli r = RunCli(RunArgs(f, out) + " --max-frames 12 --poses-jsonl -", out.string() + ".err");
  ASSERT_EQ(r.status, 0) << r.err;
  std::vector<nlohmann::json> lines;
  CheckStream(r, out, &lines);
  // 12 pose lines (CheckStream); the rest are the "geo" lines of frames sent before the
  // heading was fixed (the simulator's SRT has no yaw: heading from the first GPS segment).
  ASSERT_GE(lines.size(), 12u);
  for (std::size_t i = 12; i < lines.size(); ++i) EXPECT_EQ(lines[i]["type"], "geo") << lines[i];
  EXPECT_EQ(lines[0]["type"], "pose");
  EXPECT_EQ(lines[0]["quality"], 100) << "the origin";
  // The messages went to stderr: the configuration and the summary table.
  EXPECT_NE(r.err.find("configuration: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" processed: ok "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("capture to pose: median"), std::string::npos) << r.err;
  // summary.json: latency figures, nothing dropped from a file.
  const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ(s["frames_dropped"], 0);
  EXPECT_EQ(s["latency_ms"]["frames"], 12);
  EXPECT_GT(s["latency_ms"]["median"].get<double>(), 0.0);
  EXPECT_GE(s["latency_ms"]["p95"].get<double>(), s["latency_ms"]["median"].get<double>());
  EXPECT_GE(s["latency_ms"]["max"].get<double>(), s["latency_ms"]["p95"].get<double>());
}

TEST(PoseStream, HeadingFromGpsLocalPosesAtOnceGeographicOnesFollow) {
  const SimulatedFlight& f = Flight();
  const fs::path out = f.dir.parent_path() / "jsonl-gps";
  const fs::path stream = f.dir.parent_path() / "poses.jsonl";
  // Into a file: stdout has the messages as usual.
  const Cli r = RunCli(RunArgs(f, out) + " --heading gps --poses-jsonl '" + stream.string() + "'",
                       out.string() + ".err");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find(" processed: ok "), std::string::npos);
  Cli from_file;
  from_file.out = ReadText(stream);
  std::vector<nlohmann::json> lines;
  CheckStream(from_file, out, &lines);
  const auto rows = e2e::ReadCsvRows(out / "frames.csv");
  ASSERT_GT(rows.size(), 20u);
  // The first poses are local only (the heading waits for 30 m of GPS track); each gets its
  // "geo" line once the heading is fixed, before the next pose, with frames.csv's WGS84.
  std::map<int, nlohmann::json> geo_of;
  int local_only = 0, geo_lines = 0;
  bool seen_geo_pose = false;
  for (const nlohmann::json& j : lines) {
    const int index = j["index"].get<int>();
    if (j["type"] == "pose") {
      if (j.contains("lat_deg")) {
        seen_geo_pose = true;
        geo_of[index] = j;
      } else {
        EXPECT_FALSE(seen_geo_pose) << "a local-only pose after geo-referenced ones: " << j;
        ++local_only;
      }
    } else {
      ASSERT_EQ(j["type"], "geo") << j;
      EXPECT_FALSE(geo_of.count(index)) << "two geographic positions for frame " << index;
      geo_of[index] = j;
      ++geo_lines;
    }
  }
  EXPECT_GT(local_only, 0) << "the heading was known at once: the test tests nothing";
  EXPECT_EQ(geo_lines, local_only);
  for (const auto& row : rows) {
    const int index = std::stoi(row.at("frame"));
    ASSERT_TRUE(geo_of.count(index)) << "frame " << index << " never geo-referenced";
    EXPECT_NEAR(geo_of[index]["lat_deg"].get<double>(), std::stod(row.at("lat_deg")), 1e-9);
    EXPECT_NEAR(geo_of[index]["lon_deg"].get<double>(), std::stod(row.at("lon_deg")), 1e-9);
  }
}

TEST(PoseStream, PrintPosesAndJsonOnStdoutConflict) {
  const SimulatedFlight& f = Flight();
  const fs::path out = f.dir.parent_path() / "conflict";
  const Cli r =
      RunCli(RunArgs(f, out) + " --print-poses --poses-jsonl -", out.string() + ".err");
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_NE(r.err.find("both write to stdout"), std::string::npos) << r.err;
}

#endif  // AEROVO_CLI_PATH

using e2e::PacedLiveSource;

TEST(LiveSource, FasterThanTheProcessingTheNewestFrameIsTakenAndTheRestCounted) {
  const SimulatedFlight& f = Flight();
  RunConfig c = f.run;
  c.out = (f.dir.parent_path() / "live").string();
  c.quiet = true;
  c.truth.clear();
  c.odometry.surf.num_threads = 1;
  c.odometry.correspondence.match.num_threads = 1;
  // A frame every 2 ms: SURF and matching on a 640x360 frame take longer than that.
  const RunSummary s = RunFlight(
      c, std::make_unique<PacedLiveSource>(std::make_unique<VideoFileSource>(f.run.input), 500.0));
  const auto rows = e2e::ReadCsvRows(fs::path(c.out) / "frames.csv");
  ASSERT_EQ(static_cast<int>(rows.size()), s.frames_processed);
  EXPECT_GT(s.frames_dropped, 0);
  EXPECT_EQ(s.frames_processed + s.frames_dropped, f.frames)
      << "every frame of the source is either processed or dropped";
  int last = -1;
  for (const auto& row : rows) {
    const int index = std::stoi(row.at("frame"));
    EXPECT_GT(index, last);
    last = index;
    EXPECT_FALSE(row.at("latency_ms").empty());
  }
  EXPECT_EQ(last, f.frames - 1) << "the newest frame is never dropped";
  // Bounded latency: a frame waits at most for the one being processed (and its own decode),
  // so the latency stays near one processing time instead of growing with the backlog.
  ASSERT_GT(s.latency.frames, 0);
  EXPECT_LT(s.latency.median_ms, 3.0 * s.mean.total_ms + 50.0)
      << "median " << s.latency.median_ms << " ms, mean processing " << s.mean.total_ms << " ms";
  const nlohmann::json j = nlohmann::json::parse(ReadText(fs::path(c.out) / "summary.json"));
  EXPECT_EQ(j["frames_dropped"].get<int>(), s.frames_dropped);
  bool warned = false;
  for (const std::string& w : s.warnings) warned |= w.find("dropped") != std::string::npos;
  EXPECT_TRUE(warned);
}

// A stream's start-up burst (frames/frame_source.h LiveFrameTimes: what a stream buffered while
// it was opened, delivered at once): the first `burst` frames of the video come together, the
// rest at the video's rate; each carries its own time k / fps (Frame::time_s) as LiveSource
// gives it from the stream's presentation times.
class BurstLiveSource : public FrameSource {
 public:
  BurstLiveSource(const std::string& video, double fps, int burst)
      : video_(video), period_s_(1.0 / fps), burst_(burst) {}
  bool Next(Frame& frame) override {
    if (count_ == 0) start_ = std::chrono::steady_clock::now();
    const int paced = std::max(0, count_ - burst_ + 1);
    std::this_thread::sleep_until(start_ + std::chrono::duration<double>(period_s_ * paced));
    if (!video_.Next(frame)) return false;
    frame.time_s = period_s_ * count_;
    frame.index = count_++;
    return true;
  }
  std::string Describe() const override { return "live source with a start-up burst"; }
  bool IsLive() const override { return true; }

 private:
  VideoFileSource video_;
  double period_s_;
  int burst_;
  std::chrono::steady_clock::time_point start_;
  int count_ = 0;
};

// The velocities an autopilot gets from a live stream are the flight's from the first frame
// pair on, the burst included (timed by arrival, the pair across the burst moved 18 m in a few
// ms); the timestamps increase and none is after the frame arrived.
TEST(LiveSource, AStreamsStartUpBurstKeepsTheFlightsVelocities) {
  const SimulatedFlight& f = Flight();
  const double speed_mps = DemoSimulation(true).sim.flight.speed_mps;
  RunConfig c = f.run;
  c.out = (f.dir.parent_path() / "burst").string();
  c.quiet = true;
  c.truth.clear();
  e2e::OdometryListener autopilot;
  ASSERT_GT(autopilot.port(), 0);
  c.mavlink = "udp:127.0.0.1:" + std::to_string(autopilot.port());
  const double fps = 5.0;  // the flight's (Flight())
  const RunSummary s = RunFlight(c, std::make_unique<BurstLiveSource>(f.run.input, fps, 10));
  const auto rows = e2e::ReadCsvRows(fs::path(c.out) / "frames.csv");
  const std::vector<mavlink::Odometry> sent = autopilot.Odometries();
  ASSERT_EQ(sent.size(), rows.size());
  ASSERT_GE(rows.size(), 15u);
  int checked = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    EXPECT_GT(sent[i].time_usec, sent[i - 1].time_usec) << i;
    if (rows[i].at("status") != "ok" || rows[i - 1].at("status").rfind("bridged", 0) == 0) continue;
    const double v = std::hypot(sent[i].vx, sent[i].vy);
    EXPECT_NEAR(v, speed_mps, 0.05 * speed_mps)
        << "frame " << rows[i].at("frame") << " after " << rows[i - 1].at("frame");
    ++checked;
  }
  EXPECT_GE(checked, 10);
  // The pair across the burst: frame 0, then the newest frame of the burst.
  EXPECT_GT(std::stoi(rows[1].at("frame")), 1);
  EXPECT_EQ(s.frames_processed, static_cast<int>(rows.size()));
}

TEST(LiveSource, AFileDropsNothingAndGivesTheSameTrackWithOrWithoutTheDecodeThread) {
  const SimulatedFlight& f = Flight();
  RunConfig c = f.run;
  c.quiet = true;
  c.max_frames = 15;
  c.odometry.surf.num_threads = 1;
  c.odometry.correspondence.match.num_threads = 1;
  c.out = (f.dir.parent_path() / "queued").string();
  const RunSummary queued = RunFlight(c);
  c.frame_queue = 0;
  c.out = (f.dir.parent_path() / "direct").string();
  const RunSummary direct = RunFlight(c);
  EXPECT_EQ(queued.frames_dropped, 0);
  EXPECT_EQ(queued.frames_processed, 15);
  EXPECT_EQ(direct.frames_processed, 15);
  const auto a = e2e::ReadCsvRows(fs::path(queued.out_dir) / "frames.csv");
  const auto b = e2e::ReadCsvRows(fs::path(direct.out_dir) / "frames.csv");
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (const char* k : {"frame", "x_m", "y_m", "status", "n_inliers"}) {
      EXPECT_EQ(a[i].at(k), b[i].at(k)) << k << " of row " << i;
    }
    EXPECT_FALSE(a[i].at("latency_ms").empty());
    EXPECT_FALSE(b[i].at("latency_ms").empty());
  }
}

}  // namespace
}  // namespace aerovo::pose_stream_test
