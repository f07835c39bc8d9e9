// The flight demo in its quick size: every output is written, and the track agrees with the exact
// ground truth. Needs no shared data (built-in terrain).
#include "aerovo/pipeline/demo.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "aerovo/core/error.h"

namespace aerovo::demo_test {
namespace {

namespace fs = std::filesystem;

TEST(Demo, QuickDemoWritesEverythingAndTracksTheTruth) {
  DemoOptions o;
  o.out_dir = fs::temp_directory_path() / ("aerovo_demo_test_" + std::to_string(::getpid()));
  fs::remove_all(o.out_dir);
  o.flight = DemoSimulation(true);
  o.illumination.k = {1.0, 0.25};
  int stages = 0;
  DemoCallbacks cb;
  cb.stage_started = [&](const std::string&, const std::string&) { ++stages; };
  const DemoResult r = RunDemo(o, cb);
  EXPECT_EQ(stages, 5);  // simulate, run, illumination, ransac, report
  EXPECT_FALSE(r.interrupted);
  EXPECT_EQ(r.flight.frames, 53);  // 2 x 100 m legs + a 40 m half-turn at 10 m/s, 2 fps
  EXPECT_NEAR(r.flight.distance_m, 260.0, 1.0);
  for (const char* f :
       {"sim/sim.json", "sim/ground_truth.csv", "run/summary.json", "run/vo.tum",
        "illumination/experiment.json", "ransac/experiment.json", "index.html", "summary.txt",
        "run/report.html", "illumination/report.html", "ransac/report.html"}) {
    EXPECT_TRUE(fs::exists(o.out_dir / f)) << f;
  }
  EXPECT_EQ(r.run.frames_processed, 53);
  EXPECT_EQ(r.run.frames_bridged, 0);
  EXPECT_EQ(r.run.frames_with_truth, 53);
  ASSERT_TRUE(r.run.truth_evaluation.has_value());
  // Measured: end-point error 0.05 m (0.02 %), ATE RMSE SE(2) 0.04 m over 263 m. The GPS
  // comparison sees the simulated 1.5 m GPS noise instead.
  EXPECT_LT(r.run.truth_evaluation->se2.end_point_error_percent, 0.5);
  EXPECT_LT(r.run.truth_evaluation->se2.ate_m.rmse, 0.5);
  ASSERT_TRUE(r.illumination.has_value());
  ASSERT_EQ(r.illumination->runs.size(), 2u);
  ASSERT_TRUE(r.ransac.has_value());
  ASSERT_EQ(r.ransac->runs.size(), 2u);
  const nlohmann::json summary =
      nlohmann::json::parse(std::ifstream(o.out_dir / "run/summary.json"));
  EXPECT_TRUE(summary["truth_evaluation"].is_object());
  const std::string text = FormatDemoSummary(r);
  for (const char* s : {"vs truth", "illumination", "ransac", "index.html"}) {
    EXPECT_NE(text.find(s), std::string::npos) << s << " in\n" << text;
  }
  std::stringstream html;
  html << std::ifstream(o.out_dir / "index.html").rdbuf();
  EXPECT_NE(html.str().find("run/report.html"), std::string::npos);
  EXPECT_NE(html.str().find("run/figures/fig2_trajectory.svg"), std::string::npos);
  fs::remove_all(o.out_dir);
}

TEST(Demo, BadOptionsAreClearErrors) {
  DemoOptions o;
  o.threads = -1;
  EXPECT_THROW(RunDemo(o), InvalidArgument);
  o = DemoOptions{};
  o.out_dir.clear();
  EXPECT_THROW(RunDemo(o), InvalidArgument);
  o = DemoOptions{};
  o.illumination.k = {};
  EXPECT_THROW(RunDemo(o), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::demo_test
