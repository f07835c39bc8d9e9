// The correspondence stage of the pipeline (docs/method.md, "Pipeline"): match the interest points
// of frame n-1 ("prev") with those of frame n ("curr") and fit the frame-to-frame transform
// robustly, either on all points ("standard", what MATLAB's matchFeatures +
// estimateGeometricTransform2D do) or with the paper's clustered RANSAC (Ivanov & Muzychuk 2023,
// step n). Both use the same matcher (aerovo/matching/matcher.h) and the same RANSAC loop
// (aerovo/estimation/ransac.h).
//
// Frames: pixel frame of features/keypoint.h ((0, 0) = centre of the top-left pixel, x right,
// y down). Every transform is curr_from_prev: it maps pixel positions of the earlier frame to
// pixel positions of the later one (3x3 homogeneous; last row (0, 0, 1) except for homography).
//
// Clustered RANSAC, precisely (ClusteredCrop, CorrespondenceStage::Clustered):
// 1. The previous step's transform last_curr_from_prev (frame n-2 -> n-1) gives the image
//    motion (t_u, t_v) = last_curr_from_prev(c) - c of the frame centre c = ((W-1)/2, (H-1)/2)
//    (exactly its translation when the rotation is zero, as the paper assumes). Image content
//    moves by (t_u, t_v) per step, i.e. the camera moves by -(t_u, t_v) in image terms.
// 2. Assuming the motion repeats from n-1 to n, prev points within |t_u| of the edge the
//    content moves toward leave the view: with t_u > 0 (content moves right, camera moves left)
//    the strip x >= W - |t_u| is dropped, with t_u < 0 the strip x < |t_u|; likewise t_v > 0
//    drops y >= H - |t_v| (bottom), t_v < 0 drops y < |t_v| (top). These are the strips "on the
//    sides opposite to the direction of the camera's motion". Strip widths are rounded up to
//    whole pixels; zero motion drops nothing.
// 3. The remaining rectangle (the crop) is split into grid_rows x grid_cols equal cells; a prev
//    point belongs to the cell containing it (points outside the crop belong to none).
// 4. Cells with at least min_points points are tried in order of increasing point count
//    (fewest first, the paper; ties: row-major order), or decreasing with CellOrder::kMostFirst.
//    For each: match only that cell's prev points against all curr points, run RANSAC on those
//    matches; the cell succeeds when RANSAC succeeds with at least min_inliers inliers. The
//    first success is the result.
// 5. If no cell succeeds (or none is eligible), the stage falls back to the standard method on
//    all points and says so (fell_back = true).
// 6. (aerovo addition, ClusteredRansacOptions::refine, on by default; refinement.h) A
//    successful cell's transform seeds a guided matching of up to refine_max_points points
//    spread over the other cells of the crop (radius refine_radius_px), and the same RANSAC runs
//    on those matches together with the cell's own. The spread fit confirms the cell's when it
//    moved it by at most refine_final_min_shift_px at the frame corners on at least min_inliers
//    more inliers: the model then holds across the frame, and the spread fit is the answer (the
//    first half of the spread points is matched and fitted first, and when that fit already
//    confirms the cell's the other half is skipped: refine_early_exit). Otherwise (the scene
//    departs from the model: relief, a tilted camera) a final pass re-matches every prev point
//    (at most refine_final_max_points of them) within refine_final_radius_px of the spread fit
//    and runs the same RANSAC again. With refine_fallback, a fall-back result is refit the same
//    way on every prev point. Accuracy and speed of each variant against the standard method:
//    BENCHMARKS.md "Correspondence".
//
// Files: cell_grid.h (crop, cells, cell of each point), match_and_fit.h (one match + RANSAC
// attempt), refinement.h (step 6), clustered.cc (steps 1-5), this header (options, result, the
// stage).
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "aerovo/core/image.h"
#include "aerovo/core/options.h"
#include "aerovo/correspondence/cell_grid.h"
#include "aerovo/correspondence/match_and_fit.h"
#include "aerovo/correspondence/refinement.h"
#include "aerovo/estimation/models.h"
#include "aerovo/estimation/ransac.h"
#include "aerovo/estimation/samplers.h"
#include "aerovo/features/keypoint.h"
#include "aerovo/matching/matcher.h"

namespace aerovo {

enum class CorrespondenceMethod {
  kStandard,   ///< Match all points, RANSAC on all matches.
  kClustered,  ///< The paper's clustered RANSAC (falls back to kStandard when it fails).
};

/// Order in which eligible cells are tried.
enum class CellOrder {
  kFewestFirst,  ///< Increasing point count (the paper: cheapest cell first).
  kMostFirst,    ///< Decreasing point count (more matches per attempt, slower).
};

/// Options specific to clustered RANSAC. Defaults are the paper's.
struct ClusteredRansacOptions {
  /// Grid over the cropped previous frame. Default 3 x 3 (the paper).
  int grid_rows = 3;
  int grid_cols = 3;
  /// Cells with fewer prev points are never tried. Default 12 (the paper).
  int min_points = 12;
  /// Default kFewestFirst (the paper).
  CellOrder cell_order = CellOrder::kFewestFirst;
  /// Drop the strips that leave the view (step 2 above). Default true (the paper); false keeps
  /// the whole frame (for ablation).
  bool crop = true;
  // Guided refinement of a cell's fit (step 6 above; refinement.h). An aerovo addition, not in
  // the paper; figures behind each default: BENCHMARKS.md "Correspondence".

  /// Refinement after a cell succeeds: take up to refine_max_points / (grid_rows * grid_cols)
  /// points from every other cell of the crop (in FeatureSet order, i.e. strongest first for
  /// SURF output), match them by guided matching around the cell transform's prediction
  /// (radius refine_radius_px) and run the same RANSAC on those matches together with the
  /// chosen cell's own matches (kept as they are, not matched again); the refined fit replaces
  /// the cell's if it succeeds with at least as many inliers. Then the final pass (below).
  /// Why: a cell covers ~1/9 of the frame, so its transform extrapolated to the frame corners is
  /// off by up to tens of pixels on real frames; well-spread points remove that, and guided
  /// matching of a bounded subset keeps the cost independent of the frame's point count.
  /// Default true; false is the paper's algorithm exactly, and turns off every refine_* below
  /// (refine_fallback included).
  bool refine = true;
  /// Search radius of the refinement's guided matching, px of the current frame: must cover the
  /// cell transform's extrapolation error. Default 40 px (MatchOptions' guided default).
  float refine_radius_px = 40.f;
  /// Points per refinement, spread over the cells (0 = every point in the crop). Default 180
  /// (our choice: 20 per cell of the 3 x 3 grid; an affine least-squares fit on that many
  /// well-spread inliers with 0.3 px noise is good to ~0.1 px at the corners).
  int refine_max_points = 180;
  /// Final pass of the refinement: every prev point (at most refine_final_max_points of them)
  /// is matched by guided matching within this radius (px of the current frame) of the refined
  /// transform's prediction and the same RANSAC runs on those matches; the result replaces the
  /// refined fit if it succeeds with at least as many inliers (among the points matched). Also
  /// the radius of refine_fallback's refit. 0 = no final pass. Why: a fit on a subset of the
  /// matches is a different estimate from one on all of them whenever the scene departs from
  /// the model (parallax, a tilted camera), so agreeing with the standard method needs the same
  /// evidence; after the spread refinement the prediction is good to a few pixels, and a disc
  /// that small holds ~1 candidate, so the pass costs a small fraction of exhaustive matching.
  /// Default 6 px (4x the RANSAC threshold of 1.5 px: the extrapolation error of the spread fit
  /// at the far corners).
  float refine_final_radius_px = 6.f;
  /// Prev points the final pass matches at most: with more, every k-th in FeatureSet order
  /// (point floor(j * n / max) for j = 0 .. max - 1: spread over the frame and over strengths
  /// like the whole set); 0 = every point. The pass's fit replaces the spread fit when it has
  /// at least as many inliers as the spread fit has among the sampled points (all of them
  /// uncapped). Why: the other stages of clustered RANSAC cost a cell's share of the points or
  /// a fixed amount, and an uncapped final pass would make the stage O(n) again (the paper's
  /// premise is thousands of points per frame), while a fit on ~1000 points' matches is
  /// statistically as close to the fit on all as the standard method is to itself with another
  /// seed. Default 1000 (our choice: the final pass then costs at most ~0.1 ms).
  int refine_final_max_points = 1000;
  /// The final pass runs only when the spread refinement moved the cell's fit by more than this
  /// at the prev frame's corners (px; largest of the four displacements); 0 = always run it.
  /// The spread fit must also have at least CorrespondenceOptions::min_inliers inliers more
  /// than the cell's: one that found no support in the other cells stays exactly on the cell's
  /// fit and confirms nothing. Why: where the frame-to-frame motion is affine (a flat scene seen
  /// from above: the paper's setting) the spread fit stays within a fraction of a pixel of the
  /// cell's and of the standard method's, so matching every point again buys nothing; where the
  /// scene departs from the model it moves the cell's fit by pixels, and only the final pass
  /// brings the answer to the standard method's. Default 1 px (our choice: between the largest
  /// shift measured on exact affine motion and the smallest on real pairs).
  float refine_final_min_shift_px = 1.f;
  /// Early exit of the spread refinement: it matches the first half of its points (per cell,
  /// the first ceil(n / 2) of the n it takes there) and fits; if that fit moved the cell's by at
  /// most refine_final_min_shift_px (> 0) at the corners, it is the answer, and neither the
  /// other half nor the final pass runs. Otherwise the other half is matched around the same
  /// prediction (the cell's fit) and the fit is made on all of them, which gives exactly the
  /// result of one pass over all the points (the matches do not depend on the split, RANSAC
  /// sees the same list, and the same seed). Why: where the model holds half of the points
  /// already show it (a fit on 10 well-spread points per cell is within ~0.05 px of one on
  /// 20); where it does not, the final pass needs the prediction of all of them. Default true;
  /// false always matches every spread point in one pass. refine_final_min_shift_px = 0
  /// disables it.
  bool refine_early_exit = true;
  /// Refit of a fall-back result (the standard method on all points, step 5): every prev point
  /// is matched by guided matching within refine_final_radius_px (> 0, checked by Validate) of
  /// the fall-back's fit, the same RANSAC runs on those matches, and the refit replaces the
  /// fall-back's fit when it has more inliers (CorrespondenceStage::RefitOnAllPoints; the
  /// odometry refits its relocalisations on a keyframe the same way). Why: the tight prior gives
  /// matches that exhaustive matching's ratio test drops (repeated texture), so the refit has at
  /// least as much evidence. Default false (a fall-back is then exactly the standard method,
  /// MATLAB's); the odometry's default is true (OdometryOptions::correspondence).
  bool refine_fallback = false;
};

/// Options of the correspondence stage (matching + robust estimation).
struct CorrespondenceOptions {
  /// Default kClustered (the paper's method); kStandard is the MATLAB baseline.
  CorrespondenceMethod method = CorrespondenceMethod::kClustered;
  /// Default kAffine (the paper's model, MATLAB 'affine').
  MotionModel model = MotionModel::kAffine;
  /// Default kUniform (MATLAB's MSAC). kProsac ranks the matches by descriptor SSD.
  SamplerKind sampler = SamplerKind::kUniform;
  /// An estimate (a cell's, or the standard one) counts as successful only with at least this
  /// many RANSAC inliers. Default 8 (our choice: the paper only says "if the attempt fails";
  /// MATLAB fails below the minimal sample, 3 for affine, which a random triple always meets;
  /// 8 leaves 5 independent confirmations of an affine fit).
  int min_inliers = 8;
  /// Guided matching: predict curr positions with the motion prior (clustered: the previous
  /// step's transform, i.e. constant image velocity; standard: the prior passed in) and compare
  /// only candidates within match.guided_radius_px. Default false (the paper matches
  /// exhaustively).
  bool guided_matching = false;
  MatchOptions match;
  RansacOptions ransac;
  ClusteredRansacOptions clustered;
};

/// Throws InvalidArgument naming the offending field (including nested match/ransac fields).
void Validate(const CorrespondenceOptions& options);
/// The option schemas (core/options.h; keys clustered.*, correspondence.* in a run configuration).
// clang-format off
template <class V>
void VisitFields(ClusteredRansacOptions& o, V& v) {
  using namespace options;
  v.Field(o.grid_rows, "grid_rows", "Grid rows over the cropped previous frame (the paper: 3)", Interval(1, 64));
  v.Field(o.grid_cols, "grid_cols", "Grid columns (the paper: 3)", Interval(1, 64));
  v.Field(o.min_points, "min_points", "Cells with fewer prev points are never tried (the paper: 12)", Interval(1, 1000000));
  v.Field(o.cell_order, "cell_order", "Order in which cells are tried (the paper: fewest-first)", Any());
  v.Field(o.crop, "crop", "Drop the strips that leave the view (the paper)", Any());
  v.Field(o.refine, "refine", "Refine a cell's fit on spread points, then on all points (false = the paper's clustered RANSAC exactly)", Any().Alias("refine"));
  v.Field(o.refine_radius_px, "refine_radius_px", "Search radius of the spread refinement's guided matching, px", GreaterThan(0).Finite());
  v.Field(o.refine_max_points, "refine_max_points", "Points per spread refinement (0 = every point in the crop)", Interval(0, 10000000));
  v.Field(o.refine_final_radius_px, "refine_final_radius_px", "Final pass on every point: search radius, px (0 = no final pass)", AtLeast(0).Finite());
  v.Field(o.refine_final_max_points, "refine_final_max_points", "Final pass: most prev points matched (0 = every point)", Interval(0, 10000000));
  v.Field(o.refine_final_min_shift_px, "refine_final_min_shift_px", "Final pass only when the spread fit moved the cell's by more, px (0 = always)", AtLeast(0).Finite());
  v.Field(o.refine_early_exit, "refine_early_exit", "Spread refinement stops after half its points when they confirm the cell's fit", Any());
  v.Field(o.refine_fallback, "refine_fallback", "Refit a fall-back's result on every point within refine_final_radius_px", Any());
}
template <class V>
void VisitFields(CorrespondenceOptions& o, V& v) {
  using namespace options;
  v.Group("match", o.match);
  v.Group("ransac", o.ransac);
  v.Group("clustered", o.clustered);
  v.Field(o.method, "method", "Correspondence: clustered (the paper) or standard (all points)", Any().Alias("mode"));
  v.Field(o.model, "model", "Motion model between frames", Any().Alias("model"));
  v.Field(o.sampler, "sampler", "RANSAC sampler: uniform (MATLAB MSAC) or prosac (best matches first)", Any());
  v.Field(o.min_inliers, "min_inliers", "RANSAC inliers needed for a successful estimate", Interval(1, 1000000).Alias("min_inliers"));
  v.Field(o.guided_matching, "guided_matching", "Guided matching with the motion prior (then unguided on failure)", Any().Alias("guided"));
}
// clang-format on
template <>
struct options::EnumTraits<CorrespondenceMethod> {
  static constexpr CorrespondenceMethod kValues[] = {CorrespondenceMethod::kStandard,
                                                     CorrespondenceMethod::kClustered};
  static const char* Name(CorrespondenceMethod m) {
    return m == CorrespondenceMethod::kStandard ? "standard" : "clustered";
  }
};
template <>
struct options::EnumTraits<CellOrder> {
  static constexpr CellOrder kValues[] = {CellOrder::kFewestFirst, CellOrder::kMostFirst};
  static const char* Name(CellOrder c) {
    return c == CellOrder::kFewestFirst ? "fewest-first" : "most-first";
  }
};
template <>
struct options::EnumTraits<SamplerKind> {  // the list of estimation/samplers.h
  static constexpr const auto& kValues = kAllSamplerKinds;
  static const char* Name(SamplerKind s) { return ToString(s); }
};
template <>
struct options::EnumTraits<MotionModel> {  // the list of estimation/models.h
  static constexpr const auto& kValues = kAllMotionModels;
  static const char* Name(MotionModel m) { return ToString(m); }
};

/// Result of the correspondence stage for one frame pair, returned by value.
struct CorrespondenceResult {
  bool success = false;
  /// Estimated transform from prev pixels to curr pixels (identity when !success).
  Eigen::Matrix3d curr_from_prev = Eigen::Matrix3d::Identity();
  /// The matches the returned transform was fitted to: those of the successful cell (or of the
  /// refinement's guided matching when `refined`), or of all points in the standard / fall-back
  /// case (the last attempt's when !success). Indices refer to prev.keypoints and
  /// curr.keypoints.
  std::vector<Match> matches;
  /// One entry per element of `matches`: 1 for RANSAC inliers of curr_from_prev.
  std::vector<std::uint8_t> inlier_mask;
  int num_inliers = 0;
  /// The method that produced the result: kClustered, or kStandard (asked for, or fall-back).
  CorrespondenceMethod method_used = CorrespondenceMethod::kStandard;
  /// Clustered RANSAC failed in every eligible cell (or none was eligible) and the standard
  /// method was run instead.
  bool fell_back = false;
  /// Cell that gave the result (row-major grid over `crop`), or -1 (standard / fall-back).
  int cell_row = -1;
  int cell_col = -1;
  /// Match + RANSAC runs made: cells tried, plus one for a standard or fall-back run, plus one
  /// for a refit on all points (refine_fallback, RefitOnAllPoints; the refinement of a cell's
  /// fit is not counted).
  int attempts = 0;
  /// The result was refined (ClusteredRansacOptions::refine): the cell's fit was replaced by
  /// the spread or the final pass's, or a fall-back's by its refit on all points.
  bool refined = false;
  /// The final pass of the refinement ran (see refine_final_min_shift_px), or a refit on all
  /// points.
  bool final_pass = false;
  /// How far the spread refinement moved the cell's fit at the prev frame's corners, px (NaN
  /// when it did not run or was not adopted).
  double refine_shift_px = std::numeric_limits<double>::quiet_NaN();
  /// The spread refinement stopped after its first half (see refine_early_exit).
  bool refine_early_exit = false;
  /// Clustered: the part of the prev frame kept (pixels, prev frame); standard: whole frame
  /// (empty when the frame size is unknown).
  RectI crop;
  /// Clustered: prev points per cell, row-major, grid_rows * grid_cols entries; else empty.
  std::vector<int> cell_point_counts;
  /// RANSAC trials and descriptor comparisons summed over all attempts.
  int ransac_trials = 0;
  std::int64_t num_comparisons = 0;
  /// Time in matching, in estimation (RANSAC incl. gathering points), and in total, ms.
  double match_ms = 0.0;
  double estimate_ms = 0.0;
  double total_ms = 0.0;
};

/// The correspondence stage with its reusable state (matcher buffers, point buffers, RANSAC
/// workspace). Not thread-safe: one instance per thread.
class CorrespondenceStage {
 public:
  /// Throws InvalidArgument if `options` are invalid.
  explicit CorrespondenceStage(const CorrespondenceOptions& options = {});

  const CorrespondenceOptions& options() const { return options_; }

  /// Runs options().method. `last_curr_from_prev` is the previous step's transform (frame n-2
  /// -> n-1); without it (first pair of a sequence) clustered RANSAC assumes zero motion and
  /// the standard method matches without prior.
  CorrespondenceResult Run(const FeatureSet& prev, int prev_width, int prev_height,
                           const FeatureSet& curr,
                           const std::optional<Eigen::Matrix3d>& last_curr_from_prev);

  /// Standard method: match all prev points against curr, RANSAC on all matches. With
  /// guided_matching and a prior, the prior (curr_from_prev predicted for this pair; affine part
  /// used) restricts the candidates. `crop` of the result is left empty.
  CorrespondenceResult Standard(const FeatureSet& prev, const FeatureSet& curr,
                                const std::optional<Eigen::Matrix3d>& prior = std::nullopt);

  /// Clustered RANSAC (see the header comment); prev_width x prev_height is the prev frame.
  CorrespondenceResult Clustered(const FeatureSet& prev, int prev_width, int prev_height,
                                 const FeatureSet& curr,
                                 const Eigen::Matrix3d& last_curr_from_prev);

  /// Refit of the successful result *result (of Standard, Clustered or Run on the same prev
  /// and curr, possibly by another stage) on every prev point, guided within
  /// clustered.refine_final_radius_px of result->curr_from_prev, with this stage's model,
  /// sampler, RANSAC options and min_inliers; the refit replaces the result's transform,
  /// matches, mask and inliers when it has more inliers (see ClusteredRansacOptions::
  /// refine_fallback, which makes Clustered() do this on a fall-back). Sets final_pass, and
  /// refined when replaced; adds its costs and one attempt. Returns whether it replaced the
  /// fit; false without running when !result->success. Throws InvalidArgument when
  /// clustered.refine_final_radius_px is 0.
  bool RefitOnAllPoints(const FeatureSet& prev, const FeatureSet& curr,
                        CorrespondenceResult* result);

 private:
  CorrespondenceOptions options_;
  Matcher matcher_;              // options.match: the cells, standard and fall-back attempts
  MatchAndFit fit_;              // match + RANSAC attempts, with the current frame prepared
  GuidedRefinement refinement_;  // step 6
  CellAssignment cells_;         // Clustered(): cell of every prev point
  std::vector<int> cell_order_;  // Clustered(): eligible cells in the order they are tried
  std::vector<int> subset_;      // prev points of one attempt (empty: every point)
};

/// One-shot conveniences (construct a CorrespondenceStage; prefer the class in a loop).
CorrespondenceResult StandardCorrespondence(
    const FeatureSet& prev, const FeatureSet& curr, const CorrespondenceOptions& options = {},
    const std::optional<Eigen::Matrix3d>& prior = std::nullopt);
CorrespondenceResult ClusteredCorrespondence(const FeatureSet& prev, int prev_width,
                                             int prev_height, const FeatureSet& curr,
                                             const Eigen::Matrix3d& last_curr_from_prev,
                                             const CorrespondenceOptions& options = {});

}  // namespace aerovo
