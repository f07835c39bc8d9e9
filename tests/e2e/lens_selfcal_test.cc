// Wide lenses without a calibration file (docs/lenses.md, "Self-calibration"): `aerovo run`'s lens
// self-calibration pre-pass (pipeline/lens_prepass.h, option lens_estimation). Simulated flights
// with a known lens (exact truth), each run three ways: without a calibration file (the pre-pass
// decides), with the true calibration file, and with --lens-estimation off (taken as an ideal
// pinhole).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/camera_files/calibration.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/protocol.h"
#include "aerovo/pipeline/frame_state.h"
#include "aerovo/pipeline/lens_switch.h"
#include "aerovo/pipeline/runner.h"
#include "e2e_testing.h"

namespace aerovo::lens_selfcal_test {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return e2e::UnusedTempPath("aerovo_selfcal", name); }

using e2e::Cli;
using e2e::ReadJson;
using e2e::ReadText;

// The simulator's lens (sim.json "camera") as an OpenCV calibration file.
void WriteTrueCalibration(const fs::path& sim_dir, const fs::path& file) {
  WriteCalibration(file.string(), e2e::SimCamera(sim_dir), CalibrationFormat::kOpenCv);
}

double EndError(const nlohmann::json& s) {
  return s["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>();
}

std::string Describe(double est, double cal, double off) {
  return "estimated " + std::to_string(est) + ", calibrated " + std::to_string(cal) + ", off " +
         std::to_string(off);
}

struct ThreeRuns {
  nlohmann::json estimated, calibrated, off;
};

// `frames` run without a calibration file, with `calibration`, and with the pre-pass off.
ThreeRuns RunThreeWays(const fs::path& dir, const std::string& frames, const fs::path& calibration) {
  ThreeRuns r;
  EXPECT_TRUE(Cli("run " + frames + " --quiet --no-report -o " + (dir / "estimated").string()));
  EXPECT_TRUE(Cli("run " + frames + " --calibration " + calibration.string() +
                  " --quiet --no-report -o " + (dir / "calibrated").string()));
  EXPECT_TRUE(Cli("run " + frames + " --lens-estimation off --quiet --no-report -o " +
                  (dir / "off").string()));
  r.estimated = ReadJson(dir / "estimated" / "summary.json");
  r.calibrated = ReadJson(dir / "calibrated" / "summary.json");
  r.off = ReadJson(dir / "off" / "summary.json");
  return r;
}

// A GoPro-like barrel in the pinhole (Brown) model: 640x480, focal 341 px, k1 = -0.1 (the
// distorted frame spans 93 degrees across, like a GoPro HERO5's, whose undistorted
// pinhole keeps 86 degrees); a 120 m line at 80 m, 2 frames/s (25 frames). The figures
// the bounds sit above: BENCHMARKS.md, "Lens self-calibration end to end".
TEST(LensSelfCalibration, GoProLikeBarrelIsEstimatedAndApplied) {
  const fs::path dir = TempDir("brown");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 120 --height-m 80 --fps 2 --width 640 "
                  "--height 480 --focal-px 341 --lens pinhole --distortion=-0.1,0,0,0 "
                  "--frames-only --image-format png --quiet --out " + (dir / "sim").string()));
  WriteTrueCalibration(dir / "sim", dir / "true.yaml");
  const ThreeRuns r = RunThreeWays(dir, (dir / "sim" / "frames").string(), dir / "true.yaml");
  const nlohmann::json& le = r.estimated["lens_estimate"];
  RecordProperty("why", le["why"].get<std::string>());
  ASSERT_EQ(le["status"], "applied") << le.dump();
  EXPECT_TRUE(le["applied"].get<bool>());
  EXPECT_EQ(le["family"], "pinhole") << le.dump();
  EXPECT_NEAR(le["k"].get<double>(), -0.1, 0.003) << le.dump();
  EXPECT_GT(le["cost_drop"].get<double>(), 0.5) << le.dump();
  EXPECT_EQ(le["pairs_read"].get<int>(), 5);
  // The estimate is a calibration file the run reads back.
  const fs::path yaml = dir / "estimated" / "lens_estimate.yaml";
  ASSERT_TRUE(fs::exists(yaml));
  const CameraIntrinsics k = ReadCalibration(yaml.string()).intrinsics;
  EXPECT_EQ(k.model, LensModel::kPinhole);
  EXPECT_EQ(k.width_px, 640);
  EXPECT_NEAR(k.distortion.at(0), le["k"].get<double>(), 1e-9);
  EXPECT_NE(r.estimated["undistortion"], "none");
  EXPECT_EQ(r.calibrated["lens_estimate"]["status"], "skipped");
  EXPECT_EQ(r.off["lens_estimate"]["status"], "skipped");
  EXPECT_EQ(r.off["undistortion"], "none");
  const double est = EndError(r.estimated), cal = EndError(r.calibrated), off = EndError(r.off);
  RecordProperty("end_error_percent", Describe(est, cal, off));
  EXPECT_EQ(r.estimated["frames_bridged"].get<int>(), 0);
  // Within 2x of the run with the true calibration, plus 0.02 % of the distance (2.4 cm on
  // 120 m: both runs are then at the simulation's own precision), and far better than without.
  EXPECT_LT(est, 2.0 * cal + 0.02) << "estimated " << est << " % vs calibrated " << cal << " %";
  EXPECT_GT(off, 20.0 * est) << "off " << off << " % vs estimated " << est << " %";
  fs::remove_all(dir);
}

// A wide fisheye of one coefficient (OpenCV equidistant k1 = -0.04, the one-parameter model the
// estimator fits; lens_estimation_test.cc RecoversAFisheyeK1): 640x480, focal 300 px (93.7
// degrees across once undistorted); a 120 m line at 80 m. The simulator's four-coefficient
// fisheye of wide_lens_test.cc is only approximated by one coefficient (BENCHMARKS.md "Lens
// self-calibration"). The figures the bounds sit above: BENCHMARKS.md, "Lens self-calibration
// end to end".
TEST(LensSelfCalibration, FisheyeIsEstimatedAndApplied) {
  const fs::path dir = TempDir("fisheye");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 120 --height-m 80 --fps 2 --width 640 "
                  "--height 480 --focal-px 300 --lens fisheye --distortion=-0.04,0,0,0 "
                  "--frames-only --image-format png --quiet --out " + (dir / "sim").string()));
  WriteTrueCalibration(dir / "sim", dir / "true.yaml");
  const ThreeRuns r = RunThreeWays(dir, (dir / "sim" / "frames").string(), dir / "true.yaml");
  const nlohmann::json& le = r.estimated["lens_estimate"];
  RecordProperty("why", le["why"].get<std::string>());
  ASSERT_EQ(le["status"], "applied") << le.dump();
  EXPECT_EQ(le["family"], "fisheye") << le.dump();
  EXPECT_NEAR(le["k"].get<double>(), -0.04, 0.003) << le.dump();
  EXPECT_GT(le["cost_drop"].get<double>(), 0.5) << le.dump();
  const CameraIntrinsics k =
      ReadCalibration((dir / "estimated" / "lens_estimate.yaml").string()).intrinsics;
  EXPECT_EQ(k.model, LensModel::kFisheye);
  // Undistort auto: the fisheye's rim is compressed beyond the points path's rule.
  EXPECT_EQ(r.estimated["undistortion"], "frames");
  const double est = EndError(r.estimated), cal = EndError(r.calibrated), off = EndError(r.off);
  RecordProperty("end_error_percent", Describe(est, cal, off));
  EXPECT_EQ(r.estimated["frames_bridged"].get<int>(), 0);
  // Within 2x of the run with the true calibration, plus 0.02 % of the distance (2.4 cm on
  // 120 m: both runs are then at the simulation's own precision), and far better than without.
  EXPECT_LT(est, 2.0 * cal + 0.02) << "estimated " << est << " % vs calibrated " << cal << " %";
  EXPECT_GT(off, 20.0 * est) << "off " << off << " % vs estimated " << est << " %";
  fs::remove_all(dir);
}

// What a sink sees of each frame: whether the run had the estimated lens then, and what
// summary.json's lens_estimate said (its status: "pending" until the estimate is taken).
struct SeenFrame {
  int index = -1;
  bool lens = false;
  bool switched = false;
  std::string estimate_status;
  int replayed = 0;  // FrameState::frames_replayed
  double live_x_m = 0.0, live_y_m = 0.0;  // the live pose (pose stream, MAVLink), local frame
};
class LensWatchSink : public run_steps::FrameSink {
 public:
  explicit LensWatchSink(std::vector<SeenFrame>* seen) : seen_(seen) {}
  const char* name() const override { return "lens watch"; }
  void Write(run_steps::FrameState& f, const run_steps::RunContext& run) override {
    seen_->push_back({f.frame.index, run.camera.calibrated.has_value(), f.lens_switched,
                      run.summary->lens_estimate.value("status", std::string()),
                      f.frames_replayed, f.result.position_m.x(), f.result.position_m.y()});
  }

 private:
  std::vector<SeenFrame>* seen_;
};

// vo.tum's rows (time x y z ...) from the row of time `from_s` on, as numbers.
std::vector<std::vector<double>> TumRowsFrom(const fs::path& file, double from_s) {
  std::vector<std::vector<double>> rows;
  std::istringstream in(ReadText(file));
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::vector<double> row;
    for (double v; ls >> v;) row.push_back(v);
    if (!row.empty() && row[0] >= from_s - 1e-9) rows.push_back(row);
  }
  return rows;
}

using e2e::OdometryListener;

// frames.csv without its timing columns (*_ms: the threads' timing), as one text.
std::string FramesCsvWithoutTimes(const fs::path& run_dir) {
  std::string out;
  for (const auto& row : e2e::ReadFramesCsv(run_dir)) {
    for (const auto& [key, value] : row) {
      if (key.size() < 3 || key.compare(key.size() - 3, 3, "_ms") != 0) out += value + ",";
    }
    out += "\n";
  }
  return out;
}

// The length of the track `rows` (time x y ...) from row `from` to row `to`, metres.
double PathLength(const std::vector<std::vector<double>>& rows, std::size_t from, std::size_t to) {
  double length = 0.0;
  for (std::size_t i = from + 1; i <= to; ++i) {
    length += std::hypot(rows[i][1] - rows[i - 1][1], rows[i][2] - rows[i - 1][2]);
  }
  return length;
}

// The run of `video` in dir/a (its lens switch at `switch_frame`, caught up at `caught_up`) is
// the same with 1 thread (the CLI), and its track files are those of a run given its
// lens_estimate.yaml as the calibration file, every frame: the frames before the catch-up frame
// hold the replay's poses (lens_switch.h), which are that run's. `live_m`: the poses the pose
// stream had, which stay those under the pinhole before the catch-up frame.
void ExpectSameRunAndCalibratedTrack(const fs::path& dir, const std::string& video,
                                     int switch_frame, int caught_up, int frames,
                                     const std::vector<SeenFrame>& live) {
  const auto rows = e2e::ReadFramesCsv(dir / "a");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(frames));
  // Deterministic: the same frames and track again (the CLI, with 1 thread this time).
  ASSERT_TRUE(Cli("run " + video + " --attitude-estimation off --threads 1 --quiet --no-report "
                  "-o " + (dir / "b").string()));
  const nlohmann::json b = ReadJson(dir / "b" / "summary.json")["lens_estimate"];
  EXPECT_EQ(b["switch_frame"], switch_frame);
  EXPECT_EQ(b["caught_up_frame"], caught_up);
  EXPECT_EQ(ReadText(dir / "a" / "vo.tum"), ReadText(dir / "b" / "vo.tum"));
  EXPECT_EQ(ReadText(dir / "a" / "transforms.csv"), ReadText(dir / "b" / "transforms.csv"));
  EXPECT_EQ(FramesCsvWithoutTimes(dir / "a"), FramesCsvWithoutTimes(dir / "b"));
  // The track of the estimate given as a calibration file, from the first frame on.
  ASSERT_TRUE(Cli("run " + video + " --calibration " + (dir / "a" / "lens_estimate.yaml").string() +
                  " --attitude-estimation off --quiet --no-report -o " + (dir / "cal").string()));
  const auto est = TumRowsFrom(dir / "a" / "vo.tum", 0.0);
  const auto cal = TumRowsFrom(dir / "cal" / "vo.tum", 0.0);
  ASSERT_EQ(est.size(), static_cast<std::size_t>(frames));
  ASSERT_EQ(cal.size(), est.size());
  // Geo-referenced (ENU, metres) by the same fit to the same fixes: the same positions, to 1 mm.
  for (std::size_t i = 0; i < est.size(); ++i) {
    EXPECT_NEAR(est[i][0], cal[i][0], 1e-6) << "row " << i;
    EXPECT_NEAR(est[i][1], cal[i][1], 1e-3) << "row " << i;
    EXPECT_NEAR(est[i][2], cal[i][2], 1e-3) << "row " << i;
  }
  EXPECT_EQ(rows[caught_up - 1].at("status"), "ok");
  // The live poses before the catch-up frame were not those (the pinhole's scale: the flight to
  // the frame before it at least 1 % shorter or longer), from the catch-up frame on they are.
  ASSERT_EQ(live.size(), static_cast<std::size_t>(frames));
  std::vector<std::vector<double>> live_rows;
  for (const SeenFrame& f : live) live_rows.push_back({0.0, f.live_x_m, f.live_y_m});
  const double live_before = PathLength(live_rows, 0, caught_up - 1);
  const double file_before = PathLength(est, 0, caught_up - 1);
  ::testing::Test::RecordProperty(
      "path_before_catch_up_m",
      "live " + std::to_string(live_before) + ", files " + std::to_string(file_before));
  EXPECT_GT(std::abs(live_before / file_before - 1.0), 0.01);
  EXPECT_NEAR(PathLength(live_rows, caught_up, frames - 1), PathLength(est, caught_up, frames - 1),
              1e-3);
  // The summary's track and comparison with the truth are the files' (RunTotals).
  const nlohmann::json sa = ReadJson(dir / "a" / "summary.json");
  const nlohmann::json sc = ReadJson(dir / "cal" / "summary.json");
  const double ate = sa["truth_evaluation"]["se2"]["ate_rmse_percent"].get<double>();
  const double ate_cal = sc["truth_evaluation"]["se2"]["ate_rmse_percent"].get<double>();
  ::testing::Test::RecordProperty("ate_rmse_percent", Describe(ate, ate_cal, -1.0));
  EXPECT_NEAR(ate, ate_cal, 1e-3);
  EXPECT_LT(ate, 1.0);  // the truth, to 1 % of the distance flown (40 m)
}

// The estimate comes beside the odometry (pipeline/lens_switch.h): the first frames are
// processed and handed to the outputs before it is taken at the switch frame, the first one
// kLensSwitchAfterS (2 s) into the stream (frame 20 at 10 frames/s), the same on every run.
// The 20 frames before it are then given again to an odometry under the lens, 3 per frame,
// while every frame still gives its pose under the old lens: no pose waits for more than
// 1 + kLensReplayFramesPerFrame frames' odometry (the whole replay, 20 frames, stalled the pose
// stream at the switch frame before). At the catch-up frame (29: 20 kept, 2 gained per frame)
// the lens becomes the run's; the live poses before it stay those under the pinhole, but the
// run's files take the replay's: the whole track (vo.tum) is the one of a run given the
// estimate as its calibration file from the first frame, to 1 mm, and so is its error against
// the truth. The autopilot sees the switch as a reset: ODOMETRY's reset_counter 1 from the
// catch-up frame on. The same outputs with 1 thread.
TEST(LensSelfCalibration, FirstPosesComeBeforeTheEstimateAppliedAtAFixedFrame) {
  const fs::path dir = TempDir("switch");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 40 --height-m 80 --fps 10 --width 640 "
                  "--height 480 --focal-px 300 --lens fisheye --distortion=-0.04,0,0,0 "
                  "--quiet --out " + (dir / "sim").string()));
  const std::string video = (dir / "sim" / "video.mp4").string();
  constexpr int kFrames = 41;
  std::vector<SeenFrame> seen;
  RunCallbacks cb;
  cb.sinks.push_back(std::make_shared<LensWatchSink>(&seen));
  RunConfig c;
  c.input = video;
  c.out = (dir / "a").string();
  c.quiet = true;
  // The lens alone (a camera tilt estimated too would run the pre-pass before the first frame,
  // pipeline/lens_prepass.h).
  c.attitude_estimation = AttitudeEstimationMode::kOff;
  OdometryListener autopilot;
  ASSERT_GT(autopilot.port(), 0);
  c.mavlink = "udp:127.0.0.1:" + std::to_string(autopilot.port());
  const RunSummary s = RunFlight(c, cb);
  const nlohmann::json& le = s.lens_estimate;
  ASSERT_EQ(le["status"], "applied") << le.dump();
  const int switch_frame = le["switch_frame"].get<int>();
  const int caught_up = le["caught_up_frame"].get<int>();
  EXPECT_EQ(switch_frame, 20);
  // 20 kept; 3 replayed and 1 kept per frame from the switch frame on.
  EXPECT_EQ(caught_up, 29);
  EXPECT_EQ(le["frames_replayed"].get<int>(), caught_up);
  ASSERT_EQ(seen.size(), static_cast<std::size_t>(kFrames));
  int replayed = 0, most_per_pose = 0;
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_EQ(seen[i].index, i);  // every frame handed to the outputs, in order
    // Before the switch frame, the estimate is pending; before the catch-up frame, the old lens.
    if (i < switch_frame) {
      EXPECT_EQ(seen[i].estimate_status, "pending") << "frame " << i;
    }
    EXPECT_EQ(seen[i].lens, i >= caught_up) << "frame " << i;
    EXPECT_EQ(seen[i].switched, i == caught_up) << "frame " << i;
    EXPECT_EQ(seen[i].replayed > 0, i >= switch_frame && i <= caught_up) << "frame " << i;
    replayed += seen[i].replayed;
    most_per_pose = std::max(most_per_pose, 1 + seen[i].replayed);
  }
  EXPECT_EQ(replayed, caught_up);
  // The largest gap of the pose stream, in frames' odometry between two poses handed out.
  RecordProperty("most_frames_per_pose", most_per_pose);
  EXPECT_EQ(most_per_pose, 1 + run_steps::kLensReplayFramesPerFrame);
  const std::vector<int> resets = autopilot.ResetCounters();
  ASSERT_EQ(resets.size(), static_cast<std::size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_EQ(resets[i], i >= caught_up ? 1 : 0) << "frame " << i;
  }
  // summary.json counts the autopilot's resets, by cause.
  EXPECT_EQ(s.pose_resets.frames, resets.back());
  EXPECT_EQ(s.pose_resets.lens_switch, 1);
  EXPECT_EQ(s.pose_resets.loop_closure + s.pose_resets.map_fix, 0);
  const auto rows = e2e::ReadFramesCsv(dir / "a");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(rows[caught_up].at("status"), "ok+lens");
  EXPECT_EQ(le["file_poses_replaced"], true);
  ExpectSameRunAndCalibratedTrack(dir, video, switch_frame, caught_up, kFrames, seen);
  fs::remove_all(dir);
}

// A live source (a camera or stream, never read twice): the pairs are its own frames as
// delivered (lens_switch.h), the estimate taken at the switch frame 2 s into the stream and
// the run switched to it once the replay of the frames before caught up (the run does not wait
// for the estimate: taken at the first frame it is ready at, 2-3 s into the stream; the replay
// then takes about half as many frames as were kept, and a newest-frame queue drops the frames
// a busy machine cannot take, so the stream goes on for 6 s after). The fisheye of
// FisheyeIsEstimatedAndApplied, 5 frames/s, delivered at that rate (9 s).
TEST(LensSelfCalibration, ALiveSourcesLensIsEstimatedFromItsOwnFrames) {
  const fs::path dir = TempDir("live");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 90 --height-m 80 --fps 5 --width 640 "
                  "--height 480 --focal-px 300 --lens fisheye --distortion=-0.04,0,0,0 "
                  "--frames-only --image-format png --quiet --out " + (dir / "sim").string()));
  RunConfig c;
  c.input = "live";  // not read: the source is given
  c.out = (dir / "run").string();
  c.quiet = true;
  c.focal_px = 300.0;
  c.altitude_m = 80.0;
  c.attitude_estimation = AttitudeEstimationMode::kOff;
  auto folder = std::make_unique<ImageFolderSource>((dir / "sim" / "frames").string());
  const RunSummary s =
      RunFlight(c, std::make_unique<e2e::PacedLiveSource>(std::move(folder), 5.0));
  const nlohmann::json& le = s.lens_estimate;
  RecordProperty("why", le.value("why", std::string()));
  EXPECT_EQ(le["family"], "fisheye") << le.dump();
  EXPECT_NEAR(le["k"].get<double>(), -0.04, 0.005) << le.dump();
  // All 5 when the run keeps up (a sanitizer build may take fewer frames before the switch).
  EXPECT_GE(le["pairs_read"].get<int>(), 3) << le.dump();
  EXPECT_LE(le["pairs_read"].get<int>(), run_steps::kLensPrepassPairs) << le.dump();
  const int switch_frame = le["switch_frame"].get<int>();
#ifdef AEROVO_INSTRUMENTED_BUILD
  // An instrumented build (ASan + UBSan at -O1) takes about 8 s for the estimate, near the end
  // of the 9 s stream, more when the other test beside it is busy: the run may end before the
  // replay from the switch frame catches up, or before the estimate is ready at all (no switch
  // frame), and then says which and applies nothing (the optimised build must apply it, below).
  if (le["status"] != "applied") {
    EXPECT_EQ(le["status"], "not applied") << le.dump();
    const std::string why = le["why"].get<std::string>();
    if (switch_frame < 0) {
      EXPECT_NE(why.find("the run ended before its switch frame"), std::string::npos) << le.dump();
    } else {
      EXPECT_NE(why.find("the run ended before the replay"), std::string::npos) << le.dump();
      for (const auto& f : le["pair_frames"]) EXPECT_LT(f.get<int>(), switch_frame) << le.dump();
    }
    EXPECT_EQ(le["caught_up_frame"], -1) << le.dump();
    fs::remove_all(dir);
    return;
  }
#endif
  // The pairs start 0.3 s of stream apart (or 8 frames), each before the switch frame.
  EXPECT_GE(switch_frame, 1) << le.dump();
  for (const auto& f : le["pair_frames"]) EXPECT_LT(f.get<int>(), switch_frame) << le.dump();
  ASSERT_EQ(le["status"], "applied") << le.dump();
  EXPECT_GT(le["frames_replayed"].get<int>(), 0) << le.dump();
  EXPECT_GT(le["caught_up_frame"].get<int>(), switch_frame) << le.dump();
  EXPECT_EQ(le["file_poses_replaced"], true) << le.dump();
  const auto rows = e2e::ReadFramesCsv(dir / "run");
  int lens_rows = 0;
  for (const auto& r : rows) lens_rows += r.at("status").find("+lens") != std::string::npos;
  EXPECT_EQ(lens_rows, 1);
  EXPECT_TRUE(fs::exists(dir / "run" / "lens_estimate.yaml"));
  fs::remove_all(dir);
}

// An ideal pinhole (the simulator's default lens): the estimate is not significant, nothing is
// applied, and the track is byte for byte the one of --lens-estimation off.
TEST(LensSelfCalibration, PinholeIsNotAppliedAndTheTrackIsUnchanged) {
  const fs::path dir = TempDir("pinhole");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 120 --height-m 80 --fps 2 --width 640 "
                  "--height 480 --hfov-deg 80 --frames-only --image-format png --quiet --out " +
                  (dir / "sim").string()));
  const std::string frames = (dir / "sim" / "frames").string();
  ASSERT_TRUE(Cli("run " + frames + " --quiet --no-report -o " + (dir / "auto").string()));
  ASSERT_TRUE(Cli("run " + frames + " --lens-estimation off --quiet --no-report -o " +
                  (dir / "off").string()));
  const nlohmann::json a = ReadJson(dir / "auto" / "summary.json");
  const nlohmann::json& le = a["lens_estimate"];
  RecordProperty("why", le["why"].get<std::string>());
  EXPECT_EQ(le["status"], "not significant") << le.dump();
  EXPECT_FALSE(le["applied"].get<bool>());
  EXPECT_LT(le["cost_drop"].get<double>(), 0.25) << le.dump();
  EXPECT_EQ(a["undistortion"], "none");
  EXPECT_FALSE(fs::exists(dir / "auto" / "lens_estimate.yaml"));
  const std::string track = ReadText(dir / "auto" / "vo.tum");
  EXPECT_FALSE(track.empty());
  EXPECT_EQ(track, ReadText(dir / "off" / "vo.tum"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::lens_selfcal_test
