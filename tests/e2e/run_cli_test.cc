// The flags of `aerovo run`, generated from the option schema, through the built binary: every
// option settable by flag with the same effect as by JSON (--print-config shows the effective
// configuration), the legacy flags and the shorthands, conflicts, docs/options.md up to date,
// and `aerovo run --config OUT/config.json` reproducing a run.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/core/options.h"
#include "aerovo/core/testing.h"
#include "aerovo/pipeline/demo.h"
#include "aerovo/pipeline/experiment.h"
#include "aerovo/pipeline/run_config.h"
#include "aerovo/pipeline/testing.h"

namespace aerovo::run_cli_test {
namespace {

namespace fs = std::filesystem;

#ifdef AEROVO_CLI_PATH

// stdout (stderr is folded in with 2>&1 when asked) and the wait status.
using CliResult = testing::CommandOutput;

CliResult RunCli(const std::string& args) {
  return testing::RunCommand(std::string(AEROVO_CLI_PATH) + " " + args);
}

// The shell word for a JSON value given as a flag's value.
std::string FlagValue(const nlohmann::json& v) {
  // A list of one (--map): the flag once with its element.
  const nlohmann::json& e = v.is_array() && v.size() == 1 ? v[0] : v;
  const std::string s = e.is_string() ? e.get<std::string>() : e.dump();
  return "'" + s + "'";
}

nlohmann::json PrintConfig(const std::string& args) {
  const CliResult r = RunCli("run " + args + " --print-config 2>&1");
  EXPECT_EQ(r.status, 0) << args << "\n" << r.out;
  try {
    return nlohmann::json::parse(r.out);
  } catch (const std::exception& e) {
    ADD_FAILURE() << args << ": " << e.what() << "\n" << r.out;
    return {};
  }
}

RunConfig Base() {
  RunConfig c;
  c.input = "flight.mp4";
  return c;
}

// Every option at once, then every legacy flag at once (one process each: the binary's start-up
// costs more than the parsing), each set to the non-default value the JSON/YAML test of
// pipeline/run_config_test.cc uses; the effective configuration must be the JSON one.
TEST(RunCli, EveryOptionByFlagWithTheSameEffectAsByJson) {
  nlohmann::json expected = ToJson(Base()), expected_by_alias = ToJson(Base());
  std::string args, alias_args = "flight.mp4";
  for (const testing::Sample& s : testing::Samples()) {
    // A calibration file gives the distortion: not with k1..k3/p1/p2 (RunCli.CalibrationFlag).
    if (s.key == "calibration") continue;
    // end_s must stay >= start_s (also given): a later end than the sample's.
    const nlohmann::json value = s.key == "end_s" ? nlohmann::json(1000.0) : s.value;
    const std::string word = s.cli_switch ? "" : " " + FlagValue(value);
    expected[s.key] = value;
    args += " " + options::FlagName(s.key) + word;  // --input for the input
    if (!s.alias.empty()) {
      expected_by_alias[s.key] = value;
      alias_args += " " + options::FlagName(s.alias) + word;
    }
  }
  const nlohmann::json got = PrintConfig(args);
  for (const auto& [key, value] : expected.items()) EXPECT_EQ(got[key], value) << key;
  EXPECT_EQ(got, expected);
  const nlohmann::json by_alias = PrintConfig(alias_args);
  for (const auto& [key, value] : expected_by_alias.items()) {
    EXPECT_EQ(by_alias[key], value) << key;
  }
  EXPECT_EQ(by_alias, expected_by_alias);
}

// --calibration: the one option the all-at-once test leaves out (it excludes k1..k3, p1, p2).
TEST(RunCli, CalibrationFlag) {
  const nlohmann::json c = PrintConfig("flight.mp4 --calibration cam.yaml");
  EXPECT_EQ(c["calibration"], "cam.yaml");
  const CliResult both = RunCli("run flight.mp4 --calibration cam.yaml --k1 0.1 --print-config 2>&1");
  EXPECT_EQ(WEXITSTATUS(both.status), 2) << both.out;
  EXPECT_NE(both.out.find("leave k1, k2, p1, p2, k3 at 0"), std::string::npos) << both.out;
}

TEST(RunCli, LegacyFlagsShorthandsAndConflicts) {
  // The spellings of users' scripts.
  const nlohmann::json paper = PrintConfig("flight.mp4 --guided 0 --refine 0 --mode standard");
  EXPECT_EQ(paper["correspondence.guided_matching"], false);
  EXPECT_EQ(paper["clustered.refine"], false);
  EXPECT_EQ(paper["correspondence.method"], "standard");
  const nlohmann::json t = PrintConfig("flight.mp4 --threads 3 --altitude 57 -q");
  EXPECT_EQ(t["surf.num_threads"], 3);
  EXPECT_EQ(t["match.num_threads"], 3);
  EXPECT_EQ(t["altitude_m"], 57.0);
  EXPECT_EQ(t["quiet"], true);
  // A shorthand and one of its keys with different values: an error naming both.
  const CliResult c =
      RunCli("run flight.mp4 --threads 3 --match-num-threads 2 --print-config 2>&1");
  EXPECT_NE(c.status, 0);
  EXPECT_NE(c.out.find("'match.num_threads' = 2 and 'threads' = 3 disagree"), std::string::npos)
      << c.out;
  // Enum choices are checked by the flag parser.
  const CliResult e = RunCli("run flight.mp4 --ransac-seed 2 --correspondence-sampler fast 2>&1");
  EXPECT_NE(e.status, 0);
  EXPECT_NE(e.out.find("fast"), std::string::npos) << e.out;
  // Out of range: the one message style, naming the key.
  const CliResult r = RunCli("run flight.mp4 --ransac-max-distance-px -1 --print-config 2>&1");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("ransac.max_distance_px must be finite and > 0, got -1"), std::string::npos)
      << r.out;
}

// One boolean style: every boolean is a switch with its negation; `--X=value` too; the last one
// given wins; a value that is no boolean is a usage error (exit 2) naming the flag.
TEST(RunCli, BooleansAreSwitchesWithNegations) {
  const nlohmann::json off = PrintConfig(
      "flight.mp4 --no-guided --no-refine --no-surf-adaptive --surf-extended "
      "--no-gps-check-enabled --quiet --no-quiet --odometry-relocalize=off");
  EXPECT_EQ(off["correspondence.guided_matching"], false);
  EXPECT_EQ(off["clustered.refine"], false);
  EXPECT_EQ(off["surf.adaptive"], false);
  EXPECT_EQ(off["surf.extended"], true);
  EXPECT_EQ(off["gps_check.enabled"], false);
  EXPECT_EQ(off["quiet"], false);
  EXPECT_EQ(off["odometry.relocalize"], false);
  const nlohmann::json on = PrintConfig(
      "--correspondence-guided-matching=false --correspondence-guided-matching flight.mp4 "
      "--match-unique=YES --lenient-telemetry 1");
  EXPECT_EQ(on["input"], "flight.mp4");
  EXPECT_EQ(on["correspondence.guided_matching"], true);
  EXPECT_EQ(on["match.unique"], true);
  EXPECT_EQ(on["lenient_telemetry"], true);
  const CliResult bad = RunCli("run flight.mp4 --guided=maybe --print-config 2>&1");
  EXPECT_EQ(WEXITSTATUS(bad.status), 2) << bad.out;
  EXPECT_NE(bad.out.find("--guided"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("'maybe' is not a boolean"), std::string::npos) << bad.out;
}

TEST(RunCli, FlagsWinOverTheConfigFile) {
  const fs::path dir = fs::temp_directory_path() / ("aerovo_run_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "c.yaml") << "input: a.mp4\nthreads: 2\nransac.max_distance_px: 2.5\n";
  const nlohmann::json j =
      PrintConfig("--config " + (dir / "c.yaml").string() + " --surf-num-threads 4");
  EXPECT_EQ(j["input"], "a.mp4");
  EXPECT_EQ(j["surf.num_threads"], 4);
  EXPECT_EQ(j["match.num_threads"], 2);
  EXPECT_EQ(j["ransac.max_distance_px"], 2.5);
  fs::remove_all(dir);
}

// docs/options.md is the output of `aerovo run --list-options` (regenerate it with that command
// when an option changes).
TEST(RunCli, DocsOptionsMdIsUpToDate) {
  const fs::path doc = fs::path(AEROVO_REFERENCE_DIR) / ".." / ".." / "docs" / "options.md";
  std::ifstream in(doc);
  ASSERT_TRUE(in) << doc;
  std::stringstream ss;
  ss << in.rdbuf();
  const CliResult r = RunCli("run --list-options");
  ASSERT_EQ(r.status, 0);
  EXPECT_EQ(r.out, RunOptionsMarkdown());
  EXPECT_EQ(ss.str(), r.out) << "docs/options.md is stale: aerovo run --list-options > "
                                "docs/options.md";
}

// The positions of frames.csv, one "x,y" per frame.
std::vector<std::string> Positions(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("frame,time_s,x_m,y_m,", 0), 0u) << line;
  std::vector<std::string> out;
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::string frame, t, x, y;
    std::getline(ls, frame, ',');
    std::getline(ls, t, ',');
    std::getline(ls, x, ',');
    std::getline(ls, y, ',');
    out.push_back(x + "," + y);
  }
  return out;
}

TEST(RunCli, RunFromItsSavedConfigJsonReproducesTheRun) {
  const fs::path dir =
      fs::temp_directory_path() / ("aerovo_run_cli_repro_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  ExperimentSimulation sim = DemoSimulation(true);
  sim.sim.flight.legs = 1;
  sim.sim.flight.leg_length_m = 40.0;
  const SimulatedFlight flight = SimulateExperimentFlight(sim, dir / "sim");
  const std::string first = (dir / "first").string(), second = (dir / "second").string();
  const CliResult a = RunCli("run " + flight.run.input + " --telemetry " + flight.run.telemetry +
                             " --focal-px " + options::FormatNumber(flight.run.focal_px) +
                             " --max-frames 8 --threads 1 --ransac-max-distance-px 1.75 "
                             "--clustered-grid-rows 2 --match-max-ratio 0.7 --seed 3 -q "
                             "--no-report -o " +
                             first + " 2>&1");
  ASSERT_EQ(a.status, 0) << a.out;
  // The saved config.json as it is (its "resolved" block included); only the output folder
  // changes, by flag.
  const CliResult b =
      RunCli("run --config " + first + "/config.json --no-report -o " + second + " 2>&1");
  ASSERT_EQ(b.status, 0) << b.out;
  const std::vector<std::string> p1 = Positions(fs::path(first) / "frames.csv");
  EXPECT_EQ(p1.size(), 8u);
  EXPECT_EQ(Positions(fs::path(second) / "frames.csv"), p1);
  nlohmann::json c1 = nlohmann::json::parse(std::ifstream(fs::path(first) / "config.json"));
  nlohmann::json c2 = nlohmann::json::parse(std::ifstream(fs::path(second) / "config.json"));
  EXPECT_EQ(c1["ransac.max_distance_px"], 1.75);
  c1.erase("out");
  c2.erase("out");
  EXPECT_EQ(c1, c2);
  fs::remove_all(dir);
}

#endif  // AEROVO_CLI_PATH

}  // namespace
}  // namespace aerovo::run_cli_test
