#include "aerovo/io/camera.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"

namespace aerovo {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

bool GoodDistortionCount(std::size_t n) { return n == 0 || n == 4 || n == 5 || n == 8; }

}  // namespace

double FocalPxFrom35mm(double focal_35mm_mm, int width_px, int height_px) {
  if (!PositiveFinite(focal_35mm_mm)) {
    throw InvalidArgument(
        fmt::format("35 mm-equivalent focal length {} mm must be > 0", focal_35mm_mm));
  }
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument(fmt::format("image size {}x{} must be positive", width_px, height_px));
  }
  const double diag_px = std::hypot(static_cast<double>(width_px), static_cast<double>(height_px));
  return focal_35mm_mm / kFullFrameDiagonalMm * diag_px;
}

double FocalPxFromHorizontalFov(double hfov_deg, int width_px) {
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0)) {
    throw InvalidArgument(
        fmt::format("horizontal field of view {} deg must be in (0, 180)", hfov_deg));
  }
  if (width_px <= 0) throw InvalidArgument(fmt::format("image width {} must be > 0", width_px));
  return 0.5 * width_px / std::tan(0.5 * hfov_deg * kDegToRad);
}

double HorizontalFovDeg(double focal_px, int width_px) {
  return 2.0 * std::atan(0.5 * width_px / focal_px) / kDegToRad;
}

bool CameraIntrinsics::HasDistortion() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double d) { return d != 0.0; });
}

CameraIntrinsics IntrinsicsFromFocalPx(double focal_px, int width_px, int height_px) {
  CameraIntrinsics k;
  k.width_px = width_px;
  k.height_px = height_px;
  k.fx_px = k.fy_px = focal_px;
  k.cx_px = 0.5 * (width_px - 1);
  k.cy_px = 0.5 * (height_px - 1);
  Validate(k);
  return k;
}

void Validate(const CameraIntrinsics& k) {
  if (k.width_px <= 0 || k.height_px <= 0) {
    throw InvalidArgument(
        fmt::format("CameraIntrinsics size {}x{} must be positive", k.width_px, k.height_px));
  }
  if (!PositiveFinite(k.fx_px) || !PositiveFinite(k.fy_px)) {
    throw InvalidArgument(
        fmt::format("CameraIntrinsics focal ({}, {}) px must be > 0", k.fx_px, k.fy_px));
  }
  if (!(k.cx_px >= 0.0 && k.cx_px <= k.width_px - 1) ||
      !(k.cy_px >= 0.0 && k.cy_px <= k.height_px - 1)) {
    throw InvalidArgument(
        fmt::format("CameraIntrinsics principal point ({}, {}) outside the {}x{} image", k.cx_px,
                    k.cy_px, k.width_px, k.height_px));
  }
  if (!GoodDistortionCount(k.distortion.size())) {
    throw InvalidArgument(
        fmt::format("CameraIntrinsics distortion has {} coefficients (expected 0, "
                    "4, 5 or 8: k1 k2 p1 p2 [k3 [k4 k5 k6]])",
                    k.distortion.size()));
  }
  for (double d : k.distortion) {
    if (!std::isfinite(d)) throw InvalidArgument("CameraIntrinsics distortion is not finite");
  }
}

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
  if (!GoodDistortionCount(o.distortion.size())) {
    throw InvalidArgument(
        fmt::format("CameraOptions.distortion has {} coefficients (expected 0, 4, "
                    "5 or 8)",
                    o.distortion.size()));
  }
}

ResolvedCamera ResolveCamera(const CameraOptions& options, int width_px, int height_px,
                             const ImageMetadata* metadata) {
  Validate(options);
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument(fmt::format("frame size {}x{} must be positive", width_px, height_px));
  }
  ResolvedCamera r;
  double f = 0.0;
  if (options.focal_px) {
    f = *options.focal_px;
    r.source = fmt::format("focal length {:.1f} px (given)", f);
  } else if (options.hfov_deg) {
    f = FocalPxFromHorizontalFov(*options.hfov_deg, width_px);
    r.source = fmt::format("focal length {:.1f} px from the horizontal field of view {} deg", f,
                           *options.hfov_deg);
  } else if (options.focal_35mm_mm) {
    f = FocalPxFrom35mm(*options.focal_35mm_mm, width_px, height_px);
    r.source = fmt::format("focal length {:.1f} px from the 35 mm equivalent {} mm (given)", f,
                           *options.focal_35mm_mm);
  } else if (metadata && metadata->calibrated_focal_px && metadata->width_px == width_px &&
             metadata->height_px == height_px) {
    f = *metadata->calibrated_focal_px;
    r.source = fmt::format("focal length {:.1f} px from DJI XMP CalibratedFocalLength of '{}'", f,
                           metadata->source);
  } else if (metadata && metadata->focal_length_35mm_mm) {
    f = FocalPxFrom35mm(*metadata->focal_length_35mm_mm, width_px, height_px);
    r.source = fmt::format("focal length {:.1f} px from EXIF FocalLengthIn35mmFilm {} mm of '{}'",
                           f, *metadata->focal_length_35mm_mm, metadata->source);
  } else {
    throw InputError(fmt::format(
        "no focal length for {}x{} frames{}: give focal_px, hfov_deg or focal_35mm_mm", width_px,
        height_px,
        metadata ? fmt::format(" ('{}' has no FocalLengthIn35mmFilm)", metadata->source) : ""));
  }
  r.intrinsics = IntrinsicsFromFocalPx(f, width_px, height_px);
  if (options.cx_px) r.intrinsics.cx_px = *options.cx_px;
  if (options.cy_px) r.intrinsics.cy_px = *options.cy_px;
  r.intrinsics.distortion = options.distortion;
  Validate(r.intrinsics);
  return r;
}

Undistorter::Undistorter(const CameraIntrinsics& k) : width_(k.width_px), height_(k.height_px) {
  Validate(k);
  const cv::Mat K(k.K());
  const cv::Mat dist = k.distortion.empty() ? cv::Mat() : cv::Mat(k.distortion, true);
  cv::initUndistortRectifyMap(K, dist, cv::Mat(), K, cv::Size(width_, height_), CV_16SC2, map1_,
                              map2_);
}

void Undistorter::Apply(const GrayImage& in, GrayImage& out) const {
  if (in.width() != width_ || in.height() != height_) {
    throw InvalidArgument(fmt::format("Undistorter: frame is {}x{}, the camera is {}x{}",
                                      in.width(), in.height(), width_, height_));
  }
  if (out.width() != width_ || out.height() != height_) out = GrayImage(width_, height_);
  const cv::Mat src(height_, width_, CV_8UC1, const_cast<std::uint8_t*>(in.data()));
  cv::Mat dst(height_, width_, CV_8UC1, out.data());
  cv::remap(src, dst, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
}

}  // namespace aerovo
