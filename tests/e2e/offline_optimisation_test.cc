// The offline whole-flight optimisation (`aerovo run --backend-enable`, odometry/flight_graph.h,
// docs/backend.md) on a simulated lawnmower with exact truth: the optimised track
// (vo_optimized.*) ends at most a third as far from the truth as the causal one, after an SE(2)
// alignment (the run's geo-referencing is the causal track's, so the unaligned end error of the
// optimised track keeps the causal heading's error), the causal files are those of a run
// without the optimisation, and the same seed gives the same vo_optimized.tum at any thread
// count. The online window (`--backend-online`) on the same flight: its live track (vo.tum,
// the windowed estimates) is closer to the truth than the causal one, every frame is matched
// against recent keyframes and none is gated, the pose stream carries the window's standard
// deviations, and the same seed gives the same track at any thread count.
#include <gtest/gtest.h>

#include <fstream>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "e2e_testing.h"

namespace aerovo {
namespace {

namespace fs = std::filesystem;

// 4 legs of 250 m, 50 m apart, 100 m high, 480x270 frames at 1.5 fps over the built-in terrain
// (155 frames, 1 km; about 2 s of CPU to simulate, 2 s per run).
const fs::path& Flight() {
  static const fs::path dir = [] {
    const fs::path d = e2e::UnusedTempPath("aerovo_offline", "lawnmower");
    EXPECT_TRUE(e2e::Cli("simulate --pattern lawnmower --legs 4 --length-m 250 --spacing-m 50 "
                         "--height-m 100 --speed-mps 12 --fps 1.5 --width 480 --height 270 "
                         "--quiet -o " + d.string()));
    return d;
  }();
  return dir;
}

fs::path RunFlight(const std::string& name, const std::string& flags) {
  const fs::path out = Flight() / name;
  EXPECT_TRUE(e2e::Cli("run " + (Flight() / "video.mp4").string() + " --quiet --no-report " +
                       flags + " -o " + out.string()));
  return out;
}

// The simulated flight and the runs are shared by the tests and removed after them.
class OfflineOptimisation : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { fs::remove_all(Flight()); }
};

TEST_F(OfflineOptimisation, LawnmowerEndErrorIsAtMostAThirdOfTheCausalOne) {
  const fs::path run = RunFlight("on", "--backend-enable --threads 2");
  const nlohmann::json s = e2e::ReadJson(run / "summary.json");
  ASSERT_TRUE(s["optimized"].is_object()) << s.dump();
  const nlohmann::json& o = s["optimized"];
  EXPECT_GT(o["pairs_verified"].get<int>(), 50);
  EXPECT_EQ(o["pairs_gated"].get<int>(), 0);
  const nlohmann::json& causal = s["truth_evaluation"]["se2"];
  const nlohmann::json& optimised = o["truth_evaluation"]["se2"];
  const double end_causal = causal["end_point_error_m"].get<double>();
  const double end_optimised = optimised["end_point_error_m"].get<double>();
  EXPECT_LE(3.0 * end_optimised, end_causal)
      << "end error " << end_causal << " m causal, " << end_optimised << " m optimised";
  EXPECT_LT(3.0 * optimised["ate_m"]["rmse"].get<double>(), causal["ate_m"]["rmse"].get<double>());
  EXPECT_TRUE(o["evaluation"].is_object());  // against the simulated GPS too
  for (const char* f : {"vo_optimized.tum", "vo_optimized.geojson", "vo_optimized.kml",
                        "vo_optimized.gpx"}) {
    EXPECT_TRUE(fs::is_regular_file(run / f)) << f;
  }
  // The causal track is the one of a run without the optimisation.
  const fs::path off = RunFlight("off", "--threads 2");
  EXPECT_EQ(e2e::ReadText(run / "vo.tum"), e2e::ReadText(off / "vo.tum"));
  EXPECT_FALSE(fs::exists(off / "vo_optimized.tum"));
  EXPECT_TRUE(e2e::ReadJson(off / "summary.json")["optimized"].is_null());
}

TEST_F(OfflineOptimisation, SameSeedSameOptimisedTrackAtAnyThreadCount) {
  const fs::path two = Flight() / "on";
  if (!fs::exists(two / "vo_optimized.tum")) RunFlight("on", "--backend-enable --threads 2");
  const fs::path one = RunFlight("one_thread", "--backend-enable --threads 1");
  const std::string a = e2e::ReadText(two / "vo_optimized.tum");
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, e2e::ReadText(one / "vo_optimized.tum"));
  EXPECT_EQ(e2e::ReadText(two / "vo_optimized.geojson"),
            e2e::ReadText(one / "vo_optimized.geojson"));
}

TEST_F(OfflineOptimisation, OnlineWindowBeatsTheCausalTrackTheSameAtAnyThreadCount) {
  const fs::path off = Flight() / "off";
  if (!fs::exists(off / "summary.json")) RunFlight("off", "--threads 2");
  const fs::path two = Flight() / "online_two";
  RunFlight("online_two", "--backend-online --threads 2 --poses-jsonl " +
                              (Flight() / "online_poses.jsonl").string());
  const fs::path one = RunFlight("online_one", "--backend-online --threads 1");
  const nlohmann::json s = e2e::ReadJson(two / "summary.json");
  ASSERT_TRUE(s["online"].is_object()) << s.dump();
  EXPECT_EQ(s["online"]["window"].get<int>(), 10);
  EXPECT_GT(s["online"]["pairs_verified"].get<int>(), 150);
  EXPECT_EQ(s["online"]["pairs_gated"].get<int>(), 0);
  EXPECT_TRUE(s["optimized"].is_null());
  const nlohmann::json off_summary = e2e::ReadJson(off / "summary.json");
  const nlohmann::json& causal = off_summary["truth_evaluation"]["se2"];
  const nlohmann::json& online = s["truth_evaluation"]["se2"];
  const double end_causal = causal["end_point_error_m"].get<double>();
  const double end_online = online["end_point_error_m"].get<double>();
  EXPECT_LT(2.0 * end_online, end_causal)
      << "end error " << end_causal << " m causal, " << end_online << " m online";
  EXPECT_LT(online["end_point_error_unaligned_m"].get<double>(),
            causal["end_point_error_unaligned_m"].get<double>());
  // The pose stream: every frame after the first with the window's standard deviations.
  std::ifstream in(Flight() / "online_poses.jsonl");
  std::string line;
  int with_sigma = 0, poses = 0;
  while (std::getline(in, line)) {
    const nlohmann::json j = nlohmann::json::parse(line);
    if (j["type"] != "pose") continue;
    ++poses;
    if (j.contains("sigma_xy_m")) {
      EXPECT_GT(j["sigma_xy_m"].get<double>(), 0.0);
      EXPECT_LT(j["sigma_xy_m"].get<double>(), 5.0);
      ++with_sigma;
    }
  }
  EXPECT_EQ(poses, s["frames_processed"].get<int>());
  EXPECT_EQ(with_sigma, poses - 1);
  // Same seed, same windowed track at any thread count; and not the causal track.
  const std::string a = e2e::ReadText(two / "vo.tum");
  EXPECT_EQ(a, e2e::ReadText(one / "vo.tum"));
  EXPECT_EQ(e2e::ReadText(two / "vo.geojson"), e2e::ReadText(one / "vo.geojson"));
  EXPECT_NE(a, e2e::ReadText(off / "vo.tum"));
}

}  // namespace
}  // namespace aerovo
