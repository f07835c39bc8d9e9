// 4K video (docs/inputs.md, "Video above 1080p: the detection budget"): the default run detects a
// 3840x2160 video at 1920x1080 (RunConfig::detect_megapixels, pipeline/preprocess.h FrameReducer)
// and its track against the simulator's exact truth stays within 5 % of the full-resolution run's
// (detect_megapixels 0).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "e2e_testing.h"

namespace aerovo::video_4k_test {
namespace {

namespace fs = std::filesystem;

using e2e::ReadJson;

// A 4K flight of 16 frames at 5 fps: 10 m/s at 80 m, 2 m (64 px at 3.1 cm/px) per frame along
// a straight line (30 m), sensor noise 1.5 DN (the simulator's truth is exact).
TEST(Video4k, DefaultRunDetectsAtHalfResolutionWithinFivePercentOfFullResolution) {
  const fs::path dir = e2e::FreshTempDir("aerovo_video4k", "track");
  const std::string cli = AEROVO_CLI_PATH;
  const std::string sim =
      cli + " simulate --pattern line --length-m 60 --height-m 80 --speed-mps 10 --fps 5" +
      " --duration-s 3.0 --width 3840 --height 2160 --noise 1.5 --terrain-seed 5 --seed 2 -q -o " +
      (dir / "sim").string() + " > " + (dir / "sim.log").string() + " 2>&1";
  ASSERT_EQ(std::system(sim.c_str()), 0) << "aerovo simulate failed: see " << dir / "sim.log";
  const auto run = [&](const std::string& name, const std::string& flags) {
    const std::string cmd = cli + " run " + (dir / "sim" / "video.mp4").string() +
                            " -q --no-report -o " + (dir / name).string() + " " + flags + " > " +
                            (dir / (name + ".log")).string() + " 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << "aerovo run " << flags << " failed";
    return ReadJson(dir / name / "summary.json");
  };
  const nlohmann::json def = run("default", "");
  const nlohmann::json full = run("full", "--detect-megapixels 0");
  ASSERT_TRUE(def.contains("evaluation")) << def.dump();
  ASSERT_TRUE(full.contains("evaluation")) << full.dump();
  EXPECT_EQ(def["processed_width_px"], 1920);
  EXPECT_EQ(def["processed_height_px"], 1080);
  EXPECT_DOUBLE_EQ(def["frame_scale"].get<double>(), 0.5);
  EXPECT_EQ(full["processed_width_px"], 3840);
  EXPECT_EQ(def["frames_processed"], 16);
  EXPECT_EQ(full["frames_processed"], 16);
  EXPECT_EQ(def["frames_bridged"], 0);
  // Focal length on the reduced frames: half the full one (metres stay metres).
  EXPECT_DOUBLE_EQ(def["focal_px"].get<double>(), full["focal_px"].get<double>());
  const auto& de = def["evaluation"]["se2"];
  const auto& fe = full["evaluation"]["se2"];
  const double def_ate = de["ate_m"]["rmse"].get<double>();
  const double full_ate = fe["ate_m"]["rmse"].get<double>();
  const double length_m = fe["distance_flown_m"].get<double>();
  EXPECT_GT(length_m, 25.0);
  // The VO path's length within 1 % of the truth's: the reduction keeps the scale.
  EXPECT_NEAR(def["vo_path_length_m"].get<double>(), length_m, 0.01 * length_m);
  // Within 5 % of the full-resolution error, with a floor of 1 cm (the errors are centimetres:
  // measured 2.09 cm default, 2.09 cm full on this flight).
  EXPECT_LE(def_ate, 1.05 * full_ate + 0.01) << "default " << def_ate << " m, full " << full_ate;
  EXPECT_LT(full_ate, 0.01 * length_m);  // both runs are good tracks, not equally lost ones
  const double def_end = de["end_point_error_m"].get<double>();
  const double full_end = fe["end_point_error_m"].get<double>();
  EXPECT_LE(def_end, 1.05 * full_end + 0.01) << "default " << def_end << " m, full " << full_end;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::video_4k_test
