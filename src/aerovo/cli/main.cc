// aerovo: visual odometry for a downward-looking UAV camera (Ivanov & Muzychuk 2023, and more).
// The command-line conventions (exit codes, suggestions, help, completion) are conventions.h.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <signal.h>
#include <algorithm>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "aerovo/cli/command.h"
#include "aerovo/core/simd.h"
#include "aerovo/cli/conventions.h"

namespace aerovo::cli {
std::vector<CommandRegistrar>& Registry() {
  static std::vector<CommandRegistrar> registry;
  return registry;
}

bool& VerboseFlag() {
  static bool verbose = false;
  return verbose;
}

namespace {

const CLI::App* FindSubcommand(const CLI::App& app, const std::string& name) {
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (sub->get_name() == name) return sub;
  }
  return nullptr;
}

// "aerovo experiment ransac" for the deepest subcommand the parse selected.
std::string ParsedPath(const CLI::App& app, const CLI::App** leaf) {
  std::string path = app.get_name();
  const CLI::App* cur = &app;
  while (!cur->get_subcommands().empty()) {
    cur = cur->get_subcommands().front();
    path += " " + cur->get_name();
  }
  *leaf = cur;
  return path;
}

// Walks the command words of `args` (argv without the program) from the root: a word where a
// command must stand (the root, `experiment`, `features`) that names none is a usage error,
// with the nearest name suggested. Stops at the first command that takes arguments. Returns the
// message, "" when the words are commands.
std::string CheckCommandWords(const CLI::App& app, const std::vector<std::string>& args) {
  const CLI::App* cur = &app;
  std::string path = app.get_name();
  for (const std::string& w : args) {
    if (w == "--") break;
    if (!w.empty() && w[0] == '-') continue;  // the root's and groups' flags take no value
    if (SubcommandNames(*cur).empty() || cur->get_require_subcommand_min() == 0) break;
    const CLI::App* sub = FindSubcommand(*cur, w);
    if (sub == nullptr) {
      std::string msg = path + ": unknown command '" + w + "'";
      const std::string near = NearestName(w, SubcommandNames(*cur));
      if (!near.empty()) msg += "; did you mean '" + near + "'?";
      msg += "\nRun '" + path + " --help' for the list of commands.";
      return msg;
    }
    cur = sub;
    path += " " + w;
  }
  return "";
}

// The footer (exit codes) on every command's --help.
void SetFooters(CLI::App& app) {
  app.footer("\n" + ExitCodesHelp());
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) SetFooters(*sub);
}

}  // namespace
}  // namespace aerovo::cli

namespace {

// A file size limit (`ulimit -f`, RLIMIT_FSIZE) is a full disk for one file: SIGXFSZ's default
// action kills the process in the middle of a write, leaving that file cut and no summary.json.
// Ignored, the write fails with EFBIG ("File too large") and takes the full-disk path (outputs/
// output_file.h): the error names the file, every file stays valid, the summary is written.
void TreatFileSizeLimitsAsWriteErrors() { ::signal(SIGXFSZ, SIG_IGN); }

}  // namespace

int main(int argc, char** argv) {
  TreatFileSizeLimitsAsWriteErrors();
  using namespace aerovo::cli;
  CLI::App app{
      "aerovo: where a UAV is, from its downward-looking camera alone.\n"
      "Visual odometry after Ivanov & Muzychuk (2023): SURF, matching, (clustered) RANSAC.",
      "aerovo"};
  app.require_subcommand(1);
  // The root's flags also after the command (`aerovo run ... --verbose`).
  app.fallthrough();
  // The SIMD kernels in use (AEROVO_SIMD=native|highway|scalar, core/simd.h), e.g.
  // "aerovo 0.1.0 (SIMD: avx2)".
  app.set_version_flag("--version", std::string("aerovo ") + AEROVO_VERSION + " (SIMD: " +
                                        aerovo::SimdTargetName() + ")");
  if (const std::string problem = aerovo::SimdEnvironmentProblem(); !problem.empty()) {
    spdlog::warn("{}", problem);
  }
  app.add_flag("-v,--verbose", VerboseFlag(),
               "Debug logging; `aerovo run` also prints its configuration (config.json)");
  app.parse_complete_callback([&] {
    spdlog::set_level(VerboseFlag() ? spdlog::level::debug : spdlog::level::info);
    spdlog::debug("SIMD kernels: {} (AEROVO_SIMD=native|highway|scalar)",
                  aerovo::SimdTargetName());
  });
  for (auto registrar : Registry()) registrar(app);
  std::vector<std::string> help_of;
  app.add_subcommand("help", "Show the help of a command (aerovo help run, aerovo help "
                             "experiment ransac)")
      ->add_option("command", help_of, "Command (and subcommand)");
  std::string shell;
  CLI::App* completion = app.add_subcommand(
      "completion", "Print the shell completion script (installed as "
                    "share/bash-completion/completions/aerovo)");
  completion->add_option("shell", shell, "Shell")->check(CLI::IsMember({"bash"}))->required();
  completion->callback([&] { std::cout << BashCompletion(app, "aerovo"); });
  SetFooters(app);
  RequireNumbers(app);

  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {  // `aerovo` alone: the usage with the commands
    std::cout << app.help();
    return kExitOk;
  }
  // `aerovo help CMD...` is `aerovo CMD... --help`.
  if (args.front() == "help") {
    args.erase(args.begin());
    args.push_back("--help");
  }
  if (const std::string msg = CheckCommandWords(app, args); !msg.empty()) {
    std::cerr << msg << "\n";
    return kExitUsage;
  }
  args = NormalizeBooleanFlags(app, std::move(args));
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 parses a reversed vector
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    const CLI::App* leaf = nullptr;
    const std::string path = ParsedPath(app, &leaf);
    std::string msg = e.what();
    if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
      // Unknown options: name each, with the nearest option of the command.
      std::vector<std::string> names = OptionNames(*leaf);
      for (const CLI::App* a = leaf->get_parent(); a != nullptr; a = a->get_parent()) {
        for (const std::string& n : OptionNames(*a)) names.push_back(n);
      }
      // The words after an unknown option are taken as its values, not reported again.
      const std::vector<std::string> extras = app.remaining(true);
      const bool any_option = std::any_of(extras.begin(), extras.end(), [](const std::string& w) {
        return w.size() > 1 && w[0] == '-';
      });
      msg.clear();
      for (const std::string& w : extras) {
        const bool option = w.size() > 1 && w[0] == '-';
        if (any_option && !option) continue;
        if (!msg.empty()) msg += "\n" + path + ": ";
        if (option) {
          const std::string flag = w.substr(0, w.find('='));
          msg += "unknown option '" + flag + "'";
          const std::string near = NearestName(flag, names);
          if (!near.empty()) msg += "; did you mean '" + near + "'?";
        } else {
          msg += "unexpected argument '" + w + "'";
        }
      }
      if (msg.empty()) msg = e.what();
    }
    std::cerr << path << ": " << msg << "\nRun '" << path << " --help' for more information.\n";
    return kExitUsage;
  } catch (const std::exception& e) {  // every error of a command: UsageError, InputError, ...
    std::cerr << "aerovo: error: " << e.what() << "\n";
    return ExitCodeForError(e);
  }
  // A stdout that could not be written (a full disk behind `> out.txt`, /dev/full, an I/O
  // error) lost the command's text: the exit status says so, as coreutils' do. (A reader that
  // went away is SIGPIPE: `aerovo run` stops on it; other commands die of it, the default.)
  errno = 0;
  std::cout.flush();
  if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    const int err = errno;
    std::cerr << "aerovo: error: cannot write to stdout: "
              << (err != 0 ? std::strerror(err) : "a write failed (disk full or an I/O error)")
              << "\n";
    return kExitFailure;
  }
  return kExitOk;
}
