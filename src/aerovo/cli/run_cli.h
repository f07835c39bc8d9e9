// What every subcommand that runs flights (`aerovo run`, `aerovo experiment ...`) shares: the flags
// of RunConfig (aerovo/pipeline/run_config.h), generated from its option schema (one flag per key,
// --ransac-max-distance-px for ransac.max_distance_px, plus the legacy short flags and the
// shorthands), with the --config file (JSON or YAML) underneath; stopping cleanly on
// SIGINT/SIGTERM. (The progress display is progress.h.)
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/pipeline/runner.h"

namespace aerovo::cli {

/// Values of the run flags. A flag given on the command line wins over the --config file; a flag
/// not given leaves the file's (or the default) value.
struct RunFlags {
  std::string config_file;
  /// --paper: start from PaperRunConfig() (run_config.h) instead of RunConfig's defaults.
  bool paper = false;
  /// The options given on the command line, by the config key of the flag used (canonical key,
  /// legacy alias or shorthand): applied over the config file as one more JSON object, so that
  /// two names of one option with different values are an error there too.
  nlohmann::json given = nlohmann::json::object();

  /// The effective configuration: defaults (or the paper's, --paper), then the --config file,
  /// then the given flags.
  /// Not validated (the caller may still change fields, then call Validate).
  RunConfig Resolve() const;
};

/// Registers the input (positional `input`, also `--input`), --config and one flag per option of
/// the RunConfig schema on `cmd` (stage options in one help group per stage), the legacy short
/// flags (--mode, --seed, ...) and the shorthands (--refine, --threads), except the options whose
/// config keys or legacy aliases are in `skip` (e.g. "out" when the command has its own output
/// folder, "mode" when it sets the mode itself). `flags` must outlive `cmd`.
void AddRunFlags(CLI::App* cmd, RunFlags& flags, const std::set<std::string>& skip = {});

/// While alive, SIGINT, SIGTERM, SIGHUP (terminal closed) and SIGPIPE (the reader of stdout
/// closed it, `aerovo run --print-poses | head`) set stop() instead of killing the process (no
/// SA_RESTART: a blocking read returns and the run loop sees the flag); a second SIGINT, SIGTERM
/// or SIGHUP kills at once (for a run that cannot stop; its outputs are valid anyway, every
/// record being flushed as written); SIGPIPE never kills (later writes fail with EPIPE).
/// SIGQUIT (Ctrl-\) keeps its default action: the user's way to kill at once. The destructor
/// restores the previous handlers (SIGPIPE stays ignored after a SIGPIPE, so the last lines
/// cannot kill the process). One instance at a time.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  const std::atomic<bool>* stop() const;
  bool stopped() const { return stop()->load(); }
  int signal() const;  ///< The signal received, 0 if none.
  /// "SIGINT", "SIGTERM" or "signal N".
  static std::string Name(int signal);
  /// The conventional exit status of a process stopped by `signal`: 128 + its number (130 for
  /// SIGINT, 143 for SIGTERM, 129 for SIGHUP, 141 for SIGPIPE); 130 when `signal` is 0.
  static int ExitCode(int signal);

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
  struct sigaction old_hup_ {};
  struct sigaction old_pipe_ {};
};

/// Runs `work(stop)` with StopSignals installed for its duration (`stop` = StopSignals::stop(),
/// for the run's stop flag) and returns what it returns; `*signal` is set to the signal received
/// (0 if none) before the previous handlers are restored. If `work` throws, the handlers are
/// restored and `*signal` is left as it was.
template <class Work>
auto WithStopSignals(int* signal, Work&& work) {
  const StopSignals signals;
  auto result = work(signals.stop());
  *signal = signals.signal();
  return result;
}

}  // namespace aerovo::cli
