// `aerovo report DIR`: the HTML report (figures as SVG/PNG, tables, mosaic) of a run or an
// experiment folder. The work is in aerovo/report/html_report.h.
#include <fcntl.h>
#include <spawn.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <vector>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/outputs/run_folder.h"
#include "aerovo/report/html_report.h"

extern char** environ;

namespace aerovo::cli {
namespace {

struct ReportArgs {
  std::string dir;
  bool no_mosaic = false;
  bool open = false;
  bool no_png = false;
  bool quiet = false;
  int mosaic_size_px = MosaicOptions{}.max_size_px;
  int mosaic_frames = MosaicOptions{}.max_frames;
};

// Hands `html` to the desktop's opener (xdg-open, found on PATH) without a shell: the path is
// one argv element, whatever quotes, semicolons or spaces the folder's name holds; it is made
// absolute so that a name with a leading dash cannot read as an option. The opener runs on its
// own (not waited for: it may keep the browser in the foreground), its output to /dev/null.
// Failing to start it is not an error.
void OpenInBrowser(const std::filesystem::path& html) {
  std::error_code ec;
  const std::string file = std::filesystem::absolute(html, ec).lexically_normal().string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  std::string exe = "xdg-open";
  std::vector<char*> argv{exe.data(), const_cast<char*>(file.c_str()), nullptr};
  pid_t pid = 0;
  const int err = posix_spawnp(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) {
    std::cout << "  (could not open a browser: xdg-open: " << std::strerror(err) << ")\n";
  }
}

void Execute(const ReportArgs& a) {
  ReportOptions o;
  o.mosaic = !a.no_mosaic;
  o.mosaic_options.max_size_px = a.mosaic_size_px;
  o.mosaic_options.max_frames = a.mosaic_frames;
  o.plot.png = !a.no_png;
  // The flags' ranges (report/mosaic.h Validate), before the folder is locked: a usage error.
  try {
    Validate(o.mosaic_options);
  } catch (const InvalidArgument& e) {
    throw UsageError(fmt::format("--mosaic-size {}, --mosaic-frames {}: {}", a.mosaic_size_px,
                                 a.mosaic_frames, e.what()));
  }
  if (!a.quiet) o.log = &std::cout;
  // Not while a run writes into the folder (outputs/run_folder.h): it fails naming that run's pid.
  std::optional<RunFolderLock> lock;
  if (std::filesystem::is_directory(a.dir)) lock.emplace(a.dir);
  const ReportResult r = WriteReport(a.dir, o);
  for (const std::string& n : r.notes) std::cout << "note: " << n << "\n";
  std::cout << fmt::format("aerovo report: {} report in {:.1f} s: {}\n", r.kind, r.seconds,
                           r.html.string());
  std::cout << fmt::format("  {} figure files in {}\n", r.figures.size(),
                           (r.html.parent_path() / ReportFileNames::kFiguresDir).string());
  for (const auto& s : r.sub_reports) std::cout << "  run report: " << s.string() << "\n";
  std::cout.flush();
  if (a.open) OpenInBrowser(r.html);
}

void RegisterReportCommand(CLI::App& app) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "HTML report of a run folder (aerovo run) or an experiment folder (aerovo experiment):\n"
      "the paper's figures (SVG inlined; SVG and PNG files in DIR/figures), tables, mosaic");
  cmd->add_option("dir", args->dir, "Run or experiment folder")->required();
  cmd->add_flag("--no-mosaic", args->no_mosaic, "Do not re-read the frames to draw the mosaic");
  cmd->add_flag("--no-png", args->no_png, "Write the figures as SVG only");
  cmd->add_option("--mosaic-size", args->mosaic_size_px, "Longer side of the mosaic, px")
      ->capture_default_str();
  cmd->add_option("--mosaic-frames", args->mosaic_frames, "At most this many frames in the mosaic")
      ->capture_default_str();
  cmd->add_flag("--open", args->open, "Open the report in the desktop's browser (xdg-open)");
  cmd->add_flag("-q,--quiet", args->quiet, "Only the final lines");
  cmd->callback([args] { Execute(*args); });
}

}  // namespace

AEROVO_REGISTER_COMMAND(RegisterReportCommand);

}  // namespace aerovo::cli
