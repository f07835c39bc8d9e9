// SURF: Speeded-Up Robust Features (Bay, Ess, Tuytelaars, Van Gool, CVIU 110(3), 2008),
// aerovo's own implementation. Semantics follow MATLAB's detectSURFFeatures/extractFeatures
// (which call OpenCV's fast-Hessian), as used by Ivanov & Muzychuk (2023); see
// ../shared/docs/METHOD.md, "Semantics of the MATLAB functions".
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "aerovo/core/image.h"
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
  /// Threads for detection and description; 1 = single-threaded, 0 = all cores.
  int num_threads = 1;
};

/// Throws InvalidArgument naming the offending field when `options` are out of range.
void Validate(const SurfOptions& options);

/// Result of one SURF call, returned by value.
struct SurfResult {
  FeatureSet features;       ///< Keypoints (sorted by decreasing response) and descriptors.
  double detect_ms = 0.0;    ///< Integral image + fast-Hessian + orientation.
  double describe_ms = 0.0;  ///< Descriptor computation.
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

  /// Detects keypoints and describes them.
  /// Throws InvalidArgument if the image is empty or smaller than the smallest filter.
  SurfResult DetectAndDescribe(const GrayImageView& image);

  /// Detects keypoints only (with orientation unless upright).
  std::vector<Keypoint> Detect(const GrayImageView& image);

  /// Computes descriptors for given keypoints (e.g. from Detect on the same image).
  /// Keypoints whose window leaves the image are described with clamped samples.
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
