// Interest points and their descriptors: the data passed from the feature stage to matching.
#pragma once

#include <cstdint>
#include <vector>

namespace aerovo {

/// A SURF interest point, in the pixel frame of the image it was detected in
/// ((0, 0) = centre of the top-left pixel, x right, y down).
struct Keypoint {
  float x = 0.f;            ///< Column, pixels (sub-pixel).
  float y = 0.f;            ///< Row, pixels (sub-pixel).
  float scale = 0.f;        ///< SURF scale s = 1.2 * filter_size / 9 (pixels); the region
                            ///< radius used for evaluation is described in surf.h.
  float orientation = 0.f;  ///< Radians in [0, 2*pi), image frame (x right, y down); 0 if upright.
  float response = 0.f;     ///< Hessian determinant (same units as SurfOptions::hessian_threshold).
  std::int8_t laplacian = 0;  ///< Sign of the trace of the Hessian: +1 or -1 (dark/bright blob).
  std::int8_t octave = 0;     ///< Octave the point was found in.
};

/// Keypoints with their descriptors stored as contiguous float rows (row i belongs to
/// keypoints[i]), each row of `descriptor_size` values (64 or 128), L2-normalised.
struct FeatureSet {
  std::vector<Keypoint> keypoints;
  std::vector<float> descriptors;
  int descriptor_size = 64;

  std::size_t size() const { return keypoints.size(); }
  bool empty() const { return keypoints.empty(); }
  const float* descriptor(std::size_t i) const { return descriptors.data() + i * descriptor_size; }
  float* descriptor(std::size_t i) { return descriptors.data() + i * descriptor_size; }
};

}  // namespace aerovo
