// `aerovo features detect` (aerovo SURF on one image) and `aerovo features eval` (repeatability
// and matching score on the Oxford benchmark, aerovo SURF beside OpenCV's SIFT, ORB, AKAZE).
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/core/error.h"
#include "aerovo/eval/feature_eval.h"
#include "aerovo/eval/oxford_dataset.h"
#include "aerovo/features/surf.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/imageio/image_io.h"

namespace aerovo::cli {
namespace {

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  if (!out) throw InputError(path + ": cannot open for writing");
  out << text;
  if (!out) throw InputError(path + ": write failed");
}

void AddSurfOptions(CLI::App* cmd, SurfOptions& o) {
  // --surf-threshold as in `aerovo run` and `aerovo correspondence`; --threshold, the old
  // spelling, still accepted (hidden).
  cmd->add_option("--surf-threshold", o.hessian_threshold,
                  "Hessian threshold on 0..255 images (MATLAB MetricThreshold)")
      ->capture_default_str();
  cmd->add_option("--threshold", o.hessian_threshold, "Old name of --surf-threshold")->group("");
  cmd->add_option("--octaves", o.num_octaves, "Number of octaves (MATLAB NumOctaves)")
      ->capture_default_str();
  cmd->add_option("--levels", o.num_scale_levels,
                  "Scale levels per octave, >= 3 (MATLAB NumScaleLevels)")
      ->capture_default_str();
  cmd->add_option("--threads", o.num_threads, "SURF threads (0 = all cores)")
      ->capture_default_str();
}

// ---------------------------------------------------------------------------------------
// features detect

struct DetectArgs {
  std::string image;
  SurfOptions surf;
  std::string draw;
  std::string json;
};

void RunDetect(const DetectArgs& a) {
  CheckUsage([&] { Validate(a.surf); });
  const cv::Mat gray = ReadGrayImage(a.image, GrayFrom::kDecoder);
  Surf surf(a.surf);
  const GrayImageView view{gray.data, gray.cols, gray.rows, static_cast<std::ptrdiff_t>(gray.step)};
  const SurfResult r = surf.DetectAndDescribe(view);
  const FeatureSet& f = r.features;
  std::cout << fmt::format(
      "{}: {}x{}, {} keypoints, detect {:.1f} ms, describe {:.1f} ms, total {:.1f} ms "
      "(threshold {}, {} octaves, {} levels, {} descriptor, {}, threads: {})\n",
      a.image, gray.cols, gray.rows, f.size(), r.detect_ms, r.describe_ms,
      r.detect_ms + r.describe_ms, a.surf.hessian_threshold, a.surf.num_octaves,
      a.surf.num_scale_levels, f.descriptor_size, a.surf.upright ? "upright" : "oriented",
      a.surf.num_threads == 0 ? std::string("all cores") : std::to_string(a.surf.num_threads));
  if (!a.draw.empty()) {
    std::vector<cv::KeyPoint> kps;
    kps.reserve(f.size());
    for (const Keypoint& kp : f.keypoints) kps.push_back(ToCvKeyPoint(kp));
    cv::Mat canvas;
    cv::drawKeypoints(gray, kps, canvas, cv::Scalar(0, 255, 0),
                      cv::DrawMatchesFlags::DRAW_RICH_KEYPOINTS);
    if (!imageio::Write(a.draw, canvas)) throw InputError(a.draw + ": cannot write image");
    std::cout << "drawn: " << a.draw << "\n";
  }
  if (!a.json.empty()) {
    nlohmann::json j;
    j["image"] = a.image;
    j["width"] = gray.cols;
    j["height"] = gray.rows;
    j["options"] = {{"hessian_threshold", a.surf.hessian_threshold},
                    {"num_octaves", a.surf.num_octaves},
                    {"num_scale_levels", a.surf.num_scale_levels},
                    {"max_keypoints", a.surf.max_keypoints},
                    {"upright", a.surf.upright},
                    {"extended", a.surf.extended},
                    {"num_threads", a.surf.num_threads}};
    j["detect_ms"] = r.detect_ms;
    j["describe_ms"] = r.describe_ms;
    j["descriptor_size"] = f.descriptor_size;
    nlohmann::json kps = nlohmann::json::array();
    for (const Keypoint& kp : f.keypoints) {
      kps.push_back({{"x", kp.x},
                     {"y", kp.y},
                     {"scale", kp.scale},
                     {"orientation_deg", kp.orientation * 180.0 / 3.14159265358979323846},
                     {"response", kp.response},
                     {"laplacian", kp.laplacian},
                     {"octave", kp.octave}});
    }
    j["keypoints"] = std::move(kps);
    WriteText(a.json, j.dump(1) + "\n");
    std::cout << "json: " << a.json << "\n";
  }
}

// ---------------------------------------------------------------------------------------
// features eval

struct EvalArgs {
  std::string dir;
  std::string detectors = "surf,sift,orb,akaze";
  std::vector<std::string> sequences;
  std::vector<int> targets;
  std::string json;
  bool markdown = false;
  bool opencv_common_part = false;
  bool no_matching_score = false;
  FeatureEvalOptions options;
};

nlohmann::json ScoreJson(const PairScore& s) {
  nlohmann::json j = {{"detected1", s.detected1},
                      {"detected2", s.detected2},
                      {"n1", s.n1},
                      {"n2", s.n2},
                      {"correspondences", s.correspondences},
                      {"repeatability", s.repeatability},
                      {"ms_img1", s.ms1},
                      {"ms_img2", s.ms2}};
  if (s.has_matching_score) {
    j["matches"] = s.matches;
    j["correct_matches"] = s.correct_matches;
    j["matching_score"] = s.matching_score;
  }
  return j;
}

void RunEval(EvalArgs a) {
  FeatureEvalOptions& o = a.options;
  CheckUsage([&] {
    o.detectors = ParseFeatureDetectorList(a.detectors);
    if (!a.sequences.empty()) o.sequences = a.sequences;
    if (!a.targets.empty()) o.targets = a.targets;
    o.common_part = a.opencv_common_part ? CommonPart::kOpenCv : CommonPart::kBothImages;
    o.matching_score = !a.no_matching_score;
    Validate(o);
  });

  std::vector<FeatureEvalSequence> results;
  for (const std::string& name : o.sequences) {
    const OxfordSequence seq = LoadOxfordSequence(std::filesystem::path(a.dir) / name, o.targets);
    spdlog::info("{}: {}x{}, evaluating {} pair(s)", name, seq.images[0].cols, seq.images[0].rows,
                 seq.targets.size());
    results.push_back(EvaluateFeatureSequence(name, seq.images, seq.targets, seq.h_from_img1, o));
  }
  std::cout << FormatFeatureEvalTable(results, o.detectors, a.markdown);

  if (!a.json.empty()) {
    nlohmann::json j;
    j["dataset"] = a.dir;
    j["protocol"] = {
        {"reference", "Mikolajczyk et al., A comparison of affine region detectors, IJCV 2005"},
        {"max_overlap_error", o.max_overlap_error},
        {"normalised_radius_px", o.normalised_radius_px},
        {"common_part", o.common_part == CommonPart::kOpenCv ? "opencv" : "both_images"},
        {"matching", "one-to-one greedy nearest neighbour"}};
    nlohmann::json dets = nlohmann::json::array();
    for (auto d : o.detectors) dets.push_back(ToString(d));
    j["detectors"] = dets;
    j["surf"] = {{"hessian_threshold", o.surf.hessian_threshold},
                 {"num_octaves", o.surf.num_octaves},
                 {"num_scale_levels", o.surf.num_scale_levels},
                 {"num_threads", o.surf.num_threads}};
    j["orb_max_features"] = o.orb_max_features;
    nlohmann::json seqs = nlohmann::json::array();
    for (const auto& s : results) {
      nlohmann::json pairs = nlohmann::json::array();
      for (const auto& p : s.pairs) {
        nlohmann::json scores;
        for (std::size_t d = 0; d < o.detectors.size(); ++d) {
          scores[ToString(o.detectors[d])] = ScoreJson(p.scores[d]);
        }
        pairs.push_back({{"pair", fmt::format("1->{}", p.target)}, {"scores", scores}});
      }
      seqs.push_back({{"name", s.name}, {"pairs", pairs}});
    }
    j["sequences"] = seqs;
    WriteText(a.json, j.dump(1) + "\n");
    std::cout << "json: " << a.json << "\n";
  }
}

void RegisterFeaturesCommand(CLI::App& app) {
  CLI::App* features =
      app.add_subcommand("features", "SURF feature detection and detector/descriptor evaluation");
  features->require_subcommand(1);

  auto detect_args = std::make_shared<DetectArgs>();
  CLI::App* detect = features->add_subcommand(
      "detect", "Detect and describe SURF keypoints in one image; print count and time");
  detect->add_option("IMAGE", detect_args->image, "Image file (read as grey)")->required();
  AddSurfOptions(detect, detect_args->surf);
  detect
      ->add_option("--max", detect_args->surf.max_keypoints,
                   "Keep at most N strongest keypoints (0 = all)")
      ->capture_default_str();
  detect->add_flag("--upright", detect_args->surf.upright, "No orientation (U-SURF)");
  detect->add_flag("--extended", detect_args->surf.extended, "128-value descriptor");
  detect->add_option("--draw", detect_args->draw, "Write the image with keypoints drawn (PNG)");
  detect->add_option("--json", detect_args->json, "Write keypoints and timings as JSON");
  detect->callback([detect_args] { RunDetect(*detect_args); });

  auto eval_args = std::make_shared<EvalArgs>();
  CLI::App* eval = features->add_subcommand(
      "eval",
      "Repeatability and matching score on the Oxford benchmark (Mikolajczyk et al. IJCV "
      "2005 protocol, as cv::evaluateFeatureDetector), detectors side by side");
  eval->add_option("DIR", eval_args->dir,
                   "Oxford benchmark folder: one folder per sequence (bark, bikes, ...) holding "
                   "img1..img6 (.png/.ppm/.pgm/.jpg) and the homographies H1to2p..H1to6p")
      ->required();
  eval->add_option("--detectors", eval_args->detectors, "Comma-separated: surf,sift,orb,akaze")
      ->capture_default_str();
  eval->add_option("--sequences", eval_args->sequences,
                   "Sequences (default: bark bikes boat graf leuven trees ubc wall)")
      ->delimiter(',');
  eval->add_option("--pairs", eval_args->targets, "Target images N of pairs 1->N (default 2..6)")
      ->delimiter(',');
  AddSurfOptions(eval, eval_args->options.surf);
  eval->add_option("--orb-features", eval_args->options.orb_max_features, "ORB nfeatures")
      ->capture_default_str();
  eval->add_flag("--opencv-common-part", eval_args->opencv_common_part,
                 "Count regions exactly as OpenCV 4.6 evaluateFeatureDetector (default: the "
                 "paper's rule, regions inside both images)");
  eval->add_flag("--no-matching-score", eval_args->no_matching_score,
                 "Repeatability only (skips descriptor matching)");
  eval->add_flag("--markdown", eval_args->markdown, "Print the table as GitHub markdown");
  eval->add_option("--json", eval_args->json, "Write every count and score as JSON");
  eval->callback([eval_args] { RunEval(*eval_args); });
}

}  // namespace
AEROVO_REGISTER_COMMAND(RegisterFeaturesCommand);
}  // namespace aerovo::cli
