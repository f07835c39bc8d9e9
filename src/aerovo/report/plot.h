// A small plotting layer over gnuplot (Debian gnuplot-nox): a Figure is described as data
// (series of x/y points, labels with units, title), written as a gnuplot script plus one data
// file, and rendered by a gnuplot child process as SVG (terminal `svg`) and PNG (terminal
// `pngcairo`). The report module uses it for the paper's figures; it does file I/O and runs a
// process, so it is not part of the core.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace aerovo {

/// How a series is drawn.
enum class SeriesStyle {
  kLines,        ///< A polyline through the points (non-finite y or x breaks the line).
  kPoints,       ///< Marks only.
  kLinesPoints,  ///< Polyline with marks.
  kImpulses,     ///< Vertical bars from 0 (e.g. per-frame events).
};

/// One curve of a figure: points (x[i], y[i]); x and y have the same size. Non-finite values are
/// written as missing (gnuplot `set datafile missing`), which breaks a line there.
struct PlotSeries {
  std::string title;  ///< Legend entry; empty: not in the legend.
  std::vector<double> x, y;
  SeriesStyle style = SeriesStyle::kLines;
  /// "#rrggbb"; empty: the series' colour of style::kSeriesPalette (report/style.h: no track
  /// colour). Tracks (GPS, VO, truth) take their style.h colour.
  std::string color;
  double line_width = 1.5;  ///< gnuplot line width units (~1 px at 96 dpi).
  double point_size = 0.6;  ///< gnuplot point size (kPoints / kLinesPoints).
  bool dashed = false;
};

/// A whole figure: axes with labelled units, a title naming what it shows (e.g. the paper figure).
struct Figure {
  /// File stem of the outputs: <name>.svg, <name>.png, <name>.gp, <name>.dat. Letters, digits,
  /// '_', '-', '.' only (InvalidArgument otherwise).
  std::string name;
  std::string title;
  std::string x_label;  ///< With the unit, e.g. "east (m)".
  std::string y_label;
  std::vector<PlotSeries> series;
  /// Same scale on both axes (maps: trajectories in metres).
  bool equal_axes = false;
  /// Logarithmic y axis (e.g. stage times spanning decades).
  bool log_y = false;
  /// Start the y axis at 0 (counts).
  bool y_from_zero = false;
  /// gnuplot key placement, e.g. "top right", "bottom left", "outside right top".
  std::string key = "top right";
  int width_px = 900;  ///< Size of the SVG and PNG, pixels.
  int height_px = 540;
};

/// Throws InvalidArgument naming the figure: bad name or size, no series, a series whose x and y
/// sizes differ, a colour that is not "#rrggbb".
void Validate(const Figure& figure);

/// Where to find gnuplot and what to write.
struct PlotOptions {
  /// The gnuplot executable: a path, or a name looked up in PATH. Default "gnuplot"; the
  /// environment variable AEROVO_GNUPLOT, when set, replaces the default.
  std::string gnuplot = "gnuplot";
  bool svg = true;
  bool png = true;
  /// Keep <name>.gp and <name>.dat beside the images (to re-run or edit the plot by hand).
  bool keep_script = true;
};

/// The gnuplot script that draws `figure` from `data_file` (written by WriteGnuplotData) into
/// `svg_file` and/or `png_file` (either may be empty: that output is skipped). Strings are quoted
/// for gnuplot; text is drawn as given (noenhanced: '_' and '^' are literal).
std::string GnuplotScript(const Figure& figure, const std::filesystem::path& data_file,
                          const std::filesystem::path& svg_file,
                          const std::filesystem::path& png_file);

/// The data file: one block per series ("x y" lines, missing values as "?"), blocks separated by
/// two blank lines (gnuplot `index`). Empty series are written as a single missing point.
std::string GnuplotData(const Figure& figure);

/// Files written for a figure.
struct FigureFiles {
  std::filesystem::path svg;  ///< Empty when not requested.
  std::filesystem::path png;  ///< Empty when not requested.
};

/// The gnuplot executable that `options` designates (absolute path), or empty when it cannot be
/// found.
std::filesystem::path FindGnuplot(const PlotOptions& options);

/// Writes the script and data into `out_dir` (created if missing), runs gnuplot and checks that
/// the requested outputs exist and are not empty. Throws InputError naming the figure when gnuplot
/// is missing ("install gnuplot-nox") or fails (with gnuplot's error message); OutputError naming
/// the figure when a file or the folder cannot be written; InvalidArgument for an invalid figure.
FigureFiles RenderFigure(const Figure& figure, const std::filesystem::path& out_dir,
                         const PlotOptions& options = {});

}  // namespace aerovo
