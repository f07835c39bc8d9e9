// The lens models of camera/pinhole.h (OpenCV's pinhole/Brown-Conrady and equidistant fisheye,
// LensModel) as functions of points, without OpenCV: where the lens puts a ray (Distort), the
// inverse by iteration (Undistort), and how much the lens changes the local scale of the image
// across a frame (the rule of `aerovo run --undistort auto`, docs/lenses.md "Points or whole
// frames"). The frames' counterpart (one cv::remap per frame) is frames/camera.h Undistorter.
#pragma once

#include <array>
#include <optional>

#include "aerovo/camera/pinhole.h"

namespace aerovo {

/// The point undistortion of one camera: pixels of the distorted frames (`lens`, as delivered) to
/// pixels of the ideal pinhole the frame path undistorts to (frames/camera.h Undistorter::output:
/// the same size, square pixels, focal lens.fx_px, principal point at the centre
/// ((w - 1) / 2, (h - 1) / 2)). Plain value, no allocation after construction; const methods
/// are thread-safe.
class LensUndistortion {
 public:
  /// Throws InvalidArgument as Validate(CameraIntrinsics) does.
  explicit LensUndistortion(const CameraIntrinsics& lens);

  const CameraIntrinsics& input() const { return input_; }
  /// IntrinsicsFromFocalPx(lens.fx_px, width, height).
  const CameraIntrinsics& output() const { return output_; }

  /// Normalised pinhole coordinates (x, y) = (X / Z, Y / Z) to where the lens puts them
  /// (normalised distorted coordinates, the formulas of LensModel).
  void DistortNormalised(double x, double y, double* xd, double* yd) const;
  /// The inverse of DistortNormalised by Newton's method (analytic 2x2 Jacobian, from (xd, yd),
  /// at most 20 steps, until the residual is below 1e-12). False when it does not converge (a
  /// point beyond the lens model's monotonic range, or a fisheye ray at or beyond 90 degrees
  /// off axis, which has no pinhole position); *x, *y are then unspecified.
  bool UndistortNormalised(double xd, double yd, double* x, double* y) const;

  /// A pixel (u, v) of the distorted frame to the output camera's pixel of the same ray. False
  /// as UndistortNormalised.
  bool UndistortPixel(double u, double v, double* u_out, double* v_out) const;
  /// The reverse: an output pixel to the distorted frame's pixel of the same ray (the
  /// frame path's map, cv::initUndistortRectifyMap's direction). False for a ray behind the
  /// camera (never for finite input).
  bool DistortPixel(double u_out, double v_out, double* u, double* v) const;

  /// The local scale the lens gives the image around an output pixel relative to the ideal
  /// pinhole: the singular values {s_min, s_max} of the 2x2 Jacobian d(distorted pixel) /
  /// d(output pixel). Both 1 without distortion; for a radial lens s are the radial scale
  /// d r_d / d r and the tangential r_d / r (r, r_d in focal units; fisheye r_d = theta_d).
  std::array<double, 2> LocalScale(double u_out, double v_out) const;

  /// The largest |s - 1| of LocalScale over the distorted frame (a 33 x 33 grid of its pixels,
  /// corners included, mapped to the output camera): how much a blob's size and shape change
  /// between the centre and the rim when SURF runs on the distorted frame. 0 without
  /// distortion; 1 when a grid point cannot be undistorted.
  double MaxScaleChange() const;

 private:
  CameraIntrinsics input_, output_;
  bool fisheye_ = false;
  bool identity_ = false;
  // Pinhole: k1 k2 p1 p2 k3 k4 k5 k6; fisheye: k1..k4 in d_[0..3].
  std::array<double, 8> d_{};
};

/// The largest local scale change of `lens` over its frame (LensUndistortion::MaxScaleChange).
double MaxLensScaleChange(const CameraIntrinsics& lens);

/// The first pixel, row by row over a 33 x 33 grid of the `lens.width_px` x `lens.height_px`
/// frame, for which the pinhole lens `lens` has no ray that it reaches without turning back:
/// the pixel cannot be undistorted, or the distorted image of the segment from the principal ray
/// to its undistorted point does not move away from the principal point all the way (64 steps;
/// Newton's method can land on a mirrored solution beyond the fold: r_d(r) = r (1 + k1 r^2) with
/// k1 < 0 reaches r_d again past its peak, upside down). Such a model folds the frame's image
/// inside the turn and describes no lens there (a typo in k1..k3, a fit gone wrong).
/// Pixels farther from the principal point than 90 % of the farthest corner's distance are not
/// checked: calibrations fitted without points in the corners often turn back there only (a
/// few features, which RANSAC sets aside), and refusing them would refuse usable files.
/// std::nullopt without distortion and for a fisheye (whose rays at or beyond 90 degrees have no
/// pinhole position, which a lens of more than 180 degrees has). Throws InvalidArgument as
/// Validate(CameraIntrinsics) does.
std::optional<std::array<double, 2>> FirstFoldedPixel(const CameraIntrinsics& lens);

/// `aerovo run --undistort auto` undistorts the keypoints instead of whole frames when the
/// lens's MaxLensScaleChange is at most this. 0.35 (our choice, measured in docs/lenses.md
/// "Points or whole frames": simulated 960x720 pinhole flights at 73.7 degrees stay within
/// 0.001 % of the distance of the frames path up to k1 = -0.1, scale change 0.33; the fisheye
/// of wide_lens_test, 0.98, has 20 times the frames path's error with points).
inline constexpr double kPointsMaxScaleChange = 0.35;

}  // namespace aerovo
