// Correspondence stage speed and accuracy: aerovo's RANSAC loop alone, and the whole stage
// (matching + estimation) with standard vs clustered RANSAC, side by side, with OpenCV's
// cv::estimateAffine2D (RANSAC and USAC_MAGSAC) on the same matches as the reference users know.
//
// Data:
// - synthetic correspondences (affine RANSAC scaling with N at 50 % outliers);
// - "synthetic-flight": 8 frames of 800 x 600 over a plane of random SURF-like points (random
//   unit descriptors + noise, ~3000 points per frame), constant image motion (-30, +12) px/step;
// - "tampa": all consecutive frames of $AEROVO_SHARED/data/flights/tampa-phantom3 (800 x 600, real
//   flight, unknown ground truth: clustered is compared with standard); "tampa-dense": its first
//   25 frames at SURF threshold 100 (~3700 points per frame, the paper's premise);
// - "callas": 1920 x 1080 crops of $AEROVO_SHARED/data/ortho/callas-quarry.jpg moved by a known
//   (72, 18) px per frame, so the true curr_from_prev is the shift (-72, -18).
// SURF (aerovo, MATLAB defaults) is computed once at start-up and is not timed.
// In every pair the clustered run gets the previous pair's clustered result as the previous
// step's transform (identity for the first pair), as the odometry pipeline would.
//
// At start-up a side-by-side report (per-pair times, speed-up, transform differences at the
// frame corners) is printed to stdout; then the Google Benchmark timings follow. Variants:
// standard, the paper's clustered RANSAC, its refinement on <= 180 spread points only, the
// refinement with a final pass over every point always (what the odometry does), aerovo's
// default (spread points, then a final pass over <= 1000 points when the spread fit does not
// confirm the cell's); the standard
// method re-run with other RANSAC seeds gives the floor of "agreement with standard"; every summary
// is repeated with RansacOptions::polish_iterations on. Run: build-x/bench/bench_correspondence
// [--benchmark_filter=...]   (see BENCHMARKS.md)
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/core/timer.h"
#include "aerovo/correspondence/correspondence.h"
#include "aerovo/estimation/ransac.h"
#include "aerovo/estimation/testing.h"
#include "aerovo/features/surf.h"
#include "aerovo/frames/image_file.h"

namespace {

namespace fs = std::filesystem;
using aerovo::CorrespondenceMethod;
using aerovo::CorrespondenceOptions;
using aerovo::CorrespondenceResult;
using aerovo::CorrespondenceStage;
using aerovo::FeatureSet;

fs::path SharedDir() {
  if (const char* env = std::getenv("AEROVO_SHARED"); env != nullptr && *env != '\0') return env;
  return AEROVO_SHARED_DIR_DEFAULT;
}

struct Sequence {
  std::string name;
  int width = 0, height = 0;
  std::vector<FeatureSet> frames;
  // truth[i]: true curr_from_prev of pair (i, i+1), when known.
  std::vector<std::optional<Eigen::Matrix3d>> truth;
  std::size_t pairs() const { return frames.empty() ? 0 : frames.size() - 1; }
};

Eigen::Matrix3d Shift(double tu, double tv) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m(0, 2) = tu;
  m(1, 2) = tv;
  return m;
}

Sequence MakeSyntheticFlight() {
  Sequence s;
  s.name = "synthetic-flight";
  s.width = 800;
  s.height = 600;
  const int num_frames = 8, dim = 64;
  const double du = -30.0, dv = 12.0;  // Image motion per frame.
  // World plane in frame-0 pixels, large enough for all frames; ~3000 points per frame.
  const double wx0 = -10, wy0 = -10 - num_frames * dv, wx1 = 810 - num_frames * du, wy1 = 610;
  const int num_world = static_cast<int>(3000.0 * (wx1 - wx0) * (wy1 - wy0) / (800.0 * 600.0));
  std::mt19937_64 rng(2023);
  std::uniform_real_distribution<double> ux(wx0, wx1), uy(wy0, wy1);
  std::normal_distribution<float> g(0.f, 1.f), dnoise(0.f, 0.012f);
  std::normal_distribution<double> pnoise(0.0, 0.3);
  std::vector<Eigen::Vector2d> pos(num_world);
  std::vector<float> desc(static_cast<std::size_t>(num_world) * dim);
  std::vector<std::int8_t> lap(num_world);
  for (int i = 0; i < num_world; ++i) {
    pos[i] = {ux(rng), uy(rng)};
    float n = 0;
    for (int k = 0; k < dim; ++k) n += (desc[i * dim + k] = g(rng)) * desc[i * dim + k];
    for (int k = 0; k < dim; ++k) desc[i * dim + k] /= std::sqrt(n);
    lap[i] = (rng() & 1) ? 1 : -1;
  }
  for (int f = 0; f < num_frames; ++f) {
    FeatureSet fs;
    fs.descriptor_size = dim;
    std::vector<float> d(dim);
    for (int i = 0; i < num_world; ++i) {
      const double x = pos[i].x() + f * du + pnoise(rng), y = pos[i].y() + f * dv + pnoise(rng);
      if (x < 0 || y < 0 || x > 799 || y > 599) continue;
      aerovo::Keypoint k;
      k.x = static_cast<float>(x);
      k.y = static_cast<float>(y);
      k.scale = 2.f;
      k.laplacian = lap[i];
      float n = 0;
      for (int j = 0; j < dim; ++j) n += (d[j] = desc[i * dim + j] + dnoise(rng)) * d[j];
      for (int j = 0; j < dim; ++j) d[j] /= std::sqrt(n);
      fs.keypoints.push_back(k);
      fs.descriptors.insert(fs.descriptors.end(), d.begin(), d.end());
    }
    s.frames.push_back(std::move(fs));
    if (f > 0) s.truth.push_back(Shift(du, dv));
  }
  return s;
}

FeatureSet Describe(aerovo::Surf& surf, const cv::Mat& gray) {
  const aerovo::GrayImageView view{gray.data, gray.cols, gray.rows,
                                   static_cast<std::ptrdiff_t>(gray.step[0])};
  return surf.DetectAndDescribe(view).features;
}

aerovo::SurfOptions SurfOpts() {
  aerovo::SurfOptions o;  // MATLAB defaults (the paper's).
  o.num_threads = 2;
  return o;
}

// num_frames <= 0: every photo of the flight.
Sequence LoadTampa(const std::string& name, int num_frames, double hessian_threshold) {
  Sequence s;
  s.name = name;
  const fs::path dir = SharedDir() / "data/flights/tampa-phantom3";
  if (!fs::is_directory(dir)) return s;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".JPG" || e.path().extension() == ".jpg") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  aerovo::SurfOptions so = SurfOpts();
  so.hessian_threshold = hessian_threshold;
  aerovo::Surf surf(so);
  if (num_frames <= 0) num_frames = static_cast<int>(files.size());
  for (int i = 0; i < num_frames && i < static_cast<int>(files.size()); ++i) {
    const cv::Mat gray = aerovo::ReadGrayImage(files[i]);  // BGR, then cvtColor
    s.width = gray.cols;
    s.height = gray.rows;
    s.frames.push_back(Describe(surf, gray));
    if (s.frames.size() > 1) s.truth.emplace_back(std::nullopt);
  }
  return s;
}

Sequence LoadCallas(int num_frames) {
  Sequence s;
  s.name = "callas";
  const fs::path file = SharedDir() / "data/ortho/callas-quarry.jpg";
  if (!fs::exists(file)) return s;
  const cv::Mat gray = aerovo::ReadGrayImage(file);  // BGR, then cvtColor
  s.width = 1920;
  s.height = 1080;
  const int x0 = 1600, y0 = 1700, dx = 72, dy = 18;  // Inside the imaged part of the quarry.
  aerovo::Surf surf(SurfOpts());
  for (int f = 0; f < num_frames; ++f) {
    const cv::Mat crop = gray(cv::Rect(x0 + f * dx, y0 + f * dy, s.width, s.height)).clone();
    s.frames.push_back(Describe(surf, crop));
    if (f > 0) s.truth.push_back(Shift(-dx, -dy));
  }
  return s;
}

const std::vector<Sequence>& Sequences() {
  static const std::vector<Sequence> seqs = [] {
    std::vector<Sequence> v;
    v.push_back(MakeSyntheticFlight());
    v.push_back(LoadTampa("tampa", 0, 1000.0));
    // The paper's premise, many points per frame: SURF threshold 100 (~4000 points on these
    // 800 x 600 photos), first 25 photos.
    v.push_back(LoadTampa("tampa-dense", 25, 100.0));
    v.push_back(LoadCallas(8));
    return v;
  }();
  return seqs;
}

const Sequence* FindSequence(const std::string& name) {
  for (const Sequence& s : Sequences()) {
    if (s.name == name && s.pairs() > 0) return &s;
  }
  return nullptr;
}

// Runs the stage over every consecutive pair; clustered gets the previous clustered result.
std::vector<CorrespondenceResult> RunSequence(const Sequence& s, CorrespondenceStage& stage) {
  std::vector<CorrespondenceResult> out;
  std::optional<Eigen::Matrix3d> last;
  for (std::size_t i = 0; i < s.pairs(); ++i) {
    out.push_back(stage.Run(s.frames[i], s.width, s.height, s.frames[i + 1], last));
    if (out.back().success) last = out.back().curr_from_prev;
  }
  return out;
}

// refine = false: the paper's clustered RANSAC exactly (the cell's own fit).
CorrespondenceOptions StageOptions(CorrespondenceMethod method, bool refine = true) {
  CorrespondenceOptions o;
  o.method = method;
  o.clustered.refine = refine;
  return o;
}

// The stage variants compared side by side (report and BM_Stage); `bench` names the
// Google Benchmark.
struct Variant {
  const char* name;
  const char* bench;
  CorrespondenceOptions options;
};
// polish: every variant with RansacOptions::polish_iterations = kPolishIterations.
constexpr int kPolishIterations = 20;
std::vector<Variant> ReportVariants(bool polish) {
  CorrespondenceOptions spread = StageOptions(CorrespondenceMethod::kClustered, true);
  spread.clustered.refine_final_radius_px = 0.f;
  CorrespondenceOptions full = StageOptions(CorrespondenceMethod::kClustered, true);
  full.clustered.refine_final_min_shift_px = 0.f;
  full.clustered.refine_final_max_points = 0;
  std::vector<Variant> v = {
      {"std", polish ? "standard_polish" : "standard",
       StageOptions(CorrespondenceMethod::kStandard)},
      {"paper", polish ? "clustered_paper_polish" : "clustered_paper",
       StageOptions(CorrespondenceMethod::kClustered, false)},
      {"spread", polish ? "clustered_spread_polish" : "clustered_spread", spread},
      {"full", polish ? "clustered_full_polish" : "clustered_full", full},
      {"ref", polish ? "clustered_refined_polish" : "clustered_refined",
       StageOptions(CorrespondenceMethod::kClustered, true)}};
  if (polish) {
    for (Variant& x : v) x.options.ransac.polish_iterations = kPolishIterations;
  }
  return v;
}

// The standard method's matches per pair (cached), as cv::Mat point arrays for OpenCV.
struct PairMatches {
  Eigen::Matrix2Xd prev_px, curr_px;
  std::vector<cv::Point2f> prev_cv, curr_cv;
};
const std::vector<PairMatches>& StandardMatches(const Sequence& s) {
  static std::map<std::string, std::vector<PairMatches>> cache;
  auto it = cache.find(s.name);
  if (it != cache.end()) return it->second;
  aerovo::Matcher matcher;
  std::vector<PairMatches> v;
  for (std::size_t i = 0; i < s.pairs(); ++i) {
    const auto mr = matcher.Match(s.frames[i], s.frames[i + 1]);
    PairMatches pm;
    const int n = static_cast<int>(mr.matches.size());
    pm.prev_px.resize(2, n);
    pm.curr_px.resize(2, n);
    for (int k = 0; k < n; ++k) {
      const auto& p = s.frames[i].keypoints[mr.matches[k].prev_index];
      const auto& c = s.frames[i + 1].keypoints[mr.matches[k].curr_index];
      pm.prev_px.col(k) << p.x, p.y;
      pm.curr_px.col(k) << c.x, c.y;
      pm.prev_cv.emplace_back(p.x, p.y);
      pm.curr_cv.emplace_back(c.x, c.y);
    }
    v.push_back(std::move(pm));
  }
  return cache.emplace(s.name, std::move(v)).first->second;
}

enum class CvMethod { kRansac, kMagsac };

// OpenCV's defaults as documented (docs/method.md, "Estimation defaults"): RANSAC, 3 px, 2000
// iterations, 0.99, 10 LM refinement iterations; USAC_MAGSAC with the same threshold (its sigma
// bound) and limits.
std::optional<Eigen::Matrix3d> CvEstimate(const PairMatches& pm, CvMethod method) {
  if (pm.prev_cv.size() < 3) return std::nullopt;
  cv::Mat inliers;
  const cv::Mat a = cv::estimateAffine2D(pm.prev_cv, pm.curr_cv, inliers,
                                         method == CvMethod::kRansac ? cv::RANSAC : cv::USAC_MAGSAC,
                                         3.0, 2000, 0.99, 10);
  if (a.empty()) return std::nullopt;
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = a.at<double>(r, c);
  }
  return m;
}

// ------------------------------------------------------------------ benchmarks

void BM_RansacAffine(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  Eigen::Matrix3d truth;
  truth << 1.03, 0.04, 15.0, -0.05, 0.97, 25.0, 0, 0, 1;
  const auto data = aerovo::testing::MakeCorrespondences(truth, n / 2, n - n / 2, 0.5, 42);
  aerovo::Ransac<aerovo::AffineModel> ransac;
  int trials = 0;
  for (auto _ : state) {
    const auto r = ransac.Estimate(data.prev, data.curr);
    trials = r.num_trials;
    benchmark::DoNotOptimize(r.curr_from_prev);
  }
  state.counters["trials"] = trials;
}
BENCHMARK(BM_RansacAffine)->Arg(500)->Arg(2000)->Arg(10000)->Unit(benchmark::kMillisecond);

void BM_Stage(benchmark::State& state, const std::string& seq,
              const CorrespondenceOptions& options) {
  const Sequence* s = FindSequence(seq);
  if (s == nullptr) {
    state.SkipWithError(("sequence " + seq + " unavailable (../shared missing?)").c_str());
    return;
  }
  CorrespondenceStage stage(options);
  for (auto _ : state) benchmark::DoNotOptimize(RunSequence(*s, stage));
  // Time per pair = reported time / pairs (CPU time is the steadier figure on a loaded machine).
  state.counters["pairs"] = static_cast<double>(s->pairs());
}

void BM_EstimateOnly(benchmark::State& state, const std::string& seq, int which) {
  const Sequence* s = FindSequence(seq);
  if (s == nullptr) {
    state.SkipWithError(("sequence " + seq + " unavailable (../shared missing?)").c_str());
    return;
  }
  const auto& pms = StandardMatches(*s);
  aerovo::Ransac<aerovo::AffineModel> ransac;
  for (auto _ : state) {
    for (const PairMatches& pm : pms) {
      if (which == 0) {
        benchmark::DoNotOptimize(ransac.Estimate(pm.prev_px, pm.curr_px));
      } else {
        benchmark::DoNotOptimize(
            CvEstimate(pm, which == 1 ? CvMethod::kRansac : CvMethod::kMagsac));
      }
    }
  }
  // Time per pair = reported time / pairs (CPU time is the steadier figure on a loaded machine).
  state.counters["pairs"] = static_cast<double>(s->pairs());
}

void RegisterStageBenchmarks() {
  for (const char* seq : {"synthetic-flight", "tampa", "tampa-dense", "callas"}) {
    const std::string name = seq;
    for (bool polish : {false, true}) {
      for (const Variant& v : ReportVariants(polish)) {
        benchmark::RegisterBenchmark(("BM_Stage/" + name + "/" + v.bench).c_str(), BM_Stage, name,
                                     v.options)
            ->Unit(benchmark::kMillisecond);
      }
    }
    benchmark::RegisterBenchmark(("BM_EstimateOnly/" + name + "/aerovo_msac").c_str(),
                                 BM_EstimateOnly, name, 0)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("BM_EstimateOnly/" + name + "/cv_ransac").c_str(),
                                 BM_EstimateOnly, name, 1)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("BM_EstimateOnly/" + name + "/cv_usac_magsac").c_str(),
                                 BM_EstimateOnly, name, 2)
        ->Unit(benchmark::kMillisecond);
  }
}

// ------------------------------------------------------------------ side-by-side report

struct Stats {
  double mean = 0, median = 0, max = 0;
};
Stats Summarise(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  for (double x : v) s.mean += x;
  s.mean /= v.size();
  std::sort(v.begin(), v.end());
  s.median = v[v.size() / 2];
  s.max = v.back();
  return s;
}

// Per-pair rows printed per sequence (the summaries cover every pair).
constexpr std::size_t kMaxRowsPrinted = 15;
// Seeds of the standard method's reproducibility check (seed 1 is the compared run).
constexpr int kSeedsChecked = 5;

// Per-sequence figures of one variant for the overall summary.
struct VariantSummary {
  double speedup = 0;       // mean standard time / mean variant time
  double mean_diff_px = 0;  // mean corner difference to standard
};
// One entry per variant (index 0 = standard, unused); empty when the sequence is unavailable.
std::vector<VariantSummary> ReportSequence(const Sequence& s, bool polish);

void Report() {
  std::printf("# Correspondence stage: standard vs clustered RANSAC (per frame pair)\n");
  std::printf(
      "# std = standard (match all + MSAC); paper = clustered RANSAC exactly as the paper; spread "
      "= "
      "clustered + refinement on <= 180 points spread over the crop (guided, 40 px; the first "
      "90 only when their fit confirms the cell's); full = spread on all 180, then a final pass "
      "over every point (guided, 6 px), always (the odometry's refinement); ref = aerovo's "
      "default: spread, then the final pass, over at most 1000 points, only if the spread fit "
      "moved the cell's by more than 1 px at the corners; seeds = the standard method itself "
      "with RANSAC "
      "seeds 2-%d (its own reproducibility: no estimate can be expected to agree with one "
      "standard run better than another standard run does). Times: wall clock, fastest of 5 runs "
      "per pair. Corner diff / error: largest displacement of the 4 frame corners, px. Lines "
      "'summary NAME +polish' repeat the summaries with RansacOptions::polish_iterations = %d in "
      "every variant (and compare with the polished standard).\n",
      1 + kSeedsChecked, kPolishIterations);
  // overall[polish][variant]: per-sequence summaries, averaged over the sequences below.
  std::vector<std::vector<std::vector<VariantSummary>>> overall(2);
  int sequences = 0;
  for (const Sequence& s : Sequences()) {
    for (bool polish : {false, true}) {
      std::vector<VariantSummary> v = ReportSequence(s, polish);
      if (!v.empty()) overall[polish].push_back(std::move(v));
    }
    sequences += s.pairs() > 0;
  }
  const std::vector<Variant> names = ReportVariants(false);
  for (int polish = 0; polish < 2 && sequences > 0; ++polish) {
    std::printf("summary overall%s (mean over the %d sequences of the per-sequence figures):",
                polish ? " +polish" : "", sequences);
    for (std::size_t v = 1; v < names.size(); ++v) {
      double speedup = 0, diff = 0, worst = 0;
      for (const auto& seq : overall[polish]) {
        speedup += seq[v].speedup;
        diff += seq[v].mean_diff_px;
        worst = std::max(worst, seq[v].mean_diff_px);
      }
      const double n = static_cast<double>(overall[polish].size());
      std::printf(" %s %.1fx, corner diff %.2f px (worst sequence %.2f px);", names[v].name,
                  speedup / n, diff / n, worst);
    }
    std::printf("\n");
  }
  std::fflush(stdout);
}

std::vector<VariantSummary> ReportSequence(const Sequence& s, bool polish) {
  const std::vector<Variant> variants = ReportVariants(polish);
  const std::size_t nv = variants.size();
  const std::string label = s.name + (polish ? " +polish" : "");
  if (s.pairs() == 0) {
    if (!polish) std::printf("\n## %s: unavailable (../shared missing), skipped\n", s.name.c_str());
    return {};
  }
  double mean_points = 0;
  for (const FeatureSet& f : s.frames) mean_points += f.size();
  mean_points /= s.frames.size();
  // Five runs each; per pair the fastest (other processes load the machine: the minimum is
  // the least disturbed). Results are identical across runs (seeded).
  std::vector<std::vector<CorrespondenceResult>> res(nv);
  std::vector<std::vector<double>> times(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    CorrespondenceStage stage(variants[v].options);
    times[v].assign(s.pairs(), std::numeric_limits<double>::infinity());
    for (int run = 0; run < 5; ++run) {
      res[v] = RunSequence(s, stage);
      for (std::size_t i = 0; i < s.pairs(); ++i) {
        times[v][i] = std::min(times[v][i], res[v][i].total_ms);
      }
    }
  }
  const auto& pms = StandardMatches(s);
  if (!polish) {
    std::printf("\n## %s: %zu pairs, %dx%d, %.0f SURF points/frame%s\n", s.name.c_str(), s.pairs(),
                s.width, s.height, mean_points,
                s.pairs() > kMaxRowsPrinted ? " (rows: the first 15 pairs; summaries: all)" : "");
    std::string names;
    for (const Variant& x : variants) names += std::string(" ") + x.name;
    std::printf(
        "pair | ms:%s | cell attempts fellback | inliers/matches:%s | corner diff to std px:%s "
        "seeds(max) | err to truth px:%s cvRANSAC cvMAGSAC | ref: final pass, spread shift px | "
        "cv ms: RANSAC MAGSAC\n",
        names.c_str(), names.c_str(), names.c_str() + 4, names.c_str());
  }
  // diffs[v]: corner difference of variant v to standard (v = 0: unused); seeds: standard with
  // other seeds vs standard; errs[v], errs[nv], errs[nv + 1]: error to truth of v, cv RANSAC,
  // cv USAC_MAGSAC.
  std::vector<std::vector<double>> diffs(nv), errs(nv + 2);
  std::vector<double> seeds, d_cvr, d_cvm, t_cvr, t_cvm;
  int fallbacks = 0, failures = 0, paper_attempts = 0;
  for (std::size_t i = 0; i < s.pairs(); ++i) {
    const CorrespondenceResult& a = res[0][i];
    const CorrespondenceResult& p = res[1][i];
    std::optional<Eigen::Matrix3d> cvr, cvm;
    double best_r = std::numeric_limits<double>::infinity(), best_m = best_r;
    for (int run = 0; run < (polish ? 1 : 5); ++run) {
      aerovo::Stopwatch w;
      cvr = CvEstimate(pms[i], CvMethod::kRansac);
      best_r = std::min(best_r, w.elapsed_ms());
      w.restart();
      cvm = CvEstimate(pms[i], CvMethod::kMagsac);
      best_m = std::min(best_m, w.elapsed_ms());
    }
    t_cvr.push_back(best_r);
    t_cvm.push_back(best_m);
    fallbacks += p.fell_back;
    paper_attempts += p.attempts;
    const auto corner = [&](const Eigen::Matrix3d& x, const Eigen::Matrix3d& y) {
      return aerovo::MaxCornerDisplacementPx(x, y, s.width, s.height);
    };
    std::vector<double> d(nv, NAN), e(nv + 2, NAN);
    for (std::size_t v = 0; v < nv; ++v) {
      const CorrespondenceResult& x = res[v][i];
      failures += !x.success;
      if (v > 0 && a.success && x.success)
        diffs[v].push_back(d[v] = corner(a.curr_from_prev, x.curr_from_prev));
      if (s.truth[i] && x.success) errs[v].push_back(e[v] = corner(x.curr_from_prev, *s.truth[i]));
    }
    double seed_max = NAN;
    for (int k = 0; k < kSeedsChecked && a.success; ++k) {
      CorrespondenceOptions o = variants[0].options;
      o.ransac.seed = variants[0].options.ransac.seed + 1 + k;
      CorrespondenceStage other(o);
      const CorrespondenceResult b = other.Standard(s.frames[i], s.frames[i + 1]);
      if (!b.success) continue;
      seeds.push_back(corner(a.curr_from_prev, b.curr_from_prev));
      seed_max = std::isnan(seed_max) ? seeds.back() : std::max(seed_max, seeds.back());
    }
    if (a.success && cvr) d_cvr.push_back(corner(a.curr_from_prev, *cvr));
    if (a.success && cvm) d_cvm.push_back(corner(a.curr_from_prev, *cvm));
    if (s.truth[i] && cvr) errs[nv].push_back(e[nv] = corner(*cvr, *s.truth[i]));
    if (s.truth[i] && cvm) errs[nv + 1].push_back(e[nv + 1] = corner(*cvm, *s.truth[i]));
    if (polish || i >= kMaxRowsPrinted) continue;
    std::printf("%zu |", i);
    for (std::size_t v = 0; v < nv; ++v) std::printf(" %.2f", times[v][i]);
    std::printf(" | (%d,%d) %d %s |", p.cell_row, p.cell_col, p.attempts,
                p.fell_back ? "yes" : "no");
    for (std::size_t v = 0; v < nv; ++v) {
      std::printf(" %d/%zu", res[v][i].num_inliers, res[v][i].matches.size());
    }
    std::printf(" |");
    for (std::size_t v = 1; v < nv; ++v) std::printf(" %.2f", d[v]);
    std::printf(" %.2f |", seed_max);
    for (std::size_t v = 0; v < nv + 2; ++v) std::printf(" %.3f", e[v]);
    const CorrespondenceResult& ref = res[nv - 1][i];
    std::printf(" | %s %.2f | %.2f %.2f\n", ref.final_pass ? "yes" : "no", ref.refine_shift_px,
                t_cvr.back(), t_cvm.back());
  }
  std::vector<Stats> st(nv);
  for (std::size_t v = 0; v < nv; ++v) st[v] = Summarise(times[v]);
  std::printf("summary %s time ms/pair mean (median, max):", label.c_str());
  for (std::size_t v = 0; v < nv; ++v) {
    std::printf(" %s %.3f (%.3f, %.3f);", variants[v].name, st[v].mean, st[v].median, st[v].max);
  }
  std::printf(" speed-up of the mean:");
  for (std::size_t v = 1; v < nv; ++v) {
    std::printf(" %s %.1fx", variants[v].name, st[0].mean / st[v].mean);
  }
  std::printf("; paper: %.2f cells tried per pair, fell back %d/%zu; failed runs %d\n",
              static_cast<double>(paper_attempts) / s.pairs(), fallbacks, s.pairs(), failures);
  const auto mm = [](const std::vector<double>& v) {
    if (v.empty()) return std::string("n/a");
    const Stats x = Summarise(v);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3f / %.3f", x.mean, x.max);
    return std::string(buf);
  };
  std::printf("summary %s corner difference to standard px, mean / max:", label.c_str());
  for (std::size_t v = 1; v < nv; ++v) {
    std::printf(" %s %s,", variants[v].name, mm(diffs[v]).c_str());
  }
  std::printf(" standard with other seeds %s, cv RANSAC (3 px) %s, cv USAC_MAGSAC %s\n",
              mm(seeds).c_str(), mm(d_cvr).c_str(), mm(d_cvm).c_str());
  if (!errs[0].empty()) {
    std::printf("summary %s corner error to ground truth px, mean / max:", label.c_str());
    for (std::size_t v = 0; v < nv; ++v) {
      std::printf(" %s %s,", variants[v].name, mm(errs[v]).c_str());
    }
    std::printf(" cv RANSAC %s, cv USAC_MAGSAC %s\n", mm(errs[nv]).c_str(),
                mm(errs[nv + 1]).c_str());
  }
  // The default's gate: how far the spread refinement moved the cell's fit (px at the corners).
  int final_passes = 0, early_exits = 0;
  std::vector<double> shifts;
  for (const CorrespondenceResult& r : res[nv - 1]) {
    final_passes += r.final_pass;
    early_exits += r.refine_early_exit;
    if (std::isfinite(r.refine_shift_px)) shifts.push_back(r.refine_shift_px);
  }
  std::sort(shifts.begin(), shifts.end());
  const auto pct = [&](double q) {
    return shifts.empty() ? NAN : shifts[static_cast<std::size_t>(q * (shifts.size() - 1) + 0.5)];
  };
  std::printf(
      "summary %s ref (default): early exit after half the spread points in %d and final pass "
      "run in %d of %zu pairs; spread refinement moved the "
      "cell's fit by (px at the corners) min %.2f, 10th percentile %.2f, median %.2f, 90th "
      "percentile %.2f, max %.2f\n",
      label.c_str(), early_exits, final_passes, s.pairs(), pct(0.0), pct(0.1), pct(0.5), pct(0.9),
      pct(1.0));
  if (!polish) {
    std::printf(
        "summary %s estimation only on the standard matches, mean ms/pair: cv RANSAC %.3f, cv "
        "USAC_MAGSAC %.3f (aerovo MSAC: BM_EstimateOnly)\n",
        s.name.c_str(), Summarise(t_cvr).mean, Summarise(t_cvm).mean);
  }
  std::vector<VariantSummary> out(nv);
  for (std::size_t v = 1; v < nv; ++v) {
    out[v].speedup = st[0].mean / st[v].mean;
    out[v].mean_diff_px = Summarise(diffs[v]).mean;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  bool report = true;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--no_report") report = false;
  }
  if (report) Report();
  RegisterStageBenchmarks();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
