// The command-line conventions: the suggestion, and through the built binary the exit codes,
// `aerovo` alone, `aerovo help CMD`, the unknown command and option messages and the bash
// completion generated at build time.
#include "aerovo/cli/conventions.h"

#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace aerovo::cli {
namespace {

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

#ifdef AEROVO_CLI_PATH

struct Cli {
  int status = -1;
  std::string out;  // stdout + stderr
};

// `aerovo ARGS` with stdout and stderr together (or stdout only with `stdout_only`).
Cli Run(const std::string& args, bool stdout_only = false) {
  const std::string cmd =
      std::string(AEROVO_CLI_PATH) + " " + args + (stdout_only ? " 2>/dev/null" : " 2>&1");
  Cli r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = ::pclose(p);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
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
  const Cli r = Run("", /*stdout_only=*/true);
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
  Cli r = Run("rnu");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "unknown command 'rnu'; did you mean 'run'?")) << r.out;
  r = Run("experiment rnasac");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "aerovo experiment: unknown command 'rnasac'; did you mean 'ransac'?"))
      << r.out;
  r = Run("help rnu");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "did you mean 'run'?")) << r.out;
  r = Run("run flight.mp4 --surf-treshold 500 --print-config");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "unknown option '--surf-treshold'; did you mean '--surf-threshold'?"))
      << r.out;
  // CLI11's own errors (104-109 before): a bad value, a missing argument, an enum not a choice.
  for (const char* args : {"run flight.mp4 --step abc --print-config", "report",
                           "run flight.mp4 --correspondence-sampler fast --print-config",
                           "simulate --height-m"}) {
    r = Run(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.out;
    EXPECT_TRUE(Has(r.out, "--help")) << args << "\n" << r.out;
  }
  // An option out of its range, found after parsing: also a usage error, naming the key.
  r = Run("run flight.mp4 --ransac-max-distance-px -1 --print-config");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(Has(r.out, "ransac.max_distance_px must be finite and > 0, got -1")) << r.out;
  // Bad input data is not a usage error.
  r = Run("run /nonexistent/flight.mp4 --hfov-deg 70 -o /tmp/aerovo_conventions_test_run");
  EXPECT_EQ(r.status, 1) << r.out;
}

TEST(CliConventions, HelpCmdIsCmdHelpAndEveryHelpListsTheExitCodes) {
  const Cli help = Run("help run", true), direct = Run("run --help", true);
  EXPECT_EQ(help.status, 0);
  EXPECT_EQ(help.out, direct.out);
  EXPECT_TRUE(Has(help.out, "Usage: aerovo run")) << help.out;
  for (const char* cmd : {"run", "simulate", "experiment ransac", "features detect"}) {
    const Cli r = Run(std::string("help ") + cmd, true);
    EXPECT_EQ(r.status, 0) << cmd;
    EXPECT_TRUE(Has(r.out, "Exit codes:")) << cmd << "\n" << r.out;
    EXPECT_TRUE(Has(r.out, "  2    usage error")) << cmd << "\n" << r.out;
  }
  EXPECT_EQ(Run("help", true).out, Run("--help", true).out);
}

TEST(CliConventions, OneNameForTheSameOptionInEveryCommand) {
  // -o/--out everywhere a command writes a folder.
  for (const char* cmd : {"run", "simulate", "demo", "experiment ransac"}) {
    const Cli r = Run(std::string("help ") + cmd, true);
    EXPECT_TRUE(std::regex_search(r.out, std::regex("-o,--out"))) << cmd << "\n" << r.out;
  }
  // The SURF threshold: --surf-threshold in run, features detect and correspondence.
  for (const char* cmd : {"run", "features detect", "correspondence"}) {
    const Cli r = Run(std::string("help ") + cmd, true);
    EXPECT_TRUE(Has(r.out, "--surf-threshold")) << cmd << "\n" << r.out;
  }
  // The old spelling still works (hidden).
  const Cli old = Run("features detect --threshold 500 /nonexistent.png");
  EXPECT_EQ(old.status, 1) << old.out;  // parsed; then the missing image
}

// The completion generated at build time (share/bash-completion/completions/aerovo) offers every
// subcommand and every flag that `aerovo run --help` lists.
TEST(CliConventions, BashCompletionListsEverySubcommandAndRunFlag) {
  std::ifstream f(AEROVO_COMPLETION_FILE);
  ASSERT_TRUE(f.good()) << AEROVO_COMPLETION_FILE;
  const std::string script((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(Has(script, "complete -o filenames -F _aerovo_complete aerovo")) << script;
  const Cli now = Run("completion bash", true);
  EXPECT_EQ(now.out, script);  // the installed file is the program's current tables
  // The root's line: every subcommand of `aerovo --help`.
  const std::smatch root = [&] {
    std::smatch m;
    std::regex_search(script, m, std::regex("'aerovo'\\) subs='([^']*)'"));
    return m;
  }();
  ASSERT_FALSE(root.empty()) << script;
  const std::string root_subs = " " + root[1].str() + " ";
  for (const std::string& c : HelpSubcommands(Run("--help", true).out)) {
    EXPECT_TRUE(Has(root_subs, " " + c + " ")) << c << " missing from " << root_subs;
  }
  std::smatch run;
  ASSERT_TRUE(std::regex_search(script, run, std::regex("'aerovo run'\\) subs='[^']*'; opts='([^']*)'")));
  const std::string run_opts = " " + run[1].str() + " ";
  const std::string help = Run("run --help", true).out;
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
}  // namespace aerovo::cli
