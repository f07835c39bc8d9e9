// The attitude correction (docs/attitude.md) on simulated flights with exact truth: a camera
// tilted up to 15 degrees in pitch and roll, known to aerovo through the flight's SRT gimbal
// angles as a user's DJI video gives them, is tracked at least 3x more accurately with the
// attitude correction (the default, `--attitude auto`) than without (`--attitude off`); a nadir
// flight whose SRT says nadir is unchanged by it. Heights (docs/attitude.md, "Heights: which
// one, from where"): an SRT with only abs_alt needs the ground's elevation.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "e2e_testing.h"

namespace aerovo::attitude_test {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return e2e::UnusedTempPath("aerovo_attitude", name); }

// Returns std::system's status: 0, or 1 << 8 for exit code 1.
int Cli(const std::string& args, const fs::path& log = "/dev/null") {
  return e2e::RunCli(args, log);
}

nlohmann::json Summary(const fs::path& run) { return e2e::ReadJson(run / "summary.json"); }

using e2e::ReadText;

void WriteText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// 640x360 frames at 80 m over the built-in terrain, 2 fps, lawnmower of 2 x 120 m (61 frames).
const char* kFlight =
    "simulate --pattern lawnmower --length-m 120 --legs 2 --spacing-m 40 --height-m 80 "
    "--width 640 --height 360 --fps 2 --gps-noise-m 1.5 --frames-only --image-format png --quiet ";

TEST(Attitude, TiltedFlightIsThreeTimesMoreAccurateWithTheCorrection) {
  const fs::path dir = TempDir("tilted");
  // Pitch 5 + 10 sin, roll -5 + 10 sin (independent phases): both reach 15 degrees.
  ASSERT_EQ(Cli(std::string(kFlight) + "--pitch-deg 5 --roll-deg -5 --wobble-deg 10 "
                "--wobble-period-s 12 --out " + (dir / "sim").string()), 0);
  // The simulator writes the camera's attitude as a DJI gimbal's.
  ASSERT_NE(ReadText(dir / "sim" / "telemetry.srt").find("gb_pitch: "), std::string::npos);
  const std::string frames = (dir / "sim" / "frames").string();
  ASSERT_EQ(Cli("run " + frames + " --quiet --no-report -o " + (dir / "auto").string()), 0);
  ASSERT_EQ(Cli("run " + frames + " --attitude off --quiet --no-report -o " +
                (dir / "off").string()), 0);
  const nlohmann::json with = Summary(dir / "auto"), without = Summary(dir / "off");
  const int n = with["frames_processed"].get<int>();
  ASSERT_EQ(n, 61);
  EXPECT_EQ(with["attitude_sources"]["gimbal"].get<int>(), n);
  EXPECT_GT(with["max_tilt_deg"].get<double>(), 14.0);
  EXPECT_EQ(without["attitude_sources"].size(), 0u);
  // The uncorrected run says why its track is off.
  bool warned = false;
  for (const auto& w : without["warnings"]) {
    warned = warned || w.get<std::string>().find("deg from nadir") != std::string::npos;
  }
  EXPECT_TRUE(warned) << without["warnings"].dump();
  EXPECT_EQ(with["frames_bridged"].get<int>(), 0);
  const nlohmann::json& a = with["truth_evaluation"]["se2"];
  const nlohmann::json& b = without["truth_evaluation"]["se2"];
  const double ate_with = a["ate_m"]["rmse"].get<double>(), ate_without = b["ate_m"]["rmse"].get<double>();
  const double end_with = a["end_point_error_unaligned_m"].get<double>();
  const double end_without = b["end_point_error_unaligned_m"].get<double>();
  EXPECT_LT(3.0 * ate_with, ate_without) << "ATE " << ate_with << " m with, " << ate_without
                                          << " m without";
  EXPECT_LT(3.0 * end_with, end_without) << "end point " << end_with << " m with, "
                                          << end_without << " m without";
  EXPECT_LT(a["end_point_error_unaligned_percent"].get<double>(), 1.0);
  // frames.csv records the camera attitude applied to each frame: the truth's (pitch, and roll
  // with the simulator's sign, docs/attitude.md) to the SRT's 0.1 deg; none without the correction.
  const auto truth = e2e::ReadCsvRows(dir / "sim" / "ground_truth.csv");
  const auto rows = e2e::ReadFramesCsv(dir / "auto"), off = e2e::ReadFramesCsv(dir / "off");
  ASSERT_EQ(rows.size(), truth.size());
  ASSERT_EQ(off.size(), truth.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_NEAR(std::stod(rows[i].at("camera_pitch_deg")), std::stod(truth[i].at("pitch_deg")),
                0.06) << "frame " << i;
    EXPECT_NEAR(std::stod(rows[i].at("camera_roll_deg")), -std::stod(truth[i].at("roll_deg")),
                0.06) << "frame " << i;
    EXPECT_EQ(off[i].at("camera_pitch_deg"), "") << "frame " << i;
  }
  fs::remove_all(dir);
}

TEST(Attitude, NadirFlightIsUnchangedByTheCorrection) {
  const fs::path dir = TempDir("nadir");
  ASSERT_EQ(Cli(std::string(kFlight) + "--out " + (dir / "sim").string()), 0);
  // The SRT says nadir, as a DJI gimbal does (gb_pitch -90, gb_roll 0).
  const fs::path srt = dir / "sim" / "telemetry.srt";
  const std::string text = ReadText(srt);
  ASSERT_EQ(text.find("gb_pitch"), std::string::npos);
  WriteText(dir / "nadir.srt",
            std::regex_replace(text, std::regex("\\[ct: "), "[gb_pitch: -90.0 gb_roll: 0.0] [ct: "));
  const std::string frames = (dir / "sim" / "frames").string();
  ASSERT_EQ(Cli("run " + frames + " --telemetry " + (dir / "nadir.srt").string() +
                " --quiet --no-report -o " + (dir / "auto").string()), 0);
  ASSERT_EQ(Cli("run " + frames + " --attitude off --quiet --no-report -o " +
                (dir / "off").string()), 0);
  EXPECT_EQ(ReadText(dir / "auto" / "vo.tum"), ReadText(dir / "off" / "vo.tum"));
  EXPECT_EQ(ReadText(dir / "auto" / "transforms.csv"), ReadText(dir / "off" / "transforms.csv"));
  EXPECT_EQ(Summary(dir / "auto")["attitude_sources"].size(), 0u);
  fs::remove_all(dir);
}

TEST(Attitude, SrtWithOnlyAnAltitudeAboveSeaLevelNeedsTheGroundElevation) {
  const fs::path dir = TempDir("amsl");
  ASSERT_EQ(Cli(std::string(kFlight) + "--duration-s 5 --out " + (dir / "sim").string()), 0);
  const fs::path srt = dir / "amsl.srt";
  WriteText(srt, std::regex_replace(ReadText(dir / "sim" / "telemetry.srt"),
                                    std::regex("rel_alt: [0-9.-]+ "), ""));
  const std::string frames = (dir / "sim" / "frames").string();
  const std::string base = "run " + frames + " --telemetry " + srt.string() + " --quiet --no-report";
  ASSERT_EQ(Cli(base + " -o " + (dir / "none").string(), dir / "none.log"), 1 << 8);
  const std::string log = ReadText(dir / "none.log");
  EXPECT_NE(log.find("no height above ground"), std::string::npos) << log;
  EXPECT_NE(log.find("amsl.srt gives only an altitude above sea level"), std::string::npos) << log;
  EXPECT_NE(log.find("--ground-elevation-m"), std::string::npos) << log;
  // The simulator's ground is 300 m above sea level.
  ASSERT_EQ(Cli(base + " --ground-elevation-m 300 -o " + (dir / "amsl").string()), 0);
  const nlohmann::json s = Summary(dir / "amsl");
  EXPECT_EQ(s["height_sources"]["telemetry_abs_alt-ground_elevation"].get<int>(),
            s["frames_processed"].get<int>());
  const std::string csv = ReadText(dir / "amsl" / "frames.csv");
  EXPECT_NE(csv.find("telemetry_abs_alt-ground_elevation"), std::string::npos);
  // Relative altitude plus the take-off point's height: the source says so.
  ASSERT_EQ(Cli("run " + frames + " --takeoff-height-agl-m 2 --quiet --no-report -o " +
                (dir / "roof").string()), 0);
  EXPECT_GT(Summary(dir / "roof")["height_sources"]["telemetry_rel_alt+takeoff_height"].get<int>(),
            0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::attitude_test
