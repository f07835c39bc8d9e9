// `aerovo report DIR`: one self-contained HTML file (opens offline: no external URL, figures
// inlined as SVG, the mosaic as a data: URI) for a run folder (`aerovo run`) or an experiment
// folder (`aerovo experiment`), plus every figure as SVG and PNG in DIR/figures/ (for papers).
//
// Run folder (frames.csv, transforms.csv, summary.json, config.json; outputs/track_writers.h):
//   fig2_trajectory   the paper's Fig. 2: VO against GPS in local ENU metres after the SE(2)
//                     alignment of summary.json (eval/trajectory_eval.h), Sim(2) dashed
//   fig3_points       the paper's Fig. 3: N_SURF, matched points, RANSAC inliers per frame
//   stage_times       detect, describe, correspond, estimate, total per frame, ms
//   ate_per_frame     SE(2)/Sim(2) position error per frame, m
//   answer            first: frames tracked, distance flown, end error and ATE against GPS
//   map               interactive and offline (Leaflet 1.7 of Debian's libjs-leaflet inlined,
//                     leaflet_assets.h; no tile server, a plain background): the VO track
//                     (frames.csv lat/lon), the GPS fixes, the ground truth, bridged frames,
//                     the geo-referenced mosaic (mosaic_geo.json) under them, a metric scale
//                     bar, per-frame hover (index, time, status, distance to GPS)
//   error_vs_distance, error_vs_time   the position error against distance flown and time
//   mosaic.jpg        frames warped into the first frame's pixels with the VO and GPS tracks
//   tables            summary (summary.json) with the timings after the accuracy, effective
//                     configuration (config.json)
// Colours: one per track in every figure, the mosaic and the map (report/style.h).
//
// Experiment folder (EXP/experiment.json, each run in EXP/<dir>/):
//   {"kind": "illumination" | "ransac" | other,
//    "runs": [{"label": "k=0.50", "dir": "k0.50", "k": 0.5}, ...]   (illumination)
//            [{"label": "standard", "dir": "standard", "mode": "standard"}, ...]  (ransac)
//    "ground_truth": "<ground_truth.csv, relative to EXP or absolute>" | null,
//    "tables": {"<name>": {"columns": [...], "rows": [[...], ...]}, ...}}
//   illumination: fig4_nsurf_per_frame (one curve per k), fig5_mean_nsurf_vs_k,
//                 fig6_trajectories (every k against GPS, or the ground truth when given)
//   ransac:       fig7_stage_times_<mode> (one per run), fig8_correspond_per_step (correspond
//                 stage of every mode side by side), trajectories
//   every kind:   the tables of experiment.json, a per-run summary table, links to each run's
//                 own report.html (written too).
//
// The page requests nothing: a Content-Security-Policy lets it load only what it holds (inline
// scripts and styles, data: images), so it works with the network off and cannot reach out.
// The HTML ends with a small script that, after load, checks that every figure (<svg>) has a
// non-zero size and every <img> decoded, and writes the count into <body data-figures-ok="N"
// data-figures-expected="M">, the requests the policy refused into data-blocked-requests, and
// for the map data-map-ready, data-map-vo-vertices, data-map-gps-vertices (SVG path vertices),
// data-map-overlay, data-map-scale, data-map-rect (x,y,w,h in page pixels) and data-map-hover,
// so that a headless browser can verify the rendering.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "aerovo/report/mosaic.h"
#include "aerovo/report/plot.h"

namespace aerovo {

/// Options of WriteReport.
struct ReportOptions {
  /// Draw the mosaic (re-reads the run's frames). Default on.
  bool mosaic = true;
  MosaicOptions mosaic_options;
  PlotOptions plot;  ///< gnuplot executable, PNG/SVG outputs.
  /// Experiments: also write each run's own report (linked from the experiment's). Default on.
  bool sub_reports = true;
  /// Progress messages (may be null).
  std::ostream* log = nullptr;
};

/// What WriteReport wrote.
struct ReportResult {
  std::string kind;                                ///< "run" or "experiment".
  std::filesystem::path html;                      ///< DIR/report.html
  std::vector<std::filesystem::path> figures;      ///< DIR/figures/*.svg and *.png
  std::filesystem::path mosaic;                    ///< DIR/figures/mosaic.jpg, empty when skipped.
  std::vector<std::filesystem::path> sub_reports;  ///< Experiments: each run's report.html.
  std::vector<std::string> notes;  ///< Non-fatal: skipped mosaic, missing GPS, failed sub-report.
  double seconds = 0.0;            ///< Wall time.
};

/// Writes DIR/report.html and DIR/figures/ for a run folder (frames.csv present) or an
/// experiment folder (experiment.json present). Throws InputError naming the folder or file when
/// DIR is neither or a file is malformed, or when gnuplot is missing or fails (naming the
/// figure); InvalidArgument for invalid options.
ReportResult WriteReport(const std::filesystem::path& dir, const ReportOptions& options = {});

/// File names.
struct ReportFileNames {
  static constexpr const char* kHtml = "report.html";
  static constexpr const char* kFiguresDir = "figures";
  static constexpr const char* kMosaic = "mosaic.jpg";
  static constexpr const char* kExperimentJson = "experiment.json";
  /// The geo-referenced north-up mosaic, shown under the map's tracks when present:
  /// {"image": "mosaic_geo.png", "south", "west", "north", "east" (degrees WGS84 of the image's
  /// outer edges), "width_px", "height_px", "m_per_px"}, the image an RGBA PNG beside it.
  static constexpr const char* kGeoMosaicJson = "mosaic_geo.json";
};

}  // namespace aerovo
