// `aerovo report DIR`: the HTML report (figures as SVG/PNG, tables, mosaic) of a run or an
// experiment folder. The work is in aerovo/report/html_report.h.
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "aerovo/cli/command.h"
#include "aerovo/report/html_report.h"

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

void Execute(const ReportArgs& a) {
  ReportOptions o;
  o.mosaic = !a.no_mosaic;
  o.mosaic_options.max_size_px = a.mosaic_size_px;
  o.mosaic_options.max_frames = a.mosaic_frames;
  o.plot.png = !a.no_png;
  if (!a.quiet) o.log = &std::cout;
  const ReportResult r = WriteReport(a.dir, o);
  for (const std::string& n : r.notes) std::cout << "note: " << n << "\n";
  std::cout << fmt::format("aerovo report: {} report in {:.1f} s: {}\n", r.kind, r.seconds,
                           r.html.string());
  std::cout << fmt::format("  {} figure files in {}\n", r.figures.size(),
                           (r.html.parent_path() / ReportFileNames::kFiguresDir).string());
  for (const auto& s : r.sub_reports) std::cout << "  run report: " << s.string() << "\n";
  std::cout.flush();
  if (a.open) {
    // xdg-open hands the file to the desktop's browser; failing to open is not an error.
    const std::string cmd = "xdg-open '" + r.html.string() + "' >/dev/null 2>&1 &";
    if (std::system(cmd.c_str()) != 0) std::cout << "  (could not open a browser)\n";
  }
}

void Register(CLI::App& app) {
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

AEROVO_REGISTER_COMMAND(Register);

}  // namespace aerovo::cli
