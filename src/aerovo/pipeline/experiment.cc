#include "aerovo/pipeline/experiment.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/sim/ground.h"
#include "aerovo/sim/sim_writer.h"
#include "aerovo/telemetry/reference_track.h"

namespace aerovo {

// ---------------------------------------------------------------------------------------------
// Statistics

namespace {
void CheckValues(const std::vector<double>& values, const char* what) {
  if (values.empty()) throw InvalidArgument(std::string(what) + ": no values");
  for (double v : values) {
    if (!std::isfinite(v)) throw InvalidArgument(std::string(what) + ": a value is not finite");
  }
}
}  // namespace

double Mean(const std::vector<double>& values) {
  CheckValues(values, "Mean");
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum / static_cast<double>(values.size());
}

double StdDev(const std::vector<double>& values) {
  CheckValues(values, "StdDev");
  const double m = Mean(values);
  double ss = 0.0;
  for (double v : values) ss += (v - m) * (v - m);
  return std::sqrt(ss / static_cast<double>(values.size()));
}

double Percentile(std::vector<double> values, double p) {
  CheckValues(values, "Percentile");
  if (!(p >= 0.0 && p <= 100.0)) {
    throw InvalidArgument(fmt::format("Percentile: p must be in [0, 100], got {}", p));
  }
  std::sort(values.begin(), values.end());
  const double h = (static_cast<double>(values.size()) - 1.0) * p / 100.0;
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (h - static_cast<double>(lo)) * (values[hi] - values[lo]);
}


// ---------------------------------------------------------------------------------------------
// Tables

namespace {

TableCell Text(std::string text) { return TableCell{std::move(text), std::nullopt}; }
TableCell NotAvailable() { return Text("-"); }

// A number shown with `decimals` decimals; the JSON number is rounded the same way.
TableCell Num(double value, int decimals) {
  if (!std::isfinite(value)) return NotAvailable();
  const double scale = std::pow(10.0, decimals);
  double rounded = std::round(value * scale) / scale;
  if (rounded == 0.0) rounded = 0.0;  // no "-0.00"
  return TableCell{fmt::format("{:.{}f}", rounded, decimals), rounded};
}

TableCell Int(long long value) {
  return TableCell{std::to_string(value), static_cast<double>(value), true};
}

std::vector<std::size_t> ColumnWidths(const ExperimentTable& t) {
  std::vector<std::size_t> w(t.columns.size(), 0);
  for (std::size_t c = 0; c < t.columns.size(); ++c) w[c] = t.columns[c].size();
  for (const auto& row : t.rows) {
    for (std::size_t c = 0; c < row.size() && c < w.size(); ++c) {
      w[c] = std::max(w[c], row[c].text.size());
    }
  }
  return w;
}

// Greedy word wrap at `width` columns; every line ends with '\n'.
std::string Wrap(const std::string& text, std::size_t width) {
  std::stringstream ss(text);
  std::string word, line, out;
  while (ss >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      out += line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) out += line + "\n";
  return out;
}

}  // namespace

std::string FormatTableText(const ExperimentTable& t) {
  const std::vector<std::size_t> w = ColumnWidths(t);
  std::string out = t.title + "\n";
  auto line = [&](const std::vector<std::string>& cells) {
    std::string l;
    for (std::size_t c = 0; c < cells.size(); ++c) {
      // First column (the label) left-aligned, figures right-aligned.
      l += c == 0 ? fmt::format("{:<{}}", cells[c], w[c]) : fmt::format("  {:>{}}", cells[c], w[c]);
    }
    while (!l.empty() && l.back() == ' ') l.pop_back();
    return l + "\n";
  };
  out += line(t.columns);
  std::size_t total = 0;
  for (std::size_t c = 0; c < w.size(); ++c) total += w[c] + (c == 0 ? 0 : 2);
  out += std::string(total, '-') + "\n";
  for (const auto& row : t.rows) {
    std::vector<std::string> cells;
    for (const TableCell& cell : row) cells.push_back(cell.text);
    out += line(cells);
  }
  if (!t.note.empty()) out += Wrap(t.note, 100);
  return out;
}

std::string FormatTableMarkdown(const ExperimentTable& t) {
  std::string out = "### " + t.title + "\n\n|";
  for (const std::string& c : t.columns) out += " " + c + " |";
  out += "\n|";
  for (std::size_t c = 0; c < t.columns.size(); ++c) out += c == 0 ? "---|" : "---:|";
  out += "\n";
  for (const auto& row : t.rows) {
    out += "|";
    for (const TableCell& cell : row) out += " " + cell.text + " |";
    out += "\n";
  }
  if (!t.note.empty()) out += "\n" + t.note + "\n";
  return out + "\n";
}

// ---------------------------------------------------------------------------------------------
// Inputs

sim::SimulationOptions DefaultExperimentSimulation() {
  sim::SimulationOptions o;
  o.fps = 3.0;
  return o;
}

namespace {

// The experiment's ground as `aerovo simulate` sets it up (sim/ground.h): the terrain fitted to
// the flight, or the orthophoto.
sim::GroundOptions GroundOf(const ExperimentSimulation& o) {
  sim::GroundOptions g;
  g.ortho = o.ortho;
  g.ortho_mpp = o.ortho_mpp;
  g.nw_lat_deg = o.nw_lat_deg;
  g.nw_lon_deg = o.nw_lon_deg;
  g.ground_alt_m = o.ground_alt_m;
  g.terrain_seed = o.terrain_seed;
  return g;
}

}  // namespace

void Validate(const ExperimentSimulation& o) {
  sim::Validate(o.sim);
  const sim::GroundOptions ground = GroundOf(o);
  sim::Validate(ground);
  // The flight's frame count and the terrain fitted to its view (made only after the
  // experiment's folder otherwise).
  const sim::TerrainOptions terrain = sim::TerrainOptionsOf(ground, o.sim);
  if (ground.ortho.empty()) sim::Validate(terrain);
}

SimulatedFlight SimulateExperimentFlight(const ExperimentSimulation& options,
                                         const std::filesystem::path& dir,
                                         const std::function<void(int, int)>& progress) {
  Validate(options);
  const sim::Simulator simulator(sim::MakeGround(GroundOf(options), options.sim), options.sim);
  sim::WriterOptions w;
  // A video (H.264, as a drone records): its frames carry their times (index / fps), which the
  // runner matches with the telemetry and the ground truth; a JPEG folder has no frame times.
  w.write_video = true;
  const sim::SimulationOutput out = sim::WriteSimulation(simulator, w, dir, progress);
  const sim::SimulationManifest m = sim::ReadSimulationManifest(dir / out.json_file);

  SimulatedFlight f;
  f.dir = std::filesystem::absolute(dir);
  f.ground_truth_csv = m.csv;
  f.run.input = m.video.string();
  f.run.telemetry = m.srt.string();
  f.run.focal_px = m.focal_px;
  f.run.truth = m.csv.string();
  f.frames = m.frame_count;
  f.distance_m = m.distance_m;
  f.messages = out.messages;
  return f;
}

// ---------------------------------------------------------------------------------------------
// Experiments: shared pieces

void Validate(const IlluminationOptions& o) {
  if (o.k.empty()) throw InvalidArgument("illumination: the list of k is empty");
  std::set<std::string> labels;
  for (double k : o.k) {
    if (!(k > 0.0 && k <= 1.0)) {
      throw InvalidArgument(fmt::format("illumination: k must be in (0, 1], got {}", k));
    }
    if (!labels.insert(IlluminationDir(k)).second) {
      throw InvalidArgument(fmt::format("illumination: k = {} is listed twice", k));
    }
  }
}

namespace {
std::string KText(double k) {
  const std::string two = fmt::format("{:.2f}", k);
  if (std::abs(std::stod(two) - k) < 1e-9) return two;
  return fmt::format("{:.6g}", k);
}
}  // namespace

std::string IlluminationLabel(double k) { return "k=" + KText(k); }
std::string IlluminationDir(double k) { return "k" + KText(k); }

TrajectoryDistance DistanceByFrame(const std::vector<FrameRecord>& a,
                                   const std::vector<FrameRecord>& b) {
  std::map<int, const FrameRecord*> by_frame;
  for (const FrameRecord& r : b) by_frame[r.frame] = &r;
  TrajectoryDistance d;
  double ss = 0.0;
  for (const FrameRecord& r : a) {
    const auto it = by_frame.find(r.frame);
    if (it == by_frame.end()) continue;
    const double dist = std::hypot(r.x_m - it->second->x_m, r.y_m - it->second->y_m);
    ss += dist * dist;
    d.max_m = std::max(d.max_m, dist);
    ++d.count;
  }
  if (d.count == 0) throw InvalidArgument("DistanceByFrame: the trajectories share no frame");
  d.rms_m = std::sqrt(ss / d.count);
  return d;
}

double DistanceFlownM(const ExperimentRun& run) {
  if (run.summary.truth_evaluation) return run.summary.truth_evaluation->se2.distance_flown_m;
  if (run.summary.evaluation) return run.summary.evaluation->se2.distance_flown_m;
  return run.summary.vo_path_length_m;
}

std::vector<double> StageTimesMs(const ExperimentRun& run, const std::string& stage) {
  double FrameRecord::*field = nullptr;
  if (stage == "detect") field = &FrameRecord::detect_ms;
  if (stage == "describe") field = &FrameRecord::describe_ms;
  if (stage == "correspond") field = &FrameRecord::correspond_ms;
  if (stage == "estimate") field = &FrameRecord::estimate_ms;
  if (stage == "total") field = &FrameRecord::total_ms;
  if (field == nullptr && stage != "correspondence") {
    throw InvalidArgument("StageTimesMs: unknown stage '" + stage + "'");
  }
  std::vector<double> out;
  for (std::size_t i = 1; i < run.frames.size(); ++i) {
    const FrameRecord& r = run.frames[i];
    out.push_back(field != nullptr ? r.*field : r.correspond_ms + r.estimate_ms);
  }
  return out;
}

nlohmann::json ToJson(const ExperimentResult& r) {
  nlohmann::json runs = nlohmann::json::array();
  for (const ExperimentRun& run : r.runs) {
    nlohmann::json j{{"label", run.label}, {"dir", run.dir}};
    FindExperiment(r.kind).describe_run(run, &j);
    runs.push_back(j);
  }
  nlohmann::json tables = nlohmann::json::object();
  for (const ExperimentTable& t : r.tables) {
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& row : t.rows) {
      nlohmann::json cells = nlohmann::json::array();
      for (const TableCell& c : row) {
        if (c.number && c.integer) {
          cells.push_back(static_cast<long long>(*c.number));
        } else if (c.number) {
          cells.push_back(*c.number);
        } else {
          cells.push_back(c.text);
        }
      }
      rows.push_back(cells);
    }
    tables[t.name] = {{"columns", t.columns}, {"rows", rows}};
  }
  return nlohmann::json{
      {"kind", ToString(r.kind)},
      {"runs", runs},
      {"ground_truth", r.ground_truth.empty() ? nlohmann::json() : nlohmann::json(r.ground_truth)},
      {"tables", tables}};
}

namespace {

std::vector<double> Column(const std::vector<FrameRecord>& frames, int FrameRecord::*field,
                           bool steps_only) {
  std::vector<double> out;
  for (std::size_t i = steps_only ? 1 : 0; i < frames.size(); ++i) out.push_back(frames[i].*field);
  return out;
}

TableCell MeanCell(const std::vector<double>& v, int decimals) {
  return v.empty() ? NotAvailable() : Num(Mean(v), decimals);
}
TableCell MedianCell(const std::vector<double>& v, int decimals) {
  return v.empty() ? NotAvailable() : Num(Median(v), decimals);
}

// ATE and end-point columns of one run (vs GPS, and vs ground truth when any run has it).
void TrajectoryCells(const ExperimentRun& run, bool with_gt, std::vector<TableCell>* row) {
  const auto& e = run.summary.evaluation;
  row->push_back(e ? Num(e->se2.ate_m.rmse, 2) : NotAvailable());
  row->push_back(e ? Num(e->sim2.ate_m.rmse, 2) : NotAvailable());
  row->push_back(e ? Num(e->se2.end_point_error_percent, 2) : NotAvailable());
  if (with_gt) {
    const auto& g = run.summary.truth_evaluation;
    row->push_back(g ? Num(g->se2.ate_m.rmse, 2) : NotAvailable());
    row->push_back(g ? Num(g->sim2.ate_m.rmse, 2) : NotAvailable());
    row->push_back(g ? Num(g->se2.end_point_error_percent, 2) : NotAvailable());
  }
}

void TrajectoryColumns(bool with_gt, std::vector<std::string>* cols) {
  for (const char* c : {"ATE GPS SE(2) m", "ATE GPS Sim(2) m", "end-point GPS %"}) {
    cols->push_back(c);
  }
  if (with_gt) {
    for (const char* c : {"ATE GT SE(2) m", "ATE GT Sim(2) m", "end-point GT %"}) {
      cols->push_back(c);
    }
  }
}

const char* kTrajectoryNote =
    "ATE = RMS absolute trajectory error after Umeyama alignment (SE(2): rotation + translation; "
    "Sim(2): + scale) against GPS, and against the ground truth (GT: --truth, or the exact "
    "ground truth of a simulated flight, as each run compares it: truth_evaluation in its "
    "summary.json); end-point = error at the last frame after SE(2) alignment, % of the distance "
    "flown.";

bool AnyGroundTruth(const std::vector<ExperimentRun>& runs) {
  return std::any_of(runs.begin(), runs.end(),
                     [](const ExperimentRun& r) { return r.summary.truth_evaluation.has_value(); });
}

}  // namespace

std::vector<ExperimentTable> IlluminationTables(const std::vector<ExperimentRun>& runs) {
  ExperimentTable features;
  features.name = "features";
  features.title = "Interest points and matches per illumination factor k (paper Fig. 4-5)";
  features.columns = {"k",
                      "SURF threshold",
                      "frames",
                      "N_SURF mean",
                      "N_SURF median",
                      "matched mean",
                      "matched median",
                      "inliers mean",
                      "inliers median",
                      "frames ok",
                      "bridged"};
  features.note =
      "N_SURF over every processed frame; matched (putative descriptor matches with the previous "
      "frame) and inliers (of the accepted transform) over the steps (frames after the first). "
      "frames ok includes the first frame; bridged = steps that failed and were bridged with the "
      "motion prior.";
  const bool with_gt = AnyGroundTruth(runs);
  const ExperimentRun* ref = nullptr;
  for (const ExperimentRun& r : runs) {
    if (ref == nullptr || r.k > ref->k) ref = &r;
  }
  ExperimentTable traj;
  traj.name = "trajectory";
  traj.title = "Trajectory per illumination factor k (paper Fig. 6)";
  traj.columns = {"k"};
  TrajectoryColumns(with_gt, &traj.columns);
  const std::string ref_label = ref ? IlluminationLabel(ref->k) : "k=1.00";
  for (const char* c : {"RMS m", "max m", "RMS %", "max %"}) {
    traj.columns.push_back("vs " + ref_label + " " + c);
  }
  traj.note = std::string(kTrajectoryNote) + " vs " + ref_label +
              ": distance between this run's and the reference run's positions as written "
              "(frames.csv, same ENU frame, no alignment), paired by frame; % of the distance "
              "flown (ground truth, else GPS, else VO path length).";

  for (const ExperimentRun& r : runs) {
    const std::vector<double> n_surf = Column(r.frames, &FrameRecord::n_surf, false);
    const std::vector<double> matched = Column(r.frames, &FrameRecord::n_matched, true);
    const std::vector<double> inliers = Column(r.frames, &FrameRecord::n_inliers, true);
    features.rows.push_back({TableCell{KText(r.k), r.k}, Num(r.config.odometry.surf.hessian_threshold, 1),
                             Int(r.summary.frames_processed), MeanCell(n_surf, 1),
                             MedianCell(n_surf, 1), MeanCell(matched, 1), MedianCell(matched, 1),
                             MeanCell(inliers, 1), MedianCell(inliers, 1), Int(r.summary.frames_ok),
                             Int(r.summary.frames_bridged)});
    std::vector<TableCell> row{TableCell{KText(r.k), r.k}};
    TrajectoryCells(r, with_gt, &row);
    std::optional<TrajectoryDistance> d;
    try {
      d = DistanceByFrame(r.frames, ref->frames);
    } catch (const InvalidArgument&) {
    }
    const double flown = DistanceFlownM(*ref);
    if (d) {
      row.push_back(Num(d->rms_m, 2));
      row.push_back(Num(d->max_m, 2));
      row.push_back(flown > 0 ? Num(100.0 * d->rms_m / flown, 2) : NotAvailable());
      row.push_back(flown > 0 ? Num(100.0 * d->max_m / flown, 2) : NotAvailable());
    } else {
      for (int i = 0; i < 4; ++i) row.push_back(NotAvailable());
    }
    traj.rows.push_back(std::move(row));
  }
  return {features, traj};
}

namespace {

// RansacTables' "stage_times": mean, median and p95 of each stage's time per step, per run.
ExperimentTable StageTimesTable(const std::vector<ExperimentRun>& runs) {
  static const char* kStages[] = {"detect",   "describe",       "correspond",
                                  "estimate", "correspondence", "total"};
  ExperimentTable stages;
  stages.name = "stage_times";
  stages.title = "Time of each stage per step, ms (paper Fig. 7-8)";
  stages.columns = {"stage"};
  for (const ExperimentRun& r : runs) {
    for (const char* s : {"mean", "median", "p95"}) stages.columns.push_back(r.label + " " + s);
  }
  stages.note =
      "Per step (every processed frame after the first). detect = SURF interest points, describe "
      "= SURF descriptors, correspond = descriptor matching, estimate = transform fitting "
      "(RANSAC/MSAC), correspondence = correspond + estimate (the paper's correspondence stage), "
      "total = the whole frame. p95 = 95th percentile (linear interpolation).";
  for (const char* stage : kStages) {
    std::vector<TableCell> row{Text(stage)};
    for (const ExperimentRun& r : runs) {
      const std::vector<double> t = StageTimesMs(r, stage);
      row.push_back(MeanCell(t, 2));
      row.push_back(MedianCell(t, 2));
      row.push_back(t.empty() ? NotAvailable() : Num(Percentile(t, 95.0), 2));
    }
    stages.rows.push_back(std::move(row));
  }
  return stages;
}

// RansacTables' "speedup": statistics of the correspondence-stage time per step of the standard
// and the clustered run (either may be null: its cells are then not available).
ExperimentTable SpeedupTable(const ExperimentRun* standard, const ExperimentRun* clustered) {
  ExperimentTable speed;
  speed.name = "speedup";
  speed.title = "Correspondence stage (matching + RANSAC) per step: standard vs clustered RANSAC";
  speed.columns = {"statistic", "standard ms", "clustered ms", "speed-up"};
  speed.note =
      "speed-up = standard / clustered, of the statistic of the per-step correspondence-stage "
      "time (correspond + estimate). std dev = population standard deviation (the paper: the "
      "clustered stage is also the least variable).";
  if (standard != nullptr || clustered != nullptr) {
    const std::vector<double> s =
        standard ? StageTimesMs(*standard, "correspondence") : std::vector<double>{};
    const std::vector<double> c =
        clustered ? StageTimesMs(*clustered, "correspondence") : std::vector<double>{};
    const std::pair<const char*, double (*)(const std::vector<double>&)> stats[] = {
        {"mean", [](const std::vector<double>& v) { return Mean(v); }},
        {"median", [](const std::vector<double>& v) { return Median(v); }},
        {"p95", [](const std::vector<double>& v) { return Percentile(v, 95.0); }},
        {"std dev", [](const std::vector<double>& v) { return StdDev(v); }}};
    for (const auto& [name, f] : stats) {
      const double a = s.empty() ? NAN : f(s);
      const double b = c.empty() ? NAN : f(c);
      speed.rows.push_back(
          {Text(name), Num(a, 3), Num(b, 3),
           (std::isfinite(a) && std::isfinite(b) && b > 0) ? Num(a / b, 2) : NotAvailable()});
    }
  }
  return speed;
}

// RansacTables' "trajectory": frame counts, mean matches and inliers and the trajectory columns
// of each run.
ExperimentTable ModeTrajectoryTable(const std::vector<ExperimentRun>& runs) {
  const bool with_gt = AnyGroundTruth(runs);
  ExperimentTable traj;
  traj.name = "trajectory";
  traj.title = "Trajectory per correspondence mode";
  traj.columns = {"mode", "frames", "frames ok", "bridged", "matched mean", "inliers mean"};
  TrajectoryColumns(with_gt, &traj.columns);
  traj.note = kTrajectoryNote;
  for (const ExperimentRun& r : runs) {
    std::vector<TableCell> row{Text(r.mode),
                               Int(r.summary.frames_processed),
                               Int(r.summary.frames_ok),
                               Int(r.summary.frames_bridged),
                               MeanCell(Column(r.frames, &FrameRecord::n_matched, true), 1),
                               MeanCell(Column(r.frames, &FrameRecord::n_inliers, true), 1)};
    TrajectoryCells(r, with_gt, &row);
    traj.rows.push_back(std::move(row));
  }
  return traj;
}

// RansacTables' "agreement": the distance between the clustered and the standard run's
// positions, paired by frame (no row unless both ran and share frames).
ExperimentTable AgreementTable(const ExperimentRun* standard, const ExperimentRun* clustered) {
  ExperimentTable agree;
  agree.name = "agreement";
  agree.title = "How far apart the two trajectories are";
  agree.columns = {"compared", "frames", "RMS m", "max m", "RMS %", "max %"};
  agree.note =
      "Distance between the positions as written (frames.csv, same ENU frame, no alignment), "
      "paired by frame; % of the distance flown (ground truth, else GPS, else VO path length).";
  if (standard != nullptr && clustered != nullptr) {
    try {
      const TrajectoryDistance d = DistanceByFrame(clustered->frames, standard->frames);
      const double flown = DistanceFlownM(*standard);
      agree.rows.push_back({Text("clustered vs standard"), Int(d.count), Num(d.rms_m, 2),
                            Num(d.max_m, 2),
                            flown > 0 ? Num(100.0 * d.rms_m / flown, 2) : NotAvailable(),
                            flown > 0 ? Num(100.0 * d.max_m / flown, 2) : NotAvailable()});
    } catch (const InvalidArgument&) {
    }
  }
  return agree;
}

}  // namespace

std::vector<ExperimentTable> RansacTables(const std::vector<ExperimentRun>& runs) {
  const ExperimentRun* standard = nullptr;
  const ExperimentRun* clustered = nullptr;
  for (const ExperimentRun& r : runs) {
    if (r.mode == "standard") standard = &r;
    if (r.mode == "clustered") clustered = &r;
  }
  return {StageTimesTable(runs), SpeedupTable(standard, clustered), ModeTrajectoryTable(runs),
          AgreementTable(standard, clustered)};
}

// ---------------------------------------------------------------------------------------------
// Experiments: the driver

namespace {

void WriteOutputs(const ExperimentResult& result) {
  WriteJsonFileAtomic(result.out_dir / "experiment.json", ToJson(result));
  std::string md = fmt::format("## Experiment: {}\n\nRuns: ", ToString(result.kind));
  for (std::size_t i = 0; i < result.runs.size(); ++i) {
    md += (i ? ", " : "") + result.runs[i].label + " (`" + result.runs[i].dir + "/`)";
  }
  if (result.runs.empty()) md += "none finished";
  md += result.interrupted ? " (interrupted)\n\n" : "\n\n";
  for (const ExperimentTable& t : result.tables) md += FormatTableMarkdown(t);
  WriteTextFileAtomic(result.out_dir / "tables.md", md);
}

// Whether `path` is a simulator ground_truth.csv (the contract's "ground_truth"; other truth
// files, e.g. TUM, are compared with by the runner but not listed).
bool IsGroundTruthCsv(const std::string& path) {
  try {
    ReadGroundTruthCsv(path);
    return true;
  } catch (const InputError&) {
    return false;
  }
}

// Runs `plan` of experiment `def`, writing EXP after every finished run.
ExperimentResult RunPlanned(const ExperimentDefinition& def, const ExperimentInput& input,
                            const std::vector<PlannedRun>& plan, const ExperimentCallbacks& cb,
                            const std::atomic<bool>* stop) {
  const auto tables = def.tables;
  namespace fs = std::filesystem;
  if (input.out_dir.empty()) throw InvalidArgument("experiment: the output folder is empty");
  for (const PlannedRun& p : plan) Validate(p.config);  // every bad option before any work

  ExperimentResult result;
  result.kind = def.kind;
  result.out_dir = input.out_dir;
  std::error_code ec;
  fs::create_directories(input.out_dir, ec);
  if (ec) {
    throw OutputError("cannot create output folder '" + input.out_dir.string() +
                      "': " + ec.message());
  }
  result.tables = tables(result.runs);
  WriteOutputs(result);

  const int total = static_cast<int>(plan.size());
  for (int i = 0; i < total; ++i) {
    if (stop != nullptr && stop->load()) {
      result.interrupted = true;
      break;
    }
    const PlannedRun& p = plan[static_cast<std::size_t>(i)];
    if (cb.run_started) cb.run_started(i, total, p.label, p.dir);
    ExperimentRun run;
    run.label = p.label;
    run.dir = p.dir;
    run.k = p.k;
    run.mode = p.mode;
    run.config = p.config;
    RunCallbacks rc;
    rc.progress = cb.progress;
    rc.frame = [&run](const FrameRecord& r) { run.frames.push_back(r); };
    run.summary = RunFlight(p.config, rc, stop);
    if (run.summary.interrupted) {
      result.interrupted = true;
      break;
    }
    if (result.ground_truth.empty() && !run.summary.truth.empty() &&
        IsGroundTruthCsv(run.summary.truth)) {
      // The truth the runs used (given, or found from a simulated flight's sim.json): relative
      // to EXP when inside it (the folder stays movable), else absolute.
      const fs::path gt = fs::weakly_canonical(fs::absolute(run.summary.truth));
      const fs::path exp = fs::weakly_canonical(fs::absolute(input.out_dir));
      const fs::path rel = gt.lexically_relative(exp);
      const bool inside = !rel.empty() && *rel.begin() != "..";
      result.ground_truth = inside ? rel.generic_string() : gt.string();
    }
    result.runs.push_back(std::move(run));
    result.tables = tables(result.runs);
    WriteOutputs(result);
    if (cb.run_finished) cb.run_finished(i, total, result.runs.back());
  }
  if (result.interrupted) WriteOutputs(result);
  return result;
}

// The runs of the illumination experiment: one per k.
std::vector<PlannedRun> PlanIllumination(const ExperimentInput& input,
                                         const ExperimentOptions& experiment) {
  const IlluminationOptions& options = experiment.illumination;
  std::vector<PlannedRun> plan;
  for (double k : options.k) {
    PlannedRun p;
    p.k = k;
    p.label = IlluminationLabel(k);
    p.dir = IlluminationDir(k);
    p.config = input.run;
    p.config.illumination_k = k;
    if (options.scale_threshold) {
      p.config.odometry.surf.hessian_threshold = input.run.odometry.surf.hessian_threshold * k * k;
    }
    p.config.out = (input.out_dir / p.dir).string();
    p.mode = options::EnumName(p.config.odometry.correspondence.method);
    plan.push_back(std::move(p));
  }
  return plan;
}

// The runs of the ransac experiment: standard, then clustered.
std::vector<PlannedRun> PlanRansac(const ExperimentInput& input, const ExperimentOptions&) {
  std::vector<PlannedRun> plan;
  for (const CorrespondenceMethod method :
       {CorrespondenceMethod::kStandard, CorrespondenceMethod::kClustered}) {
    PlannedRun p;
    p.mode = p.label = p.dir = options::EnumName(method);
    p.config = input.run;
    p.config.odometry.correspondence.method = method;
    p.config.out = (input.out_dir / p.dir).string();
    p.k = p.config.illumination_k;
    plan.push_back(std::move(p));
  }
  return plan;
}

}  // namespace

const std::vector<ExperimentDefinition>& Experiments() {
  static const std::vector<ExperimentDefinition> kExperiments = {
      {ExperimentKind::kIllumination,
       "Run the flight with brightness f_k = k f for each k; N_SURF, matches, inliers, ATE per k "
       "and the distance of each trajectory from the k = 1 one",
       {"illumination_k"},
       [](const ExperimentOptions& o) { Validate(o.illumination); },
       PlanIllumination,
       IlluminationTables,
       [](const ExperimentRun& run, nlohmann::json* entry) { (*entry)["k"] = run.k; }},
      {ExperimentKind::kRansac,
       "Run the flight with standard and with clustered RANSAC; time of each stage per step, "
       "speed-up of the correspondence stage, ATE and trajectory distance",
       {"mode"},
       [](const ExperimentOptions&) {},
       PlanRansac,
       RansacTables,
       [](const ExperimentRun& run, nlohmann::json* entry) { (*entry)["mode"] = run.mode; }},
  };
  return kExperiments;
}

const ExperimentDefinition& FindExperiment(ExperimentKind kind) {
  for (const ExperimentDefinition& def : Experiments()) {
    if (def.kind == kind) return def;
  }
  throw InternalError(std::string("experiment '") + ToString(kind) + "' has no registry entry");
}

ExperimentResult RunExperiment(ExperimentKind kind, const ExperimentInput& input,
                               const ExperimentOptions& options,
                               const ExperimentCallbacks& callbacks,
                               const std::atomic<bool>* stop) {
  const ExperimentDefinition& def = FindExperiment(kind);
  def.validate(options);
  return RunPlanned(def, input, def.plan(input, options), callbacks, stop);
}

ExperimentResult RunIlluminationExperiment(const ExperimentInput& input,
                                           const IlluminationOptions& options,
                                           const ExperimentCallbacks& callbacks,
                                           const std::atomic<bool>* stop) {
  ExperimentOptions o;
  o.illumination = options;
  return RunExperiment(ExperimentKind::kIllumination, input, o, callbacks, stop);
}

ExperimentResult RunRansacExperiment(const ExperimentInput& input,
                                     const ExperimentCallbacks& callbacks,
                                     const std::atomic<bool>* stop) {
  return RunExperiment(ExperimentKind::kRansac, input, ExperimentOptions{}, callbacks, stop);
}

}  // namespace aerovo
