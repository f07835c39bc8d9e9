// Camera model helpers: focal length in pixels from a 35 mm equivalent, a field of view or
// explicit intrinsics; choice among them for a flight; optional lens undistortion (OpenCV).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "aerovo/core/image.h"
#include "aerovo/io/image_metadata.h"

namespace aerovo {

/// Diagonal of the 36 x 24 mm full frame: sqrt(36^2 + 24^2) = 43.2666 mm.
inline constexpr double kFullFrameDiagonalMm = 43.266615305567875;

/// Focal length in pixels from a 35 mm-equivalent focal length. The equivalent focal length
/// (EXIF FocalLengthIn35mmFilm, CIPA DC-008) gives the same angle of view as on a 36 x 24 mm
/// frame; the angle matched is the DIAGONAL one, because sensors differ in aspect ratio:
///   f_px = f35_mm / 43.27 mm * sqrt(width_px^2 + height_px^2).
/// Example (tampa-phantom3, FC300S): 20 mm at 800x600 -> 20 / 43.27 * 1000 = 462.2 px.
/// (Using the 36 mm width instead would give 444.4 px, 4 % short for a 4:3 sensor.)
/// Throws InvalidArgument for f35 <= 0 or an empty size.
double FocalPxFrom35mm(double focal_35mm_mm, int width_px, int height_px);

/// Focal length in pixels from the horizontal field of view: f = (w / 2) / tan(hfov / 2).
/// Throws InvalidArgument unless 0 < hfov_deg < 180 and width_px > 0.
double FocalPxFromHorizontalFov(double hfov_deg, int width_px);

/// Horizontal field of view (degrees) of a focal length in pixels: 2 atan(w / (2 f)).
double HorizontalFovDeg(double focal_px, int width_px);

/// Pinhole camera with optional distortion (OpenCV model and order: k1 k2 p1 p2 [k3 [k4 k5
/// k6]]), all in pixels of the frames as delivered. Pixel centres at integer coordinates, so
/// the centre of a W x H image is ((W - 1) / 2, (H - 1) / 2).
struct CameraIntrinsics {
  int width_px = 0;
  int height_px = 0;
  double fx_px = 0.0;
  double fy_px = 0.0;
  double cx_px = 0.0;
  double cy_px = 0.0;
  std::vector<double> distortion;  ///< Empty or all zero = no distortion.

  bool HasDistortion() const;
  cv::Matx33d K() const { return {fx_px, 0, cx_px, 0, fy_px, cy_px, 0, 0, 1}; }
};

/// Square pixels, principal point at the image centre.
CameraIntrinsics IntrinsicsFromFocalPx(double focal_px, int width_px, int height_px);

/// Throws InvalidArgument naming the field: size <= 0, focal <= 0 or not finite, principal
/// point outside the image, distortion with a count other than 0, 4, 5, 8.
void Validate(const CameraIntrinsics& intrinsics);

/// How the camera of a run is known. Every field is optional; the first that is set wins, in
/// this order: focal_px, hfov_deg, focal_35mm_mm, then the photo/telemetry metadata
/// (DJI XMP CalibratedFocalLength when the metadata's image size equals the frame size, then
/// EXIF FocalLengthIn35mmFilm).
struct CameraOptions {
  std::optional<double> focal_px;       ///< Focal length in pixels (e.g. from a calibration).
  std::optional<double> hfov_deg;       ///< Horizontal field of view, degrees.
  std::optional<double> focal_35mm_mm;  ///< 35 mm-equivalent focal length, overrides EXIF.
  std::optional<double> cx_px, cy_px;   ///< Principal point; default the image centre.
  std::vector<double> distortion;       ///< OpenCV order; default none.
};

/// Throws InvalidArgument naming the field (non-positive or non-finite values, hfov outside
/// (0, 180), bad distortion count).
void Validate(const CameraOptions& options);

struct ResolvedCamera {
  CameraIntrinsics intrinsics;
  std::string source;  ///< How the focal length was obtained, for the run log.
};

/// Intrinsics for frames of width_px x height_px. `metadata` may be null (video). Throws
/// InputError when nothing gives a focal length ("no focal length: give focal_px, hfov_deg or
/// focal_35mm_mm ...").
ResolvedCamera ResolveCamera(const CameraOptions& options, int width_px, int height_px,
                             const ImageMetadata* metadata);

/// Undistorts frames with OpenCV (maps computed once; bilinear remap). The output keeps the
/// same K (no new camera matrix), so focal length and principal point stay valid.
class Undistorter {
 public:
  explicit Undistorter(const CameraIntrinsics& intrinsics);
  /// Precondition: `in` has the intrinsics' size. `out` may be reused between calls.
  void Apply(const GrayImage& in, GrayImage& out) const;

 private:
  int width_ = 0, height_ = 0;
  cv::Mat map1_, map2_;
};

}  // namespace aerovo
