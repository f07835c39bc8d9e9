#include "aerovo/cli/run_cli.h"

#include <algorithm>
#include <cstdio>

#include <fmt/format.h>

namespace aerovo::cli {
namespace {

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_signal = 0;

extern "C" void OnStopSignal(int sig) {
  g_signal = sig;
  g_stop.store(true);  // lock-free on every platform we build for: async-signal-safe
}

template <class T>
CLI::Option* Bind(CLI::App* cmd, RunFlags& a, const std::string& name, T RunConfig::*field,
                  const std::string& help) {
  CLI::Option* opt = cmd->add_option(name, a.flags.*field, help)->capture_default_str();
  a.appliers.push_back([opt, field, &a](RunConfig& c) {
    if (opt->count() > 0) c.*field = a.flags.*field;
  });
  return opt;
}

CLI::Option* BindFlag(CLI::App* cmd, RunFlags& a, const std::string& name, bool RunConfig::*field,
                      const std::string& help) {
  CLI::Option* opt = cmd->add_flag(name, a.flags.*field, help);
  a.appliers.push_back([opt, field, &a](RunConfig& c) {
    if (opt->count() > 0) c.*field = a.flags.*field;
  });
  return opt;
}

}  // namespace

RunConfig RunFlags::Resolve() const {
  RunConfig config;
  if (!config_file.empty()) config = LoadRunConfig(config_file, config);
  for (const auto& apply : appliers) apply(config);
  return config;
}

void AddRunFlags(CLI::App* cmd, RunFlags& a, const std::set<std::string>& skip) {
  const auto want = [&](const char* key) { return skip.count(key) == 0; };
  if (want("input")) {
    Bind(cmd, a, "input,--input", &RunConfig::input,
         "Video file, image folder (telemetry from EXIF/XMP), camera index, /dev/videoN or URL");
  }
  cmd->add_option("--config", a.config_file,
                  "JSON or YAML (.yaml/.yml) file with any of the options below (keys as in the "
                  "saved config.json); flags given on the command line win");
  if (want("telemetry")) {
    Bind(cmd, a, "--telemetry", &RunConfig::telemetry, "Telemetry file: DJI .srt, .gpx or .csv");
  }
  if (want("lenient_telemetry")) {
    BindFlag(cmd, a, "--lenient-telemetry", &RunConfig::lenient_telemetry,
             "Skip malformed telemetry records (counted in the warnings) instead of stopping");
  }
  if (want("truth")) {
    Bind(cmd, a, "--truth", &RunConfig::truth,
         "Ground truth to compare with beside GPS: TUM (.tum/.txt) or a track with positions "
         "(.csv, .gpx, .srt); default for a simulated flight: its ground_truth.csv");
  }
  if (want("out")) Bind(cmd, a, "-o,--out", &RunConfig::out, "Output folder");
  if (want("step")) Bind(cmd, a, "--step", &RunConfig::step, "Process every k-th frame");
  if (want("start_s")) {
    Bind(cmd, a, "--start-s", &RunConfig::start_s, "Start time in the source, s");
  }
  if (want("end_s")) {
    Bind(cmd, a, "--end-s", &RunConfig::end_s, "End time in the source, s (< 0: to the end)");
  }
  if (want("max_frames")) {
    Bind(cmd, a, "--max-frames", &RunConfig::max_frames, "Stop after N frames (0 = all)");
  }
  if (want("mode")) {
    Bind(cmd, a, "--mode", &RunConfig::mode, "Correspondence: clustered (paper) | standard")
        ->check(CLI::IsMember({"clustered", "standard"}));
  }
  if (want("model")) {
    Bind(cmd, a, "--model", &RunConfig::model, "affine | similarity | homography | translation")
        ->check(CLI::IsMember({"affine", "similarity", "homography", "translation"}));
  }
  if (want("scale")) {
    Bind(cmd, a, "--scale", &RunConfig::scale,
         "metric (height/focal per step) | affine-chain (the paper's pure chaining)")
        ->check(CLI::IsMember({"metric", "affine-chain"}));
  }
  if (want("heading")) {
    Bind(cmd, a, "--heading", &RunConfig::heading,
         "VO heading in ENU: auto | yaw (telemetry) | gps (first GPS segment)")
        ->check(CLI::IsMember({"auto", "yaw", "gps"}));
  }
  if (want("altitude_m")) {
    Bind(cmd, a, "--altitude", &RunConfig::altitude_m,
         "Height above ground, m (overrides telemetry; 0 = from telemetry)");
  }
  if (want("focal_px")) {
    Bind(cmd, a, "--focal-px", &RunConfig::focal_px, "Focal length in pixels (0 = from EXIF)");
  }
  if (want("hfov_deg")) {
    Bind(cmd, a, "--hfov-deg", &RunConfig::hfov_deg, "Horizontal field of view, deg");
  }
  if (want("k1"))
    Bind(cmd, a, "--k1", &RunConfig::k1, "Lens distortion k1 (OpenCV model; 0 = none)");
  if (want("k2")) Bind(cmd, a, "--k2", &RunConfig::k2, "Lens distortion k2");
  if (want("p1")) Bind(cmd, a, "--p1", &RunConfig::p1, "Lens distortion p1 (tangential)");
  if (want("p2")) Bind(cmd, a, "--p2", &RunConfig::p2, "Lens distortion p2 (tangential)");
  if (want("k3")) Bind(cmd, a, "--k3", &RunConfig::k3, "Lens distortion k3");
  if (want("illumination_k")) {
    Bind(cmd, a, "--illumination-k", &RunConfig::illumination_k,
         "Illumination factor k in (0, 1]: every frame's brightness times k before SURF "
         "(the paper's f_k = k f)");
  }
  if (want("guided")) {
    Bind(cmd, a, "--guided", &RunConfig::guided, "Guided matching with the motion prior (0/1)");
  }
  if (want("matcher")) {
    Bind(cmd, a, "--matcher", &RunConfig::matcher,
         "Matching without a motion prior: exhaustive (exact) | kdtree (approximate k-d forest, "
         "faster from a few thousand points per frame)")
        ->check(CLI::IsMember({"exhaustive", "kdtree"}));
  }
  if (want("refine")) {
    Bind(cmd, a, "--refine", &RunConfig::refine,
         "Refine cell fits on spread points, then on all points (0/1; 0 = the paper's clustered "
         "RANSAC exactly)");
  }
  if (want("min_inliers")) {
    Bind(cmd, a, "--min-inliers", &RunConfig::min_inliers, "RANSAC inliers needed for a step");
  }
  if (want("surf_threshold")) {
    Bind(cmd, a, "--surf-threshold", &RunConfig::surf_threshold, "SURF Hessian threshold");
  }
  if (want("max_keypoints")) {
    Bind(cmd, a, "--max-keypoints", &RunConfig::max_keypoints, "Keep the N strongest (0 = all)");
  }
  if (want("seed")) Bind(cmd, a, "--seed", &RunConfig::seed, "RANSAC seed");
  if (want("polish")) {
    Bind(cmd, a, "--polish", &RunConfig::polish,
         "Robust polish of RANSAC fits, IRLS rounds (0 = off; 20 makes tracks seed-independent)");
  }
  if (want("threads")) Bind(cmd, a, "--threads", &RunConfig::threads, "Threads (0 = all cores)");
  if (want("quiet")) {
    BindFlag(cmd, a, "-q,--quiet", &RunConfig::quiet, "No progress bar or configuration dump");
  }
}

StopSignals::StopSignals() {
  g_stop.store(false);
  g_signal = 0;
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  // No SA_RESTART: a blocking read returns and the loop sees the flag. SA_RESETHAND: the next
  // signal of the same kind takes the default action (kills).
  sa.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &sa, &old_int_);
  sigaction(SIGTERM, &sa, &old_term_);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &old_int_, nullptr);
  sigaction(SIGTERM, &old_term_, nullptr);
}

const std::atomic<bool>* StopSignals::stop() const { return &g_stop; }
int StopSignals::signal() const { return static_cast<int>(g_signal); }

std::string StopSignals::Name(int signal) {
  if (signal == SIGINT) return "SIGINT";
  if (signal == SIGTERM) return "SIGTERM";
  return "signal " + std::to_string(signal);
}

int StopSignals::ExitCode(int signal) { return 128 + (signal > 0 ? signal : SIGINT); }

}  // namespace aerovo::cli
