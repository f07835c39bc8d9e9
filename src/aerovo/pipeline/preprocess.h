// Frame preprocessing before SURF: lens undistortion and the paper's illumination change.
#pragma once

#include <memory>

#include "aerovo/core/image.h"

namespace aerovo {

/// Undistorts frames of one size with a pinhole camera (focal_px, principal point at the image
/// centre ((w-1)/2, (h-1)/2)) and OpenCV distortion coefficients (k1, k2, p1, p2, k3); the output
/// keeps the same camera matrix, so focal_px still converts pixels to angles. The run's form of
/// io/camera.h Undistorter (which does the work) with an output buffer of its own.
class FrameUndistorter {
 public:
  /// Throws InvalidArgument for a non-positive size or focal length.
  FrameUndistorter(int width_px, int height_px, double focal_px, double k1, double k2, double p1,
                   double p2, double k3);
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
