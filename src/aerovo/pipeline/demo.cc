#include "aerovo/pipeline/demo.h"
#include "aerovo/core/text.h"

#include <cmath>
#include <fstream>
#include <utility>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/report/html_report.h"

namespace aerovo {

ExperimentSimulation DemoSimulation(bool quick) {
  ExperimentSimulation s;
  sim::SimulationOptions& o = s.sim;
  o.flight.pattern = sim::FlightPattern::kLawnmower;
  o.flight.legs = quick ? 2 : 3;
  o.flight.leg_length_m = quick ? 100.0 : 250.0;
  o.flight.spacing_m = quick ? 40.0 : 50.0;
  o.flight.height_m = 100.0;
  o.flight.speed_mps = 10.0;
  o.camera.width_px = quick ? 640 : 960;
  o.camera.height_px = quick ? 360 : 540;
  o.fps = 2.0;
  // Consumer GNSS (no RTK): 1.5 m per axis, wandering with a 30 s correlation time. The run is
  // compared with it and with the exact ground truth, which shows what GPS alone cannot.
  o.gps.horizontal_sigma_m = 1.5;
  o.gps.correlation_time_s = 30.0;
  return s;
}

void Validate(const DemoOptions& o) {
  if (o.out_dir.empty()) throw InvalidArgument("demo: the output folder must not be empty");
  if (o.threads < 0) throw InvalidArgument("demo: threads must be >= 0 (0 = all cores)");
  Validate(o.flight);
  Validate(o.illumination);
}

namespace {

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw InputError("cannot write '" + path.string() + "'");
}

// DEMO/index.html: the summary and links to what exists (each folder's report.html when it was
// written, else its tables/summary).
void WriteIndex(const DemoResult& r, const std::string& summary) {
  namespace fs = std::filesystem;
  const auto link = [&](const std::string& dir, const char* fallback, const std::string& what) {
    const fs::path report = r.out_dir / dir / "report.html";
    const std::string target = fs::exists(report) ? dir + "/report.html" : dir + "/" + fallback;
    if (!fs::exists(r.out_dir / target)) return std::string();
    return fmt::format("<li><a href=\"{0}\">{0}</a>: {1}</li>\n", XmlEscape(target), what);
  };
  std::string items =
      link("run", "summary.json", "the run: trajectory against GPS and the exact ground truth") +
      link("illumination", "tables.md",
           "illumination experiment (paper Fig. 4-6): brightness f_k = k f") +
      link("ransac", "tables.md", "standard vs clustered RANSAC (paper Fig. 7-8): stage times") +
      link("sim", "sim.json", "the simulated flight (frames, SRT, ground truth)");
  // The run's trajectory figure (html_report.h's Fig. 2) on the index page, when it was drawn.
  std::string figure;
  if (fs::exists(r.out_dir / "run" / "figures" / "fig2_trajectory.svg")) {
    figure =
        "<h2>The run's trajectory</h2>\n<p><a href=\"run/report.html\"><img "
        "src=\"run/figures/fig2_trajectory.svg\" alt=\"trajectory\" style=\"max-width:100%\">"
        "</a></p>\n";
  }
  const std::string html = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>aerovo "
      "demo</title>\n<style>body{{font-family:sans-serif;max-width:62em;margin:2em auto;"
      "padding:0 1em}}pre{{background:#f4f4f4;padding:1em;overflow-x:auto}}</style></head>\n"
      "<body>\n<h1>aerovo demo</h1>\n<p>Visual odometry after Ivanov &amp; Muzychuk (2023) on a "
      "flight simulated over aerovo's built-in terrain, with exact ground truth.</p>\n"
      "<pre>{}</pre>\n<h2>Outputs</h2>\n<ul>\n{}</ul>\n{}</body></html>\n",
      XmlEscape(summary), items, figure);
  WriteText(r.out_dir / "index.html", html);
}

double MeanNsurf(const ExperimentRun& run) {
  if (run.frames.empty()) return 0.0;
  double sum = 0.0;
  for (const FrameRecord& f : run.frames) sum += f.n_surf;
  return sum / static_cast<double>(run.frames.size());
}

// "0.12 m (0.013 %)" end-point error against the truth (SE(2)-aligned), or "-".
std::string EndPoint(const RunSummary& s) {
  if (!s.truth_evaluation) return "-";
  const TrajectoryErrors& e = s.truth_evaluation->se2;
  return fmt::format("{:.2f} m ({:.3f} %)", e.end_point_error_m, e.end_point_error_percent);
}

// Step 3 of RunDemo: the illumination and RANSAC experiments on the run's configuration
// `base`, each skipped once `stop` is set; their results and stage times into `r`.
void RunDemoExperiments(const DemoOptions& options, const RunConfig& base,
                        const DemoCallbacks& cb, const std::atomic<bool>* stop, DemoResult& r) {
  const auto stopped = [&] { return stop != nullptr && stop->load(); };
  const auto start = [&](const char* stage, const std::string& what) {
    if (cb.stage_started) cb.stage_started(stage, what);
  };
  Stopwatch clock;
  ExperimentInput in;
  in.run = base;
  ExperimentCallbacks ecb;
  ecb.progress = [&](int done, int total, double) {
    if (cb.progress) cb.progress(done, total);
  };
  if (!stopped()) {
    clock.restart();
    in.out_dir = r.out_dir / "illumination";
    std::string ks;
    for (double k : options.illumination.k) ks += (ks.empty() ? "" : ", ") + fmt::format("{}", k);
    start("illumination", fmt::format("k = {} -> {}", ks, in.out_dir.string()));
    r.illumination = RunIlluminationExperiment(in, options.illumination, ecb, stop);
    r.stages.push_back({"illumination", clock.elapsed_ms() / 1000.0});
  }
  if (!stopped()) {
    clock.restart();
    in.out_dir = r.out_dir / "ransac";
    if (options.ransac_unguided) in.run.odometry.correspondence.guided_matching = false;
    start("ransac",
          fmt::format("standard, clustered{} -> {}",
                      options.ransac_unguided ? " (unguided matching, as the paper)" : "",
                      in.out_dir.string()));
    r.ransac = RunRansacExperiment(in, ecb, stop);
    r.stages.push_back({"ransac", clock.elapsed_ms() / 1000.0});
  }
}

}  // namespace

DemoResult RunDemo(const DemoOptions& options, const DemoCallbacks& cb,
                   const std::atomic<bool>* stop) {
  Validate(options);
  namespace fs = std::filesystem;
  Stopwatch wall;
  DemoResult r;
  r.out_dir = options.out_dir;
  r.flight_options = options.flight;
  r.illumination_scaled_threshold = options.illumination.scale_threshold;
  std::error_code ec;
  fs::create_directories(r.out_dir, ec);
  if (ec) throw InputError("cannot create '" + r.out_dir.string() + "': " + ec.message());
  const auto stopped = [&] { return stop != nullptr && stop->load(); };
  const auto start = [&](const char* stage, const std::string& what) {
    if (cb.stage_started) cb.stage_started(stage, what);
  };
  const auto progress = [&](int done, int total) {
    if (cb.progress) cb.progress(done, total);
  };

  // 1. The flight.
  Stopwatch clock;
  start("simulate", "flight over the built-in terrain -> " + (r.out_dir / "sim").string());
  r.flight = SimulateExperimentFlight(options.flight, r.out_dir / "sim", progress);
  r.stages.push_back({"simulate", clock.elapsed_ms() / 1000.0});
  for (const std::string& m : r.flight.messages) r.notes.push_back(m);

  // 2. The run (defaults of `aerovo run`), compared with GPS and the exact ground truth.
  RunConfig base = r.flight.run;
  base.odometry.surf.num_threads = options.threads;
  base.odometry.correspondence.match.num_threads = options.threads;
  base.quiet = true;
  if (!stopped()) {
    clock.restart();
    RunConfig run = base;
    run.out = (r.out_dir / "run").string();
    start("run", "visual odometry (clustered RANSAC) -> " + run.out);
    RunCallbacks rcb;
    rcb.progress = [&](int done, int total, double) { progress(done, total); };
    r.run = RunFlight(run, rcb, stop);
    r.stages.push_back({"run", clock.elapsed_ms() / 1000.0});
  }

  // 3. The experiments on the same flight.
  if (options.experiments) RunDemoExperiments(options, base, cb, stop, r);

  // 4. The HTML reports of what finished (a failure is a note: the outputs are complete).
  if (options.report && !stopped()) {
    clock.restart();
    start("report",
          "HTML reports -> " + (r.out_dir / "{run,illumination,ransac}/report.html").string());
    for (const char* dir : {"run", "illumination", "ransac"}) {
      const fs::path d = r.out_dir / dir;
      if (!fs::exists(d / "summary.json") && !fs::exists(d / ReportFileNames::kExperimentJson)) {
        continue;
      }
      try {
        const ReportResult rep = WriteReport(d);
        for (const std::string& n : rep.notes) r.notes.push_back(std::string(dir) + ": " + n);
      } catch (const std::exception& e) {
        r.notes.push_back(fmt::format("no report for {}: {}", d.string(), e.what()));
      }
    }
    r.stages.push_back({"report", clock.elapsed_ms() / 1000.0});
  }

  r.interrupted = stopped();
  r.wall_s = wall.elapsed_ms() / 1000.0;
  r.index_html = r.out_dir / "index.html";
  const std::string summary = FormatDemoSummary(r);
  WriteText(r.out_dir / "summary.txt", summary);
  WriteIndex(r, summary);
  return r;
}

std::string FormatDemoSummary(const DemoResult& r) {
  std::string t;
  const auto row = [&](const std::string& label, const std::string& value) {
    t += fmt::format("{:<14}{}\n", label, value);
  };
  const sim::SimulationOptions& o = r.flight_options.sim;
  row("flight", fmt::format("{:.0f} m {} at {:.0f} m above the built-in terrain, {} frames "
                            "{}x{} at {:g} fps, GPS noise {:g} m",
                            r.flight.distance_m, sim::FlightPatternName(o.flight.pattern),
                            o.flight.height_m, r.flight.frames, o.camera.width_px,
                            o.camera.height_px, o.fps, o.gps.horizontal_sigma_m));
  const RunSummary& s = r.run;
  if (s.frames_processed > 0) {
    row("run", fmt::format("{} frames (ok {}, bridged {}) at {:.1f} fps, `aerovo run` defaults "
                           "(clustered RANSAC, affine, metric scale)",
                           s.frames_processed, s.frames_ok, s.frames_bridged, s.fps));
    if (s.truth_evaluation) {
      const TrajectoryComparison& e = *s.truth_evaluation;
      row("  vs truth", fmt::format("end-point error {:.2f} m ({:.3f} % of {:.0f} m), ATE RMSE "
                                    "SE(2) {:.2f} m, Sim(2) {:.2f} m",
                                    e.se2.end_point_error_m, e.se2.end_point_error_percent,
                                    e.se2.distance_flown_m, e.se2.ate_m.rmse, e.sim2.ate_m.rmse));
    }
    if (s.evaluation) {
      row("  vs GPS", fmt::format("ATE RMSE SE(2) {:.2f} m, Sim(2) {:.2f} m (mostly the GPS "
                                  "noise: compare with the truth)",
                                  s.evaluation->se2.ate_m.rmse, s.evaluation->sim2.ate_m.rmse));
    }
  }
  if (r.illumination && !r.illumination->runs.empty()) {
    std::string k = "k        ", n = "N_SURF   ", e = "end-point";
    for (const ExperimentRun& run : r.illumination->runs) {
      k += fmt::format("{:>10.2f}", run.k);
      n += fmt::format("{:>10.0f}", MeanNsurf(run));
      e += fmt::format(
          "{:>10}",
          run.summary.truth_evaluation
              ? fmt::format("{:.3f}%", run.summary.truth_evaluation->se2.end_point_error_percent)
              : std::string("-"));
    }
    row("illumination", k + (r.illumination_scaled_threshold ? "   (SURF threshold x k^2)" : ""));
    row("", n + "   (mean interest points per frame)");
    row("", e + "   (error vs truth, % of distance)");
  }
  if (r.ransac && !r.ransac->runs.empty()) {
    std::string times, ends;
    double standard_ms = 0.0, clustered_ms = 0.0;
    for (const ExperimentRun& run : r.ransac->runs) {
      const std::vector<double> ms = StageTimesMs(run, "correspondence");
      const double mean = ms.empty() ? 0.0 : Mean(ms);
      (run.mode == "standard" ? standard_ms : clustered_ms) = mean;
      times += fmt::format("{}{} {:.2f} ms", times.empty() ? "" : ", ", run.mode, mean);
      ends += fmt::format("{}{} {}", ends.empty() ? "" : ", ", run.mode, EndPoint(run.summary));
    }
    row("ransac", "correspondence stage (matching + RANSAC) per step, mean: " + times +
                      (standard_ms > 0 && clustered_ms > 0
                           ? fmt::format(": speed-up {:.1f}x", standard_ms / clustered_ms)
                           : std::string()));
    row("", "end-point error vs truth: " + ends);
  }
  row("report", r.index_html.string());
  std::string times;
  for (const DemoStage& st : r.stages) {
    times += fmt::format("{}{} {:.1f} s", times.empty() ? "" : ", ", st.name, st.seconds);
  }
  row("time",
      fmt::format("{}; total {:.0f} s{}", times, r.wall_s, r.interrupted ? " (interrupted)" : ""));
  return t;
}

}  // namespace aerovo
