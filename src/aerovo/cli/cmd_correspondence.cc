// `aerovo correspondence PREV CURR`: the correspondence stage (matching + RANSAC) on one frame
// pair, standard and clustered RANSAC side by side (time, transform, inliers, cell used, and how
// far apart the two transforms are at the frame corners).
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/core/error.h"
#include "aerovo/correspondence/correspondence.h"
#include "aerovo/features/surf.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/matching/matcher.h"

namespace aerovo::cli {
namespace {

struct Args {
  std::string prev, curr;
  std::vector<double> last_shift{0.0, 0.0};
  std::string model = "affine";
  bool paper = false;
  bool prosac = false;
  std::string matcher = "exhaustive";
  double hessian_threshold = SurfOptions{}.hessian_threshold;
  CorrespondenceOptions options;
};

std::string Describe(const char* name, const CorrespondenceResult& r) {
  std::string s = fmt::format(
      "{}: {} in {:.2f} ms (match {:.2f}, estimate {:.2f}); {} inliers / {} matches; {} "
      "descriptor comparisons; {} RANSAC trials",
      name, r.success ? "success" : "FAILED", r.total_ms, r.match_ms, r.estimate_ms, r.num_inliers,
      r.matches.size(), r.num_comparisons, r.ransac_trials);
  if (r.method_used == CorrespondenceMethod::kClustered || r.fell_back) {
    s += fmt::format("\n  crop x {} y {} {}x{}; cell ({}, {}); attempts {}; {}{}", r.crop.x,
                     r.crop.y, r.crop.width, r.crop.height, r.cell_row, r.cell_col, r.attempts,
                     r.fell_back ? "FELL BACK to standard" : "clustered",
                     r.refined ? ", refined" : "");
    if (std::isfinite(r.refine_shift_px)) {
      s += fmt::format("; spread refinement moved the cell's fit by {:.2f} px{}, final pass {}",
                       r.refine_shift_px,
                       r.refine_early_exit ? " (first half of its points: early exit)" : "",
                       r.final_pass ? "run" : "skipped");
    }
  }
  const Eigen::Matrix3d& m = r.curr_from_prev;
  s += fmt::format(
      "\n  curr_from_prev = [{:.6f} {:.6f} {:.3f}; {:.6f} {:.6f} {:.3f}; {:.3g} {:.3g} {:.3g}]",
      m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2));
  return s;
}

void Run(Args a) {
  CheckUsage([&] {
    if (a.last_shift.size() != 2) throw InvalidArgument("--last-shift takes two numbers: U V");
    // A shift that is not finite became a non-finite transform, refused deep in the crop
    // ("ClusteredCrop: the previous step's transform has non-finite entries", exit 1).
    if (!std::isfinite(a.last_shift[0]) || !std::isfinite(a.last_shift[1])) {
      throw InvalidArgument(fmt::format("--last-shift {} {}: both must be finite, px",
                                        a.last_shift[0], a.last_shift[1]));
    }
    a.options.model = ParseMotionModel(a.model.c_str());
    a.options.sampler = a.prosac ? SamplerKind::kProsac : SamplerKind::kUniform;
    a.options.clustered.refine = !a.paper;
    a.options.match.algorithm = ParseMatchAlgorithm(a.matcher);
    try {
      Validate(a.options);
    } catch (const InvalidArgument& e) {
      // The checks name the options' keys (clustered.refine_final_max_points); this command's
      // flags for them are its own.
      throw InvalidArgument(
          NameFlags(e.what(), {{"refine_max_points", "--spread-points"},
                               {"refine_final_radius_px", "--final-radius"},
                               {"refine_final_max_points", "--final-points"},
                               {"refine_final_min_shift_px", "--final-min-shift"}}));
    }
  });
  SurfOptions so;
  so.hessian_threshold = a.hessian_threshold;
  Surf surf(so);
  const cv::Mat g0 = ReadGrayImage(a.prev), g1 = ReadGrayImage(a.curr);
  auto features = [&](const cv::Mat& g) {
    return surf
        .DetectAndDescribe(
            GrayImageView{g.data, g.cols, g.rows, static_cast<std::ptrdiff_t>(g.step[0])})
        .features;
  };
  const FeatureSet prev = features(g0), curr = features(g1);
  std::cout << fmt::format("{}: {}x{}, {} SURF points\n{}: {}x{}, {} SURF points\n", a.prev,
                           g0.cols, g0.rows, prev.size(), a.curr, g1.cols, g1.rows, curr.size());
  Eigen::Matrix3d last = Eigen::Matrix3d::Identity();
  last(0, 2) = a.last_shift[0];
  last(1, 2) = a.last_shift[1];
  CorrespondenceStage stage(a.options);
  stage.Standard(prev, curr);  // Warm-up (buffers), so that both timings are steady-state.
  const CorrespondenceResult rs = stage.Standard(prev, curr);
  const CorrespondenceResult rc = stage.Clustered(prev, g0.cols, g0.rows, curr, last);
  std::cout << Describe("standard", rs) << "\n" << Describe("clustered", rc) << "\n";
  if (rs.success && rc.success) {
    std::cout << fmt::format(
        "clustered vs standard: {:.1f}x faster, transforms {:.3f} px apart at the corners\n",
        rs.total_ms / rc.total_ms,
        MaxCornerDisplacementPx(rs.curr_from_prev, rc.curr_from_prev, g0.cols, g0.rows));
  }
}

void RegisterCorrespondenceCommand(CLI::App& app) {
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "correspondence",
      "Match two frames and fit curr_from_prev with standard and clustered RANSAC, side by side");
  cmd->add_option("prev", args->prev, "Earlier frame (image file)")->required();
  cmd->add_option("curr", args->curr, "Later frame (image file)")->required();
  cmd->add_option("--last-shift", args->last_shift,
                  "Previous step's image motion U V in px (content shift, curr_from_prev "
                  "translation) for the clustered crop; default 0 0")
      ->expected(2);
  cmd->add_option("--model", args->model, "translation, similarity, affine or homography")
      ->capture_default_str();
  cmd->add_flag("--paper", args->paper,
                "Clustered RANSAC exactly as the paper (the cell's own fit, no refinement)");
  cmd->add_option("--spread-points", args->options.clustered.refine_max_points,
                  "Refinement: points spread over the crop re-matched around the cell's fit "
                  "(0 = all)")
      ->capture_default_str();
  cmd->add_option("--final-radius", args->options.clustered.refine_final_radius_px,
                  "Refinement's final pass: every point (at most --final-points) re-matched "
                  "within this radius (px) of the refined fit (0 = no final pass)")
      ->capture_default_str();
  cmd->add_option("--final-points", args->options.clustered.refine_final_max_points,
                  "Refinement's final pass: at most this many prev points, every k-th (0 = all)")
      ->capture_default_str();
  cmd->add_option("--final-min-shift", args->options.clustered.refine_final_min_shift_px,
                  "Refinement's final pass only when the spread refinement moved the cell's fit "
                  "by more than this at the corners, px (0 = always)")
      ->capture_default_str();
  cmd->add_option("--refine-fallback", args->options.clustered.refine_fallback,
                  "Refinement: a fall-back's fit (standard method) re-fitted on every point "
                  "matched within --final-radius of it, kept with more inliers (true/false; "
                  "aerovo run: true)")
      ->capture_default_str();
  cmd->add_option("--early-exit", args->options.clustered.refine_early_exit,
                  "Refinement: accept the fit on the first half of the spread points when it "
                  "confirms the cell's (moved it by at most --final-min-shift, with 8 more "
                  "inliers) (true/false)")
      ->capture_default_str();
  cmd->add_flag("--prosac", args->prosac, "PROSAC sampling ordered by match SSD");
  cmd->add_option("--matcher", args->matcher,
                  "Matching without a motion prior: exhaustive (exact) | kdtree (approximate "
                  "k-d forest)")
      ->check(CLI::IsMember(options::EnumNames<MatchAlgorithm>()))
      ->capture_default_str();
  // --threshold: the old spelling (hidden), --surf-threshold as in `aerovo run`.
  cmd->add_option("--threshold", args->hessian_threshold, "Old name of --surf-threshold")
      ->group("");
  cmd->add_option("--surf-threshold", args->hessian_threshold,
                  "SURF Hessian threshold (MATLAB 1000)")
      ->capture_default_str();
  cmd->add_option("--max-distance", args->options.ransac.max_distance_px,
                  "RANSAC inlier threshold, px (MATLAB MaxDistance)")
      ->capture_default_str();
  cmd->add_option("--max-trials", args->options.ransac.max_num_trials,
                  "RANSAC trial cap (MATLAB MaxNumTrials)")
      ->capture_default_str();
  cmd->add_option("--seed", args->options.ransac.seed, "RANSAC seed")->capture_default_str();
  cmd->add_option(
         "--polish", args->options.ransac.polish_iterations,
         "Robust polish after RANSAC, IRLS rounds (0 = off, MATLAB; 20 = seed-independent)")
      ->capture_default_str();
  cmd->add_option("--grid", args->options.clustered.grid_rows, "Clustered grid rows = cols")
      ->capture_default_str()
      ->each([args](const std::string&) {
        args->options.clustered.grid_cols = args->options.clustered.grid_rows;
      });
  cmd->add_option("--min-points", args->options.clustered.min_points,
                  "Clustered: minimum points per cell (paper: 12)")
      ->capture_default_str();
  cmd->callback([args] { Run(*args); });
}

}  // namespace

AEROVO_REGISTER_COMMAND(RegisterCorrespondenceCommand);

}  // namespace aerovo::cli
