// The camera's tilt from the flight itself (a camera fixed off nadir, photos without gimbal
// angles; docs/attitude.md "Estimated from the flight"): one roll and pitch for the whole flight,
// estimated from matched interest points of a few frame pairs over roughly planar ground. No I/O.
// `aerovo run` calls it from its self-calibration pre-pass (pipeline/lens_prepass.h, option
// attitude_estimation), which reads the pairs and applies a significant estimate the way
// `--camera-mount-pitch-deg` is applied (pipeline/run_steps.h CameraAttitudeOf).
//
// Principle. A nadir camera moving over flat ground sees the ground move by a 2D similarity
// between frames (translation, the heading's rotation, the height's scale). A tilted camera sees
// a homography: ground farther from the camera (towards the tilt) moves less. Mapping each
// keypoint through the candidate attitude's rotation to a virtual nadir camera (odometry/
// attitude.h NadirFromCameraHomography, the K R K^-1 of a pure rotation, Hartley & Zisserman
// 2004, 8.4.2) makes the pairs' motion a similarity again only at the true attitude. For a
// candidate (roll, pitch) each pair gets its least-squares similarity between the nadir-mapped
// points (iteratively reweighted with a Cauchy loss), and the cost is the Cauchy loss of the
// residuals measured where the noise is: in the current frame's pixels (the previous point
// mapped to nadir, moved by the similarity, mapped back by the inverse rotation). The attitude
// minimises the sum over pairs: a grid over the bounded range, then finer grids around the best
// point. The points are the inliers of a RANSAC homography on the pixels (a homography
// holds for any attitude over a plane). The plane-induced homography's normal is observable
// whenever the camera moves (Hartley & Zisserman 2004, 13.1.1); a pair with no motion (a hover)
// tells nothing and is dropped.
//
// Coordinates: pixel frame of features/keypoint.h ((0, 0) = centre of the top-left pixel, x
// right, y down) of frames WITHOUT lens distortion (undistort the points first); attitude as
// odometry/attitude.h's CameraAttitude (pitch > 0 towards the image top, roll > 0 towards the
// image left).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "aerovo/correspondence/lens_estimation.h"  // LensPair: the matches of one frame pair
#include "aerovo/odometry/attitude.h"

namespace aerovo {

struct AttitudeEstimationOptions {
  /// The camera: focal length and principal point, px, and the frame size (for the RANSAC
  /// threshold). Required (> 0).
  double focal_px = 0.0;
  double cx_px = 0.0, cy_px = 0.0;
  int width_px = 0, height_px = 0;
  /// Inlier threshold of the RANSAC homography, as a fraction of the frame diagonal. Default
  /// 0.004 (5 px at 960x720; our choice: SURF positions are good to a fraction of a pixel, relief
  /// of a few per cent of the height moves points by a few pixels).
  double inlier_fraction = 0.004;
  /// Scale s of the Cauchy loss s^2 log(1 + e^2 / s^2) of the pixel residuals e. Default 1 px.
  double loss_scale_px = 1.0;
  /// Pairs with fewer homography inliers are not used. Default 30.
  int min_inliers = 30;
  /// Pairs whose points move less than this fraction of the frame diagonal (median) are not used:
  /// without motion the tilt is not observable. Default 0.05.
  double min_motion_fraction = 0.05;
  /// At least this many usable pairs, else no estimate. Default 3.
  int min_pairs = 3;
  /// Search range of roll and pitch, degrees (each in [-max_tilt_deg, max_tilt_deg]); points
  /// whose ray the candidate attitude turns to within 5 degrees of the horizon cost as a residual
  /// of 100 s. Default 35.
  double max_tilt_deg = 35.0;
  /// Step of the coarse grid, degrees (then three grids of a quarter of the previous step around
  /// the best point: 5 / 64 = 0.08 deg at the default). Each pair's own minimiser (for the
  /// uncertainty) is searched within one coarse step of the whole estimate. Default 5.
  double grid_step_deg = 5.0;
  /// The decision: significant (apply it) when the tilt from nadir is at least min_tilt_deg and
  /// at least 3 times its uncertainty, the total cost at the estimate is at most
  /// (1 - min_cost_drop) of the nadir attitude's, and at least min_pair_fraction of the pairs
  /// have their own cost lowered by at least min_pair_drop. Defaults 2 deg, 0.2, 0.75, 0.05 (our
  /// choice; measured margins in BENCHMARKS.md "Camera tilt from the flight").
  double min_tilt_deg = 2.0;
  double min_cost_drop = 0.2;
  double min_pair_fraction = 0.75;
  double min_pair_drop = 0.05;
  /// Seed of the RANSAC fits (same seed, same result).
  std::uint64_t seed = 1;
};

/// Throws InvalidArgument naming the field.
void Validate(const AttitudeEstimationOptions& options);

struct AttitudeEstimate {
  bool valid = false;        ///< Enough pairs and points to estimate (else `why`).
  bool significant = false;  ///< Apply it: the decision of AttitudeEstimationOptions.
  CameraAttitude attitude;   ///< The estimate (degrees).
  double tilt_deg = 0.0;     ///< Its angle from nadir.
  /// Uncertainty of roll and pitch, degrees: 1.4826 MAD of the pairs' own minima / sqrt(pairs).
  double sigma_roll_deg = 0.0, sigma_pitch_deg = 0.0;
  double cost_nadir = 0.0;  ///< Total cost with the camera taken as nadir, px^2.
  double cost = 0.0;        ///< Total cost at the estimate, px^2.
  double cost_drop = 0.0;   ///< 1 - cost / cost_nadir.
  /// Median pixel residual over every pair's points, px: nadir and at the estimate.
  double median_residual_nadir_px = 0.0, median_residual_px = 0.0;
  int pairs_used = 0;
  int points_used = 0;
  int pairs_improved = 0;
  std::vector<CameraAttitude> pair_attitude;  ///< Each usable pair's own minimiser.
  std::string why;                            ///< The decision in one sentence.
};

/// The estimate from the matches of `pairs` (pixel positions in frames without lens distortion;
/// see the file comment). Deterministic for a given seed. Throws InvalidArgument for invalid
/// options or a pair whose two point sets differ in size.
AttitudeEstimate EstimateCameraAttitude(const std::vector<LensPair>& pairs,
                                        const AttitudeEstimationOptions& options);

}  // namespace aerovo
