// The full flight demo (`aerovo demo`, README's first command), needing no file: a flight
// simulated over the built-in procedural terrain with exact ground truth, the pipeline run on it
// (`aerovo run`), the paper's two experiments on the same flight (illumination, standard vs
// clustered RANSAC; report/experiment.h), their HTML reports (report/html_report.h), and an index
// page linking everything.
//
// Output folder DEMO:
//   DEMO/sim/           the simulated flight (JPEG frames, DJI SRT, GPX, ground truth, sim.json)
//   DEMO/run/           the run (runner.h: frames.csv, vo.tum, summary.json with the comparison
//                       with GPS and with the ground truth, ...)
//   DEMO/illumination/  the illumination experiment (experiment.json, tables.md, a run per k)
//   DEMO/ransac/        the RANSAC experiment (a run per mode)
//   DEMO/{run,illumination,ransac}/report.html   the HTML reports (figures, tables)
//   DEMO/index.html     the summary table and links to every report
//   DEMO/summary.txt    the summary table as printed
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "aerovo/pipeline/experiment.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo {

/// The demo's flight over the built-in terrain. Full (quick = false): lawnmower of 3 legs of
/// 250 m, 50 m apart (about 910 m flown), 100 m above ground at 10 m/s, 960x540 camera with the
/// simulator's 73.7 deg field of view, 2 frames per second (5 m, 12 % of the along-track view,
/// between frames): 183 frames, sized so that the whole demo (7 runs of the flight) takes a few
/// minutes on 2 cores. Quick: one 120 m leg at 640x360, 2 fps (25 frames), for tests.
ExperimentSimulation DemoSimulation(bool quick);

struct DemoOptions {
  /// Output folder DEMO (created). Default "aerovo-demo".
  std::filesystem::path out_dir = "aerovo-demo";
  /// The simulated flight. Default DemoSimulation(false).
  ExperimentSimulation flight = DemoSimulation(false);
  /// Run the two experiments. Default on.
  bool experiments = true;
  /// Illumination experiment. Default k = 1, 0.5, 0.25, 0.1: the paper's range (down to
  /// "practically darkness") in 4 runs rather than 5, for time; SURF threshold scaled by k^2
  /// (scale_threshold): with the paper's fixed threshold the built-in terrain, less contrasted
  /// than the paper's videos, keeps 8 % of its points at k = 0.5 and none at k = 0.1
  /// (`aerovo experiment illumination --simulate` runs the paper's protocol).
  IlluminationOptions illumination = {{1.0, 0.5, 0.25, 0.1}, true};
  /// RANSAC experiment with unguided matching (correspondence.guided_matching = false), as the
  /// paper: every step matches without the motion prior, which is what clustered RANSAC speeds
  /// up. Default on.
  bool ransac_unguided = true;
  /// Write the HTML reports (report/html_report.h) of the run and of each experiment. Default on.
  bool report = true;
  /// Threads for SURF and matching (0 = all cores).
  int threads = 0;
};

/// Throws InvalidArgument naming the bad field.
void Validate(const DemoOptions& options);

/// Wall time of one stage of the demo.
struct DemoStage {
  std::string name;  ///< "simulate", "run", "illumination", "ransac", "report".
  double seconds = 0.0;
};

struct DemoResult {
  std::filesystem::path out_dir;
  ExperimentSimulation flight_options;         ///< The flight simulated (DemoOptions::flight).
  bool illumination_scaled_threshold = false;  ///< DemoOptions::illumination.scale_threshold.
  SimulatedFlight flight;
  RunSummary run;
  std::optional<ExperimentResult> illumination, ransac;
  std::filesystem::path index_html;  ///< DEMO/index.html
  std::vector<DemoStage> stages;
  double wall_s = 0.0;
  bool interrupted = false;  ///< Stopped by the stop flag; what finished is kept.
  std::vector<std::string> notes;
};

/// Where the demo reports to (all optional).
struct DemoCallbacks {
  /// A stage starts ("simulate", "run", "illumination", "ransac", "report"), with a description.
  std::function<void(const std::string& stage, const std::string& what)> stage_started;
  /// Progress inside a stage: frames rendered or processed (done, total or -1).
  std::function<void(int done, int total)> progress;
};

/// Runs the whole demo into options.out_dir. Stops cleanly when `stop` becomes true (finished
/// stages keep their files). Throws InvalidArgument for bad options, InputError when a file
/// cannot be written.
DemoResult RunDemo(const DemoOptions& options, const DemoCallbacks& callbacks = {},
                   const std::atomic<bool>* stop = nullptr);

/// The short summary table printed at the end (flight, accuracy against the exact ground truth
/// and GPS, the experiments' headline figures, where the outputs are, times); lines end '\n'.
std::string FormatDemoSummary(const DemoResult& result);

}  // namespace aerovo
