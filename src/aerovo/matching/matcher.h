// Descriptor matching between the features of two frames (prev = frame n-1, curr = frame n),
// with MATLAB matchFeatures semantics by default (see ../shared/docs/METHOD.md).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "aerovo/features/keypoint.h"

namespace aerovo {

/// Options of the matching stage. Defaults are MATLAB matchFeatures' defaults (the paper's).
struct MatchOptions {
  /// Ratio test on squared distances: accept the best candidate only if
  /// ssd_best <= max_ratio * ssd_second. Default 0.6 (MATLAB MaxRatio, ratio of SSDs).
  float max_ratio = 0.6f;
  /// Reject matches whose SSD exceeds this percentage of the largest possible SSD between two
  /// L2-normalised descriptors (4). Default 1.0 % => SSD <= 0.04 (MATLAB MatchThreshold).
  float match_threshold_percent = 1.0f;
  /// Keep only mutual best matches (MATLAB Unique). Default false.
  bool unique = false;
  /// Never compare points whose Laplacian signs differ (SURF's free speed-up). Default true.
  bool check_laplacian = true;
  /// Guided matching: with a motion prior (see Matcher::Match), only candidates within this
  /// radius (pixels) of the predicted position are compared. Default 40 px.
  float guided_radius_px = 40.f;
  /// Threads; 1 = single-threaded, 0 = all cores.
  int num_threads = 1;
};

/// Throws InvalidArgument naming the offending field when out of range.
void Validate(const MatchOptions& options);

/// One correspondence: prev.keypoints[prev_index] <-> curr.keypoints[curr_index].
struct Match {
  int prev_index = -1;
  int curr_index = -1;
  float ssd = 0.f;  ///< Squared L2 distance between the two descriptors.
};

struct MatchResult {
  std::vector<Match> matches;
  std::int64_t num_comparisons = 0;  ///< Descriptor distances evaluated.
  double time_ms = 0.0;
};

/// Exhaustive (optionally guided) matcher. Reuses its buffers between calls.
class Matcher {
 public:
  explicit Matcher(const MatchOptions& options = {});
  ~Matcher();
  Matcher(Matcher&&) noexcept;
  Matcher& operator=(Matcher&&) noexcept;

  const MatchOptions& options() const;

  /// Matches prev (restricted to `prev_subset` indices if non-empty) against all of curr.
  /// `curr_from_prev_prior`, if given, is a 2x3 affine predicting curr pixel positions from prev
  /// pixel positions: only curr points within guided_radius_px of the prediction are compared.
  /// Preconditions: equal descriptor sizes; descriptors L2-normalised.
  MatchResult Match(const FeatureSet& prev, const FeatureSet& curr,
                    const std::vector<int>& prev_subset = {},
                    const std::optional<Eigen::Matrix<double, 2, 3>>& curr_from_prev_prior =
                        std::nullopt);

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace aerovo
