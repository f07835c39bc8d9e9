// `aerovo run`: the main job. A flight (video, photo folder or live source) and its telemetry in;
// a geo-referenced trajectory, its comparison with GPS and every per-frame output out. The work
// is in aerovo/report/runner.h; this file maps flags and signals onto it.
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "aerovo/cli/command.h"
#include "aerovo/report/runner.h"

namespace aerovo::cli {
namespace {

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_signal = 0;

extern "C" void OnStopSignal(int sig) {
  g_signal = sig;
  g_stop.store(true);  // lock-free on every platform we build for: async-signal-safe
}

// Progress bar on a terminal: "[#####.....]  45/172  3.2 fps  ETA 0:40".
void DrawProgress(int done, int expected, double fps) {
  std::string line;
  if (expected > 0) {
    const int width = 30;
    const int filled = std::min(width, done * width / expected);
    const double eta = fps > 0 ? (expected - done) / fps : 0.0;
    line = fmt::format("\r[{}{}] {:>5}/{:<5} {:6.2f} fps  ETA {}:{:02d} ", std::string(filled, '#'),
                       std::string(width - filled, '.'), done, expected, fps,
                       static_cast<int>(eta) / 60, static_cast<int>(eta) % 60);
  } else {
    line = fmt::format("\r{:>6} frames {:6.2f} fps ", done, fps);
  }
  std::fputs(line.c_str(), stderr);
  std::fflush(stderr);
}

struct RunArgs {
  std::string config_file;
  bool print_poses = false;
  RunConfig flags;  // values of the flags; applied over the config file only when given
  std::vector<std::function<void(RunConfig&)>> appliers;
};

template <class T>
CLI::Option* Bind(CLI::App* cmd, RunArgs& a, const std::string& name, T RunConfig::*field,
                  const std::string& help) {
  CLI::Option* opt = cmd->add_option(name, a.flags.*field, help)->capture_default_str();
  a.appliers.push_back([opt, field, &a](RunConfig& c) {
    if (opt->count() > 0) c.*field = a.flags.*field;
  });
  return opt;
}

CLI::Option* BindFlag(CLI::App* cmd, RunArgs& a, const std::string& name, bool RunConfig::*field,
                      const std::string& help) {
  CLI::Option* opt = cmd->add_flag(name, a.flags.*field, help);
  a.appliers.push_back([opt, field, &a](RunConfig& c) {
    if (opt->count() > 0) c.*field = a.flags.*field;
  });
  return opt;
}

void Execute(RunArgs& a) {
  RunConfig config;
  if (!a.config_file.empty()) config = LoadRunConfig(a.config_file, config);
  for (auto& apply : a.appliers) apply(config);
  Validate(config);

  g_stop.store(false);
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking read returns and the loop sees the flag
  struct sigaction old_int {
  }, old_term{};
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);

  const bool tty = ::isatty(STDERR_FILENO) != 0;
  RunCallbacks cb;
  cb.log = &std::cout;
  if (tty && !config.quiet && !a.print_poses) cb.progress = DrawProgress;
  if (a.print_poses) cb.poses = &std::cout;
  RunSummary s;
  try {
    s = RunFlight(config, cb, &g_stop);
  } catch (...) {
    sigaction(SIGINT, &old_int, nullptr);
    sigaction(SIGTERM, &old_term, nullptr);
    throw;
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  if (cb.progress) std::fputs("\n", stderr);
  if (s.interrupted) {
    std::cout << fmt::format(
        "aerovo run: stopped by signal {} after {} frames{}; outputs in '{}' are complete up to "
        "that frame\n",
        static_cast<int>(g_signal), s.frames_processed,
        s.frames_expected > 0 ? fmt::format(" of {}", s.frames_expected) : "", s.out_dir.string());
  }
  if (!config.quiet) {
    for (const std::string& w : s.warnings) std::cout << "warning: " << w << "\n";
  }
  std::cout << "\n" << FormatSummaryTable(s);
  std::cout << "\nOutputs: " << s.out_dir.string()
            << "/{frames.csv, vo.tum, gps.tum, vo/gps .geojson .kml .gpx, run.kml, summary.json, "
               "config.json}\n";
  std::cout.flush();
  if (s.interrupted) std::exit(130);  // conventional exit status after SIGINT
}

void Register(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  RunArgs& a = *args;
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Visual odometry on a flight: video, photo folder or live source (+ telemetry) in;\n"
      "geo-referenced trajectory, comparison with GPS and per-frame outputs out");
  Bind(cmd, a, "input", &RunConfig::input,
       "Video file, image folder (telemetry from EXIF/XMP), camera index, /dev/videoN or URL");
  cmd->add_option("--config", a.config_file,
                  "JSON or YAML (.yaml/.yml) file with any of the options below (keys as in the "
                  "saved config.json); "
                  "flags given on the command line win");
  Bind(cmd, a, "--telemetry", &RunConfig::telemetry, "Telemetry file: DJI .srt, .gpx or .csv");
  Bind(cmd, a, "-o,--out", &RunConfig::out, "Output folder");
  Bind(cmd, a, "--step", &RunConfig::step, "Process every k-th frame");
  Bind(cmd, a, "--start-s", &RunConfig::start_s, "Start time in the source, s");
  Bind(cmd, a, "--end-s", &RunConfig::end_s, "End time in the source, s (< 0: to the end)");
  Bind(cmd, a, "--max-frames", &RunConfig::max_frames, "Stop after N frames (0 = all)");
  Bind(cmd, a, "--mode", &RunConfig::mode, "Correspondence: clustered (paper) | standard")
      ->check(CLI::IsMember({"clustered", "standard"}));
  Bind(cmd, a, "--model", &RunConfig::model, "affine | similarity | homography | translation")
      ->check(CLI::IsMember({"affine", "similarity", "homography", "translation"}));
  Bind(cmd, a, "--scale", &RunConfig::scale,
       "metric (height/focal per step) | affine-chain (the paper's pure chaining)")
      ->check(CLI::IsMember({"metric", "affine-chain"}));
  Bind(cmd, a, "--heading", &RunConfig::heading,
       "VO heading in ENU: auto | yaw (telemetry) | gps (first GPS segment)")
      ->check(CLI::IsMember({"auto", "yaw", "gps"}));
  Bind(cmd, a, "--altitude", &RunConfig::altitude_m,
       "Height above ground, m (overrides telemetry; 0 = from telemetry)");
  Bind(cmd, a, "--focal-px", &RunConfig::focal_px, "Focal length in pixels (0 = from EXIF)");
  Bind(cmd, a, "--hfov-deg", &RunConfig::hfov_deg, "Horizontal field of view, deg");
  Bind(cmd, a, "--k1", &RunConfig::k1, "Lens distortion k1 (OpenCV model; 0 = none)");
  Bind(cmd, a, "--k2", &RunConfig::k2, "Lens distortion k2");
  Bind(cmd, a, "--p1", &RunConfig::p1, "Lens distortion p1 (tangential)");
  Bind(cmd, a, "--p2", &RunConfig::p2, "Lens distortion p2 (tangential)");
  Bind(cmd, a, "--k3", &RunConfig::k3, "Lens distortion k3");
  Bind(cmd, a, "--guided", &RunConfig::guided, "Guided matching with the motion prior (0/1)");
  Bind(cmd, a, "--refine", &RunConfig::refine, "Refine cell fits on all points (0/1)");
  Bind(cmd, a, "--min-inliers", &RunConfig::min_inliers, "RANSAC inliers needed for a step");
  Bind(cmd, a, "--surf-threshold", &RunConfig::surf_threshold, "SURF Hessian threshold");
  Bind(cmd, a, "--max-keypoints", &RunConfig::max_keypoints, "Keep the N strongest (0 = all)");
  Bind(cmd, a, "--seed", &RunConfig::seed, "RANSAC seed");
  Bind(cmd, a, "--threads", &RunConfig::threads, "Threads (0 = all cores)");
  cmd->add_flag("--print-poses", a.print_poses,
                "Streaming: print each pose on stdout as soon as it is computed "
                "(frame time_s x_m y_m lat lon status)");
  BindFlag(cmd, a, "-q,--quiet", &RunConfig::quiet, "No progress bar or configuration dump");
  cmd->callback([args] { Execute(*args); });
}

}  // namespace

AEROVO_REGISTER_COMMAND(Register);

}  // namespace aerovo::cli
