#include "aerovo/pipeline/preprocess.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/io/camera.h"

namespace aerovo {

struct FrameUndistorter::Impl {
  explicit Impl(const CameraIntrinsics& intrinsics) : undistorter(intrinsics) {}
  Undistorter undistorter;
  GrayImage out;
};

namespace {

CameraIntrinsics FrameUndistorterIntrinsics(int width_px, int height_px, double focal_px, double k1,
                                            double k2, double p1, double p2, double k3) {
  if (width_px <= 0 || height_px <= 0 || !(focal_px > 0.0)) {
    throw InvalidArgument("FrameUndistorter: size and focal length must be positive");
  }
  CameraIntrinsics k = IntrinsicsFromFocalPx(focal_px, width_px, height_px);
  k.distortion = {k1, k2, p1, p2, k3};
  return k;
}

}  // namespace

FrameUndistorter::FrameUndistorter(int width_px, int height_px, double focal_px, double k1,
                                   double k2, double p1, double p2, double k3)
    : impl_(std::make_unique<Impl>(
          FrameUndistorterIntrinsics(width_px, height_px, focal_px, k1, k2, p1, p2, k3))) {}
FrameUndistorter::~FrameUndistorter() = default;
FrameUndistorter::FrameUndistorter(FrameUndistorter&&) noexcept = default;
FrameUndistorter& FrameUndistorter::operator=(FrameUndistorter&&) noexcept = default;

GrayImageView FrameUndistorter::Apply(const GrayImageView& frame) {
  const Undistorter& u = impl_->undistorter;
  if (frame.width != u.width_px() || frame.height != u.height_px()) {
    throw InvalidArgument("FrameUndistorter: frame size differs from the calibrated size");
  }
  return u.Apply(frame, &impl_->out);
}

GrayImageView ScaleBrightness(const GrayImageView& frame, double k, GrayImage* buffer) {
  if (!(k >= 0.0) || !std::isfinite(k)) {
    throw InvalidArgument(fmt::format("ScaleBrightness: k must be finite and >= 0, got {}", k));
  }
  std::uint8_t lut[256];
  for (int v = 0; v < 256; ++v) {
    lut[v] = static_cast<std::uint8_t>(std::min(255.0, std::floor(k * v + 0.5)));
  }
  if (buffer->width() != frame.width || buffer->height() != frame.height) {
    *buffer = GrayImage(frame.width, frame.height);
  }
  for (int y = 0; y < frame.height; ++y) {
    const std::uint8_t* in = frame.row(y);
    std::uint8_t* out = buffer->row(y);
    for (int x = 0; x < frame.width; ++x) out[x] = lut[in[x]];
  }
  return buffer->view();
}

}  // namespace aerovo
