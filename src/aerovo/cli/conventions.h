// The command-line conventions every `aerovo` subcommand follows: exit codes, the nearest-name
// suggestion for a mistyped command or option, and the bash completion generated from the
// command and flag tables (CLI11's App tree). Used by main.cc; tested in conventions_test.cc
// and, through the binary, in tests/e2e/cli_conventions_test.cc.
#pragma once

#include <CLI/CLI.hpp>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "aerovo/core/error.h"

namespace aerovo::cli {

/// The exit codes of `aerovo` (also in `aerovo --help` and the README).
enum ExitCode : int {
  kExitOk = 0,         ///< Success (also --help, --version, `aerovo` alone).
  kExitFailure = 1,    ///< The command failed: bad input data, a file it could not read or write.
  kExitUsage = 2,      ///< Usage error: unknown command or option, bad or missing value.
  kExitSigint = 130,   ///< Stopped by SIGINT (128 + 2); the outputs are valid up to that frame.
  kExitSigterm = 143,  ///< Stopped by SIGTERM (128 + 15); same.
  kExitSighup = 129,   ///< Stopped by SIGHUP (128 + 1, the terminal closed); same.
  kExitSigpipe = 141,  ///< Stopped by SIGPIPE (128 + 13, the reader of stdout went away); same.
};

/// A usage error found by a command after parsing (an option's value out of range, options that
/// disagree): main prints it and exits with kExitUsage.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// `message` of a failed check of a library's options with the flags it is about first, e.g.
/// "--height-m: FlightPlan: height_m = 0 must be in [1, 10000]": each entry of `fields` is a text
/// a check's message names a field by (sim/*.cc Validate: "leg_length_m", "legs =") and the flag
/// or flags that set it; the message alone when it names none.
std::string NameFlags(const std::string& message,
                      const std::vector<std::pair<const char*, const char*>>& fields);

/// Runs `f`, the reading and checking of a command's options before it works: an
/// InvalidArgument it throws (an option out of range, options that disagree) is a UsageError.
template <class F>
auto CheckUsage(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InvalidArgument& e) {
    throw UsageError(e.what());
  }
}

/// The exit code of a command that failed with `error` (thrown out of its callback to main, which
/// prints "aerovo: error: " + what()). The one place that maps error types to exit codes:
///   UsageError                            kExitUsage (2)
///   InputError   bad input data           kExitFailure (1)
///   OutputError  a write that failed      kExitFailure (1)
///   Cancelled    a stop request           kExitFailure (1): a command stopped by a signal exits
///                                         128 + the signal itself (StopSignals::ExitCode in
///                                         run_cli.h); a Cancelled reaching main names none
///   InternalError, InvalidArgument (options not checked through CheckUsage), any other
///   std::exception                        kExitFailure (1)
/// CLI11's parse errors are main's own (the help and suggestion they print): not handled here.
int ExitCodeForError(const std::exception& error);

/// The "Exit codes:" paragraph of every --help.
std::string ExitCodesHelp();

/// Levenshtein distance (insertions, deletions, substitutions, each 1).
int EditDistance(const std::string& a, const std::string& b);

/// The candidate nearest to `word`, "" when none is near enough: within 2 edits for words of
/// up to 8 characters, 3 for longer ones, or a candidate that `word` is a prefix of (`--surf-t`
/// -> `--surf-threshold`). Ties: the first in `candidates`.
std::string NearestName(const std::string& word, const std::vector<std::string>& candidates);

/// The names of the (non-hidden-group) subcommands of `app`, in registration order.
std::vector<std::string> SubcommandNames(const CLI::App& app);

/// Every long and short option name of `app` (with dashes: "--out", "-o"), help included.
std::vector<std::string> OptionNames(const CLI::App& app);

/// true/false, 1/0, on/off, yes/no (any case): the values a boolean flag takes after '='.
bool IsBooleanWord(const std::string& word);

/// Every boolean option is a switch (`--X`, `--no-X`, `--X=false`); earlier versions wrote
/// `--X 0`. Rewrites each `--X V`, where --X is a long flag name of any command of `app` and V a
/// boolean word, to `--X=V`, so that old command lines keep their meaning. A positional argument
/// literally named "0" or "true" after a flag must be given as `--input 0` (or `-- 0`).
/// Stops at "--" (what follows is positional).
std::vector<std::string> NormalizeBooleanFlags(const CLI::App& app, std::vector<std::string> args);

/// Every option of `app` and of its subcommands whose value is a number (CLI11's type INT, UINT
/// or FLOAT, list elements included) refuses an empty value, which CLI11 would read as 0
/// (`--altitude ""` from an unset shell variable was a height of 0, "from telemetry"; `simulate
/// --noise ""` no noise), and an unsigned one a negative value (CLI11 wraps `--seed -1` around
/// to 18446744073709551615): a usage error naming the option. main calls it once, after every
/// command is registered.
void RequireNumbers(CLI::App& app);

/// A bash completion script for `app` (program `name`): completes subcommands at every level
/// and each command's options, and files for the rest. Generated from the App tree, so it lists
/// every subcommand and every flag of `aerovo run` as they are registered.
std::string BashCompletion(const CLI::App& app, const std::string& name);

}  // namespace aerovo::cli
