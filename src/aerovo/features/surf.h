// SURF: Speeded-Up Robust Features (Bay, Ess, Tuytelaars, Van Gool, CVIU 110(3), 2008),
// aerovo's own implementation. Semantics follow MATLAB's detectSURFFeatures/extractFeatures
// (which call OpenCV's fast-Hessian), as used by Ivanov & Muzychuk (2023); see
// docs/method.md, "Detection defaults" and "SURF details".
//
// What Surf computes (facts from Bay et al. 2008 and OpenCV's documented SURF; the code is ours):
// - Integral image in uint32 (exact box sums, see integral_image.h).
// - Fast-Hessian: octave o, layer l uses box filters of side (9 + 6 l) 2^o sampled every 2^o
//   pixels; Dxx, Dyy, Dxy have each lobe divided by its area (OpenCV), det = Dxx Dyy -
//   0.81 Dxy^2 on 0..255 intensities, so `hessian_threshold` means exactly OpenCV's
//   hessianThreshold / MATLAB's MetricThreshold. Maxima strictly greater than their 26
//   neighbours in the 3x3x3 (x, y, layer) neighbourhood, above the threshold; one quadratic
//   step refines x, y and the filter size (rejected if any offset exceeds one sample).
//   Keypoint::scale = 1.2 * size / 9 with the interpolated size (OpenCV rounds the size; we do
//   not). A Gaussian blob of standard deviation sigma is found at scale ~0.75 sigma (the box
//   filters smooth more than the 1.2-sigma Gaussian they stand for; see surf_test.cc).
//   Keypoint::response is the determinant at the sample (not interpolated), as OpenCV.
//   Keypoint::laplacian = sign(Dxx + Dyy): -1 for bright blobs on dark, +1 for dark blobs.
// - Orientation: Haar wavelets of side 4s at the 113 points of a disc of radius 6s sampled every
//   s, Gaussian weights (sigma 2.5s), vector sums over a 60-degree window slid in 5-degree steps;
//   the strongest window's summed vector gives Keypoint::orientation = atan2(sum dy, sum dx) in
//   the image frame (x right, y down, so positive angles turn clockwise on screen).
// - Descriptor: a 20s x 20s window turned to the orientation, 20x20 samples s apart, Haar
//   wavelets of side 2s, responses rotated into the keypoint frame and Gaussian weighted
//   (sigma 3.3s); 4x4 sub-regions of 5x5 samples give (sum du, sum dv, sum |du|, sum |dv|)
//   (64 values) or, extended, du sums split by the sign of dv and dv sums split by the sign of
//   du (128 values, OpenCV's layout); L2-normalised.
// - Results do not depend on num_threads (bit-identical).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/core/options.h"
#include "aerovo/features/keypoint.h"

namespace aerovo {

/// Options of the SURF stage. Defaults are MATLAB's detectSURFFeatures/extractFeatures
/// defaults, the ones the paper used.
struct SurfOptions {
  /// Minimum Hessian determinant, on 0..255 intensities; identical in meaning to MATLAB's
  /// MetricThreshold and OpenCV's hessianThreshold. Default 1000 (MATLAB).
  double hessian_threshold = 1000.0;
  /// Number of octaves (filter sizes double per octave). Default 3 (MATLAB NumOctaves).
  int num_octaves = 3;
  /// Scale levels per octave, >= 3 (MATLAB NumScaleLevels; OpenCV nOctaveLayers = this - 2).
  /// Default 4 (MATLAB).
  int num_scale_levels = 4;
  /// Only keypoints whose centre lies inside this rectangle (pixels) are kept; whole image
  /// when unset (MATLAB ROI).
  std::optional<RectI> roi;
  /// Keep at most this many keypoints, strongest response first; 0 keeps all.
  int max_keypoints = 0;
  /// Skip orientation assignment (orientation = 0): faster, not rotation invariant.
  /// Default false (MATLAB extractFeatures Upright = false).
  bool upright = false;
  /// 128-value descriptor instead of 64. Default false (MATLAB FeatureSize 64).
  bool extended = false;
  /// Adaptive interest points (aerovo's, not MATLAB's; the default of `aerovo run`, see
  /// OdometryOptions): instead of the fixed hessian_threshold (then ignored), every frame keeps
  /// about target_points well-spread points whatever its contrast. The fast-Hessian runs once at
  /// a low floor, min_response scaled by the frame's contrast ((robust intensity range / 255)^2:
  /// the determinant scales with the square of the intensities, so a dim or hazy frame has the
  /// same floor relative to its texture as a bright one); then each cell of a grid x grid grid
  /// over the image (or roi) keeps its strongest target_points / grid^2 points, and the rest of
  /// the target goes to the strongest remaining points anywhere; only the kept points get an
  /// orientation and a descriptor. Points that can no longer be kept are rejected as soon as
  /// the scan meets them (SurfResult::candidates), and in a stream each grid cell is searched
  /// only above a floor of its own steered by the previous frame (SurfResult::
  /// next_cell_min_response), which keeps the cost of the low floor small (BENCHMARKS.md,
  /// "Adaptive interest points", "SURF at the same number of points"). Default false (MATLAB's
  /// fixed threshold).
  bool adaptive = false;
  /// Adaptive: points kept per frame (fewer when the frame has fewer above the floor).
  /// Default 1500 (BENCHMARKS.md, "Adaptive interest points": simulated flights, normal and
  /// thermal-like, and the shared flights).
  int target_points = 1500;
  /// Adaptive: cells per side of the spreading grid. Default 6 (a multiple of the 3x3 cells of
  /// the clustered RANSAC, so that every one of its cells gets points).
  int grid = 6;
  /// Adaptive: the floor of the Hessian determinant, on a frame of full contrast (robust range
  /// 255 intensity levels); the frame's floor is this times (range / 255)^2, the range being the
  /// 1st to 99th percentile of its intensities (at least 8 levels, so that a nearly uniform
  /// frame is not amplified into noise). Default 100 (1/10 of MATLAB's threshold; the thermal-like
  /// simulated flight gives the same track at 20, 100 and 300, and the floor sets the cost of
  /// the adaptation: BENCHMARKS.md, "Adaptive interest points").
  double min_response = 100.0;
  /// Threads for detection and description; 1 = single-threaded, 0 = one per core this process
  /// may use (core/parallel.h). Results are identical for any value.
  int num_threads = 1;
};

/// Throws InvalidArgument naming the offending field when `options` are out of range.
void Validate(const SurfOptions& options);
/// The option schema (core/options.h; keys surf.* in a run configuration). roi is not in it.
// clang-format off
template <class V>
void VisitFields(SurfOptions& o, V& v) {
  using namespace options;
  v.Field(o.hessian_threshold, "hessian_threshold", "SURF Hessian threshold (MATLAB MetricThreshold)", AtLeast(0).Finite().Alias("surf_threshold"));
  v.Field(o.num_octaves, "num_octaves", "Octaves of box filters (MATLAB NumOctaves)", Interval(1, 10));
  v.Field(o.num_scale_levels, "num_scale_levels", "Scale levels per octave (MATLAB NumScaleLevels)", Interval(3, 16));
  v.Field(o.max_keypoints, "max_keypoints", "Keep the N strongest keypoints per frame (0 = all)", Interval(0, 10000000).Alias("max_keypoints"));
  v.Field(o.upright, "upright", "No orientation (faster, not rotation invariant)", Any());
  v.Field(o.extended, "extended", "128-value descriptor instead of 64", Any());
  v.Field(o.adaptive, "adaptive", "Adaptive points: about target_points per frame spread over a grid, whatever the contrast (false = fixed hessian_threshold, MATLAB)", Any());
  v.Field(o.target_points, "target_points", "Adaptive: points kept per frame", Interval(1, 1000000));
  v.Field(o.grid, "grid", "Adaptive: cells per side of the spreading grid (each keeps its strongest points)", Interval(1, 64));
  v.Field(o.min_response, "min_response", "Adaptive: Hessian floor at full contrast, scaled by (frame's robust intensity range / 255)^2", AtLeast(0).Finite());
  v.Field(o.num_threads, "num_threads", "SURF threads (0 = all cores; same results)", Interval(0, kMaxOptionThreads));
}
// clang-format on

/// Result of one SURF call, returned by value.
struct SurfResult {
  FeatureSet features;       ///< Keypoints (sorted by decreasing response) and descriptors.
  double detect_ms = 0.0;    ///< Integral image + fast-Hessian + orientation.
  double describe_ms = 0.0;  ///< Descriptor computation.
  /// Adaptive mode: points found above the frame's floor that reached the selection, the
  /// frame's robust intensity range (1st to 99th percentile, levels) and its floor (determinant
  /// units). 0 in fixed-threshold mode. A point already beaten by enough stronger ones (its
  /// cell's quota and the rest of the target) is rejected before its outer-layer test and
  /// refinement and not counted, so `candidates` is at most the number of points above the
  /// floor (all of them when they are no more than target_points); it does not depend on
  /// num_threads. The kept points are exactly those a selection over every point above the
  /// floor keeps.
  int candidates = 0;
  double contrast_range = 0.0;
  double floor_response = 0.0;
  /// Adaptive mode: a floor (min_response units, full contrast) for the next frame of a stream:
  /// half the weakest cell's first dropped response, or half this frame's floor when some cell
  /// (or the frame) had fewer candidates than its share. Passing it to the next call
  /// (steered_min_response) keeps the candidates few on textured frames (the cost of the
  /// adaptation: BENCHMARKS.md) and lets the floor fall back to min_response when frames get
  /// weaker. 0 in fixed-threshold mode.
  double next_min_response = 0.0;
  /// Adaptive mode: a floor per cell of the grid (grid x grid values, row-major from the top
  /// left of the image or roi; min_response units, full contrast) for the next frame of a
  /// stream: a fraction of the lower of the cell's first dropped response and the weakest point
  /// kept beyond the cells' quotas, 0.8 when this frame's own cell floors all held (none was
  /// searched again), else 0.5; 0 for a cell that had no more candidates than its quota, and
  /// for every cell when the frame had no more than target_points. Passed to the next call
  /// (steered_cell_min_response), each cell is searched only above its own floor, so that one
  /// flat cell no longer holds the whole frame at next_min_response (the cost of the
  /// adaptation: BENCHMARKS.md, "SURF at the same number of points"). Empty in fixed-threshold
  /// mode.
  std::vector<float> next_cell_min_response;
  /// Adaptive mode: the cells whose floor (steered_cell_min_response) may have cut a point the
  /// selection keeps (or a cell's first dropped point): each was searched again over its own
  /// rectangle down to the frame's floor, so that the output is the same as without cell
  /// floors, at the cost of that second search. 0 when the floors held (or none was given).
  int cells_redone = 0;
};

/// Reusable SURF engine. Keeps its buffers (integral image, response maps) between calls, so
/// repeated calls on frames of the same size do not allocate. Not thread-safe: use one
/// instance per thread (it parallelises internally when num_threads != 1).
class Surf {
 public:
  explicit Surf(const SurfOptions& options = {});
  ~Surf();
  Surf(Surf&&) noexcept;
  Surf& operator=(Surf&&) noexcept;

  const SurfOptions& options() const;

  /// Detects keypoints and describes them. Adaptive mode: the floor is max(min_response,
  /// steered_min_response) times the frame's contrast factor; a stream passes the previous
  /// frame's SurfResult::next_min_response (the odometry does), a single image 0. A stream
  /// also passes the previous frame's SurfResult::next_cell_min_response as
  /// steered_cell_min_response (empty: none): cell c is then searched only above
  /// max(floor, steered_cell_min_response[c] times the contrast factor). The output (points,
  /// descriptors, next_min_response) is exactly that of the call without cell floors: a cell
  /// whose floor cut a point the selection needs is searched again down to the frame's floor
  /// (SurfResult::cells_redone). Both are ignored in fixed-threshold mode.
  /// Throws InvalidArgument if the image is empty or smaller than the smallest filter, or if
  /// steered_cell_min_response is neither empty nor grid x grid finite values >= 0.
  SurfResult DetectAndDescribe(const GrayImageView& image, double steered_min_response = 0.0,
                               const std::vector<float>& steered_cell_min_response = {});

  /// Detects keypoints only (with orientation unless upright).
  std::vector<Keypoint> Detect(const GrayImageView& image);

  /// Computes descriptors for given keypoints (e.g. from Detect on the same image).
  /// Keypoints whose window leaves the image are described with clamped samples.
  /// Throws InvalidArgument for a keypoint with non-finite x, y or orientation, or a scale
  /// outside (0, max(width, height)].
  FeatureSet Describe(const GrayImageView& image, std::vector<Keypoint> keypoints);

 private:
  struct Impl;
  Impl* impl_;
};

/// What OpenCV's SURF reports as KeyPoint::size for this keypoint: the (interpolated) box
/// filter size in pixels, i.e. scale * 9 / 1.2. Used to compare with OpenCV detectors under
/// cv::evaluateFeatureDetector's convention (region radius = size / 2).
float OpenCvKeypointSize(const Keypoint& kp);

}  // namespace aerovo
