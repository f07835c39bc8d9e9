// The run configuration's option schema: every option settable by JSON and by YAML with the same
// effect, its legacy alias too; shorthands; one message style for bad values; a run's saved
// config.json read back as the configuration that made it. (By flag: tests/e2e/run_cli_test.cc.)
#include "aerovo/pipeline/run_config.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/options_json.h"
#include "aerovo/pipeline/demo.h"
#include "aerovo/pipeline/experiment.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/pipeline/testing.h"

namespace aerovo::run_config_test {
namespace {

namespace fs = std::filesystem;
using testing::Sample;
using testing::Samples;

RunConfig Base() {
  RunConfig c;
  c.input = "flight.mp4";
  return c;
}

TEST(RunConfigSchema, EveryOptionByJsonAndYamlWithTheSameEffect) {
  const std::vector<Sample> samples = Samples();
  EXPECT_GT(samples.size(), 70u);  // run-level + every stage's options
  int aliases = 0;
  for (const Sample& s : samples) {
    SCOPED_TRACE(s.key);
    nlohmann::json expected = ToJson(Base());
    ASSERT_TRUE(expected.contains(s.key));
    expected[s.key] = s.value;
    const RunConfig by_json = RunConfigFromJson({{s.key, s.value}}, Base(), "t.json");
    EXPECT_EQ(ToJson(by_json), expected);
    // Options that go together (odometry/map_match.h Validate): one alone is refused.
    if (s.key.rfind("map_fix.start_", 0) == 0) {
      EXPECT_THROW(Validate(by_json), InvalidArgument);
    } else {
      EXPECT_NO_THROW(Validate(by_json));
    }
    const RunConfig by_yaml =
        ParseRunConfig(s.key + ": " + s.value.dump() + "\n", RunConfigFormat::kYaml, Base());
    EXPECT_EQ(ToJson(by_yaml), expected);
    if (!s.alias.empty()) {
      ++aliases;
      EXPECT_EQ(ToJson(RunConfigFromJson({{s.alias, s.value}}, Base())), expected) << s.alias;
      EXPECT_EQ(ToJson(ParseRunConfig(s.alias + ": " + s.value.dump() + "\n",
                                      RunConfigFormat::kYaml, Base())),
                expected)
          << s.alias;
    }
  }
  EXPECT_EQ(aliases, 11);  // mode model scale guided matcher refine min_inliers surf_threshold ...
}

TEST(RunConfigSchema, DefaultsAreTheStagesDefaults) {
  // The run's defaults are OdometryOptions' (which MakeOdometryOptions reproduced before the
  // schema): written config.json keys and values of a default run.
  const nlohmann::json j = ToJson(RunConfig{});
  EXPECT_EQ(j["correspondence.method"], "clustered");
  EXPECT_EQ(j["correspondence.model"], "affine");
  EXPECT_EQ(j["correspondence.guided_matching"], true);
  EXPECT_EQ(j["correspondence.min_inliers"], 12);
  EXPECT_EQ(j["surf.hessian_threshold"], 1000.0);
  EXPECT_EQ(j["surf.num_threads"], 0);
  EXPECT_EQ(j["match.num_threads"], 0);
  EXPECT_EQ(j["match.algorithm"], "exhaustive");
  EXPECT_EQ(j["match.max_ratio"], 0.6);
  EXPECT_EQ(j["ransac.seed"], 1);
  EXPECT_EQ(j["ransac.polish_iterations"], 0);
  EXPECT_EQ(j["clustered.refine"], true);
  EXPECT_EQ(j["odometry.scale_mode"], "metric");
  EXPECT_EQ(j["heading"], "auto");
  EXPECT_EQ(j["step"], 1);
  EXPECT_FALSE(j.contains("mode"));  // canonical keys only
  EXPECT_FALSE(j.contains("threads"));
  EXPECT_FALSE(j.contains("odometry.focal_px"));  // set by the run, not an option
}

TEST(RunConfigSchema, ShorthandsSetEveryKeyAndConflictsNameBoth) {
  // refine is the legacy name of clustered.refine, which turns every refinement off.
  const RunConfig r = RunConfigFromJson({{"refine", false}}, Base());
  EXPECT_FALSE(r.odometry.correspondence.clustered.refine);
  const RunConfig t = RunConfigFromJson({{"threads", 3}}, Base());
  EXPECT_EQ(t.odometry.surf.num_threads, 3);
  EXPECT_EQ(t.odometry.correspondence.match.num_threads, 3);
  EXPECT_EQ(RunConfigFromJson({{"threads", 3}, {"surf.num_threads", 3}}, Base())
                .odometry.correspondence.match.num_threads,
            3);
  try {
    RunConfigFromJson({{"threads", 3}, {"match.num_threads", 2}}, Base(), "c.yaml");
    ADD_FAILURE() << "conflict accepted";
  } catch (const InvalidArgument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("c.yaml"), std::string::npos) << m;
    EXPECT_NE(m.find("'match.num_threads' = 2 and 'threads' = 3 disagree"), std::string::npos) << m;
  }
  EXPECT_THROW(RunConfigFromJson({{"refine", true}, {"clustered.refine", false}}, Base()),
               InvalidArgument);
  // An alias and its key disagreeing is the same error.
  EXPECT_THROW(
      RunConfigFromJson({{"mode", "standard"}, {"correspondence.method", "clustered"}}, Base()),
      InvalidArgument);
  // The shorthand table's keys are all keys of the schema.
  const nlohmann::json keys = ToJson(RunConfig{});
  for (const RunShorthand& s : RunShorthands()) {
    for (const char* k : s.keys) EXPECT_TRUE(keys.contains(k)) << s.name << " -> " << k;
  }
}

// Sets one field to a value outside its range (the range's open or closed bound crossed, or
// inf for a field that must be finite) and checks Validate's message.
class OutOfRange : public options::GroupingVisitor<OutOfRange> {
 public:
  template <class T>
  void Field(T& v, const char* key, const char*, const options::Spec& spec) {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      if (!spec.HasRange()) return;
      const T saved = v;
      if (spec.has_min) {
        v = static_cast<T>(spec.min_open ? spec.min : spec.min - 1);
      } else if (spec.has_max) {
        v = static_cast<T>(spec.max_open ? spec.max : spec.max + 1);
      } else if constexpr (std::is_floating_point_v<T>) {
        v = std::numeric_limits<T>::infinity();
      }
      const std::string expected = "run configuration: " + Key(key) + " must be " +
                                   spec.Describe() + ", got " + options::FormatNumber(v);
      try {
        Validate(*config);
        ADD_FAILURE() << Key(key) << " = " << options::FormatNumber(v) << " accepted";
      } catch (const InvalidArgument& e) {
        EXPECT_EQ(std::string(e.what()), expected);
      }
      v = saved;
      ++checked;
    }
  }
  RunConfig* config = nullptr;
  int checked = 0;
};

TEST(RunConfigSchema, OutOfRangeValuesGiveTheOneMessageStyle) {
  RunConfig c = Base();
  OutOfRange v;
  v.config = &c;
  VisitFields(c, v);
  EXPECT_GE(v.checked, 45);
  // Rules between fields, same style.
  RunConfig e = Base();
  e.start_s = 10;
  e.end_s = 5;
  EXPECT_THROW(Validate(e), InvalidArgument);
  RunConfig m = Base();
  m.odometry.correspondence.model = MotionModel::kHomography;
  m.odometry.correspondence.min_inliers = 3;
  try {
    Validate(m);
    ADD_FAILURE();
  } catch (const InvalidArgument& ex) {
    EXPECT_NE(std::string(ex.what()).find("correspondence.min_inliers must be at least"),
              std::string::npos)
        << ex.what();
  }
  EXPECT_THROW(Validate(RunConfig{}), InvalidArgument);  // no input
}

// Collects the keys of the integer options without an upper bound, and checks that one past the
// bound of those with one is refused.
class IntegerBounds : public options::GroupingVisitor<IntegerBounds> {
 public:
  template <class T>
  void Field(T& v, const char* key, const char*, const options::Spec& spec) {
    if constexpr (std::is_same_v<T, int>) {
      if (!spec.has_max) {
        unbounded.push_back(Key(key));
        return;
      }
      const T saved = v;
      v = static_cast<T>(spec.max) + (spec.max_open ? 0 : 1);
      EXPECT_THROW(Validate(*config), InvalidArgument) << Key(key) << " = " << v;
      v = saved;
      ++checked;
    }
  }
  RunConfig* config = nullptr;
  std::vector<std::string> unbounded;
  int checked = 0;
};

// Every integer option is a count, a size or an index, used to size buffers (a grid of
// grid_rows x grid_cols cells, keyframes kept), start threads or bound loops: each has an upper
// bound. Before, `--surf-num-threads 100000` crashed aerovo run (segmentation fault, exit 139),
// `--threads 2147483647` and `--clustered-grid-rows 100000 --clustered-grid-cols 100000` ended
// in `std::bad_alloc`; through a config file too, where the error now names the file.
TEST(RunConfigSchema, EveryIntegerOptionHasAnUpperBound) {
  RunConfig c = Base();
  IntegerBounds v;
  v.config = &c;
  VisitFields(c, v);
  EXPECT_TRUE(v.unbounded.empty()) << "integer options without an upper bound: "
                                   << fmt::format("{}", fmt::join(v.unbounded, ", "));
  EXPECT_GE(v.checked, 40);
  const auto message = [](const std::function<void(RunConfig&)>& set) {
    RunConfig r = Base();
    set(r);
    try {
      Validate(r);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(message([](RunConfig& r) { r.odometry.surf.num_threads = 100000; }),
            "run configuration: surf.num_threads must be in [0, 256], got 100000");
  EXPECT_EQ(message([](RunConfig& r) { r.odometry.correspondence.clustered.grid_rows = 100000; }),
            "run configuration: clustered.grid_rows must be in [1, 64], got 100000");
  EXPECT_EQ(message([](RunConfig& r) { r.odometry.surf.num_threads = options::kMaxOptionThreads; }),
            "(accepted)");
  // A config file's value out of its range names the file.
  const fs::path dir = fs::temp_directory_path() /
                       ("aerovo_int_bounds_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const char* name : {"c.json", "c.yaml"}) {
    const fs::path f = dir / name;
    std::ofstream(f) << (fs::path(name).extension() == ".json" ? "{\"surf.num_threads\": 100000}"
                                                                : "surf.num_threads: 100000\n");
    try {
      LoadRunConfig(f, Base());
      ADD_FAILURE() << name << " accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(std::string(e.what()), "config file '" + f.string() +
                                           "': surf.num_threads must be in [0, 256], got 100000");
    }
  }
  fs::remove_all(dir);
}

// A file that is not a configuration by its size, or a device that never ends: refused after
// 16 MiB. Before, `--config /dev/zero` grew to 876 MB in 4 s and went on until out of memory.
TEST(RunConfigFile, AFileLargerThanAnyConfigurationIsRefusedUnread) {
  const fs::path dir =
      fs::temp_directory_path() / ("aerovo_config_size_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path big = dir / "big.json";
  {
    std::ofstream out(big, std::ios::binary);
    const std::string spaces(1 << 20, ' ');
    for (int k = 0; k < 16; ++k) out << spaces;
    out << "{}";  // 16 MiB + 2 bytes
  }
  for (const fs::path& f : {big, fs::path("/dev/zero")}) {
    if (!fs::exists(f)) continue;
    try {
      LoadRunConfig(f, Base());
      ADD_FAILURE() << f << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()), "config file '" + f.string() +
                                           "': more than 16 MiB, not a configuration file "
                                           "(aerovo's are a few kilobytes)");
    }
  }
  try {
    LoadRunConfig(dir, Base());
    ADD_FAILURE() << "a folder accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "config file '" + dir.string() + "': a folder, not a configuration file");
  }
  // Exactly 16 MiB of white space around "{}" is read as the empty configuration.
  fs::resize_file(big, (std::uintmax_t{16} << 20) - 2);
  std::ofstream(big, std::ios::binary | std::ios::app) << "{}";
  EXPECT_EQ(fs::file_size(big), std::uintmax_t{16} << 20);
  EXPECT_NO_THROW(LoadRunConfig(big, Base()));
  fs::remove_all(dir);
}

TEST(RunConfigSchema, WrongTypesAndUnknownKeysNameTheKey) {
  const auto message = [](const nlohmann::json& j) {
    try {
      RunConfigFromJson(j, Base(), "c.json");
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(message({{"ransac.max_distance_px", "far"}}),
            "c.json: key 'ransac.max_distance_px' must be a number, got string \"far\"");
  EXPECT_EQ(message({{"mode", "fast"}}),
            "c.json: key 'mode' must be one of standard | clustered, got string \"fast\"");
  EXPECT_EQ(message({{"correspondence.guided_matching", 1}}),
            "c.json: key 'correspondence.guided_matching' must be a boolean (true or false), got "
            "number 1");
  EXPECT_NE(message({{"ransac.max_distanse_px", 2}}).find("unknown key 'ransac.max_distanse_px'"),
            std::string::npos);
  EXPECT_NE(message({{"resolved", 3}}).find("'resolved'"), std::string::npos);
  // "resolved" (a run's config.json) is accepted and ignored; nested objects read as dotted keys.
  const RunConfig n = RunConfigFromJson(
      {{"resolved", {{"focal_px", 1000.0}}}, {"ransac", {{"max_distance_px", 2.5}}}}, Base());
  EXPECT_EQ(n.odometry.correspondence.ransac.max_distance_px, 2.5);
  EXPECT_EQ(n.focal_px, 0.0);
}

TEST(RunConfigSchema, OptionsMarkdownListsEveryKey) {
  const std::string md = RunOptionsMarkdown();
  const nlohmann::json keys = ToJson(RunConfig{});
  for (const auto& [key, value] : keys.items()) {
    EXPECT_NE(md.find("| `" + key + "`"), std::string::npos) << key;
  }
  EXPECT_NE(md.find("`--ransac-max-distance-px`"), std::string::npos);
  EXPECT_NE(md.find("| `threads` | `--threads` |"), std::string::npos);
}

// A run's saved config.json is the configuration that made it: LoadRunConfig of it gives it back
// (the "resolved" block the run adds is ignored).
TEST(RunConfigSchema, SavedConfigJsonReadsBackAsTheRunsConfiguration) {
  const fs::path dir =
      fs::temp_directory_path() / ("aerovo_run_config_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  ExperimentSimulation sim = DemoSimulation(true);
  sim.sim.flight.legs = 1;
  sim.sim.flight.leg_length_m = 40.0;
  const SimulatedFlight flight = SimulateExperimentFlight(sim, dir / "sim");
  RunConfig c = flight.run;
  c.out = (dir / "run").string();
  c.quiet = true;
  c.max_frames = 6;
  c.odometry.correspondence.ransac.max_distance_px = 1.75;  // options no flag had before
  c.odometry.correspondence.clustered.grid_rows = 2;
  c.odometry.correspondence.match.max_ratio = 0.7f;
  c.odometry.surf.num_threads = 1;
  c.odometry.correspondence.match.num_threads = 1;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 6);
  const nlohmann::json saved = nlohmann::json::parse(std::ifstream(dir / "run" / "config.json"));
  EXPECT_TRUE(saved["resolved"].is_object());
  const RunConfig back = LoadRunConfig(dir / "run" / "config.json", RunConfig{});
  EXPECT_EQ(ToJson(back), ToJson(c));
  fs::remove_all(dir);
}

TEST(RunConfigSchema, MavlinkOptions) {
  RunConfig c;
  c.input = "0";
  c.mavlink = "udpin:0.0.0.0:14540";
  EXPECT_NO_THROW(Validate(c));
  const RunConfig j = RunConfigFromJson({{"mavlink", "serial:/dev/ttyAMA0:921600"},
                                         {"mavlink_message", "vision_position_delta"},
                                         {"mavlink_sysid", 7},
                                         {"mavlink_time", "unix"}},
                                        c);
  EXPECT_EQ(j.mavlink_message, mavlink::VisionMessageKind::kVisionPositionDelta);
  EXPECT_EQ(j.mavlink_time, mavlink::TimestampClock::kUnix);
  EXPECT_EQ(j.mavlink_sysid, 7);
  c.mavlink = "tcp:127.0.0.1:5760";
  try {
    Validate(c);
    FAIL() << "accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("--mavlink 'tcp:127.0.0.1:5760': unknown link"),
              std::string::npos)
        << e.what();
  }
  c.mavlink = "udp:127.0.0.1:14550";
  c.mavlink_sysid = 0;
  EXPECT_THROW(Validate(c), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::run_config_test

namespace aerovo::run_config_test {
namespace {

// YAML anchors (&a), aliases (*a) and merge keys (<<) are resolved, not read as unknown keys.
TEST(RunConfigYaml, AnchorsAliasesAndMergeKeys) {
  const RunConfig a = ParseRunConfig(
      "step: &two 2\n"
      "max_frames: *two\n"
      "altitude_m: &h 57.5\n"
      "focal_px: *h\n",
      RunConfigFormat::kYaml, Base());
  EXPECT_EQ(a.step, 2);
  EXPECT_EQ(a.max_frames, 2);
  EXPECT_DOUBLE_EQ(a.altitude_m, 57.5);
  EXPECT_DOUBLE_EQ(a.focal_px, 57.5);
  // A template mapping merged in; the mapping's own keys win over merged ones.
  const RunConfig m = ParseRunConfig(
      ".common: &common {step: 3, altitude_m: 40, max_frames: 9}\n"
      "<<: *common\n"
      "max_frames: 5\n",
      RunConfigFormat::kYaml, Base());
  EXPECT_EQ(m.step, 3);
  EXPECT_DOUBLE_EQ(m.altitude_m, 40.0);
  EXPECT_EQ(m.max_frames, 5);
  // Several merged mappings: the first wins.
  const RunConfig l =
      ParseRunConfig(".a: &a {step: 4}\n.b: &b {step: 6, max_frames: 7}\n<<: [*a, *b]\n",
                     RunConfigFormat::kYaml, Base());
  EXPECT_EQ(l.step, 4);
  EXPECT_EQ(l.max_frames, 7);
  // Errors name the line and the problem.
  const auto message = [](const std::string& yaml) {
    try {
      ParseRunConfig(yaml, RunConfigFormat::kYaml, Base(), "c.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string unknown = message("step: 2\nmax_frames: *nope\n");
  EXPECT_NE(unknown.find("c.yaml: line 2"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("*nope"), std::string::npos) << unknown;
  const std::string nested = message("step: 2\nsurf: {hessian_threshold: 3}\n");
  EXPECT_NE(nested.find("line 2"), std::string::npos) << nested;
  EXPECT_NE(nested.find("nested mappings are not allowed"), std::string::npos) << nested;
  const std::string twice = message("step: 2\nstep: 3\n");
  EXPECT_NE(twice.find("'step' is given twice"), std::string::npos) << twice;
  const std::string merge_scalar = message("<<: 3\n");
  EXPECT_NE(merge_scalar.find("merge key"), std::string::npos) << merge_scalar;
}

// The message of the error a config text raises, or "no error".
std::string ConfigError(const std::string& text, RunConfigFormat format, const std::string& where) {
  try {
    ParseRunConfig(text, format, Base(), where);
  } catch (const InputError& e) {
    return e.what();
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "no error";
}

// Hostile YAML ends in an error naming the line, never a crash or a run away: 20000 nested flow
// sequences (the reader recursed per level and overflowed the stack, exit 139), and 9 levels of
// anchors each aliasing the one before 10 times (10^9 values: 4.5 GB after 30 s before).
TEST(RunConfigYaml, DeepNestingAndAliasBombsAreErrorsNamingTheLine) {
  const std::string deep = "step: 2\na: " + std::string(20000, '[') + std::string(20000, ']');
  const std::string d = ConfigError(deep, RunConfigFormat::kYaml, "deep.yaml");
  EXPECT_NE(d.find("deep.yaml: line 2: nested deeper than 64 levels"), std::string::npos) << d;
  std::string bomb = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i <= 8; ++i) {
    bomb += fmt::format("a{}: &a{} [", i, i);
    for (int k = 0; k < 10; ++k) bomb += fmt::format("{}*a{}", k > 0 ? ", " : "", i - 1);
    bomb += "]\n";
  }
  const auto start = std::chrono::steady_clock::now();
  const std::string b = ConfigError(bomb, RunConfigFormat::kYaml, "bomb.yaml");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  // a0..a3 hold 11, 111, 1111, 11111 values; a4's aliases pass 100000 (line 5).
  EXPECT_NE(b.find("bomb.yaml: line 5: the document holds more than 100000 values"),
            std::string::npos)
      << b;
  // Aliases within the budget still resolve (a list option given by an alias).
  EXPECT_EQ(ConfigError("step: &s 3\nmax_frames: *s\n", RunConfigFormat::kYaml, "ok.yaml"),
            "no error");
}

// A YAML number is a plain decimal (ParseDecimal, core/text.h): strtod also read "0x1p6" as 64,
// and followed the C locale's decimal point.
TEST(RunConfigYaml, NumbersArePlainDecimals) {
  EXPECT_EQ(ConfigError("altitude_m: 64.5\n", RunConfigFormat::kYaml, "ok.yaml"), "no error");
  EXPECT_EQ(ConfigError("altitude_m: 6.45e1\n", RunConfigFormat::kYaml, "ok.yaml"), "no error");
  for (const char* bad : {"0x1p6", "0x40"}) {
    const std::string m =
        ConfigError(std::string("altitude_m: ") + bad + "\n", RunConfigFormat::kYaml, "c.yaml");
    EXPECT_NE(m.find("c.yaml"), std::string::npos) << bad << ": " << m;
    EXPECT_NE(m.find("altitude_m"), std::string::npos) << bad << ": " << m;
  }
}

// A JSON key given twice is an error (nlohmann-json kept the last one silently), as in YAML; a
// UTF-16 file is named as such instead of a syntax error at its first byte.
TEST(RunConfigJson, DuplicateKeysAndUtf16AreErrors) {
  const std::string twice =
      ConfigError("{\"altitude_m\": 50,\n \"altitude_m\": 60}", RunConfigFormat::kJson, "c.json");
  EXPECT_EQ(twice, "c.json: key 'altitude_m' is given twice in one object");
  // One key in two objects is no duplicate (resolved is an object of its own).
  EXPECT_EQ(
      ConfigError("{\"step\": 2, \"resolved\": {\"step\": 3}}", RunConfigFormat::kJson, "r.json"),
      "no error");
  const std::string utf16("\xFF\xFE{\0}\0", 6);
  const std::string u = ConfigError(utf16, RunConfigFormat::kJson, "u.json");
  EXPECT_EQ(u.rfind("u.json: the file is UTF-16 text", 0), 0u) << u;
}

}  // namespace
}  // namespace aerovo::run_config_test
