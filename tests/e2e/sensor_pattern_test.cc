// Sensor non-uniformity (pipeline/stage_flat_field.cc, features/flat_field.h) on a simulated
// thermal flight with exact truth: the thermal camera's vignetting and fixed pattern (`aerovo
// simulate --render thermal`: 30 and 3 DN) lose the track unless the run removes the flat field,
// which the defaults do, from a photo folder's median and from a video's running estimate.
// BENCHMARKS.md, "Sensor non-uniformity".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "aerovo/pipeline/runner.h"
#include "e2e_testing.h"
#include "nadir_ground.h"

namespace aerovo::sensor_pattern_test {
namespace {

namespace fs = std::filesystem;
using e2e::Cli;

// 640x512 thermal-like camera, 61 frames, 300 m at 80 m (AdaptivePoints.ThermalLikeFlight...'s
// flight), with the pattern's strengths given explicitly.
constexpr const char* kThermalFlight =
    "simulate --render thermal --vignetting 30 --fixed-pattern 3 --pattern lawnmower "
    "--length-m 120 --legs 2 --spacing-m 40 --height-m 80 --fps 2 --gps-noise-m 1.5 --quiet ";

nlohmann::json RunOn(const fs::path& input, const fs::path& out, const std::string& flags) {
  EXPECT_TRUE(
      Cli("run " + input.string() + " " + flags + " --quiet --no-report -o " + out.string()));
  return e2e::ReadJson(out / "summary.json");
}

TEST(SensorPattern, ThermalFlightWithVignettingAndFixedPatternIsTrackedWithTheDefaults) {
  const fs::path dir = e2e::UnusedTempPath("aerovo_flat_field", "thermal");
  ASSERT_TRUE(Cli(std::string(kThermalFlight) + "--frames-only --image-format png --out " +
                  (dir / "sim").string()));
  const fs::path frames = dir / "sim" / "frames";
  const nlohmann::json s = RunOn(frames, dir / "default", "");
  const int n = s["frames_processed"].get<int>();
  ASSERT_EQ(n, 61);
  const nlohmann::json& ff = s["flat_field"];
  EXPECT_EQ(ff["estimate"], "photo median");
  EXPECT_TRUE(ff["applied"].get<bool>());
  EXPECT_EQ(ff["frames_corrected"].get<int>(), n);
  EXPECT_EQ(ff["samples"].get<int>(), 21);
  // The pattern (30 DN r^2 vignette, 3 DN per pixel and per column) against the ground's 5 DN.
  EXPECT_GT(ff["significance"].get<double>(), 1.0);
  // The motion test: the ground moves between the samples, and the first and the last third
  // (the two legs) share less than max_ground_overlap of it.
  EXPECT_TRUE(ff["ground_seen"].get<bool>());
  EXPECT_LE(ff["ground_overlap"].get<double>(), 0.5);
  std::printf("photo median: significance %.2f, ground overlap %.2f\n",
              ff["significance"].get<double>(), ff["ground_overlap"].get<double>());
  EXPECT_LE(s["frames_bridged"].get<int>(), n / 50) << "at most 2 % of the frames bridged";
  EXPECT_LT(s["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>(), 1.0);
  // Without the correction the same frames lose the track: bridged after the first turn, then
  // held at zero motion on the sensor's pattern.
  const nlohmann::json off = RunOn(frames, dir / "off", "--flat-field-mode off");
  EXPECT_EQ(off["flat_field"]["applied"], false);
  const int bridged_off = off["frames_bridged"].get<int>();
  const double end_off = off["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>();
  std::printf(
      "flat field off: %d of %d frames bridged, end-point error %.1f %% (on: %d, %.3f %%)\n",
      bridged_off, n, end_off, s["frames_bridged"].get<int>(),
      s["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>());
  EXPECT_GE(bridged_off, 10);
  EXPECT_GT(end_off, 20.0);
  fs::remove_all(dir);
}

// The same flight as a video: the running estimate is judged after its warm-up (20 samples, one
// per frame at 2 fps) and removed from the frames after it. The first corrected frame may be
// bridged (its predecessor was not corrected; measured: 1 frame).
TEST(SensorPattern, ThermalVideoIsCorrectedByTheRunningEstimate) {
  const fs::path dir = e2e::UnusedTempPath("aerovo_flat_field", "video");
  ASSERT_TRUE(Cli(std::string(kThermalFlight) + "--out " + (dir / "sim").string()));
  const nlohmann::json s = RunOn(dir / "sim" / "video.mp4", dir / "run", "");
  const int n = s["frames_processed"].get<int>();
  ASSERT_EQ(n, 61);
  const nlohmann::json& ff = s["flat_field"];
  EXPECT_EQ(ff["estimate"], "running");
  EXPECT_TRUE(ff["applied"].get<bool>());
  EXPECT_EQ(ff["frames_corrected"].get<int>(), n - 19);  // from the 20th sample on
  EXPECT_GT(ff["significance"].get<double>(), 1.0);
  EXPECT_TRUE(ff["ground_seen"].get<bool>());
  EXPECT_LE(ff["ground_overlap"].get<double>(), 0.75);  // applied: up to 3/2 of 0.5
  std::printf("running: significance %.2f, ground overlap %.2f\n", ff["significance"].get<double>(),
              ff["ground_overlap"].get<double>());
  EXPECT_LE(s["frames_bridged"].get<int>(), n / 50);
  EXPECT_LT(s["truth_evaluation"]["se2"]["end_point_error_percent"].get<double>(), 1.0);
  fs::remove_all(dir);
}

// Frames cut from the nadir terrain (nadir_ground.h: 320x240, 0.25 m/px) with their top-left
// corners at `offsets` (px), its contrast about 128 DN scaled by `contrast` (0.15: the thermal
// preset of `aerovo simulate`), plus a sensor pattern when `vignetting_dn` > 0 (corners that
// many DN below the centre, r^2, and Gaussian per-pixel and per-column offsets of 3 DN, seed 5),
// written as frame_0000.png, ... into `dir`.
void WriteNadirFrames(const fs::path& dir, const std::vector<std::pair<int, int>>& offsets,
                      double contrast, double vignetting_dn) {
  using namespace e2e::nadir;
  fs::create_directories(dir);
  cv::Mat pattern(kH, kW, CV_32F, cv::Scalar(0));
  if (vignetting_dn > 0.0) {
    std::mt19937 rng(5);
    std::normal_distribution<float> n(0.0f, 3.0f);
    std::vector<float> column(kW);
    for (float& c : column) c = n(rng);
    const double cx = 0.5 * (kW - 1), cy = 0.5 * (kH - 1), r2max = cx * cx + cy * cy;
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max;
        pattern.at<float>(y, x) = static_cast<float>(-vignetting_dn * r2) + column[x] + n(rng);
      }
    }
  }
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    cv::Mat frame;
    Ground()(cv::Rect(offsets[i].first, offsets[i].second, kW, kH))
        .convertTo(frame, CV_32F, contrast, 128.0 * (1.0 - contrast));
    frame += pattern;
    frame.convertTo(frame, CV_8U);  // saturates
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("frame_{:04d}.png", i)).string(), frame));
  }
}

// A hover over textured ground: 21 photos drifting 0-2 px each way per frame (a position hold
// that wanders within 12 px). The photo median of the ground that stays is as static as a
// sensor's pattern (its significance is well above min_significance) but the motion test
// leaves it undecided, and the frames are processed as read: no frame bridged, no motion.
TEST(SensorPattern, AHoverOverTexturedGroundIsNotCorrected) {
  const fs::path dir = e2e::UnusedTempPath("aerovo_flat_field", "hover");
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> step(-2, 2);
  std::vector<std::pair<int, int>> offsets;
  int x = 600, y = 600;
  for (int i = 0; i < 21; ++i) {
    offsets.emplace_back(x, y);
    x = std::clamp(x + step(rng), 594, 606);
    y = std::clamp(y + step(rng), 594, 606);
  }
  WriteNadirFrames(dir / "photos", offsets, 1.0, 0.0);
  const RunSummary s = RunFlight(e2e::nadir::Config(dir / "photos", dir / "run"));
  std::printf("hover: %s\n", s.flat_field.why.c_str());
  EXPECT_EQ(s.flat_field.estimate, "photo median");
  EXPECT_GT(s.flat_field.significance, 0.5);
  EXPECT_GT(s.flat_field.ground_overlap, 0.5);
  EXPECT_FALSE(s.flat_field.applied) << s.flat_field.why;
  EXPECT_EQ(s.frames_bridged, 0);
  const std::vector<std::map<std::string, std::string>> rows = e2e::ReadFramesCsv(dir / "run");
  ASSERT_EQ(rows.size(), 21u);
  // The last frame is within 12 px (3 m) of the first: the track stays within 4 m.
  EXPECT_LT(std::hypot(std::stod(rows.back().at("x_m")), std::stod(rows.back().at("y_m"))), 4.0);
  fs::remove_all(dir);
}

// The same ground at a thermal camera's contrast flown over (a 40-photo leg, 8 px = 2 m per
// photo, the last third 216 px from the first in a 320 px frame) with a sensor pattern (20 DN
// vignetting, 3 DN per pixel and per column): the motion test sees the ground move and the two
// thirds share less than half of it, so the pattern is removed.
TEST(SensorPattern, AMovingGroundWithAPatternIsCorrected) {
  const fs::path dir = e2e::UnusedTempPath("aerovo_flat_field", "leg");
  std::vector<std::pair<int, int>> offsets;
  for (int i = 0; i < 40; ++i) offsets.emplace_back(400 + 8 * i, 600);
  WriteNadirFrames(dir / "photos", offsets, 0.15, 20.0);
  const RunSummary s = RunFlight(e2e::nadir::Config(dir / "photos", dir / "run"));
  std::printf("leg with a pattern: %s\n", s.flat_field.why.c_str());
  EXPECT_TRUE(s.flat_field.ground_seen);
  EXPECT_LT(s.flat_field.ground_overlap, 0.5);
  EXPECT_GT(s.flat_field.significance, 0.5);
  EXPECT_TRUE(s.flat_field.applied) << s.flat_field.why;
  EXPECT_EQ(s.flat_field.frames_corrected, 40);
  EXPECT_EQ(s.frames_bridged, 0);
  const std::vector<std::map<std::string, std::string>> rows = e2e::ReadFramesCsv(dir / "run");
  ASSERT_EQ(rows.size(), 40u);
  // 39 steps of 2 m east.
  EXPECT_NEAR(std::stod(rows.back().at("x_m")) - std::stod(rows.front().at("x_m")), 78.0, 1.5);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::sensor_pattern_test
