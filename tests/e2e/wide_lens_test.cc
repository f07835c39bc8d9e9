// Wide lenses end to end (docs/lenses.md): a simulated wide-angle fisheye flight (OpenCV's
// equidistant model with known k1..k4, exact truth) run with the calibration file the test writes
// is accurate; the same frames taken for an ideal pinhole are not. Also: a fast fixed-wing flight
// with banked turns keeps every frame.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "aerovo/camera_files/calibration.h"
#include "e2e_testing.h"

namespace aerovo::wide_lens_test {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return e2e::UnusedTempPath("aerovo_wide", name); }

using e2e::Cli;
using e2e::ReadJson;

// 960x720 fisheye, focal 450 px (93.7 degrees across once undistorted), k = (-0.05, 0.01,
// -0.002, 0.0005): the image corners are 8 % closer to the centre than a pinhole's. A 200 m line
// at 80 m, 2 frames/s (41 frames). Figures: BENCHMARKS.md, "Wide lenses end to end".
TEST(WideLens, FisheyeFlightIsAccurateWithItsCalibrationFileOnly) {
  const fs::path dir = TempDir("fisheye");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 200 --height-m 80 --fps 2 --width 960 "
                  "--height 720 --focal-px 450 --lens fisheye "
                  "--distortion=-0.05,0.01,-0.002,0.0005 --frames-only --image-format png "
                  "--quiet --out " + (dir / "sim").string()));
  // The calibration as OpenDroneMap would give it, from the simulator's own record.
  ASSERT_EQ(ReadJson(dir / "sim" / "sim.json")["camera"]["model"], "fisheye");
  const CameraIntrinsics k = e2e::SimCamera(dir / "sim");
  WriteCalibration((dir / "cameras.json").string(), k, CalibrationFormat::kOdmJson);

  const std::string frames = (dir / "sim" / "frames").string();
  ASSERT_TRUE(Cli("run " + frames + " --calibration " + (dir / "cameras.json").string() +
                  " --quiet --no-report -o " + (dir / "calibrated").string()));
  // Taken as an ideal pinhole: the lens self-calibration (lens_selfcal_test.cc) off.
  ASSERT_TRUE(Cli("run " + frames + " --lens-estimation off --quiet --no-report -o " +
                  (dir / "pinhole").string()));
  const nlohmann::json cal = ReadJson(dir / "calibrated" / "summary.json");
  const nlohmann::json pin = ReadJson(dir / "pinhole" / "summary.json");
  EXPECT_EQ(cal["focal_source"], "calibration");
  // undistort auto (the default): this fisheye's local scale change over the frame (0.98) is
  // beyond the points path's rule (camera/lens.h kPointsMaxScaleChange), so frames are remapped.
  EXPECT_EQ(cal["undistortion"], "frames");
  EXPECT_GT(cal["lens_scale_change"].get<double>(), 0.9);
  EXPECT_EQ(cal["frames_processed"].get<int>(), 41);
  EXPECT_EQ(cal["frames_bridged"].get<int>(), 0);
  const double cal_end = cal["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>();
  const double pin_end = pin["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>();
  EXPECT_LT(cal_end, 0.05) << "with the calibration";
  EXPECT_GT(pin_end, 1.0) << "the same frames taken as an ideal pinhole";
  EXPECT_GT(pin_end, 20 * cal_end);
  fs::remove_all(dir);
}

// Points or whole frames (docs/lenses.md): a mildly distorted pinhole lens (k1 = -0.05 at 960x720,
// 73.7 degrees; local scale change 0.145 over the frame) run with undistort points (SURF on the
// distorted frames, keypoints undistorted) and auto (which picks points) ends as close to the
// truth as the frames path (200 m line at 80 m, 41 frames; figures: BENCHMARKS.md, "Wide lenses
// end to end").
TEST(WideLens, MildPinholeLensPointsPathMatchesTheFramesPath) {
  const fs::path dir = TempDir("mild");
  ASSERT_TRUE(Cli("simulate --pattern line --length-m 200 --height-m 80 --fps 2 --width 960 "
                  "--height 720 --lens pinhole --distortion=-0.05,0,0,0 --frames-only "
                  "--image-format png --quiet --out " + (dir / "sim").string()));
  const std::string frames = (dir / "sim" / "frames").string();
  auto run = [&](const std::string& mode) {
    EXPECT_TRUE(Cli("run " + frames + " --k1 -0.05 --undistort " + mode +
                    " --quiet --no-report -o " + (dir / mode).string()));
    return ReadJson(dir / mode / "summary.json");
  };
  const nlohmann::json fr = run("frames"), pt = run("points"), au = run("auto");
  EXPECT_EQ(fr["undistortion"], "frames");
  EXPECT_EQ(pt["undistortion"], "points");
  EXPECT_EQ(au["undistortion"], "points") << "auto: scale change " << au["lens_scale_change"];
  EXPECT_NEAR(au["lens_scale_change"].get<double>(), 0.145, 0.01);
  auto end = [](const nlohmann::json& s) {
    return s["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>();
  };
  auto unaligned = [](const nlohmann::json& s) {
    return s["truth_evaluation"]["se2"]["end_point_error_unaligned_percent"].get<double>();
  };
  for (const nlohmann::json* s : {&fr, &pt, &au}) {
    EXPECT_EQ((*s)["frames_processed"].get<int>(), 41);
    EXPECT_EQ((*s)["frames_bridged"].get<int>(), 0);
    EXPECT_LT(end(*s), 0.02) << "within 0.02 % of the distance of the truth";
    EXPECT_LT(unaligned(*s), 0.1);
  }
  EXPECT_NEAR(end(pt), end(fr), 0.01) << "points within 0.01 % of the distance of frames";
  EXPECT_NEAR(end(au), end(pt), 1e-9) << "auto is the points run";
  // Without undistortion the same frames are 0.98 % off: the points path does undo the lens.
  ASSERT_TRUE(Cli("run " + frames + " --lens-estimation off --quiet --no-report -o " +
                  (dir / "none").string()));
  EXPECT_GT(end(ReadJson(dir / "none" / "summary.json")), 20 * end(pt));
  fs::remove_all(dir);
}

// A fast fixed-wing survey (docs/attitude.md, "A banking fixed-wing aircraft") with a 93-degree
// camera: 22 m/s at 30 m, 1.15 photos/s (19.1 m steps over a 47.5 m along-track footprint: 60 %
// overlap), two legs joined by a 90-degree turn of the radius a 20-degree bank gives at that speed
// (v^2 / (g tan 20deg) = 136 m). With the camera stabilised (nadir through the turn) every frame is
// kept and the track ends within 0.1 % of the distance (BENCHMARKS.md, "Wide lenses end to end").
TEST(WideLens, FastFixedWingFlightKeepsEveryFrame) {
  const fs::path dir = TempDir("fixedwing");
  const std::string common =
      " --legs 2 --length-m 150 --turn-angle-deg 90 --speed-mps 22 --height-m 30 --fps 1.15 "
      "--width 960 --height 720 --hfov-deg 93 --frames-only --image-format png --quiet";
  ASSERT_TRUE(Cli("simulate --pattern turns --turn-radius-m 136" + common + " --out " +
                  (dir / "nadir").string()));
  ASSERT_TRUE(Cli("run " + (dir / "nadir" / "frames").string() + " --quiet --no-report -o " +
                  (dir / "nadir_run").string()));
  const nlohmann::json s = ReadJson(dir / "nadir_run" / "summary.json");
  EXPECT_GE(s["frames_processed"].get<int>(), 20);
  EXPECT_EQ(s["frames_bridged"].get<int>(), 0);
  EXPECT_LT(s["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>(), 0.1);
  EXPECT_LT(s["truth_evaluation"]["se2"]["end_point_error_unaligned_percent"].get<double>(), 0.5);
  // The camera fixed to the airframe, banking 20 degrees in the turn (pattern fixed-wing): the
  // tilt's perspective shear takes the place of the turn's rotation in the affine steps, so
  // without the attitude the heading is lost in the turn. The simulator writes the bank into its
  // SRT (gb_roll), and the attitude correction (odometry/attitude.h, docs/attitude.md) keeps the
  // track (figures: BENCHMARKS.md, "Wide lenses end to end").
  std::string video_common = common;
  video_common.replace(video_common.find(" --frames-only --image-format png"),
                       std::string(" --frames-only --image-format png").size(), "");
  ASSERT_TRUE(Cli("simulate --pattern fixed-wing --max-bank-deg 20" + video_common + " --out " +
                  (dir / "banked").string()));
  const std::string video = (dir / "banked" / "video.mp4").string();
  ASSERT_TRUE(Cli("run " + video + " --quiet --no-report -o " + (dir / "banked_run").string()));
  ASSERT_TRUE(Cli("run " + video + " --attitude off --quiet --no-report -o " +
                  (dir / "banked_uncorrected").string()));
  const nlohmann::json b = ReadJson(dir / "banked_run" / "summary.json");
  const nlohmann::json u = ReadJson(dir / "banked_uncorrected" / "summary.json");
  EXPECT_EQ(b["frames_bridged"].get<int>(), 0);
  EXPECT_GT(b["attitude_sources"]["gimbal"].get<int>(), 5);
  EXPECT_NEAR(b["max_tilt_deg"].get<double>(), 20.0, 0.5);
  const nlohmann::json& be = b["truth_evaluation"]["se2"];
  const nlohmann::json& ue = u["truth_evaluation"]["se2"];
  EXPECT_LT(be["end_point_error_percent"].get<double>(), 0.2);
  EXPECT_LT(be["end_point_error_unaligned_percent"].get<double>(), 1.0);
  EXPECT_GT(ue["end_point_error_percent"].get<double>(),
            10.0 * be["end_point_error_percent"].get<double>());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::wide_lens_test
