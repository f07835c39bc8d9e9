#include "aerovo/pipeline/preprocess.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"

namespace aerovo {

struct FrameUndistorter::Impl {
  int width = 0, height = 0;
  cv::Mat map1, map2, out;
};

FrameUndistorter::FrameUndistorter(int width_px, int height_px, double focal_px, double k1,
                                   double k2, double p1, double p2, double k3)
    : impl_(std::make_unique<Impl>()) {
  if (width_px <= 0 || height_px <= 0 || !(focal_px > 0.0)) {
    throw InvalidArgument("FrameUndistorter: size and focal length must be positive");
  }
  impl_->width = width_px;
  impl_->height = height_px;
  const cv::Matx33d k(focal_px, 0, 0.5 * (width_px - 1), 0, focal_px, 0.5 * (height_px - 1), 0, 0,
                      1);
  const cv::Vec<double, 5> dist(k1, k2, p1, p2, k3);
  cv::initUndistortRectifyMap(k, dist, cv::Matx33d::eye(), k, cv::Size(width_px, height_px),
                              CV_16SC2, impl_->map1, impl_->map2);
}
FrameUndistorter::~FrameUndistorter() = default;
FrameUndistorter::FrameUndistorter(FrameUndistorter&&) noexcept = default;
FrameUndistorter& FrameUndistorter::operator=(FrameUndistorter&&) noexcept = default;

GrayImageView FrameUndistorter::Apply(const GrayImageView& frame) {
  if (frame.width != impl_->width || frame.height != impl_->height) {
    throw InvalidArgument("FrameUndistorter: frame size differs from the calibrated size");
  }
  const cv::Mat in(frame.height, frame.width, CV_8UC1, const_cast<std::uint8_t*>(frame.data),
                   static_cast<std::size_t>(frame.stride));
  cv::remap(in, impl_->out, impl_->map1, impl_->map2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return GrayImageView{impl_->out.data, impl_->out.cols, impl_->out.rows,
                       static_cast<std::ptrdiff_t>(impl_->out.step)};
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
