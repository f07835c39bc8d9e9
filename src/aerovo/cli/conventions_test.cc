// The command-line conventions: the suggestion, and through the built binary the exit codes,
// `aerovo` alone, `aerovo help CMD`, the unknown command and option messages and the bash
// completion generated at build time.
#include "aerovo/cli/conventions.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "aerovo/core/testing.h"

namespace aerovo::cli::conventions_test {
namespace {

// Every error type maps to its exit code whatever the type's place in core/error.h, through
// a reference to its base as main catches it.
TEST(Conventions, ExitCodeForEachErrorType) {
  const auto code = [](const std::exception& e) { return ExitCodeForError(e); };
  EXPECT_EQ(code(UsageError("--k: 2 is not in (0, 1]")), kExitUsage);
  EXPECT_EQ(code(InputError("frames.csv:3: bad number")), kExitFailure);
  EXPECT_EQ(code(OutputError("cannot write 'vo.tum': No space left on device")), kExitFailure);
  EXPECT_EQ(code(Cancelled("SURF detection")), kExitFailure);
  EXPECT_EQ(code(InternalError("broken invariant")), kExitFailure);
  EXPECT_EQ(code(InvalidArgument("give an input flight or --simulate")), kExitFailure);
  EXPECT_EQ(code(std::runtime_error("other")), kExitFailure);
  EXPECT_EQ(kExitUsage, 2);
  EXPECT_EQ(kExitFailure, 1);
}

// OutputError is a sibling of InputError: a handler of one does not catch the other.
TEST(Conventions, OutputErrorIsNotAnInputError) {
  EXPECT_THROW(
      {
        try {
          throw OutputError("disk full");
        } catch (const InputError&) {
          FAIL() << "an OutputError caught as an InputError";
        }
      },
      OutputError);
  EXPECT_THROW(throw OutputError("x"), Error);
  EXPECT_THROW(throw InputError("x"), Error);
  EXPECT_THROW(throw Cancelled("x"), Error);
  EXPECT_THROW(throw InternalError("x"), Error);
}

// A library check's message with the flags it is about first; the message alone when it names
// none; every flag whose field it names.
TEST(Conventions, NameFlagsPutsTheFlagsBeforeTheMessage) {
  const std::vector<std::pair<const char*, const char*>> fields = {
      {"leg_length_m", "--length-m"}, {"image size", "--width, --height"}, {"fps", "--fps"}};
  EXPECT_EQ(NameFlags("FlightPlan: leg_length_m = -5 must be in (0, 1e6)", fields),
            "--length-m: FlightPlan: leg_length_m = -5 must be in (0, 1e6)");
  EXPECT_EQ(NameFlags("image size 3x720 at 100 fps", fields),
            "--width, --height, --fps: image size 3x720 at 100 fps");
  EXPECT_EQ(NameFlags("something else", fields), "something else");
}

TEST(Conventions, EditDistance) {
  EXPECT_EQ(EditDistance("", ""), 0);
  EXPECT_EQ(EditDistance("run", "run"), 0);
  EXPECT_EQ(EditDistance("rnu", "run"), 2);  // a transposition is two edits
  EXPECT_EQ(EditDistance("simulte", "simulate"), 1);
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3);
  EXPECT_EQ(EditDistance("", "abc"), 3);
}

TEST(Conventions, NearestNameSuggestsOnlyNearNames) {
  const std::vector<std::string> commands = {"run",    "simulate", "report",  "features",
                                             "correspondence", "demo", "experiment", "telemetry"};
  EXPECT_EQ(NearestName("rnu", commands), "run");
  EXPECT_EQ(NearestName("simualte", commands), "simulate");
  EXPECT_EQ(NearestName("reprot", commands), "report");
  EXPECT_EQ(NearestName("corespondance", commands), "correspondence");
  EXPECT_EQ(NearestName("exp", commands), "experiment");  // a prefix
  EXPECT_EQ(NearestName("xyzzy", commands), "");
  EXPECT_EQ(NearestName("", commands), "");
  const std::vector<std::string> flags = {"--surf-threshold", "--surf-num-threads", "--out", "-o"};
  EXPECT_EQ(NearestName("--surf-treshold", flags), "--surf-threshold");
  EXPECT_EQ(NearestName("--outt", flags), "--out");
  EXPECT_EQ(NearestName("--banana", flags), "");
}

TEST(Conventions, BooleanWords) {
  for (const char* w : {"true", "FALSE", "1", "0", "On", "off", "yes", "NO"}) {
    EXPECT_TRUE(IsBooleanWord(w)) << w;
  }
  for (const char* w : {"", "2", "maybe", "truee", "-1", "flight.mp4"}) {
    EXPECT_FALSE(IsBooleanWord(w)) << w;
  }
}

// `--X V` with a boolean word V becomes `--X=V` for the flags of any command; options that take
// a value, non-boolean words and everything after "--" are left alone.
TEST(Conventions, NormalizeBooleanFlagsKeepsOldCommandLines) {
  CLI::App app;
  CLI::App* run = app.add_subcommand("run");
  bool b = false;
  int n = 0;
  std::string in;
  run->add_flag("--guided,!--no-guided", b);
  run->add_option("--count", n);
  run->add_option("input", in);
  using V = std::vector<std::string>;
  EXPECT_EQ(NormalizeBooleanFlags(app, V{"run", "--guided", "0", "a.mp4"}),
            (V{"run", "--guided=0", "a.mp4"}));
  EXPECT_EQ(NormalizeBooleanFlags(app, V{"run", "--no-guided", "TRUE"}),
            (V{"run", "--no-guided=TRUE"}));
  EXPECT_EQ(NormalizeBooleanFlags(app, V{"run", "--guided", "a.mp4", "--count", "1"}),
            (V{"run", "--guided", "a.mp4", "--count", "1"}));
  EXPECT_EQ(NormalizeBooleanFlags(app, V{"run", "--", "--guided", "1"}),
            (V{"run", "--", "--guided", "1"}));
  EXPECT_EQ(NormalizeBooleanFlags(app, V{"run", "--guided"}), (V{"run", "--guided"}));
}

#ifdef AEROVO_CLI_PATH

struct Cli {
  int status = -1;
  std::string out;  // stdout + stderr
};

// `aerovo ARGS` with stdout and stderr together (or stdout only with `stdout_only`).
Cli Aerovo(const std::string& args, bool stdout_only = false) {
  const testing::CommandOutput c = testing::RunCommand(
      std::string(AEROVO_CLI_PATH) + " " + args + (stdout_only ? " 2>/dev/null" : " 2>&1"));
  return {c.ExitCode(), c.out};
}

bool Has(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

// The subcommand names of a --help's "Subcommands:" section.
std::set<std::string> HelpSubcommands(const std::string& help) {
  std::set<std::string> names;
  std::istringstream in(help.substr(help.find("Subcommands:")));
  std::string line;
  std::getline(in, line);
  const std::regex row("^  ([a-z]+) ");
  while (std::getline(in, line) && !line.empty()) {
    std::smatch m;
    if (std::regex_search(line, m, row)) names.insert(m[1]);
  }
  return names;
}

TEST(CliConventions, AloneItPrintsTheUsageWithTheCommandsAndExitsZero) {
  const Cli r = Aerovo("", /*stdout_only=*/true);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(Has(r.out, "Usage: aerovo")) << r.out;
  const std::set<std::string> subs = HelpSubcommands(r.out);
  for (const char* c : {"run", "simulate", "report", "features", "correspondence", "experiment",
                        "demo", "telemetry", "help", "completion"}) {
    EXPECT_EQ(subs.count(c), 1u) << c << "\n" << r.out;
  }
  EXPECT_TRUE(Has(r.out, "Exit codes:")) << r.out;
}

TEST(CliConventions, UsageErrorsExitTwoWithTheNearestName) {
  Cli r = Aerovo("rnu");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "unknown command 'rnu'; did you mean 'run'?")) << r.out;
  r = Aerovo("experiment rnasac");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "aerovo experiment: unknown command 'rnasac'; did you mean 'ransac'?"))
      << r.out;
  r = Aerovo("help rnu");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "did you mean 'run'?")) << r.out;
  r = Aerovo("run flight.mp4 --surf-treshold 500 --print-config");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "unknown option '--surf-treshold'; did you mean '--surf-threshold'?"))
      << r.out;
  // CLI11's own errors (104-109 before): a bad value, a missing argument, an enum not a choice.
  for (const char* args : {"run flight.mp4 --step abc --print-config", "report",
                           "run flight.mp4 --correspondence-sampler fast --print-config",
                           "simulate --height-m"}) {
    r = Aerovo(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
    EXPECT_TRUE(Has(r.out, "--help")) << args << "\n" << r.out;
  }
  // An option out of its range, found after parsing: also a usage error, naming the key.
  r = Aerovo("run flight.mp4 --ransac-max-distance-px -1 --print-config");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "ransac.max_distance_px must be finite and > 0, got -1")) << r.out;
  // Bad input data is not a usage error.
  r = Aerovo("run /nonexistent/flight.mp4 --hfov-deg 70 -o /tmp/aerovo_conventions_test_run");
  EXPECT_EQ(r.status, 1) << r.out;
}

// Hostile numbers on the command line: an empty value (an unset shell variable) was read as 0
// by CLI11 (`--altitude ""`: a height "from telemetry"; `simulate --noise ""`), a negative one
// wrapped around in an unsigned option (`--ransac-seed -1`), 100000 SURF threads crashed the run
// (exit 139), and simulate's checks exited 1 after creating the output folder, naming the
// struct's field only. Each is now a usage error naming the option, before any output.
TEST(CliConventions, HostileNumbersAreUsageErrorsNamingTheOption) {
  const std::string dir = "/tmp/aerovo_conventions_numbers_" + std::to_string(::getpid());
  const struct {
    const char* args;
    const char* message;
  } kCases[] = {
      {"run flight.mp4 --altitude '' --print-config", "--altitude: an empty value is not a number"},
      {"run flight.mp4 --step ' ' --print-config", "--step: an empty value is not a number"},
      {"run flight.mp4 --ransac-seed -1 --print-config",
       "--ransac-seed: '-1': a negative value for a count or seed (0 or more)"},
      {"run flight.mp4 --surf-num-threads 100000 --print-config",
       "surf.num_threads must be in [0, 256], got 100000"},
      {"run flight.mp4 --clustered-grid-rows 100000 --print-config",
       "clustered.grid_rows must be in [1, 64], got 100000"},
      {"simulate --noise '' -o DIR", "--noise: an empty value is not a number"},
      {"simulate --seed -1 -o DIR", "--seed: '-1': a negative value"},
      {"simulate --height-m 0 -o DIR",
       "--height-m: FlightPlan: height_m = 0 must be in [1, 10000]"},
      {"simulate --pattern turns --legs 0 -o DIR", "--legs: FlightPlan: legs = 0 must be in"},
      {"simulate --width 0 -o DIR", "--width, --height: CameraModel: image size 0x720 px"},
      {"simulate --gps-rate-hz nan -o DIR", "--gps-rate-hz: GpsOptions: rate_hz = nan"},
      {"simulate --render hot -o DIR", "--render must be 'visible' or 'thermal', not 'hot'"},
      // Found only after the folder was made before: a terrain beyond 32768 px a side (given, or
      // fitted to a long flight) and a flight of more frames than the simulator makes.
      {"simulate --terrain-size-px 200000 --terrain-mpp 0.1 -o DIR",
       "--terrain-size-px, --terrain-mpp: the terrain for this flight cannot be made: "
       "TerrainOptions: image size 200000x200000 px"},
      {"simulate --length-m 100000 -o DIR", "the terrain for this flight cannot be made"},
      {"simulate --length-m 900000 -o DIR", "frames (limit 2000000)"},
      {"report --mosaic-size '' DIR", "--mosaic-size: an empty value is not a number"},
      {"report --mosaic-size 0 DIR",
       "--mosaic-size 0, --mosaic-frames 60: mosaic: max_size_px must be within 100..20000"},
      {"correspondence a.png b.png --last-shift nan 0", "--last-shift nan 0: both must be finite"},
      // experiment: its checks and the simulation's before the folder (an empty folder with a
      // lock file was left behind).
      {"experiment illumination --simulate --k 0 -o DIR", "illumination: k must be in (0, 1]"},
      {"experiment ransac --simulate --sim-fps 0 -o DIR",
       "--sim-fps: SimulationOptions: fps = 0 must be in (0, 1000]"},
      {"experiment ransac --simulate --sim-length-m -5 -o DIR",
       "--sim-length-m: FlightPlan: leg_length_m = -5 must be in (0, 1e6)"},
      {"experiment ransac --simulate --sim-width 3 -o DIR",
       "--sim-width, --sim-height: CameraModel"},
      {"experiment ransac --simulate --ortho x.jpg -o DIR", "--mpp: GroundOptions"},
      {"experiment ransac --simulate --sim-length-m 100000 -o DIR",
       "--sim-length-m, --sim-legs, --sim-spacing-m (the terrain fitted to the flight): "
       "TerrainOptions: image size"},
      {"correspondence a.png b.png --final-points -5",
       "--final-points: clustered.refine_final_max_points must be in [0, 10000000], got -5"},
      {"correspondence a.png b.png --final-radius -1", "--final-radius: clustered"},
      {"experiment ransac -o DIR", "give an input flight"},
      {"experiment illumination --simulate --k '' -o DIR", "--k '': an empty item"},
      {"experiment illumination --simulate --k 1,,0.5 -o DIR", "--k '1,,0.5': an empty item"},
      // strtod took these as numbers (k = NaN passed the range check).
      {"experiment illumination --simulate --k 1,nan -o DIR", "--k: 'nan' is not a number"},
      {"experiment illumination --simulate --k 0x1 -o DIR", "--k: '0x1' is not a number"},
  };
  for (const auto& c : kCases) {
    std::string args = c.args;
    if (args.find("DIR") != std::string::npos) args.replace(args.find("DIR"), 3, dir);
    const Cli r = Aerovo(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
    EXPECT_TRUE(Has(r.out, c.message)) << args << "\n" << r.out;
    EXPECT_FALSE(std::filesystem::exists(dir)) << args << ": the output folder was created";
    std::filesystem::remove_all(dir);
  }
}

// `aerovo report` of a run whose summary.json holds values of the wrong JSON type (strings,
// null): before, `aerovo: error: [json.exception.type_error.302] type must be boolean, but is
// string`, naming no file; now an input error naming the files, exit 1, and without the summary
// the report is written from frames.csv.
TEST(CliConventions, ReportOfASummaryWithWrongTypesNamesTheFile) {
  const std::string dir = "/tmp/aerovo_conventions_report_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  ASSERT_EQ(Aerovo("simulate --pattern line --length-m 20 --fps 2 --width 320 --height 240 -q -o " +
                   dir + "/sim").status, 0);
  ASSERT_EQ(Aerovo("run " + dir + "/sim/video.mp4 --telemetry " + dir +
                   "/sim/telemetry.srt -q -o " + dir + "/run").status, 0);
  const std::string summary = dir + "/run/summary.json";
  for (const char* value : {"\"yes\"", "null"}) {
    std::ifstream in(summary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    const std::regex interrupted("\"interrupted\": (false|true|\"yes\"|null)");
    ASSERT_TRUE(std::regex_search(text, interrupted)) << text;
    std::ofstream(summary) << std::regex_replace(
        text, interrupted, std::string("\"interrupted\": ") + value);
    const Cli r = Aerovo("report --no-png --no-mosaic -q " + dir + "/run");
    EXPECT_EQ(r.status, 1) << value << "\n" << r.out;
    EXPECT_TRUE(Has(r.out, "aerovo: error: '" + summary + "' or '" + dir +
                               "/run/config.json' holds a value of another type than aerovo run "
                               "writes ([json.exception.type_error.302] type must be boolean"))
        << value << "\n" << r.out;
  }
  std::filesystem::remove(summary);
  const Cli r = Aerovo("report --no-png --no-mosaic -q " + dir + "/run");
  EXPECT_EQ(r.status, 0) << r.out;
  std::filesystem::remove_all(dir);
}

TEST(CliConventions, HelpCmdIsCmdHelpAndEveryHelpListsTheExitCodes) {
  const Cli help = Aerovo("help run", true), direct = Aerovo("run --help", true);
  EXPECT_EQ(help.status, 0);
  EXPECT_EQ(help.out, direct.out);
  EXPECT_TRUE(Has(help.out, "Usage: aerovo run")) << help.out;
  for (const char* cmd : {"run", "simulate", "experiment ransac", "features detect"}) {
    const Cli r = Aerovo(std::string("help ") + cmd, true);
    EXPECT_EQ(r.status, 0) << cmd;
    EXPECT_TRUE(Has(r.out, "Exit codes:")) << cmd << "\n" << r.out;
    EXPECT_TRUE(Has(r.out, "  2    usage error")) << cmd << "\n" << r.out;
    // Every code a run can end with (cli/run_cli.h StopSignals::ExitCode: 128 + the signal).
    for (const char* code :
         {"130  stopped by SIGINT", "143 by SIGTERM", "129 by SIGHUP", "141 by SIGPIPE"}) {
      EXPECT_TRUE(Has(r.out, code)) << cmd << ": " << code << "\n" << r.out;
    }
  }
  EXPECT_EQ(Aerovo("help", true).out, Aerovo("--help", true).out);
}

TEST(CliConventions, OneNameForTheSameOptionInEveryCommand) {
  // -o/--out everywhere a command writes a folder.
  for (const char* cmd : {"run", "simulate", "demo", "experiment ransac"}) {
    const Cli r = Aerovo(std::string("help ") + cmd, true);
    EXPECT_TRUE(std::regex_search(r.out, std::regex("-o,--out"))) << cmd << "\n" << r.out;
  }
  // The SURF threshold: --surf-threshold in run, features detect and correspondence.
  for (const char* cmd : {"run", "features detect", "correspondence"}) {
    const Cli r = Aerovo(std::string("help ") + cmd, true);
    EXPECT_TRUE(Has(r.out, "--surf-threshold")) << cmd << "\n" << r.out;
  }
  // The old spelling still works (hidden).
  const Cli old = Aerovo("features detect --threshold 500 /nonexistent.png");
  EXPECT_EQ(old.status, 1) << old.out;  // parsed; then the missing image
}

// `aerovo run` on a small simulated flight, stdout and stderr to files (a log, CI): the
// configuration is in config.json only (printed with --verbose), progress is plain lines on
// stderr, and the summary opens with the one-line answer, every line within 80 columns.
TEST(CliConventions, RunPrintsTheAnswerFirstWithin80ColumnsAndTheConfigOnlyWhenVerbose) {
  const std::string dir = "/tmp/aerovo_conventions_run_" + std::to_string(::getpid());
  ASSERT_EQ(Aerovo("simulate --pattern line --length-m 30 --speed-mps 10 --fps 2 --width 640 "
                "--height 480 -q -o " + dir + "/sim").status, 0);
  const auto read = [](const std::string& path) {
    std::ifstream f(path);
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  };
  for (const bool verbose : {false, true}) {
    const std::string out = dir + "/run" + (verbose ? "-v" : "");
    const std::string cmd = std::string(AEROVO_CLI_PATH) + " run " + dir +
                            "/sim/video.mp4 --no-report -o " + out + (verbose ? " --verbose" : "") +
                            " > " + out + ".stdout 2> " + out + ".stderr";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << read(out + ".stdout") << read(out + ".stderr");
    const std::string log = read(out + ".stdout"), err = read(out + ".stderr");
    EXPECT_EQ(Has(log, "effective configuration"), verbose) << log;
    EXPECT_TRUE(Has(log, "configuration: " + out + "/config.json") || verbose) << log;
    EXPECT_EQ(err.find('\r'), std::string::npos) << err;
    EXPECT_TRUE(std::regex_search(err, std::regex("\\d+/\\d+ frames"))) << err;
    if (verbose) continue;
    // The answer, then a blank line, then the details; no line over 80 columns.
    const std::regex headline(
        "\nTracked (\\d+) of (\\d+) frames over (\\d+) m; the track ends [0-9.]+ m "
        "\\([0-9.]+ %\\) from GPS\\.\n\n");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(log, m, headline)) << log;
    EXPECT_EQ(m[1], m[2]) << "every frame of a textured nadir flight tracked";
    // GPS's path length of the 30 m line: its 1.5 m noise lengthens it.
    EXPECT_GE(std::stod(m[3]), 28.0);
    EXPECT_LE(std::stod(m[3]), 45.0);
    const std::string summary = log.substr(m.position(0));
    std::istringstream lines(summary);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("  " + out, 0) == 0) continue;  // a path may be long
      EXPECT_LE(line.size(), 80u) << line;
    }
    EXPECT_TRUE(Has(summary, "Outputs in " + out + "/:")) << summary;
    EXPECT_TRUE(Has(summary, "frames.csv")) << summary;
    // The folder's lock stays (outputs/run_folder.h) but is not an output.
    EXPECT_TRUE(std::filesystem::exists(out + "/.aerovo.lock")) << out;
    EXPECT_FALSE(Has(summary, ".aerovo.lock")) << summary;
  }
  std::system(("rm -rf " + dir).c_str());
}

// The completion generated at build time (share/bash-completion/completions/aerovo) offers every
// subcommand and every flag that `aerovo run --help` lists.
TEST(CliConventions, BashCompletionListsEverySubcommandAndRunFlag) {
  std::ifstream f(AEROVO_COMPLETION_FILE);
  ASSERT_TRUE(f.good()) << AEROVO_COMPLETION_FILE;
  const std::string script((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(Has(script, "complete -o filenames -F _aerovo_complete aerovo")) << script;
  const Cli now = Aerovo("completion bash", true);
  EXPECT_EQ(now.out, script);  // the installed file is the program's current tables
  // The root's line: every subcommand of `aerovo --help`.
  const std::smatch root = [&] {
    std::smatch m;
    std::regex_search(script, m, std::regex("'aerovo'\\) subs='([^']*)'"));
    return m;
  }();
  ASSERT_FALSE(root.empty()) << script;
  const std::string root_subs = " " + root[1].str() + " ";
  for (const std::string& c : HelpSubcommands(Aerovo("--help", true).out)) {
    EXPECT_TRUE(Has(root_subs, " " + c + " ")) << c << " missing from " << root_subs;
  }
  std::smatch run;
  ASSERT_TRUE(std::regex_search(script, run, std::regex("'aerovo run'\\) subs='[^']*'; opts='([^']*)'")));
  const std::string run_opts = " " + run[1].str() + " ";
  const std::string help = Aerovo("run --help", true).out;
  const std::regex flag("(^|[ ,])(--[a-z0-9][a-z0-9-]*)");
  int n = 0;
  for (auto it = std::sregex_iterator(help.begin(), help.end(), flag); it != std::sregex_iterator();
       ++it) {
    const std::string name = (*it)[2];
    // Flags quoted in the descriptions (of other commands, e.g. "aerovo report ... --no-mosaic")
    // are not run's; run's own are all offered.
    if (!Has(help, "  " + name) && !Has(help, "," + name)) continue;
    EXPECT_TRUE(Has(run_opts, " " + name + " ")) << name;
    ++n;
  }
  EXPECT_GT(n, 60) << "run lists every option of the schema";
}

#endif  // AEROVO_CLI_PATH

}  // namespace
}  // namespace aerovo::cli::conventions_test
