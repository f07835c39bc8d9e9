// `aerovo run`: the main job. A flight (video, photo folder or live source) and its telemetry in;
// a geo-referenced trajectory, its comparison with GPS and every per-frame output out. The work
// is in aerovo/pipeline/runner.h; this file maps flags and signals onto it.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/cli/progress.h"
#include "aerovo/cli/run_cli.h"
#include "aerovo/cli/run_summary.h"
#include "aerovo/core/error.h"
#include "aerovo/outputs/run_folder.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/geo_mosaic.h"
#include "aerovo/report/html_report.h"

namespace aerovo::cli {
namespace {

struct RunArgs {
  RunFlags run;
  bool print_poses = false;
  bool no_report = false;
  bool list_options = false;
  bool print_config = false;
};

void Execute(RunArgs& a) {
  if (a.list_options) {  // docs/options.md is this output
    std::cout << RunOptionsMarkdown();
    return;
  }
  const RunConfig config = CheckUsage([&] {
    RunConfig c = a.run.Resolve();
    Validate(c);
    return c;
  });
  if (a.print_config) {  // what config.json will hold, without running
    std::cout << ToJson(config).dump(2) << "\n";
    return;
  }

  // A run owns its folder: one run at a time (the lock, held until the end of the report),
  // started in an empty folder unless --force (which removes aerovo's own files first).
  const RunFolderLock lock(config.out);
  {
    std::vector<std::string> own = RunFileNames::All();
    for (const char* n : {ReportFileNames::kHtml, ReportFileNames::kFiguresDir,
                          ReportFileNames::kMosaic}) {
      own.emplace_back(n);
    }
    for (const std::string& n : GeoMosaicFileNames::All()) own.push_back(n);
    const ClaimResult claim = ClaimOutputFolder(config.out, config.force, own, "aerovo run");
    if (!claim.removed.empty()) {
      std::cerr << fmt::format("aerovo run: --force: removed {} file(s) of an earlier run from "
                               "'{}': {}\n",
                               claim.removed.size(), config.out, fmt::join(claim.removed, ", "));
    }
    if (!claim.kept.empty()) {
      std::cerr << fmt::format("aerovo run: --force: kept {} file(s) aerovo did not write in "
                               "'{}': {}\n",
                               claim.kept.size(), config.out, fmt::join(claim.kept, ", "));
    }
  }

  // With --print-poses or --poses-jsonl - stdout is the pose stream: everything else goes to
  // stderr (configuration, progress, warnings, summary, report lines), and there is no
  // progress. Warnings always go to stderr, even with -q (which hides the progress and the
  // configuration dump only).
  const bool stdout_is_stream = a.print_poses || config.poses_jsonl == "-";
  if (a.print_poses && config.poses_jsonl == "-") {
    throw InvalidArgument("--print-poses and --poses-jsonl - both write to stdout: give one");
  }
  std::ostream& text = stdout_is_stream ? std::cerr : std::cout;
  Progress progress(DefaultProgressStyle(config.quiet || a.print_poses));
  RunCallbacks cb;
  cb.log = &text;
  cb.log_config = VerboseFlag();  // else config.json only
  if (progress.enabled()) {
    cb.progress = [&progress](int done, int expected, double fps) {
      progress.Update(done, expected, fps);
    };
  }
  if (a.print_poses) cb.poses = &std::cout;
  int signal = 0;
  const RunSummary s = WithStopSignals(
      &signal, [&](const std::atomic<bool>* stop) { return RunFlight(config, cb, stop); });
  progress.Finish();
  if (s.interrupted) {
    // On stderr: stdout may be the pose stream.
    std::cerr << fmt::format(
        "aerovo run: interrupted by {} after {} of {} frames; the outputs in '{}' are valid and "
        "complete up to the last frame processed (summary.json says interrupted); exit code {}\n",
        StopSignals::Name(signal), s.frames_processed,
        s.frames_expected >= 0 ? std::to_string(s.frames_expected) : std::string("?"),
        s.out_dir.string(), StopSignals::ExitCode(signal));
    std::cerr.flush();
  }
  for (const std::string& w : s.warnings) std::cerr << "warning: " << w << "\n";
  std::cerr.flush();
  text << "\n";
  PrintRunSummary(text, s);
  text.flush();
  // The HTML report of what was computed (also after an interruption). A failure is a warning:
  // the run's outputs are already complete on disk.
  if (!a.no_report && s.frames_processed > 0) {
    try {
      const ReportResult r = WriteReport(s.out_dir);
      for (const std::string& n : r.notes) text << "note: " << n << "\n";
      text << fmt::format("Report: {} ({:.1f} s)\n", r.html.string(), r.seconds);
    } catch (const std::exception& e) {
      std::cerr << "warning: no report (the run's outputs are complete): " << e.what() << "\n";
    }
    text.flush();
  }
  // 130 SIGINT, 143 SIGTERM, 129 SIGHUP, 141 SIGPIPE
  if (s.interrupted) std::exit(StopSignals::ExitCode(signal));
}

void RegisterRunCommand(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  RunArgs& a = *args;
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Visual odometry on a flight: video, photo folder or live source (+ telemetry) in;\n"
      "geo-referenced trajectory, comparison with GPS and per-frame outputs out");
  AddRunFlags(cmd, a.run);
  cmd->add_flag("--print-poses", a.print_poses,
                "Streaming: print each pose on stdout as soon as it is written to frames.csv "
                "(frame time_s x_m y_m lat lon status; held back while the heading waits for "
                "GPS); everything else goes to stderr. --poses-jsonl - is the JSON stream");
  cmd->add_flag(
      "--no-report", a.no_report,
      "Do not write report.html and figures/ at the end (aerovo report DIR does it later)");
  cmd->add_flag("--list-options", a.list_options,
                "Print every option (config key, flag, type, default, range, description) as "
                "Markdown and exit (docs/options.md)");
  cmd->add_flag("--print-config", a.print_config,
                "Print the effective configuration (defaults, then --config, then the flags; "
                "validated) as config.json will hold it, and exit without running");
  cmd->callback([args] { Execute(*args); });
}

}  // namespace

AEROVO_REGISTER_COMMAND(RegisterRunCommand);

}  // namespace aerovo::cli
