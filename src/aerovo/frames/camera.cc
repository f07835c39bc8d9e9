#include "aerovo/frames/camera.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"

namespace aerovo {
namespace {

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

bool GoodDistortionCount(std::size_t n) { return n == 0 || n == 4 || n == 5 || n == 8; }

}  // namespace

void Validate(const CameraOptions& o) {
  if (o.focal_px && !PositiveFinite(*o.focal_px)) {
    throw InvalidArgument(fmt::format("CameraOptions.focal_px {} must be > 0", *o.focal_px));
  }
  if (o.hfov_deg && !(*o.hfov_deg > 0.0 && *o.hfov_deg < 180.0)) {
    throw InvalidArgument(
        fmt::format("CameraOptions.hfov_deg {} must be in (0, 180)", *o.hfov_deg));
  }
  if (o.focal_35mm_mm && !PositiveFinite(*o.focal_35mm_mm)) {
    throw InvalidArgument(
        fmt::format("CameraOptions.focal_35mm_mm {} must be > 0", *o.focal_35mm_mm));
  }
  if ((o.cx_px && !std::isfinite(*o.cx_px)) || (o.cy_px && !std::isfinite(*o.cy_px))) {
    throw InvalidArgument("CameraOptions principal point is not finite");
  }
  if (o.sensor_aspect && !(std::isfinite(*o.sensor_aspect) && *o.sensor_aspect >= 1.0 &&
                           *o.sensor_aspect <= 4.0)) {
    throw InvalidArgument(fmt::format(
        "CameraOptions.sensor_aspect {} must be in [1, 4] (long side / short side)",
        *o.sensor_aspect));
  }
  if (!GoodDistortionCount(o.distortion.size())) {
    throw InvalidArgument(
        fmt::format("CameraOptions.distortion has {} coefficients (expected 0, 4, "
                    "5 or 8)",
                    o.distortion.size()));
  }
}

SensorAspect SensorAspectOf(const CameraOptions& options, const ImageMetadata& metadata,
                            int width_px, int height_px) {
  const double long_px = std::max(width_px, height_px);
  const double short_px = std::max(1, std::min(width_px, height_px));
  const double image_aspect = long_px / short_px;
  if (options.sensor_aspect) {
    return {*options.sensor_aspect, fmt::format("sensor aspect {:.4g} (given)", *options.sensor_aspect)};
  }
  // Full-frame photo sizes of drone cameras from DJI's specifications: a photo of another
  // aspect from these cameras is a crop of that frame.
  struct Known {
    const char* model;
    double aspect;
    const char* name;
  };
  static constexpr Known kKnown[] = {
      {"FC300S", 4.0 / 3.0, "4:3"}, {"FC300X", 4.0 / 3.0, "4:3"}, {"FC330", 4.0 / 3.0, "4:3"},
      {"FC220", 4.0 / 3.0, "4:3"},  {"FC6310", 1.5, "3:2"},       {"FC6310S", 1.5, "3:2"},
      {"L1D-20c", 1.5, "3:2"},
  };
  for (const Known& k : kKnown) {
    if (metadata.model == k.model) {
      return {k.aspect, fmt::format("the {}'s {} sensor", k.model, k.name)};
    }
  }
  if (image_aspect > 1.7) {
    return {4.0 / 3.0, fmt::format("a {:.3g}:1 photo taken as a crop of a 4:3 sensor", image_aspect)};
  }
  return {image_aspect, "the photo's own frame"};
}

ResolvedCamera ResolveCamera(const CameraOptions& options, int width_px, int height_px,
                             const ImageMetadata* metadata,
                             std::optional<double> telemetry_focal_35mm_mm) {
  Validate(options);
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument(fmt::format("frame size {}x{} must be positive", width_px, height_px));
  }
  ResolvedCamera r;
  if (options.calibration) {
    r.intrinsics = ScaledTo(*options.calibration, width_px, height_px);
    const CameraIntrinsics& c = *options.calibration;
    r.source = fmt::format(
        "focal length {:.1f} px from the calibration {} ({} lens{}{})", r.intrinsics.fx_px,
        options.calibration_source.empty() ? std::string("given") : "'" + options.calibration_source + "'",
        LensModelName(c.model), r.intrinsics.HasDistortion() ? ", distortion corrected" : "",
        c.width_px != width_px || c.height_px != height_px
            ? fmt::format(", scaled from {}x{}", c.width_px, c.height_px)
            : "");
    r.source_key = "calibration";
    return r;
  }
  double f = 0.0;
  if (options.focal_px) {
    f = *options.focal_px;
    r.source = fmt::format("focal length {:.1f} px (given)", f);
    r.source_key = "flag";
  } else if (options.hfov_deg) {
    f = FocalPxFromHorizontalFov(*options.hfov_deg, width_px);
    r.source = fmt::format("focal length {:.1f} px from the horizontal field of view {} deg", f,
                           *options.hfov_deg);
    r.source_key = "hfov";
  } else if (options.focal_35mm_mm) {
    f = FocalPxFrom35mm(*options.focal_35mm_mm, width_px, height_px);
    r.source = fmt::format("focal length {:.1f} px from the 35 mm equivalent {} mm (given)", f,
                           *options.focal_35mm_mm);
    r.source_key = "35mm";
  } else if (metadata && metadata->calibrated_focal_px && metadata->width_px == width_px &&
             metadata->height_px == height_px) {
    f = *metadata->calibrated_focal_px;
    r.source = fmt::format("focal length {:.1f} px from DJI XMP CalibratedFocalLength of '{}'", f,
                           metadata->source);
    r.source_key = "xmp-calibrated";
  } else if (metadata && metadata->focal_length_35mm_mm) {
    const SensorAspect a = SensorAspectOf(options, *metadata, width_px, height_px);
    f = FocalPxFrom35mmOfSensor(*metadata->focal_length_35mm_mm, width_px, height_px, a.aspect);
    r.source = fmt::format(
        "focal length {:.1f} px from EXIF FocalLengthIn35mmFilm {} mm of '{}' over {}", f,
        *metadata->focal_length_35mm_mm, metadata->source, a.why);
    r.source_key = "exif-35mm";
  } else if (metadata && metadata->focal_length_mm && metadata->focal_plane_px_per_mm &&
             metadata->width_px == width_px && metadata->height_px == height_px) {
    // The focal length over the pixel pitch (EXIF FocalPlaneXResolution: at the photo's own
    // size, so only when the frames have it). Cameras without a 35 mm equivalent write it
    // (MicaSense's bands: its imageprocessing library's focal length in pixels is the same
    // product).
    f = *metadata->focal_length_mm * *metadata->focal_plane_px_per_mm;
    r.source = fmt::format(
        "focal length {:.1f} px from EXIF FocalLength {} mm and FocalPlaneXResolution {:.2f} px/mm "
        "of '{}'",
        f, *metadata->focal_length_mm, *metadata->focal_plane_px_per_mm, metadata->source);
    r.source_key = "exif-focal-plane";
  } else if (telemetry_focal_35mm_mm) {
    f = FocalPxFrom35mm(*telemetry_focal_35mm_mm, width_px, height_px);
    r.source = fmt::format("focal length {:.1f} px from the telemetry's 35 mm equivalent {} mm", f,
                           *telemetry_focal_35mm_mm);
    r.source_key = "telemetry-35mm";
  } else {
    throw InputError(fmt::format(
        "no focal length for {}x{} frames{}: give focal_px, hfov_deg or focal_35mm_mm", width_px,
        height_px,
        metadata ? fmt::format(" ('{}' has no FocalLengthIn35mmFilm, nor FocalLength with "
                               "FocalPlaneXResolution)",
                               metadata->source)
                 : ""));
  }
  r.intrinsics = IntrinsicsFromFocalPx(f, width_px, height_px);
  if (options.cx_px) r.intrinsics.cx_px = *options.cx_px;
  if (options.cy_px) r.intrinsics.cy_px = *options.cy_px;
  r.intrinsics.distortion = options.distortion;
  Validate(r.intrinsics);
  return r;
}

Undistorter::Undistorter(const CameraIntrinsics& k)
    : width_(k.width_px), height_(k.height_px), input_(k) {
  Validate(k);
  output_ = IntrinsicsFromFocalPx(k.fx_px, width_, height_);
  const cv::Matx33d camera_matrix(k.fx_px, 0, k.cx_px, 0, k.fy_px, k.cy_px, 0, 0, 1);
  const cv::Matx33d new_matrix(output_.fx_px, 0, output_.cx_px, 0, output_.fy_px, output_.cy_px,
                               0, 0, 1);
  if (k.model == LensModel::kFisheye) {
    cv::Vec4d d(0, 0, 0, 0);
    for (std::size_t i = 0; i < k.distortion.size() && i < 4; ++i) d[i] = k.distortion[i];
    cv::fisheye::initUndistortRectifyMap(camera_matrix, d, cv::Matx33d::eye(), new_matrix,
                                         cv::Size(width_, height_), CV_16SC2, map1_, map2_);
  } else {
    const cv::Mat dist = k.distortion.empty() ? cv::Mat() : cv::Mat(k.distortion, true);
    cv::initUndistortRectifyMap(camera_matrix, dist, cv::Matx33d::eye(), new_matrix,
                                cv::Size(width_, height_), CV_16SC2, map1_, map2_);
  }
}

void Undistorter::UndistortPoints(std::vector<cv::Point2f>* points) {
  if (points->empty()) return;
  const CameraIntrinsics& k = input_;
  const cv::Matx33d camera_matrix(k.fx_px, 0, k.cx_px, 0, k.fy_px, k.cy_px, 0, 0, 1);
  const cv::Matx33d new_matrix(output_.fx_px, 0, output_.cx_px, 0, output_.fy_px, output_.cy_px,
                               0, 0, 1);
  scratch_.resize(points->size());
  if (k.model == LensModel::kFisheye) {
    cv::Vec4d d(0, 0, 0, 0);
    for (std::size_t i = 0; i < k.distortion.size() && i < 4; ++i) d[i] = k.distortion[i];
    cv::fisheye::undistortPoints(*points, scratch_, camera_matrix, d, cv::noArray(), new_matrix);
  } else {
    const cv::Mat dist = k.distortion.empty() ? cv::Mat() : cv::Mat(k.distortion, true);
    cv::undistortPoints(*points, scratch_, camera_matrix, dist, cv::noArray(), new_matrix);
  }
  points->swap(scratch_);
}

void Undistorter::CheckSize(int width_px, int height_px) const {
  if (width_px != width_ || height_px != height_) {
    throw InvalidArgument(fmt::format("Undistorter: frame is {}x{}, the camera is {}x{}", width_px,
                                      height_px, width_, height_));
  }
}

void Undistorter::Apply(const GrayImage& in, GrayImage& out) const { Apply(in.view(), &out); }

GrayImageView Undistorter::Apply(const GrayImageView& in, GrayImage* buffer) const {
  CheckSize(in.width, in.height);
  if (buffer->width() != width_ || buffer->height() != height_) {
    *buffer = GrayImage(width_, height_);
  }
  const cv::Mat src(height_, width_, CV_8UC1, const_cast<std::uint8_t*>(in.data),
                    static_cast<std::size_t>(in.stride));
  cv::Mat dst(height_, width_, CV_8UC1, buffer->data());
  cv::remap(src, dst, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return buffer->view();
}

void Undistorter::Apply(const cv::Mat& in, cv::Mat& out) const {
  CheckSize(in.cols, in.rows);
  cv::remap(in, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
}

}  // namespace aerovo
