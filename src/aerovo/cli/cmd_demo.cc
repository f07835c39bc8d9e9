// `aerovo demo`: the full flight demo, needing no file (report/demo.h): a flight simulated over
// the built-in terrain, the run, the paper's experiments, a summary and an index page.
// `aerovo demo --surf-only`: SURF on one view of the built-in terrain (the first demo).

#include <fmt/core.h>
#include <fmt/ranges.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <string>

#include "aerovo/cli/command.h"
#include "aerovo/cli/progress.h"
#include "aerovo/cli/run_cli.h"
#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/features/surf.h"
#include "aerovo/imageio/image_io.h"
#include "aerovo/outputs/run_folder.h"
#include "aerovo/pipeline/demo.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::cli {
namespace {

struct DemoArgs {
  bool surf_only = false;
  bool quick = false;
  bool no_experiments = false;
  std::string out = "aerovo-demo";
  bool force = false;
  int width = 0;  // 0 = the mode's default
  int height = 0;
  std::uint64_t seed = 1;
  int threads = -1;  // -1 = the mode's default
  std::string draw;
};

GrayImageView View(const cv::Mat& gray) {
  return GrayImageView{gray.ptr<std::uint8_t>(), gray.cols, gray.rows,
                       static_cast<std::ptrdiff_t>(gray.step)};
}

void RunSurfDemo(DemoArgs args) {
  if (args.width == 0) args.width = 1280;
  if (args.height == 0) args.height = 720;
  if (args.threads < 0) args.threads = 1;
  Stopwatch clock;
  sim::TerrainOptions terrain;
  terrain.width_px = std::max(2048, args.width + 64);
  terrain.height_px = std::max(2048, args.height + 64);
  terrain.seed = args.seed;
  const cv::Mat ground = sim::GenerateTerrain(terrain);
  const double terrain_ms = clock.elapsed_ms();
  // A camera-sized view from the middle of the generated ground, as a nadir frame.
  const cv::Rect roi((ground.cols - args.width) / 2, (ground.rows - args.height) / 2, args.width,
                     args.height);
  cv::Mat gray;
  cv::cvtColor(ground(roi), gray, cv::COLOR_BGR2GRAY);

  SurfOptions options;  // MATLAB detectSURFFeatures defaults, as in the paper.
  options.num_threads = args.threads;
  Surf surf(options);
  surf.DetectAndDescribe(View(gray));  // warm-up: buffers sized once, as on board
  const SurfResult result = surf.DetectAndDescribe(View(gray));

  fmt::print("aerovo demo: SURF on a built-in generated aerial scene\n");
  fmt::print("  scene        {}x{} px terrain (seed {}, generated in {:.0f} ms), view {}x{} px\n",
             terrain.width_px, terrain.height_px, args.seed, terrain_ms, args.width, args.height);
  fmt::print("  options      threshold {:.0f}, {} octaves, {} scale levels, {} thread(s)\n",
             options.hessian_threshold, options.num_octaves, options.num_scale_levels,
             args.threads);
  fmt::print("  keypoints    {}\n", result.features.size());
  fmt::print("  time         detect {:.1f} ms, describe {:.1f} ms, total {:.1f} ms\n",
             result.detect_ms, result.describe_ms, result.detect_ms + result.describe_ms);
  const std::size_t shown = std::min<std::size_t>(5, result.features.size());
  if (shown > 0) fmt::print("  strongest    x        y        scale   orient.  response  lapl.\n");
  for (std::size_t i = 0; i < shown; ++i) {
    const Keypoint& k = result.features.keypoints[i];
    fmt::print("               {:7.2f}  {:7.2f}  {:6.2f}  {:6.1f}°  {:8.0f}  {:+d}\n", k.x, k.y,
               k.scale, k.orientation * 180.0 / 3.14159265358979, k.response, k.laplacian);
  }
  if (!args.draw.empty()) {
    cv::Mat canvas = ground(roi).clone();
    for (const Keypoint& k : result.features.keypoints) {
      cv::circle(canvas, cv::Point2f(k.x, k.y), std::max(2, static_cast<int>(k.scale * 2)),
                 k.laplacian > 0 ? cv::Scalar(0, 255, 255) : cv::Scalar(255, 0, 255), 1,
                 cv::LINE_AA);
    }
    if (!imageio::Write(args.draw, canvas)) {
      throw InputError(fmt::format("cannot write image '{}'", args.draw));
    }
    fmt::print("  drawing      {}\n", args.draw);
  }
}

void RunFlightDemo(const DemoArgs& args) {
  if (!args.draw.empty()) throw InvalidArgument("--draw is an option of --surf-only");
  DemoOptions o;
  o.out_dir = args.out;
  o.flight = DemoSimulation(args.quick);
  if (args.width > 0) o.flight.sim.camera.width_px = args.width;
  if (args.height > 0) o.flight.sim.camera.height_px = args.height;
  o.flight.terrain_seed = args.seed;
  o.experiments = !args.no_experiments;
  if (args.quick) o.illumination.k = {1.0, 0.25};
  o.threads = std::max(0, args.threads);
  // Like aerovo run: one demo at a time in a folder, a new or empty folder unless --force
  // (which removes what an earlier demo wrote: its index and its run, sim and experiment
  // folders; other files are kept).
  const RunFolderLock lock(args.out);
  const ClaimResult claim = ClaimOutputFolder(
      args.out, args.force,
      OwnEntries(args.out, {"index.html", "sim", "run", "illumination", "ransac"}), "aerovo demo");
  if (!claim.removed.empty()) {
    fmt::print(stderr, "aerovo demo: --force: removed from '{}': {}\n", args.out,
               fmt::join(claim.removed, ", "));
  }
  fmt::print(
      "aerovo demo: a flight simulated over the built-in terrain, the visual odometry, the\n"
      "paper's experiments (illumination, standard vs clustered RANSAC) -> {}\n",
      args.out);
  std::fflush(stdout);
  Progress progress(DefaultProgressStyle(false));
  std::string stage;
  DemoCallbacks cb;
  cb.stage_started = [&](const std::string& name, const std::string& what) {
    progress.Clear();  // also restarts the stage's clock
    fmt::print("  {:<13}{}\n", name, what);
    std::fflush(stdout);
    stage = name;
  };
  cb.progress = [&](int done, int total) { progress.Update(done, total, "  " + stage + " "); };
  int signal = 0;
  const DemoResult r =
      WithStopSignals(&signal, [&](const std::atomic<bool>* stop) { return RunDemo(o, cb, stop); });
  progress.Clear();
  for (const std::string& n : r.notes) fmt::print("  note         {}\n", n);
  fmt::print("\n{}\nOpen {} in a browser (reports, tables, tracks); everything is in {}/\n",
             FormatDemoSummary(r), r.index_html.string(), args.out);
  std::fflush(stdout);
  if (r.interrupted) std::exit(StopSignals::ExitCode(signal));
}

void RegisterDemoCommand(CLI::App& app) {
  auto args = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "The full demo, no input file needed: simulate a flight over the built-in terrain, run the "
      "visual odometry on it, run the paper's experiments, compare with the exact ground truth "
      "(--surf-only: SURF on one view of the terrain)");
  cmd->add_option("-o,--out", args->out, "Output folder")->capture_default_str();
  cmd->add_flag("--force", args->force,
                "Write into a non-empty output folder: first remove what an earlier demo wrote "
                "there (other files are kept)");
  cmd->add_flag("--quick", args->quick,
                "A small flight (260 m, 640x360, 53 frames) and 2 illumination runs: ~20 s");
  cmd->add_flag("--no-experiments", args->no_experiments, "Only simulate and run");
  cmd->add_flag("--surf-only", args->surf_only,
                "Only SURF on one view of the built-in terrain (the first demo)");
  cmd->add_option("--width", args->width,
                  "Camera / view width (px); default 960 (flight), 1280 (--surf-only)")
      ->check(CLI::Range(64, 8192));
  cmd->add_option("--height", args->height,
                  "Camera / view height (px); default 540 (flight), 720 (--surf-only)")
      ->check(CLI::Range(64, 8192));
  cmd->add_option("--seed", args->seed, "Terrain seed")->capture_default_str();
  cmd->add_option("--threads", args->threads,
                  "Threads (0 = all cores); default all (flight), 1 (--surf-only)")
      ->check(CLI::Range(0, 256));
  cmd->add_option("--draw", args->draw,
                  "--surf-only: write the view with its keypoints to this image file");
  cmd->callback([args] {
    if (args->surf_only) {
      RunSurfDemo(*args);
    } else {
      RunFlightDemo(*args);
    }
  });
}

AEROVO_REGISTER_COMMAND(RegisterDemoCommand);

}  // namespace
}  // namespace aerovo::cli
