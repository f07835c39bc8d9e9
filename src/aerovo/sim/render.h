// Rendering what a pinhole camera sees over a flat, geo-referenced ground image, and the image
// effects of the paper's experiments (illumination f_k = k f) and of real cameras (noise, motion
// blur, JPEG). In memory only: no file I/O here (see sim_writer.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "aerovo/geo/geo_point.h"
#include "aerovo/sim/camera.h"

namespace aerovo::sim {

/// A north-up ground image over flat ground. Pixel (u, v)'s centre is at map-frame
/// (east, north) = ((u + 0.5) * metres_per_px, -(v + 0.5) * metres_per_px): the map frame's
/// origin is the image's outer north-west corner. Pixels equal to 0 in every channel are
/// "no data" (e.g. the black margins of an orthophoto mosaic).
struct GroundImage {
  cv::Mat image;               ///< CV_8UC1 or CV_8UC3 (BGR).
  double metres_per_px = 0.0;  ///< Ground sampling distance (m/px), same along x and y.
  GeoPoint nw_corner;          ///< WGS84 position of the outer NW corner (alt = ground altitude).
  std::string source_kind;     ///< "terrain" or "orthophoto" (for the record in sim.json).
  std::string source_path;     ///< The file, for orthophotos.
  std::uint64_t terrain_seed = 0;  ///< The seed, for procedural terrain.
};

/// Throws InvalidArgument unless the image is non-empty 8-bit 1- or 3-channel, metres_per_px > 0
/// and the corner is a valid position.
void Validate(const GroundImage& ground);

/// Map-frame (east, north) of the centre of the ground image.
Eigen::Vector2d GroundCentreEnM(const GroundImage& ground);

/// Renders camera views of a ground image. Keeps a Gaussian pyramid of the ground (cv::pyrDown)
/// and warps from the level whose resolution is closest to the camera's, so that strong
/// downscaling does not alias and large grounds warp fast. Thread-safe after construction
/// (Render is const and does not touch shared mutable state).
class GroundRenderer {
 public:
  /// Builds the pyramid (levels down to about the camera's size). Throws InvalidArgument on an
  /// invalid ground or camera.
  GroundRenderer(GroundImage ground, CameraModel camera);

  const GroundImage& ground() const { return ground_; }
  const CameraModel& camera() const { return camera_; }
  int levels() const { return static_cast<int>(pyramid_.size()); }

  /// The pyramid level Render uses for `pose`: round(log2(gsd / metres_per_px)), clamped, where
  /// gsd is the camera's ground sampling distance at the image centre.
  int LevelFor(const CameraPose& pose) const;

  /// Homography image_from_levelpx: maps pixels of pyramid level `level` of the ground to camera
  /// pixels. Level-l pixel u corresponds to level-0 pixel 2^l u.
  Eigen::Matrix3d ImageFromGroundLevelPx(const CameraPose& pose, int level) const;

  /// Renders the view from `pose` into `out` (same type as the ground image, camera size).
  /// Parts of the view beyond the ground image are black (no data). Bilinear interpolation.
  /// A camera with lens distortion: every pixel's ray (UndistortNormalised, computed once) is
  /// followed to the ground (cv::remap through the ground homography), so the frame is exactly
  /// what the lens sees.
  void Render(const CameraPose& pose, cv::Mat& out) const;
  cv::Mat Render(const CameraPose& pose) const;

  /// Fraction (0..1) of the view that shows no data (beyond the ground or on black no-data
  /// pixels), estimated on a 1/8-resolution view of a validity mask.
  double NoDataFraction(const CameraPose& pose) const;

 private:
  GroundImage ground_;
  CameraModel camera_;
  std::vector<cv::Mat> pyramid_;  // level 0 = ground_.image
  cv::Mat valid_mask_;            // 255 where the ground has data, at level mask_level_
  cv::Mat rays_;                  // distorted cameras: per pixel the pinhole's normalised (x, y)
  int mask_level_ = 0;
};

/// Image effects, applied in this order: grey, contrast, optics blur, motion blur,
/// illumination k, sensor non-uniformity (vignetting, fixed pattern), sensor noise, JPEG.
struct EffectsOptions {
  /// No colour: every pixel becomes its luminance (cv::COLOR_BGR2GRAY), kept in all channels.
  /// Default false.
  bool grayscale = false;
  /// Contrast factor c in (0, 1]: every pixel v becomes m + c (v - m), m the frame's mean
  /// brightness (a thermal camera sees small temperature differences over a ground of nearly
  /// one temperature). Default 1 (none).
  double contrast = 1.0;
  /// Gaussian blur of the optics, standard deviation in pixels (thermal lenses and detectors
  /// blur more than visible ones). Default 0 (none).
  double optics_blur_sigma_px = 0.0;
  /// Illumination factor k in (0, 1]: every pixel's brightness is multiplied by k and rounded
  /// (the paper's f_k = k f, "every pixel's brightness multiplied by k"). Default 1 (none).
  double illumination_k = 1.0;
  /// Gaussian sensor noise, standard deviation in digital numbers (0..255 scale), independent
  /// per pixel and channel, added after the illumination factor (so darker frames have a worse
  /// signal-to-noise ratio, as with a real sensor at fixed gain). Default 0.
  double noise_sigma_dn = 0.0;
  /// Linear motion blur: length (px) of a box kernel along the image motion direction. Default
  /// 0 (none). A drone at 10 m/s with a 1/500 s exposure at GSD 0.1 m/px blurs 0.2 px; 2-5 px is
  /// a slow shutter in dim light.
  double motion_blur_px = 0.0;
  /// JPEG compression round trip at this quality (1..100); 0 = none. Default 0.
  int jpeg_quality = 0;
  /// Vignetting, DN: an offset static in the frame, 0 at the centre falling as the squared
  /// distance from it to -vignetting_dn at the corners (additive, as the shading of an uncooled
  /// thermal camera's optics and housing). Default 0 (none).
  double vignetting_dn = 0.0;
  /// Fixed-pattern noise, DN: a static Gaussian offset of this standard deviation per pixel plus
  /// one of the same standard deviation per column (a microbolometer's readout), the same in
  /// every frame (drawn from fixed_pattern_seed). Default 0 (none).
  double fixed_pattern_dn = 0.0;
  /// Seed of the fixed pattern (one pattern per camera, not per frame).
  std::uint64_t fixed_pattern_seed = 1;
};

/// Throws aerovo::InvalidArgument naming the bad field.
void Validate(const EffectsOptions& effects);

/// The thermal-like render mode's effects (`aerovo simulate --render thermal`): grey, contrast
/// 0.15, optics blur sigma 1.2 px, vignetting 30 DN, fixed pattern 3 DN, sensor noise 1.5 DN.
/// What a radiometric camera's 8-bit export of a uniform-temperature scene looks like: a few
/// tens of grey levels of texture, soft edges, visible noise, and a static shading and pattern
/// of the sensor as strong as the ground's texture (our model, not a calibrated sensor; with
/// them most frames of the simulated flight are bridged unless the run removes the flat
/// field, BENCHMARKS.md "Sensor non-uniformity").
EffectsOptions ThermalEffects();
/// The thermal-like camera: 640x512 px (DJI Zenmuse XT2 / FLIR Tau 2 640 detector), 45 degrees
/// horizontal field of view (the 13 mm lens of the XT2 640; DJI's XT2 specifications).
inline constexpr int kThermalWidthPx = 640;
inline constexpr int kThermalHeightPx = 512;
inline constexpr double kThermalHfovDeg = 45.0;

/// Applies the effects to `frame` in place (CV_8UC1 or CV_8UC3). `motion_px` is the image motion
/// during a frame interval (its direction orients the blur kernel; zero = no blur direction,
/// then horizontal). `seed` drives the sensor noise (use a different one per frame).
void ApplyEffects(cv::Mat& frame, const EffectsOptions& effects, const Eigen::Vector2d& motion_px,
                  std::uint64_t seed);

/// Image motion (px) of the ground point at the image centre from pose `a` to pose `b`: where
/// that point appears in b minus the image centre.
Eigen::Vector2d ImageMotionPx(const CameraModel& camera, const CameraPose& a, const CameraPose& b);

}  // namespace aerovo::sim
