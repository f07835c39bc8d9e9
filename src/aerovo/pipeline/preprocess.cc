#include "aerovo/pipeline/preprocess.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/frames/camera.h"

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
FrameUndistorter::FrameUndistorter(const CameraIntrinsics& intrinsics)
    : impl_(std::make_unique<Impl>(intrinsics)) {}
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

FrameReducer::FrameReducer(int width_px, int height_px, double max_megapixels,
                           double detect_megapixels)
    : w_(width_px), h_(height_px), out_w_(width_px), out_h_(height_px) {
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument(
        fmt::format("FrameReducer: frame size {}x{} must be positive", width_px, height_px));
  }
  if (!std::isfinite(max_megapixels)) {
    throw InvalidArgument("FrameReducer: max_megapixels must be finite");
  }
  if (!std::isfinite(detect_megapixels)) {
    throw InvalidArgument("FrameReducer: detect_megapixels must be finite");
  }
  const double pixels = static_cast<double>(width_px) * height_px;
  const double budget = max_megapixels * 1e6;
  if (detect_megapixels > 0.0 && pixels > detect_megapixels * 1e6) {
    const double limit =
        max_megapixels > 0.0 ? std::min(budget, detect_megapixels * 1e6) : detect_megapixels * 1e6;
    int n = 2;
    while (static_cast<double>(width_px / n) * (height_px / n) > limit && width_px / n > 1 &&
           height_px / n > 1) {
      ++n;
    }
    factor_ = n;
    out_w_ = std::max(1, width_px / n);
    out_h_ = std::max(1, height_px / n);
    sx_ = sy_ = 1.0 / n;
    active_ = true;
    return;
  }
  if (max_megapixels <= 0.0 || pixels <= budget) return;
  const double s = std::sqrt(budget / pixels);
  out_w_ = std::max(1, static_cast<int>(std::floor(width_px * s)));
  out_h_ = std::max(1, static_cast<int>(std::floor(height_px * s)));
  sx_ = static_cast<double>(out_w_) / width_px;
  sy_ = static_cast<double>(out_h_) / height_px;
  active_ = true;
}

Eigen::Matrix3d FrameReducer::reduced_from_full() const {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m(0, 0) = sx_;
  m(0, 2) = 0.5 * (sx_ - 1.0);
  m(1, 1) = sy_;
  m(1, 2) = 0.5 * (sy_ - 1.0);
  return m;
}

GrayImageView FrameReducer::Apply(const GrayImageView& frame) {
  if (frame.width != w_ || frame.height != h_) {
    throw InvalidArgument(fmt::format("FrameReducer: frame is {}x{}, expected {}x{}", frame.width,
                                      frame.height, w_, h_));
  }
  if (!active_) return frame;
  if (out_.width() != out_w_ || out_.height() != out_h_) out_ = GrayImage(out_w_, out_h_);
  const cv::Mat in(frame.height, frame.width, CV_8UC1, const_cast<std::uint8_t*>(frame.data),
                   static_cast<std::size_t>(frame.stride));
  cv::Mat dst(out_h_, out_w_, CV_8UC1, out_.data());
  if (factor_ > 1) {
    // The whole n x n blocks only: an exact integer ratio, OpenCV's block-mean path of
    // INTER_AREA (each output pixel the rounded mean of its block).
    const cv::Mat blocks = in(cv::Rect(0, 0, out_w_ * factor_, out_h_ * factor_));
    cv::resize(blocks, dst, cv::Size(out_w_, out_h_), 0.0, 0.0, cv::INTER_AREA);
    return out_.view();
  }
  cv::resize(in, dst, cv::Size(out_w_, out_h_), 0.0, 0.0, cv::INTER_AREA);
  return out_.view();
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
