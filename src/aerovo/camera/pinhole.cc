#include "aerovo/camera/pinhole.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"

namespace aerovo {
namespace {

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

void CheckSize(int width_px, int height_px) {
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument(fmt::format("image size {}x{} must be positive", width_px, height_px));
  }
}

}  // namespace

double FocalPxFrom35mm(double focal_35mm_mm, int width_px, int height_px) {
  if (!PositiveFinite(focal_35mm_mm)) {
    throw InvalidArgument(
        fmt::format("35 mm-equivalent focal length {} mm must be > 0", focal_35mm_mm));
  }
  CheckSize(width_px, height_px);
  const double diag_px = std::hypot(static_cast<double>(width_px), static_cast<double>(height_px));
  return focal_35mm_mm / kFullFrameDiagonalMm * diag_px;
}

double FocalPxFrom35mmOfSensor(double focal_35mm_mm, int width_px, int height_px,
                               double sensor_aspect) {
  if (!(std::isfinite(sensor_aspect) && sensor_aspect >= 1.0)) {
    throw InvalidArgument(
        fmt::format("sensor aspect ratio {} must be >= 1 (long side / short side)", sensor_aspect));
  }
  if (!PositiveFinite(focal_35mm_mm)) {
    throw InvalidArgument(
        fmt::format("35 mm-equivalent focal length {} mm must be > 0", focal_35mm_mm));
  }
  CheckSize(width_px, height_px);
  const double long_px = std::max(width_px, height_px);
  const double short_px = std::min(width_px, height_px);
  const double diag_px = long_px / short_px >= sensor_aspect
                             ? long_px * std::sqrt(1.0 + 1.0 / (sensor_aspect * sensor_aspect))
                             : short_px * std::sqrt(1.0 + sensor_aspect * sensor_aspect);
  return focal_35mm_mm / kFullFrameDiagonalMm * diag_px;
}

double Focal35mmFromPx(double focal_px, int width_px, int height_px) {
  if (!PositiveFinite(focal_px)) {
    throw InvalidArgument(fmt::format("focal length {} px must be > 0", focal_px));
  }
  CheckSize(width_px, height_px);
  return focal_px * kFullFrameDiagonalMm /
         std::hypot(static_cast<double>(width_px), static_cast<double>(height_px));
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

const char* LensModelName(LensModel model) {
  return model == LensModel::kFisheye ? "fisheye" : "pinhole";
}

LensModel ParseLensModel(const std::string& name) {
  if (name == "pinhole") return LensModel::kPinhole;
  if (name == "fisheye") return LensModel::kFisheye;
  throw InvalidArgument(fmt::format("lens model '{}' is not one of pinhole, fisheye", name));
}

CameraIntrinsics ScaledTo(const CameraIntrinsics& k, int width_px, int height_px) {
  Validate(k);
  CheckSize(width_px, height_px);
  if (width_px == k.width_px && height_px == k.height_px) return k;
  const double aspect_from = static_cast<double>(k.width_px) / k.height_px;
  const double aspect_to = static_cast<double>(width_px) / height_px;
  if (std::abs(aspect_to / aspect_from - 1.0) > 0.01) {
    throw InvalidArgument(fmt::format(
        "the calibration is for {}x{} frames (aspect {:.4g}), the frames are {}x{} (aspect "
        "{:.4g}): a crop, not a scaling, so the calibration does not apply",
        k.width_px, k.height_px, aspect_from, width_px, height_px, aspect_to));
  }
  const double sx = static_cast<double>(width_px) / k.width_px;
  const double sy = static_cast<double>(height_px) / k.height_px;
  CameraIntrinsics out = k;
  out.width_px = width_px;
  out.height_px = height_px;
  out.fx_px = k.fx_px * sx;
  out.fy_px = k.fy_px * sy;
  out.cx_px = std::clamp((k.cx_px + 0.5) * sx - 0.5, 0.0, width_px - 1.0);
  out.cy_px = std::clamp((k.cy_px + 0.5) * sy - 0.5, 0.0, height_px - 1.0);
  Validate(out);
  return out;
}

bool CameraIntrinsics::HasDistortion() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double d) { return d != 0.0; });
}

Eigen::Matrix3d CameraIntrinsics::K() const {
  Eigen::Matrix3d k;
  k << fx_px, 0, cx_px, 0, fy_px, cy_px, 0, 0, 1;
  return k;
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
  const std::size_t n = k.distortion.size();
  if (k.model == LensModel::kFisheye && !(n == 0 || n == 4)) {
    throw InvalidArgument(fmt::format(
        "CameraIntrinsics fisheye distortion has {} coefficients (expected 0 or 4: k1 k2 k3 k4)",
        n));
  }
  if (!(n == 0 || n == 4 || n == 5 || n == 8)) {
    throw InvalidArgument(
        fmt::format("CameraIntrinsics distortion has {} coefficients (expected 0, "
                    "4, 5 or 8: k1 k2 p1 p2 [k3 [k4 k5 k6]])",
                    n));
  }
  for (double d : k.distortion) {
    if (!std::isfinite(d)) throw InvalidArgument("CameraIntrinsics distortion is not finite");
  }
}

}  // namespace aerovo
