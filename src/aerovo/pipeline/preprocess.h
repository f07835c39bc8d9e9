// Frame preprocessing before SURF: lens undistortion and the paper's illumination change.
#pragma once

#include <memory>

#include <Eigen/Core>

#include "aerovo/camera/pinhole.h"
#include "aerovo/core/image.h"

namespace aerovo {

/// Reduces frames larger than a pixel budget before SURF, so that the work and memory of a
/// frame are bounded whatever the camera (RunConfig::max_megapixels). The reduced size keeps
/// the aspect ratio: scale s = sqrt(budget / (width * height)), out = floor(size * s); pixels by
/// area averaging (cv::resize INTER_AREA, no aliasing). A camera model of the full frame
/// (focal f, principal point at the centre) becomes, on the reduced frame, focal f * scale()
/// with the principal point at the reduced centre: reduced_from_full() maps the coordinates.
///
/// Detection budget (RunConfig::detect_megapixels, video and live frames): frames above
/// detect_megapixels are instead reduced by the smallest integer factor n >= 2 that brings
/// floor(w / n) x floor(h / n) within both budgets, each reduced pixel the rounded mean of an
/// n x n block (a box filter; the last w mod n columns and h mod n rows are dropped). Then
/// scale() = focal_scale() = 1 / n exactly and a full-frame pixel x maps to x / n - (n - 1) / (2n).
/// SURF at n times the ground sampling distance: 4K (3840x2160) with n = 2 is detected at
/// 1920x1080, the scale space SURF would otherwise reach at its second octave (Bay et al. 2008
/// section 4.1: the scale space may start with a sampling step of 2).
class FrameReducer {
 public:
  /// Frames of width_px x height_px; max_megapixels <= 0: no budget, detect_megapixels <= 0: no
  /// integer reduction (neither: active() false). Throws InvalidArgument for a non-positive size
  /// or a non-finite budget.
  FrameReducer(int width_px, int height_px, double max_megapixels, double detect_megapixels = 0.0);
  /// The integer factor n of a detection reduction (1 when the frames are not reduced by the
  /// detection budget, including an area reduction to max_megapixels alone).
  int factor() const { return factor_; }
  /// The frames exceed the budget and are reduced.
  bool active() const { return active_; }
  int out_width_px() const { return out_w_; }
  int out_height_px() const { return out_h_; }
  /// Reduced pixels per full-frame pixel, horizontally (1 when not active). The vertical factor
  /// differs by less than one reduced pixel over the height; the focal length scales by their
  /// mean, focal_scale().
  double scale() const { return sx_; }
  double focal_scale() const { return 0.5 * (sx_ + sy_); }
  /// Homogeneous pixel coordinates of the full frame (pixel centres at integers) to those of
  /// the reduced frame: x_r = sx x + (sx - 1) / 2 (cv::resize's pixel-area alignment), same for y.
  Eigen::Matrix3d reduced_from_full() const;
  /// The reduced copy of `frame` (InvalidArgument for another size), or `frame` itself when
  /// not active. The view stays valid until the next call.
  GrayImageView Apply(const GrayImageView& frame);

 private:
  int w_ = 0, h_ = 0, out_w_ = 0, out_h_ = 0;
  double sx_ = 1.0, sy_ = 1.0;
  int factor_ = 1;
  bool active_ = false;
  GrayImage out_;
};

/// Undistorts frames of one size with a pinhole camera (focal_px, principal point at the image
/// centre ((w-1)/2, (h-1)/2)) and OpenCV distortion coefficients (k1, k2, p1, p2, k3); the output
/// keeps the same camera matrix, so focal_px still converts pixels to angles. The run's form of
/// frames/camera.h Undistorter (which does the work) with an output buffer of its own.
class FrameUndistorter {
 public:
  /// Throws InvalidArgument for a non-positive size or focal length.
  FrameUndistorter(int width_px, int height_px, double focal_px, double k1, double k2, double p1,
                   double p2, double k3);
  /// Any calibrated camera (pinhole or fisheye lens, any principal point): the output is the
  /// centred square-pixel pinhole of focal intrinsics.fx_px (frames/camera.h Undistorter). Throws
  /// InvalidArgument as Validate(CameraIntrinsics) does.
  explicit FrameUndistorter(const CameraIntrinsics& intrinsics);
  ~FrameUndistorter();
  FrameUndistorter(FrameUndistorter&&) noexcept;
  FrameUndistorter& operator=(FrameUndistorter&&) noexcept;
  /// The undistorted copy of `frame` (same size; InvalidArgument for another size). The view
  /// stays valid until the next call.
  GrayImageView Apply(const GrayImageView& frame);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The paper's illumination change f_k = k f on one frame: out(x, y) = min(255, floor(k in(x, y)
/// + 0.5)) (round half up, saturated to 0..255), written into `*buffer` (resized as needed).
/// Returns a view of `*buffer`. Throws InvalidArgument unless k is finite and >= 0.
GrayImageView ScaleBrightness(const GrayImageView& frame, double k, GrayImage* buffer);

}  // namespace aerovo
