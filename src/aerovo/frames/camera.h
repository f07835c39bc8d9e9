// A run's camera: the choice of focal length among options and photo/telemetry metadata
// (ResolveCamera), and the lens undistortion of frames (OpenCV maps computed once). The camera
// model and its conversions (35 mm equivalent, field of view) are camera/pinhole.h.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "aerovo/camera/pinhole.h"
#include "aerovo/core/image.h"
#include "aerovo/frames/image_metadata.h"

namespace aerovo {

/// How the camera of a run is known. Every field is optional; the first that is set wins, in
/// this order: focal_px, hfov_deg, focal_35mm_mm, then the photo/telemetry metadata
/// (DJI XMP CalibratedFocalLength when the metadata's image size equals the frame size, then
/// EXIF FocalLengthIn35mmFilm over the sensor's full frame (sensor_aspect), then the
/// telemetry's 35 mm equivalent, e.g. SRT focal_len, over the frame's own diagonal).
struct CameraOptions {
  std::optional<double> focal_px;       ///< Focal length in pixels (e.g. from a calibration).
  std::optional<double> hfov_deg;       ///< Horizontal field of view, degrees.
  std::optional<double> focal_35mm_mm;  ///< 35 mm-equivalent focal length, overrides EXIF.
  std::optional<double> cx_px, cy_px;   ///< Principal point; default the image centre.
  std::vector<double> distortion;       ///< OpenCV order; default none.
  /// Aspect ratio (long side / short side) of the sensor's full frame, which a photo's EXIF
  /// FocalLengthIn35mmFilm refers to (camera/pinhole.h FocalPxFrom35mmOfSensor). Unset: known
  /// from the camera model (SensorAspectOf), else 4:3 for photos wider than 1.7:1 (a 16:9 mode
  /// of a 4:3 drone sensor), else the photo is the full frame.
  std::optional<double> sensor_aspect;
  /// A calibrated camera (camera_files/calibration.h ReadCalibration): wins over every other
  /// source, scaled to the frames' size when its aspect ratio matches (ScaledTo), else
  /// InvalidArgument naming both sizes. Its distortion and lens model replace `distortion`.
  std::optional<CameraIntrinsics> calibration;
  /// Where the calibration came from (its file), for the run log.
  std::string calibration_source;
};

/// The sensor aspect ratio ResolveCamera uses for the EXIF 35 mm equivalent of this photo and
/// why, e.g. {4/3, "the FC300S's 4:3 sensor"}: `options.sensor_aspect` when set; else the
/// camera models whose full-frame aspect is known (DJI FC300S/FC300X/FC330/FC220: 4:3,
/// 4000x3000; FC6310/FC6310S/L1D-20c: 3:2, 5472x3648; from DJI's specifications); else 4:3
/// when the photo is wider than 1.7:1; else the photo's own aspect (it is the full frame).
struct SensorAspect {
  double aspect = 0.0;
  std::string why;
};
SensorAspect SensorAspectOf(const CameraOptions& options, const ImageMetadata& metadata,
                            int width_px, int height_px);

/// Throws InvalidArgument naming the field (non-positive or non-finite values, hfov outside
/// (0, 180), bad distortion count).
void Validate(const CameraOptions& options);

struct ResolvedCamera {
  CameraIntrinsics intrinsics;
  std::string source;  ///< How the focal length was obtained, for the run log.
  /// The same as a short key (a run's summary focal_source): "calibration", "flag" (focal_px),
  /// "hfov", "35mm" (focal_35mm_mm), "xmp-calibrated", "exif-35mm", "exif-focal-plane" (EXIF
  /// FocalLength x FocalPlaneXResolution, when the photo has no 35 mm equivalent),
  /// "telemetry-35mm".
  std::string source_key;
};

/// Intrinsics for frames of width_px x height_px. `metadata` may be null (video);
/// `telemetry_focal_35mm_mm` is the telemetry's 35 mm-equivalent focal length (DJI SRT
/// focal_len, TelemetrySample::focal_length_35mm_mm), the last resort. Throws InputError when
/// nothing gives a focal length ("no focal length: give focal_px, hfov_deg or focal_35mm_mm
/// ..."), InvalidArgument for a non-positive telemetry value.
ResolvedCamera ResolveCamera(const CameraOptions& options, int width_px, int height_px,
                             const ImageMetadata* metadata,
                             std::optional<double> telemetry_focal_35mm_mm = std::nullopt);

/// Undistorts frames of one camera with OpenCV, pinhole (Brown-Conrady) or fisheye
/// (equidistant) lens (CameraIntrinsics::model): the maps (cv::initUndistortRectifyMap or
/// cv::fisheye::initUndistortRectifyMap, 16-bit fixed point) are computed once, each frame is
/// one bilinear cv::remap; pixels whose source falls outside the frame repeat the nearest edge
/// pixel (BORDER_REPLICATE). The output is an ideal pinhole camera of the same size with square
/// pixels, focal fx_px and the principal point at the image centre (output()): for the usual
/// camera (fx = fy, centred) that is the same K, so focal length and principal point stay valid.
/// A fisheye frame undistorted at the same focal length shows the central part of its field
/// (the pinhole's 2 atan(w / 2f) across; the rim beyond is cut). The one undistorter of the
/// run's frames (pipeline/preprocess.h FrameUndistorter) and the mosaic's.
class Undistorter {
 public:
  /// Throws InvalidArgument as Validate(CameraIntrinsics) does.
  explicit Undistorter(const CameraIntrinsics& intrinsics);

  int width_px() const { return width_; }
  int height_px() const { return height_; }
  /// The camera of the undistorted frames: IntrinsicsFromFocalPx(fx_px, width, height).
  const CameraIntrinsics& output() const { return output_; }

  /// Precondition: `in` has the intrinsics' size (InvalidArgument otherwise). `out` is resized
  /// if needed and may be reused between calls.
  void Apply(const GrayImage& in, GrayImage& out) const;
  /// Same for a view (any stride); writes into `*buffer` and returns a view of it.
  GrayImageView Apply(const GrayImageView& in, GrayImage* buffer) const;
  /// Any OpenCV image type (e.g. the colour frames of the mosaic) of the intrinsics' size.
  /// `out` must not share data with `in`.
  void Apply(const cv::Mat& in, cv::Mat& out) const;

  /// The points' alternative to Apply: pixel positions (x, y) in the distorted frame to the
  /// positions the same rays have in the undistorted frame (output()), by cv::undistortPoints
  /// or cv::fisheye::undistortPoints (iterative inverse of the lens model). `points` is
  /// rewritten in place; a scratch buffer of the undistorter is reused (no allocation once it
  /// has the capacity), so one undistorter serves one thread here.
  void UndistortPoints(std::vector<cv::Point2f>* points);

 private:
  void CheckSize(int width_px, int height_px) const;

  int width_ = 0, height_ = 0;
  CameraIntrinsics input_, output_;
  cv::Mat map1_, map2_;
  std::vector<cv::Point2f> scratch_;
};

}  // namespace aerovo
