// Lens self-calibration from the flight itself (wide lenses without a calibration file;
// docs/lenses.md, "Self-calibration"): a one-parameter radial distortion estimated from matched
// interest points of a few frame pairs of a nadir flight over roughly planar ground. No I/O.
// `aerovo run` calls it from its self-calibration pre-pass (pipeline/lens_prepass.h, option
// lens_estimation), which reads the pairs and applies a significant estimate.
//
// Principle. The rays of two views of one plane are related by a homography, whatever the lens;
// undistorting the points with the wrong lens model bends that relation. For a candidate
// coefficient k every point of both frames is turned into a unit ray (the family's inverse lens
// model), each pair gets its ray homography (weighted DLT, iteratively reweighted with a Cauchy
// loss on the pixel residuals), and the cost is the Cauchy loss of the residuals measured where
// the noise is: in the distorted image (curr point against the prev ray mapped by the homography
// and distorted back into pixels). k minimises the sum over pairs: a coarse grid over the bounded
// range, then golden section around the best grid point. The points are the inliers of a RANSAC
// homography fit on the raw pixels (k = 0) with a widened threshold.
//
// Coordinates: pixel frame of features/keypoint.h ((0, 0) = centre of the top-left pixel, x
// right, y down); normalised coordinates (x - cx) / f, (y - cy) / f; coefficients in OpenCV's
// conventions (camera/pinhole.h, docs/lenses.md), so the estimate is a CameraIntrinsics the
// run's Undistorter and WriteCalibration take as they are.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace aerovo {

/// The one-parameter lens families searched.
enum class RadialFamily {
  /// OpenCV fisheye (equidistant) k1 with k2..k4 = 0: theta_d = theta (1 + k theta^2), theta the
  /// ray's angle from the axis, the distorted normalised radius being theta_d. k = 0 is the
  /// ideal equidistant fisheye, not the pinhole (which is near k = 1/3 for small angles).
  kFisheyeK1,
  /// OpenCV pinhole (Brown-Conrady) k1 with the rest 0: r_d = r (1 + k r^2), r = tan(theta).
  /// k = 0 is the ideal pinhole: no distortion.
  kBrownK1,
};
const char* ToString(RadialFamily family);

/// Matches of one frame pair: column i of prev_px and curr_px is one correspondence, pixel
/// positions in the distorted frames as delivered.
struct LensPair {
  Eigen::Matrix2Xd prev_px;
  Eigen::Matrix2Xd curr_px;
};

struct LensEstimationOptions {
  /// The camera without distortion: focal length and principal point, px, and the frame size
  /// (for the RANSAC threshold). Required (> 0).
  double focal_px = 0.0;
  double cx_px = 0.0, cy_px = 0.0;
  int width_px = 0, height_px = 0;
  /// Inlier threshold of the k = 0 RANSAC homography, as a fraction of the frame diagonal: wide
  /// enough for the residuals an unmodelled wide lens leaves (tens of px at the rim). Default
  /// 0.015 (18 px at 960x720; our choice: a random wrong match falls that close to the model's
  /// prediction with probability < 0.2 %).
  double widen_fraction = 0.015;
  /// Scale s of the Cauchy loss s^2 log(1 + e^2 / s^2) of the pixel residuals e. Default 1 px
  /// (SURF positions are good to a fraction of a pixel; relief and mismatches beyond a few s
  /// count little).
  double loss_scale_px = 1.0;
  /// Pairs with fewer inliers at k = 0 are not used. Default 30.
  int min_inliers = 30;
  /// At least this many usable pairs, else no estimate. Default 3 (the spread over pairs needs
  /// three).
  int min_pairs = 3;
  /// Grid points of the coarse search over each family's range. Default 25.
  int grid_points = 25;
  /// Search ranges (bounded further by the data so that every point's inverse exists and its ray
  /// is less than 89 degrees off axis). Fisheye: theta_d = theta (1 + k theta^2) from strong
  /// barrel (-0.3) to about the pinhole's own curve (0.6); Brown: -0.5 .. 0.5 (GoPro-like
  /// barrels need about -0.3 on normalised radii up to 1).
  double fisheye_k_min = -0.3, fisheye_k_max = 0.6;
  double brown_k_min = -0.5, brown_k_max = 0.5;
  /// The decision: the estimate is significant (apply it) when the total cost at the estimate is
  /// at most (1 - min_cost_drop) of the cost of the ideal pinhole (Brown k = 0) AND at least
  /// min_pair_fraction of the pairs have their own cost lowered by at least min_pair_drop.
  /// Defaults 0.25, 0.75, 0.10 (our choice; measured margins in BENCHMARKS.md "Lens
  /// self-calibration": tampa-phantom3 drops 2 %, turin-p4m 24.8 %, the simulated wide lenses
  /// 85-92 %; `aerovo run` therefore uses min_cost_drop 0.5, pipeline/lens_prepass.cc).
  double min_cost_drop = 0.25;
  double min_pair_fraction = 0.75;
  double min_pair_drop = 0.10;
  /// Seed of the RANSAC fits (same seed, same result).
  std::uint64_t seed = 1;
};

/// Throws InvalidArgument naming the field.
void Validate(const LensEstimationOptions& options);

/// The best coefficient of one family.
struct LensFamilyFit {
  RadialFamily family = RadialFamily::kBrownK1;
  double k = 0.0;
  double k_min = 0.0, k_max = 0.0;  ///< The searched range (after the data's bounds).
  double cost = 0.0;                ///< Total Cauchy cost at k, px^2.
  std::vector<double> pair_k;       ///< Each usable pair's own minimiser.
  /// Uncertainty of k: the larger of 1.4826 MAD(pair_k) / sqrt(pairs) (spread over pairs) and
  /// the Laplace estimate from the cost's curvature at k (sigma^2 = 2 s2 / C'', s2 the cost per
  /// residual degree of freedom).
  double sigma_k = 0.0;
  double sigma_k_pairs = 0.0, sigma_k_curvature = 0.0;
  int pairs_improved = 0;  ///< Pairs whose cost drops by min_pair_drop from the pinhole's.
};

struct LensEstimate {
  bool valid = false;        ///< Enough pairs and points to estimate (else `why`).
  bool significant = false;  ///< Apply it: the decision of LensEstimationOptions.
  RadialFamily family = RadialFamily::kBrownK1;  ///< The family of the lower cost.
  double k = 0.0;
  double sigma_k = 0.0;
  double cost_pinhole = 0.0;  ///< Total cost with no distortion (Brown k = 0), px^2.
  double cost = 0.0;          ///< Total cost at the estimate, px^2.
  /// 1 - cost / cost_pinhole: the fraction of the pinhole's cost the lens model removes.
  double cost_drop = 0.0;
  /// Median pixel residual over every pair's points, px: with the ideal pinhole and with the
  /// estimate.
  double median_residual_pinhole_px = 0.0, median_residual_px = 0.0;
  int pairs_used = 0;
  int points_used = 0;
  int pairs_improved = 0;
  std::vector<double> pair_k;
  std::vector<LensFamilyFit> fits;  ///< Every family searched.
  std::string why;                  ///< The decision in one sentence.
};

/// The estimate from the matches of `pairs` (see the file comment). Pairs with fewer than
/// min_inliers RANSAC inliers are skipped. Deterministic for a given seed. Throws
/// InvalidArgument for invalid options.
LensEstimate EstimateRadialDistortion(const std::vector<LensPair>& pairs,
                                      const LensEstimationOptions& options);

/// The unit ray of normalised distorted coordinates (xd, yd) under `family` with coefficient k;
/// false when the inverse does not exist (beyond the model's monotonic range, or more than
/// 89 degrees off axis). Newton iterations safeguarded by bisection, to 1e-12.
bool RayOfDistorted(RadialFamily family, double k, double xd, double yd, Eigen::Vector3d* ray);
/// The normalised distorted coordinates of a ray (any length, z > 0 for kBrownK1); false for a
/// ray the model cannot image (kBrownK1 with z <= 0).
bool DistortedOfRay(RadialFamily family, double k, const Eigen::Vector3d& ray,
                    Eigen::Vector2d* xd);

}  // namespace aerovo
