// `aerovo demo`: runs aerovo on its built-in generated aerial scene, needing no file.
#include <fmt/core.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <string>

#include "aerovo/cli/command.h"
#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/features/surf.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::cli {
namespace {

struct DemoArgs {
  int width = 1280;
  int height = 720;
  std::uint64_t seed = 1;
  int threads = 1;
  std::string draw;
};

GrayImageView View(const cv::Mat& gray) {
  return GrayImageView{gray.ptr<std::uint8_t>(), gray.cols, gray.rows,
                       static_cast<std::ptrdiff_t>(gray.step)};
}

void RunDemo(const DemoArgs& args) {
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
    if (!cv::imwrite(args.draw, canvas)) {
      throw InputError(fmt::format("cannot write image '{}'", args.draw));
    }
    fmt::print("  drawing      {}\n", args.draw);
  }
}

void Register(CLI::App& app) {
  auto args = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "demo", "Run aerovo on its built-in generated aerial scene (no input file needed)");
  cmd->add_option("--width", args->width, "View width (px)")->check(CLI::Range(64, 8192));
  cmd->add_option("--height", args->height, "View height (px)")->check(CLI::Range(64, 8192));
  cmd->add_option("--seed", args->seed, "Terrain seed");
  cmd->add_option("--threads", args->threads, "SURF threads (0 = all cores)")
      ->check(CLI::Range(0, 256));
  cmd->add_option("--draw", args->draw, "Write the view with its keypoints to this image file");
  cmd->callback([args] { RunDemo(*args); });
}

AEROVO_REGISTER_COMMAND(Register);

}  // namespace
}  // namespace aerovo::cli
