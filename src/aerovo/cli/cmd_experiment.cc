// `aerovo experiment illumination|ransac`: the paper's measurements on any flight (or on a
// simulated one with exact ground truth). The work is in aerovo/pipeline/experiment.h; this file
// maps flags, signals and terminal output onto it, one subcommand per entry of Experiments().
#include <cstdio>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/cli/progress.h"
#include "aerovo/cli/run_cli.h"
#include "aerovo/core/error.h"
#include "aerovo/core/text.h"
#include "aerovo/outputs/run_folder.h"
#include "aerovo/pipeline/experiment.h"
#include "aerovo/report/html_report.h"

namespace aerovo::cli {
namespace {

struct ExperimentArgs {
  ExperimentKind kind = ExperimentKind::kIllumination;
  RunFlags run;
  std::string out = "aerovo-experiment";
  bool simulate = false;
  bool no_report = false;
  std::string k_list;    // illumination
  bool k_given = false;  // --k given (also as "")
  bool scale_threshold = false;
  ExperimentSimulation sim;
  std::string sim_pattern = "lawnmower";
};

// --k's list. An empty item (`--k 1,,0.5`, `--k ""`: an unset shell variable) is an error, not
// skipped: before, `--k ""` ran the default list of five runs without a word.
std::vector<double> ParseKList(const std::string& text) {
  std::vector<double> out;
  std::stringstream ss(text + ",");  // getline drops a last empty item: "1," reads as "1"
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto first = item.find_first_not_of(" \t");
    if (first == std::string::npos) {
      throw InvalidArgument("--k '" + text +
                            "': an empty item (expected numbers separated by commas, e.g. --k "
                            "1,0.5,0.1)");
    }
    item = item.substr(first, item.find_last_not_of(" \t") - first + 1);
    const std::optional<double> v = ParseDecimal(item);
    if (!v) {
      throw InvalidArgument("--k: '" + item + "' is not a number (expected e.g. --k 1,0.5,0.1)");
    }
    out.push_back(*v);
  }
  return out;
}

// The --simulate flags named in the checks of the options they set (sim/*.cc Validate), as
// `aerovo simulate` names its own (cmd_simulate.cc).
const std::vector<std::pair<const char*, const char*>> kSimFlagOfField = {
    {"ortho_mpp", "--mpp"},
    {"nw_lat_deg", "--nw-lat"},
    {"nw_lon_deg", "--nw-lon"},
    {"leg_length_m", "--sim-length-m"},
    {"legs =", "--sim-legs"},
    {"spacing_m", "--sim-spacing-m"},
    {"height_m", "--sim-altitude-m"},
    {"speed_mps", "--sim-speed-mps"},
    {"SimulationOptions: fps", "--sim-fps"},
    {"CameraModel: image size", "--sim-width, --sim-height"},
    {"TerrainOptions: image size",
     "--sim-length-m, --sim-legs, --sim-spacing-m (the terrain fitted "
     "to the flight)"},
    {"hfov_deg", "--sim-hfov-deg"},
    {"noise_sigma_dn", "--sim-noise"},
    {"horizontal_sigma_m", "--sim-gps-noise-m"},
};

// --simulate: checks the simulation flags (InvalidArgument naming the flag; called through
// CheckUsage before the output folder is touched).
void CheckSimulation(ExperimentArgs& a, const ExperimentInput& input) {
  if (!input.run.input.empty()) {
    throw InvalidArgument("give an input flight or --simulate, not both");
  }
  if (!input.run.truth.empty()) {
    throw InvalidArgument("--truth is for a given input; --simulate has its own ground truth");
  }
  try {
    a.sim.sim.flight.pattern = sim::ParseFlightPattern(a.sim_pattern);
    Validate(a.sim);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(NameFlags(e.what(), kSimFlagOfField));
  }
}

// --simulate: simulates the flight (checked by CheckSimulation) into EXP/sim and makes it
// `input`'s flight (video, telemetry, focal length, ground truth).
void SimulateFlight(ExperimentArgs& a, ExperimentInput& input) {
  const bool quiet = input.run.quiet;
  const std::filesystem::path dir = std::filesystem::path(a.out) / "sim";
  if (!quiet)
    fmt::print("aerovo experiment {}: simulating a flight into {}\n", ToString(a.kind),
               dir.string());
  std::fflush(stdout);
  Progress rendering(DefaultProgressStyle(quiet));
  const SimulatedFlight flight = SimulateExperimentFlight(
      a.sim, dir, [&](int done, int total) { rendering.Update(done, total, "  rendering "); });
  rendering.Finish();
  if (!quiet) {
    fmt::print("  {} frames, {:.0f} m flown, focal {:.1f} px; ground truth {}\n", flight.frames,
               flight.distance_m, flight.run.focal_px, flight.ground_truth_csv.string());
    for (const std::string& m : flight.messages) fmt::print("  note: {}\n", m);
  }
  input.run.input = flight.run.input;
  input.run.telemetry = flight.run.telemetry;
  input.run.focal_px = flight.run.focal_px;
  input.run.hfov_deg = 0.0;
  input.run.truth = flight.run.truth;
}

// The tables, the outputs and, unless --no-report or interrupted, the report of `result`.
void PrintOutcome(const ExperimentArgs& a, const ExperimentResult& result) {
  fmt::print("\n");
  for (const ExperimentTable& t : result.tables) fmt::print("{}\n", FormatTableText(t));
  fmt::print("Outputs: {0}/experiment.json, {0}/tables.md, runs in {0}/<", a.out);
  for (std::size_t i = 0; i < result.runs.size(); ++i) {
    fmt::print("{}{}", i ? "|" : "", result.runs[i].dir);
  }
  fmt::print(">/\n");
  if (!a.no_report && !result.interrupted && !result.runs.empty()) {
    try {
      const ReportResult r = WriteReport(a.out);
      for (const std::string& n : r.notes) fmt::print("note: {}\n", n);
      fmt::print("Report: {} ({:.1f} s)\n", r.html.string(), r.seconds);
    } catch (const std::exception& e) {
      fmt::print(stderr, "warning: no report (the experiment's outputs are complete): {}\n",
                 e.what());
    }
  }
}

void Execute(ExperimentArgs& a) {
  ExperimentInput input;
  input.run = CheckUsage([&] { return a.run.Resolve(); });
  input.out_dir = a.out;
  const bool quiet = input.run.quiet;
  // Every option checked before the output folder is touched: a usage error (exit 2) leaves no
  // folder behind (before, the simulation's and the experiment's checks came after the claim).
  ExperimentOptions options;
  CheckUsage([&] {
    if (a.kind == ExperimentKind::kIllumination) {
      if (a.k_given) options.illumination.k = ParseKList(a.k_list);
      options.illumination.scale_threshold = a.scale_threshold;
    }
    FindExperiment(a.kind).validate(options);
    if (a.simulate) {
      CheckSimulation(a, input);
    } else if (input.run.input.empty()) {
      throw InvalidArgument(
          "give an input flight (as for aerovo run: video, photo folder, with --telemetry, "
          "--altitude, ... as needed) or --simulate to make one");
    }
  });
  // Like aerovo run: one experiment at a time in a folder, a new or empty folder unless --force
  // (which removes what an earlier experiment wrote: experiment.json, tables.md, the report,
  // its run and sim folders; other files are kept).
  const RunFolderLock lock(a.out);
  const ClaimResult claim = ClaimOutputFolder(
      a.out, input.run.force,
      OwnEntries(a.out, {"experiment.json", "tables.md", "report.html", "figures", "mosaic.jpg",
                         "sim"}),
      "aerovo experiment");
  if (!claim.removed.empty()) {
    fmt::print(stderr, "aerovo experiment: --force: removed from '{}': {}\n", a.out,
               fmt::join(claim.removed, ", "));
  }
  if (a.simulate) SimulateFlight(a, input);

  Progress progress(DefaultProgressStyle(quiet));
  std::string prefix;
  ExperimentCallbacks cb;
  cb.run_started = [&](int i, int total, const std::string& label, const std::string& dir) {
    prefix = fmt::format("run {}/{} {} ", i + 1, total, label);
    if (!quiet) {
      fmt::print("{}-> {}\n", prefix, (std::filesystem::path(a.out) / dir).string());
      std::fflush(stdout);
    }
  };
  if (progress.enabled()) {
    cb.progress = [&](int done, int expected, double fps) {
      progress.Update(done, expected, fps, prefix);
    };
  }
  cb.run_finished = [&](int, int, const ExperimentRun& r) {
    progress.Finish();
    if (quiet) return;
    const RunSummary& s = r.summary;
    fmt::print("  {}: {} frames (ok {}, bridged {}), {:.1f} s{}\n", r.label, s.frames_processed,
               s.frames_ok, s.frames_bridged, s.wall_s,
               s.evaluation
                   ? fmt::format(", ATE vs GPS SE(2) {:.2f} m, Sim(2) {:.2f} m",
                                 s.evaluation->se2.ate_m.rmse, s.evaluation->sim2.ate_m.rmse)
                   : std::string(", no comparison with GPS"));
    std::fflush(stdout);
  };

  int signal = 0;
  const ExperimentResult result = WithStopSignals(&signal, [&](const std::atomic<bool>* stop) {
    return RunExperiment(a.kind, input, options, cb, stop);
  });
  if (result.interrupted) {
    progress.Finish();
    fmt::print("aerovo experiment: stopped by signal {}; {} finished run(s) kept in '{}'\n", signal,
               result.runs.size(), a.out);
  }
  PrintOutcome(a, result);
  std::fflush(stdout);
  if (result.interrupted) std::exit(StopSignals::ExitCode(signal));
}

void AddExperiment(CLI::App* parent, const ExperimentDefinition& def) {
  auto args = std::make_shared<ExperimentArgs>();
  ExperimentArgs& a = *args;
  a.kind = def.kind;
  CLI::App* cmd = parent->add_subcommand(ToString(def.kind), def.help);
  // The experiment sets its own parameter and output folders.
  std::set<std::string> own_keys(def.own_run_keys.begin(), def.own_run_keys.end());
  own_keys.insert("out");
  AddRunFlags(cmd, a.run, own_keys);
  cmd->add_option("-o,--out", a.out,
                  "Experiment folder EXP (experiment.json, tables.md, one "
                  "run folder per run)")
      ->capture_default_str();
  if (def.kind == ExperimentKind::kIllumination) {
    cmd->add_option("--k", a.k_list,
                    "Illumination factors, comma separated, each in (0, 1] (default "
                    "1,0.75,0.5,0.25,0.1)")
        ->each([&a](const std::string&) { a.k_given = true; });
    cmd->add_flag("--scale-threshold", a.scale_threshold,
                  "SURF threshold x k^2 in each run (the Hessian determinant scales with k^2); "
                  "default: the same threshold for every k, as the paper");
  }
  cmd->add_flag("--no-report", a.no_report,
                "Do not write EXP/report.html and figures/ (aerovo report EXP does it later)");
  // Simulated flight.
  CLI::Option* sim = cmd->add_flag(
      "--simulate", a.simulate,
      "No input: simulate a flight into EXP/sim (built-in terrain or --ortho; default lawnmower "
      "3 x 300 m at 100 m, 1280x720, 3 fps, ~320 frames) and use its exact ground truth");
  sim::SimulationOptions& so = a.sim.sim;
  const auto simopt = [&](const std::string& name, auto& value, const std::string& text) {
    cmd->add_option(name, value, text)->capture_default_str()->needs(sim);
  };
  simopt("--ortho", a.sim.ortho, "Simulate over this orthophoto (north-up) instead of the terrain");
  simopt("--mpp", a.sim.ortho_mpp, "Orthophoto metres per pixel");
  simopt("--nw-lat", a.sim.nw_lat_deg, "Latitude of the ground image's north-west corner, deg");
  simopt("--nw-lon", a.sim.nw_lon_deg, "Longitude of the north-west corner, deg");
  simopt("--ground-alt-m", a.sim.ground_alt_m, "Ground altitude above MSL, m");
  simopt("--terrain-seed", a.sim.terrain_seed, "Seed of the built-in terrain");
  simopt("--sim-pattern", a.sim_pattern, "line | lawnmower | turns");
  simopt("--sim-legs", so.flight.legs, "Number of legs");
  simopt("--sim-length-m", so.flight.leg_length_m, "Length of each leg, m");
  simopt("--sim-spacing-m", so.flight.spacing_m, "Lawnmower leg spacing, m");
  simopt("--sim-altitude-m", so.flight.height_m, "Height above ground, m");
  simopt("--sim-speed-mps", so.flight.speed_mps, "Ground speed, m/s");
  simopt("--sim-fps", so.fps, "Frame rate of the simulated video");
  simopt("--sim-width", so.camera.width_px, "Image width, px");
  simopt("--sim-height", so.camera.height_px, "Image height, px");
  simopt("--sim-hfov-deg", so.camera.hfov_deg, "Horizontal field of view, deg");
  simopt("--sim-noise", so.effects.noise_sigma_dn, "Sensor noise sigma, DN");
  simopt("--sim-gps-noise-m", so.gps.horizontal_sigma_m, "GPS horizontal error sigma per axis, m");
  simopt("--sim-seed", so.seed, "Seed of the simulation's noise");
  cmd->callback([args] { Execute(*args); });
}

void RegisterExperimentCommand(CLI::App& app) {
  CLI::App* exp = app.add_subcommand(
      "experiment",
      "The paper's experiments on a flight (or a simulated one): illumination (Fig. 4-6) and "
      "standard vs clustered RANSAC (Fig. 7-8)");
  exp->require_subcommand(1);
  for (const ExperimentDefinition& def : Experiments()) AddExperiment(exp, def);
}

}  // namespace

AEROVO_REGISTER_COMMAND(RegisterExperimentCommand);

}  // namespace aerovo::cli
