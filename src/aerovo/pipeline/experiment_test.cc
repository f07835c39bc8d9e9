// The experiments (illumination, ransac) on a short simulated flight, the illumination option of
// the runner, the statistics helpers and the option checks. About 10-15 s on 2 cores (one
// simulated 31-frame 640x480 flight, five short runs).
#include "aerovo/pipeline/experiment.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::experiment_test {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  return ::aerovo::testing::UnusedTempPath("aerovo_experiment_test", name);
}

nlohmann::json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

// ---------------------------------------------------------------------------------------------
// Statistics and small helpers

TEST(ExperimentStats, MeanMedianPercentileStdDevExact) {
  EXPECT_DOUBLE_EQ(Mean({1, 2, 3, 4}), 2.5);
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);  // even count: mean of the two middle values
  EXPECT_DOUBLE_EQ(Median({5, 1, 3}), 3.0);
  EXPECT_DOUBLE_EQ(Median({7}), 7.0);
  std::vector<double> v;
  for (int i = 20; i >= 1; --i) v.push_back(i);  // 1..20, unsorted
  // Type 7: h = 19 * 0.95 = 18.05 -> v[18] + 0.05 (v[19] - v[18]) = 19 + 0.05.
  EXPECT_NEAR(Percentile(v, 95.0), 19.05, 1e-12);
  EXPECT_DOUBLE_EQ(Percentile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(Percentile(v, 100.0), 20.0);
  EXPECT_DOUBLE_EQ(Percentile({10, 20}, 25.0), 12.5);
  EXPECT_DOUBLE_EQ(StdDev({2, 4, 4, 4, 5, 5, 7, 9}), 2.0);  // population sd
  EXPECT_THROW(Median({}), InvalidArgument);
  EXPECT_THROW(Percentile({1, 2}, 101.0), InvalidArgument);
  EXPECT_THROW(Percentile({1, 2}, -1.0), InvalidArgument);
  EXPECT_THROW(Mean({1.0, NAN}), InvalidArgument);
}

TEST(ExperimentStats, DistanceByFrameAndLabels) {
  std::vector<FrameRecord> a(3), b(2);
  for (int i = 0; i < 3; ++i) {
    a[i].frame = i;
    a[i].x_m = i;
  }
  b[0].frame = 1;
  b[0].x_m = 1.0;
  b[0].y_m = 3.0;  // 3 m from a[1]
  b[1].frame = 2;
  b[1].x_m = 6.0;  // 4 m from a[2]
  const TrajectoryDistance d = DistanceByFrame(a, b);
  EXPECT_EQ(d.count, 2);
  EXPECT_DOUBLE_EQ(d.max_m, 4.0);
  EXPECT_NEAR(d.rms_m, std::sqrt((9.0 + 16.0) / 2.0), 1e-12);
  b[0].frame = b[1].frame = 7;
  EXPECT_THROW(DistanceByFrame(a, b), InvalidArgument);

  EXPECT_EQ(IlluminationLabel(0.5), "k=0.50");
  EXPECT_EQ(IlluminationDir(1.0), "k1.00");
  EXPECT_EQ(IlluminationDir(0.125), "k0.125");
}

TEST(ExperimentOptions, BadIlluminationOptionsAreClearErrors) {
  const auto message = [](const IlluminationOptions& o) {
    try {
      Validate(o);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(IlluminationOptions{{}}).find("empty"), std::string::npos);
  EXPECT_NE(message(IlluminationOptions{{1.0, 0.0}}).find("(0, 1]"), std::string::npos);
  EXPECT_NE(message(IlluminationOptions{{1.5}}).find("(0, 1]"), std::string::npos);
  EXPECT_NE(message(IlluminationOptions{{-0.5}}).find("(0, 1]"), std::string::npos);
  EXPECT_NE(message(IlluminationOptions{{0.5, 1.0, 0.5}}).find("twice"), std::string::npos);
  EXPECT_NO_THROW(Validate(IlluminationOptions{}));

  // Nothing is run or written when an option is bad.
  ExperimentInput input;
  input.run.input = "/nonexistent/flight";
  input.out_dir = TempDir("bad");
  EXPECT_THROW(RunIlluminationExperiment(input, IlluminationOptions{{0.5, 2.0}}), InvalidArgument);
  EXPECT_FALSE(fs::exists(input.out_dir));

  RunConfig c;
  c.input = "x";
  c.illumination_k = 0.0;
  EXPECT_THROW(Validate(c), InvalidArgument);
  c.illumination_k = 1.01;
  EXPECT_THROW(Validate(c), InvalidArgument);
  c.illumination_k = 0.1;
  EXPECT_NO_THROW(Validate(c));
  // The key round-trips through the JSON config.
  EXPECT_DOUBLE_EQ(RunConfigFromJson(ToJson(c), RunConfig{}).illumination_k, 0.1);
  EXPECT_THROW(RunConfigFromJson(nlohmann::json{{"illumination_k", "dark"}}, RunConfig{}),
               InvalidArgument);
}

// The registry: one entry per ExperimentKind, in enum order, each complete; the names are the
// subcommands and experiment.json's "kind".
TEST(ExperimentRegistry, EveryKindOnce) {
  ASSERT_EQ(Experiments().size(), kNumExperimentKinds);
  for (std::size_t i = 0; i < kNumExperimentKinds; ++i) {
    const ExperimentDefinition& def = Experiments()[i];
    EXPECT_EQ(def.kind, kAllExperimentKinds[i]);
    EXPECT_EQ(&FindExperiment(def.kind), &def);
    EXPECT_NE(std::string(def.help), "");
    EXPECT_FALSE(def.own_run_keys.empty());
    EXPECT_NE(def.validate, nullptr);
    EXPECT_NE(def.plan, nullptr);
    EXPECT_NE(def.tables, nullptr);
    EXPECT_NE(def.describe_run, nullptr);
  }
  EXPECT_EQ(options::EnumNames<ExperimentKind>(),
            (std::vector<std::string>{"illumination", "ransac"}));
  EXPECT_EQ(ParseExperimentKind("ransac"), ExperimentKind::kRansac);
  EXPECT_EQ(ParseExperimentKind("Ransac"), std::nullopt);
}

// What each experiment plans: its parameter changed, everything else as given, one folder each.
TEST(ExperimentRegistry, PlansChangeOnlyTheirParameter) {
  ExperimentInput in;
  in.run.input = "flight.mp4";
  in.run.odometry.surf.hessian_threshold = 400.0;
  in.out_dir = "EXP";
  ExperimentOptions o;
  o.illumination.k = {1.0, 0.5};
  o.illumination.scale_threshold = true;
  const std::vector<PlannedRun> ill = FindExperiment(ExperimentKind::kIllumination).plan(in, o);
  ASSERT_EQ(ill.size(), 2u);
  EXPECT_EQ(ill[1].label, "k=0.50");
  EXPECT_EQ(ill[1].dir, "k0.50");
  EXPECT_EQ(ill[1].config.out, (fs::path("EXP") / "k0.50").string());
  EXPECT_DOUBLE_EQ(ill[1].config.illumination_k, 0.5);
  EXPECT_DOUBLE_EQ(ill[1].config.odometry.surf.hessian_threshold, 100.0);  // 400 x 0.5^2
  EXPECT_EQ(ill[1].config.input, "flight.mp4");

  const std::vector<PlannedRun> ransac = FindExperiment(ExperimentKind::kRansac).plan(in, o);
  ASSERT_EQ(ransac.size(), 2u);
  EXPECT_EQ(ransac[0].dir, "standard");
  EXPECT_EQ(ransac[1].dir, "clustered");
  EXPECT_EQ(ransac[0].config.odometry.correspondence.method, CorrespondenceMethod::kStandard);
  EXPECT_EQ(ransac[1].config.odometry.correspondence.method, CorrespondenceMethod::kClustered);
  EXPECT_DOUBLE_EQ(ransac[1].config.odometry.surf.hessian_threshold, 400.0);

  ExperimentRun run;
  run.k = 0.25;
  run.mode = "clustered";
  nlohmann::json a = nlohmann::json::object(), b = nlohmann::json::object();
  FindExperiment(ExperimentKind::kIllumination).describe_run(run, &a);
  FindExperiment(ExperimentKind::kRansac).describe_run(run, &b);
  EXPECT_EQ(a, (nlohmann::json{{"k", 0.25}}));
  EXPECT_EQ(b, (nlohmann::json{{"mode", "clustered"}}));
  EXPECT_THROW(FindExperiment(ExperimentKind::kIllumination).validate(ExperimentOptions{{{2.0}}}),
               InvalidArgument);
}

TEST(ExperimentOptions, ScaleBrightnessRoundsHalfUp) {
  GrayImage in(6, 2);
  const std::uint8_t values[6] = {0, 1, 3, 100, 254, 255};
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 6; ++x) in.at(x, y) = values[x];
  }
  GrayImage buffer;
  GrayImageView out = ScaleBrightness(in.view(), 0.5, &buffer);
  const int half[6] = {0, 1, 2, 50, 127, 128};  // 0.5 -> 1, 1.5 -> 2, 127.5 -> 128
  for (int x = 0; x < 6; ++x) EXPECT_EQ(out.at(x, 1), half[x]) << x;
  out = ScaleBrightness(in.view(), 0.1, &buffer);
  const int tenth[6] = {0, 0, 0, 10, 25, 26};  // 25.4 -> 25, 25.5 -> 26
  for (int x = 0; x < 6; ++x) EXPECT_EQ(out.at(x, 0), tenth[x]) << x;
  out = ScaleBrightness(in.view(), 1.0, &buffer);
  for (int x = 0; x < 6; ++x) EXPECT_EQ(out.at(x, 0), values[x]);
  EXPECT_THROW(ScaleBrightness(in.view(), -1.0, &buffer), InvalidArgument);
}

// ---------------------------------------------------------------------------------------------
// Experiments on one short simulated flight: a 150 m line at 100 m over the built-in terrain,
// 640x480, 2 frames per second (31 frames, 5 m between frames).

class ExperimentOnSimulatedFlight : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new fs::path(TempDir("sim"));
    ExperimentSimulation s;
    s.sim.flight.pattern = sim::FlightPattern::kLine;
    s.sim.flight.legs = 1;
    s.sim.flight.leg_length_m = 150.0;
    s.sim.camera.width_px = 640;
    s.sim.camera.height_px = 480;
    s.sim.fps = 2.0;
    flight_ = new SimulatedFlight(SimulateExperimentFlight(s, *root_ / "exp" / "sim"));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete flight_;
    delete root_;
  }
  static ExperimentInput Input(const std::string& name) {
    ExperimentInput in;
    in.run = flight_->run;
    // The paper's protocol (fixed SURF threshold): what these tests measure (N_SURF falling
    // with k). The defaults' adaptive points are tested in tests/e2e/adaptive_points_test.cc.
    ApplyPaperPreset(in.run);
    in.run.quiet = true;
    in.out_dir = *root_ / name;
    return in;
  }
  static fs::path* root_;
  static SimulatedFlight* flight_;
};
fs::path* ExperimentOnSimulatedFlight::root_ = nullptr;
SimulatedFlight* ExperimentOnSimulatedFlight::flight_ = nullptr;

// Every table: as many cells per row as columns.
void CheckTables(const nlohmann::json& tables) {
  for (auto it = tables.begin(); it != tables.end(); ++it) {
    ASSERT_TRUE(it.value().contains("columns")) << it.key();
    ASSERT_TRUE(it.value().contains("rows")) << it.key();
    ASSERT_EQ(it.value().size(), 2u) << it.key();
    const std::size_t n = it.value()["columns"].size();
    for (const auto& row : it.value()["rows"]) {
      EXPECT_EQ(row.size(), n) << it.key();
      for (const auto& cell : row) EXPECT_TRUE(cell.is_string() || cell.is_number()) << it.key();
    }
  }
}

TEST_F(ExperimentOnSimulatedFlight, IlluminationLowersNsurfAndKeepsFinishedRuns) {
  EXPECT_EQ(flight_->frames, 31);
  // The experiment folder holds the simulation: ground_truth is written relative to it.
  ExperimentInput in = Input("exp");
  IlluminationOptions o;
  o.k = {1.0, 0.5, 0.25};
  std::atomic<bool> stop{false};
  ExperimentCallbacks cb;
  std::vector<std::string> started;
  cb.run_started = [&](int, int, const std::string& label, const std::string&) {
    started.push_back(label);
  };
  cb.run_finished = [&](int i, int, const ExperimentRun&) {
    // Interrupt after the second run: the first two must be kept and listed.
    if (i == 1) stop = true;
  };
  const ExperimentResult r = RunIlluminationExperiment(in, o, cb, &stop);
  EXPECT_TRUE(r.interrupted);
  ASSERT_EQ(r.runs.size(), 2u);
  EXPECT_EQ(started, (std::vector<std::string>{"k=1.00", "k=0.50"}));
  const ExperimentRun& bright = r.runs[0];
  const ExperimentRun& dim = r.runs[1];
  EXPECT_EQ(bright.summary.frames_processed, 31);
  EXPECT_EQ(bright.frames.size(), 31u);
  EXPECT_EQ(bright.summary.frames_bridged, 0);
  double surf1 = 0, surf05 = 0;
  for (const auto& f : bright.frames) surf1 += f.n_surf;
  for (const auto& f : dim.frames) surf05 += f.n_surf;
  // The Hessian determinant scales with k^2: at k = 0.5 a quarter of the response, far fewer
  // points above the same threshold (measured 504 -> 27 per frame).
  EXPECT_GT(surf1 / 31, 300.0);
  EXPECT_LT(surf05, 0.5 * surf1);
  ASSERT_TRUE(bright.summary.truth_evaluation.has_value());
  EXPECT_LT(bright.summary.truth_evaluation->se2.ate_m.rmse, 0.5);  // measured 0.00 m
  EXPECT_NEAR(DistanceFlownM(bright), 150.0, 1.0);

  // experiment.json follows the contract and lists only the finished runs.
  const nlohmann::json j = ReadJson(in.out_dir / "experiment.json");
  EXPECT_EQ(j["kind"], "illumination");
  ASSERT_EQ(j["runs"].size(), 2u);
  EXPECT_EQ(j["runs"][0], (nlohmann::json{{"label", "k=1.00"}, {"dir", "k1.00"}, {"k", 1.0}}));
  EXPECT_EQ(j["runs"][1], (nlohmann::json{{"label", "k=0.50"}, {"dir", "k0.50"}, {"k", 0.5}}));
  EXPECT_EQ(j["ground_truth"], "sim/ground_truth.csv");
  EXPECT_TRUE(fs::exists(in.out_dir / j["ground_truth"].get<std::string>()));
  EXPECT_EQ(j.size(), 4u);
  ASSERT_TRUE(j["tables"].contains("features"));
  ASSERT_TRUE(j["tables"].contains("trajectory"));
  CheckTables(j["tables"]);
  const auto& features = j["tables"]["features"];
  ASSERT_EQ(features["rows"].size(), 2u);
  EXPECT_EQ(features["columns"][3], "N_SURF mean");
  EXPECT_TRUE(features["rows"][0][2].is_number_integer());  // frames: a count
  EXPECT_EQ(features["rows"][0][2], 31);
  EXPECT_DOUBLE_EQ(features["rows"][0][0].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(features["rows"][1][1].get<double>(), 1000.0);  // the same threshold
  EXPECT_GT(features["rows"][0][3].get<double>(), features["rows"][1][3].get<double>());
  const auto& traj = j["tables"]["trajectory"];
  ASSERT_EQ(traj["rows"].size(), 2u);
  // The reference row is at distance 0 from itself.
  EXPECT_EQ(traj["columns"][7], "vs k=1.00 RMS m");
  EXPECT_DOUBLE_EQ(traj["rows"][0][7].get<double>(), 0.0);
  for (const char* dir : {"k1.00", "k0.50"}) {
    EXPECT_TRUE(fs::exists(in.out_dir / dir / "summary.json")) << dir;
    EXPECT_TRUE(fs::exists(in.out_dir / dir / "frames.csv")) << dir;
    EXPECT_DOUBLE_EQ(ReadJson(in.out_dir / dir / "config.json")["illumination_k"].get<double>(),
                     dir == std::string("k1.00") ? 1.0 : 0.5);
  }
  EXPECT_FALSE(fs::exists(in.out_dir / "k0.25" / "summary.json"));  // never started
  EXPECT_TRUE(fs::exists(in.out_dir / "tables.md"));
}

TEST_F(ExperimentOnSimulatedFlight, ScaledThresholdKeepsThePointsOfADimFlight) {
  const ExperimentInput in = Input("scaled");
  IlluminationOptions o;
  o.k = {0.5};
  o.scale_threshold = true;
  const ExperimentResult r = RunIlluminationExperiment(in, o);
  ASSERT_EQ(r.runs.size(), 1u);
  EXPECT_DOUBLE_EQ(r.runs[0].config.odometry.surf.hessian_threshold, 250.0);  // 1000 * 0.5^2
  double surf = 0;
  for (const auto& f : r.runs[0].frames) surf += f.n_surf;
  // With the threshold following k^2, the dim flight keeps most of the bright flight's points
  // (measured 504 per frame at k = 1; 27 at k = 0.5 with the fixed threshold).
  EXPECT_GT(surf / r.runs[0].frames.size(), 300.0);
  EXPECT_EQ(r.runs[0].summary.frames_bridged, 0);
}

TEST_F(ExperimentOnSimulatedFlight, RansacGivesBothRunsAndASpeedUp) {
  const ExperimentInput in = Input("ransac");
  const ExperimentResult r = RunRansacExperiment(in);
  EXPECT_FALSE(r.interrupted);
  ASSERT_EQ(r.runs.size(), 2u);
  EXPECT_EQ(r.runs[0].mode, "standard");
  EXPECT_EQ(r.runs[1].mode, "clustered");
  for (const ExperimentRun& run : r.runs) {
    EXPECT_EQ(run.summary.frames_processed, 31);
    EXPECT_EQ(run.summary.frames_bridged, 0);
    EXPECT_EQ(StageTimesMs(run, "correspondence").size(), 30u);  // steps only
  }
  // The ground truth is outside the experiment folder: an absolute path.
  const nlohmann::json j = ReadJson(in.out_dir / "experiment.json");
  EXPECT_EQ(j["kind"], "ransac");
  EXPECT_EQ(j["runs"][1],
            (nlohmann::json{{"label", "clustered"}, {"dir", "clustered"}, {"mode", "clustered"}}));
  EXPECT_TRUE(fs::path(j["ground_truth"].get<std::string>()).is_absolute());
  CheckTables(j["tables"]);
  const auto& stages = j["tables"]["stage_times"];
  ASSERT_EQ(stages["rows"].size(), 6u);
  EXPECT_EQ(stages["columns"].size(), 7u);
  EXPECT_EQ(stages["rows"][4][0], "correspondence");
  const auto& speed = j["tables"]["speedup"];
  ASSERT_EQ(speed["rows"].size(), 4u);
  EXPECT_EQ(speed["rows"][0][0], "mean");
  for (const auto& row : speed["rows"]) {
    ASSERT_TRUE(row[3].is_number());
    EXPECT_GT(row[3].get<double>(), 0.0);
    // speed-up = standard / clustered, as shown (each rounded to 0.001 ms: a few % off).
    if (row[2].get<double>() > 0.05) {
      const double ratio = row[1].get<double>() / row[2].get<double>();
      EXPECT_NEAR(row[3].get<double>(), ratio, 0.03 * ratio + 0.01);
    }
  }
  ASSERT_EQ(j["tables"]["agreement"]["rows"].size(), 1u);
  // Same flight, same matches: the two trajectories agree to centimetres (measured 0.00 m).
  EXPECT_LT(j["tables"]["agreement"]["rows"][0][2].get<double>(), 0.5);
  ASSERT_EQ(j["tables"]["trajectory"]["rows"].size(), 2u);
  for (const ExperimentRun& run : r.runs) {
    ASSERT_TRUE(run.summary.truth_evaluation.has_value());
    EXPECT_LT(run.summary.truth_evaluation->se2.ate_m.rmse, 0.5);
  }
}

}  // namespace
}  // namespace aerovo::experiment_test
