// Experiments that reproduce the paper's measurements on any flight (docs/method.md,
// "The paper's figures"): the same flight run several times with one parameter changed, every
// run a normal run folder (RunFlight), and tables comparing the runs. The experiments are the
// entries of Experiments() below, one per ExperimentKind (report/experiment_kind.h: how to add
// one):
//
//   illumination  Fig. 4-6: brightness f_k = k f for k in a list (RunConfig::illumination_k);
//                 interest points, matches, inliers and the trajectory per k, and how far each
//                 k's trajectory lies from the k = 1 trajectory.
//   ransac        Fig. 7-8: standard vs clustered RANSAC (correspondence.method); time of each
//                 stage per step, the speed-up of the correspondence stage, the two trajectories.
//
// Output folder EXP (the contract with the HTML report, report/html_report.h):
//   EXP/experiment.json  {"kind": "illumination" | "ransac",
//                         "runs": [{"label", "dir", "k"} | {"label", "dir", "mode"}, ...],
//                         "ground_truth": the simulator's ground_truth.csv the runs compared
//                                         with (RunConfig::truth, or found from sim.json),
//                                         relative to EXP when inside it, else absolute; null
//                                         when none or another kind of truth file,
//                         "tables": {"<name>": {"columns": [string...],
//                                               "rows": [[string | number, ...], ...]}, ...}}
//   EXP/tables.md        the same tables in Markdown, with their titles and definitions
//   EXP/<dir>/           a run folder of RunFlight (frames.csv, summary.json, vo.tum, ...)
// experiment.json and tables.md are rewritten after every finished run, so an interrupted
// experiment keeps the runs it finished.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "aerovo/core/statistics.h"
#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/outputs/frame_record.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/experiment_kind.h"
#include "aerovo/sim/simulator.h"

namespace aerovo {

// ---------------------------------------------------------------------------------------------
// Statistics

/// Mean of `values`. Throws InvalidArgument when empty or a value is not finite.
double Mean(const std::vector<double>& values);
/// Population standard deviation (divides by n). Throws as Mean.
double StdDev(const std::vector<double>& values);
/// The p-th percentile (p in [0, 100]) with linear interpolation between closest ranks (NumPy's
/// default, Hyndman & Fan type 7): on the sorted values v_0..v_{n-1}, h = (n - 1) p / 100 and the
/// result is v_floor(h) + (h - floor(h)) (v_floor(h)+1 - v_floor(h)). Throws InvalidArgument for an
/// empty set, a non-finite value or p outside [0, 100].
double Percentile(std::vector<double> values, double p);
// Median: core/statistics.h (equal to Percentile(values, 50)).

// ---------------------------------------------------------------------------------------------
// Tables

/// One table cell: the text shown, and the number behind it when it is one (experiment.json
/// writes the number, rounded as shown; else the text, "-" for not available).
struct TableCell {
  std::string text;
  std::optional<double> number;
  bool integer = false;  ///< A count: written as a JSON integer.
};

struct ExperimentTable {
  std::string name;   ///< Key in experiment.json "tables".
  std::string title;  ///< Heading in tables.md and on the terminal.
  std::vector<std::string> columns;
  std::vector<std::vector<TableCell>> rows;  ///< Each row has columns.size() cells.
  std::string note;                          ///< Definitions of the figures (may be empty).
};

/// Aligned plain-text table (title, header, rows, note); lines end with '\n'.
std::string FormatTableText(const ExperimentTable& table);
/// Markdown: "### title", a pipe table, the note as a paragraph.
std::string FormatTableMarkdown(const ExperimentTable& table);

// ---------------------------------------------------------------------------------------------
// Inputs

// The simulator's ground_truth.csv is read by ReadGroundTruthCsv (telemetry/reference_track.h).

/// The simulator's defaults (lawnmower, 3 legs of 300 m 50 m apart at 100 m height and 10 m/s,
/// 1280x720 camera with a 73.7 deg field of view, no image effects, exact GPS at 10 Hz) rendered
/// at 3 frames per second: about 320 frames, 3.3 m (4 % of the along-track view) between frames,
/// a run of a few tens of seconds.
sim::SimulationOptions DefaultExperimentSimulation();

/// A flight simulated for an experiment when the user has none (sim/simulator.h).
struct ExperimentSimulation {
  /// Flight, camera, effects and GPS. Default DefaultExperimentSimulation().
  sim::SimulationOptions sim = DefaultExperimentSimulation();
  /// Orthophoto (any format OpenCV reads; north-up) with its metres per pixel and outer
  /// north-west corner; empty = the built-in procedural terrain, fitted to the flight.
  std::string ortho;
  double ortho_mpp = 0.0;
  double nw_lat_deg = sim::kDefaultTerrainLatDeg;
  double nw_lon_deg = sim::kDefaultTerrainLonDeg;
  /// Ground altitude above MSL, m (the corner's altitude). Default as `aerovo simulate`.
  double ground_alt_m = sim::kDefaultTerrainAltM;
  /// Seed of the procedural terrain. Default 1.
  std::uint64_t terrain_seed = 1;
};

/// Throws InvalidArgument naming the bad field.
void Validate(const ExperimentSimulation& options);

/// A simulated flight on disk, ready to run.
struct SimulatedFlight {
  std::filesystem::path dir;               ///< Folder of sim.json.
  std::filesystem::path ground_truth_csv;  ///< Absolute.
  /// input (the video), telemetry (the SRT: GPS and height above ground), focal_px (the
  /// simulated camera's) and truth (ground_truth_csv); everything else default.
  RunConfig run;
  int frames = 0;
  double distance_m = 0.0;            ///< Flown.
  std::vector<std::string> messages;  ///< The simulator's warnings and notes.
};

/// Renders `options` into `dir` as `aerovo simulate` does (H.264 video, DJI SRT,
/// GPX, ground truth, sim.json). `progress(done, total)` is called as frames are written.
/// Throws InvalidArgument for bad options, InputError when a file cannot be read, OutputError when
/// one cannot be written.
SimulatedFlight SimulateExperimentFlight(const ExperimentSimulation& options,
                                         const std::filesystem::path& dir,
                                         const std::function<void(int, int)>& progress = {});

// ---------------------------------------------------------------------------------------------
// Experiments

/// What every experiment runs on.
struct ExperimentInput {
  /// The flight and every run parameter (RunConfig), including the ground truth to compare with
  /// (RunConfig::truth; found from sim.json for a simulated flight). `out` is ignored: run i goes
  /// to out_dir/<dir of run i>. The experiment changes only its own parameter (illumination_k, or
  /// mode).
  RunConfig run;
  /// Output folder EXP (created). Default "aerovo-experiment".
  std::filesystem::path out_dir = "aerovo-experiment";
};

/// Illumination experiment (paper Fig. 4-6).
struct IlluminationOptions {
  /// Illumination factors, each in (0, 1], distinct, run in this order. Default the paper's range
  /// 1, 0.75, 0.5, 0.25, 0.1 (0.1 is "practically darkness"). The reference trajectory is the run
  /// with k = 1, or with the largest k when 1 is not in the list.
  std::vector<double> k = {1.0, 0.75, 0.5, 0.25, 0.1};
  /// When true, each run's SURF threshold is surf.hessian_threshold * k^2. The determinant of
  /// the Hessian scales with k^2, so a fixed threshold (the paper's protocol, the default: false)
  /// loses points because the contrast fell; the scaled threshold keeps the detector's
  /// sensitivity relative to the contrast, leaving what rounding to 8 bits and noise cost.
  bool scale_threshold = false;
};

/// Throws InvalidArgument: empty list, k outside (0, 1], or two k with the same label.
void Validate(const IlluminationOptions& options);

/// Label ("k=0.50") and folder name ("k0.50") of an illumination run: two decimals, or up to 6
/// significant digits when two decimals would not represent k exactly.
std::string IlluminationLabel(double k);
std::string IlluminationDir(double k);

/// One finished run of an experiment.
struct ExperimentRun {
  std::string label;  ///< "k=0.50", "standard", "clustered".
  std::string dir;    ///< Folder under out_dir.
  double k = 1.0;     ///< Illumination factor of the run.
  std::string mode;   ///< Correspondence mode of the run.
  RunConfig config;   ///< The configuration the run used.
  /// What RunFlight returned (summary.truth_evaluation: the comparison with the ground truth).
  RunSummary summary;
  std::vector<FrameRecord> frames;  ///< Every frame's record as written to frames.csv.
};

/// How far apart two trajectories of the same flight are: positions as written (the ENU frame of
/// frames.csv, no alignment) paired by frame index.
struct TrajectoryDistance {
  int count = 0;  ///< Frames present in both.
  double rms_m = 0.0;
  double max_m = 0.0;
};

/// Throws InvalidArgument when no frame index is present in both.
TrajectoryDistance DistanceByFrame(const std::vector<FrameRecord>& a,
                                   const std::vector<FrameRecord>& b);

/// Distance flown on the run's flight, m, for percentages: the ground truth path length when
/// known, else the GPS path length, else the run's own VO path length.
double DistanceFlownM(const ExperimentRun& run);

/// Per-step stage times, ms, of a run (frames after the first processed one; the first has no
/// correspondence). `stage` is "detect", "describe", "correspond", "estimate", "correspondence"
/// (= correspond + estimate: descriptor matching plus transform fitting) or "total".
/// InvalidArgument for another stage name.
std::vector<double> StageTimesMs(const ExperimentRun& run, const std::string& stage);

struct ExperimentResult {
  ExperimentKind kind = ExperimentKind::kIllumination;
  std::filesystem::path out_dir;
  std::vector<ExperimentRun> runs;  ///< Finished runs, in run order.
  std::string ground_truth;         ///< As written in experiment.json; empty = null.
  std::vector<ExperimentTable> tables;
  bool interrupted = false;  ///< Stopped by the stop flag; `runs` holds the finished ones.
};

/// experiment.json (the contract above).
nlohmann::json ToJson(const ExperimentResult& result);

/// Tables of the illumination experiment from its finished runs: "features" (N_SURF, matched,
/// inliers, frames ok and bridged per k) and "trajectory" (ATE and end-point error vs GPS and vs
/// ground truth, distance to the reference trajectory). Empty rows when no run finished.
std::vector<ExperimentTable> IlluminationTables(const std::vector<ExperimentRun>& runs);
/// Tables of the ransac experiment: "stage_times" (mean, median, 95th percentile per stage and
/// mode), "speedup" (correspondence stage, standard / clustered), "trajectory" (per mode) and
/// "agreement" (distance between the two trajectories, once both finished).
std::vector<ExperimentTable> RansacTables(const std::vector<ExperimentRun>& runs);

/// Where an experiment reports to (all optional).
struct ExperimentCallbacks {
  /// Before run `index` (0-based) of `total` starts: its label and folder (under out_dir).
  std::function<void(int index, int total, const std::string& label, const std::string& dir)>
      run_started;
  /// After every frame of the current run (as RunCallbacks::progress).
  std::function<void(int done, int expected, double fps)> progress;
  /// After a run finished and experiment.json was rewritten.
  std::function<void(int index, int total, const ExperimentRun& run)> run_finished;
};

// ---------------------------------------------------------------------------------------------
// The registry of experiments

/// The options of the experiments that have any; each experiment reads its own.
struct ExperimentOptions {
  IlluminationOptions illumination;  ///< kIllumination.
};

/// One run an experiment plans.
struct PlannedRun {
  std::string label;  ///< As ExperimentRun::label.
  std::string dir;    ///< Folder under out_dir.
  std::string mode;   ///< Correspondence mode of the run.
  double k = 1.0;     ///< Illumination factor of the run.
  RunConfig config;   ///< Everything of the run, `out` included (out_dir / dir).
};

/// One experiment: everything the driver (RunExperiment), experiment.json and the CLI need of
/// it. Its figures are the report's (kExperimentFigures in report/html_report.cc).
struct ExperimentDefinition {
  ExperimentKind kind;
  /// The description of its `aerovo experiment` subcommand.
  const char* help;
  /// The run flags the experiment sets itself, by option key (RunConfig's schema): its command
  /// does not offer them.
  std::vector<std::string> own_run_keys;
  /// Throws InvalidArgument for bad options of the experiment (called before any work).
  void (*validate)(const ExperimentOptions& options);
  /// The runs, in order: input.run with the experiment's parameter changed.
  std::vector<PlannedRun> (*plan)(const ExperimentInput& input, const ExperimentOptions& options);
  /// The tables of experiment.json and tables.md from the finished runs (may be none).
  std::vector<ExperimentTable> (*tables)(const std::vector<ExperimentRun>& runs);
  /// The experiment's parameter in the run's entry of experiment.json ("k" or "mode").
  void (*describe_run)(const ExperimentRun& run, nlohmann::json* entry);
};

/// Every experiment, one per ExperimentKind, in enum order.
const std::vector<ExperimentDefinition>& Experiments();
/// The entry of `kind`.
const ExperimentDefinition& FindExperiment(ExperimentKind kind);

/// Runs experiment `kind` (its plan), writing EXP as above. Stops cleanly when `stop` becomes
/// true (the interrupted run is not listed). Throws InvalidArgument for bad options (before
/// running anything), InputError for unreadable input, OutputError when EXP cannot be written.
ExperimentResult RunExperiment(ExperimentKind kind, const ExperimentInput& input,
                               const ExperimentOptions& options,
                               const ExperimentCallbacks& callbacks = {},
                               const std::atomic<bool>* stop = nullptr);

/// RunExperiment(kIllumination): the flight once per k (RunConfig::illumination_k = k).
ExperimentResult RunIlluminationExperiment(const ExperimentInput& input,
                                           const IlluminationOptions& options,
                                           const ExperimentCallbacks& callbacks = {},
                                           const std::atomic<bool>* stop = nullptr);

/// RunExperiment(kRansac): the flight with mode "standard", then "clustered", everything else
/// equal.
ExperimentResult RunRansacExperiment(const ExperimentInput& input,
                                     const ExperimentCallbacks& callbacks = {},
                                     const std::atomic<bool>* stop = nullptr);

}  // namespace aerovo
