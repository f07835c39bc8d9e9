#include "aerovo/sim/render.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/LU>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/imageio/image_io.h"

namespace aerovo::sim {

void Validate(const GroundImage& g) {
  if (g.image.empty()) throw InvalidArgument("GroundImage: the image is empty");
  if (g.image.depth() != CV_8U || (g.image.channels() != 1 && g.image.channels() != 3)) {
    throw InvalidArgument("GroundImage: the image must be 8-bit with 1 or 3 channels");
  }
  if (!(g.metres_per_px > 0.0 && std::isfinite(g.metres_per_px))) {
    throw InvalidArgument(
        fmt::format("GroundImage: metres_per_px = {} must be > 0", g.metres_per_px));
  }
  aerovo::Validate(g.nw_corner, "GroundImage: nw_corner");
}

Eigen::Vector2d GroundCentreEnM(const GroundImage& g) {
  return {0.5 * g.image.cols * g.metres_per_px, -0.5 * g.image.rows * g.metres_per_px};
}

namespace {
// map_from_levelpx: level-l pixel u is level-0 pixel 2^l u (cv::pyrDown's kernel is centred on
// the even source pixels), whose centre is at east (2^l u + 0.5) * mpp.
Eigen::Matrix3d MapFromLevelPx(double mpp, int level) {
  const double s = mpp * std::ldexp(1.0, level);
  Eigen::Matrix3d a;
  a << s, 0, 0.5 * mpp, 0, -s, -0.5 * mpp, 0, 0, 1;
  return a;
}

cv::Matx33d ToCv(const Eigen::Matrix3d& m) {
  cv::Matx33d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m(r, c);
  }
  return out;
}
}  // namespace

GroundRenderer::GroundRenderer(GroundImage ground, CameraModel camera)
    : ground_(std::move(ground)), camera_(camera) {
  Validate(ground_);
  Validate(camera_);
  pyramid_.push_back(ground_.image);
  const int min_side = std::min(camera_.width_px, camera_.height_px);
  while (std::min(pyramid_.back().cols, pyramid_.back().rows) > min_side &&
         std::min(pyramid_.back().cols, pyramid_.back().rows) >= 32) {
    cv::Mat next;
    cv::pyrDown(pyramid_.back(), next);
    pyramid_.push_back(next);
  }
  // Validity mask at the level about 8x coarser than the camera's typical view resolution.
  mask_level_ = std::min<int>(static_cast<int>(pyramid_.size()) - 1, 2);
  const cv::Mat& src = pyramid_[mask_level_];
  cv::Mat gray;
  if (src.channels() == 3) {
    cv::Mat channels[3];
    cv::split(src, channels);
    gray = cv::max(cv::max(channels[0], channels[1]), channels[2]);
  } else {
    gray = src;
  }
  // The pyramid blurs no-data edges; a few DN marks the margin as valid data.
  cv::threshold(gray, valid_mask_, 2, 255, cv::THRESH_BINARY);
  if (HasDistortion(camera_)) {
    const Eigen::Matrix3d k = IntrinsicMatrix(camera_);
    rays_.create(camera_.height_px, camera_.width_px, CV_32FC2);
    for (int v = 0; v < camera_.height_px; ++v) {
      auto* row = rays_.ptr<cv::Vec2f>(v);
      for (int u = 0; u < camera_.width_px; ++u) {
        const Eigen::Vector2d n = UndistortNormalised(
            camera_, Eigen::Vector2d((u - k(0, 2)) / k(0, 0), (v - k(1, 2)) / k(1, 1)));
        row[u] = cv::Vec2f(static_cast<float>(n.x()), static_cast<float>(n.y()));
      }
    }
  }
}

namespace {
// Level pixel coordinates of every ray of `rays` (normalised pinhole x, y) through
// levelpx_from_normalised; rays that miss the ground (w <= 0) get -1 (outside: no data).
void RayMaps(const cv::Mat& rays, const Eigen::Matrix3d& g, int step, cv::Mat* map) {
  const int h = (rays.rows + step - 1) / step, w = (rays.cols + step - 1) / step;
  map->create(h, w, CV_32FC2);
  for (int y = 0; y < h; ++y) {
    const auto* in = rays.ptr<cv::Vec2f>(y * step);
    auto* out = map->ptr<cv::Vec2f>(y);
    for (int x = 0; x < w; ++x) {
      const cv::Vec2f r = in[x * step];
      const Eigen::Vector3d p = g * Eigen::Vector3d(r[0], r[1], 1.0);
      out[x] = p.z() > 1e-12 ? cv::Vec2f(static_cast<float>(p.x() / p.z()),
                                         static_cast<float>(p.y() / p.z()))
                             : cv::Vec2f(-1.0f, -1.0f);
    }
  }
}
}  // namespace

int GroundRenderer::LevelFor(const CameraPose& pose) const {
  const double gsd = NadirGsdMetresPerPx(camera_, std::max(1e-3, pose.position_m.z()));
  const double ratio = gsd / ground_.metres_per_px;
  const int level = ratio <= 1.0 ? 0 : static_cast<int>(std::lround(std::log2(ratio)));
  return std::clamp(level, 0, levels() - 1);
}

Eigen::Matrix3d GroundRenderer::ImageFromGroundLevelPx(const CameraPose& pose, int level) const {
  return ImageFromGroundHomography(camera_, pose) * MapFromLevelPx(ground_.metres_per_px, level);
}

void GroundRenderer::Render(const CameraPose& pose, cv::Mat& out) const {
  if (!(pose.position_m.z() > 0.0) || !pose.position_m.allFinite()) {
    throw InvalidArgument(fmt::format("Render: the camera must be above the ground (height {} m)",
                                      pose.position_m.z()));
  }
  const int level = LevelFor(pose);
  if (!rays_.empty()) {
    const Eigen::Matrix3d g =
        (IntrinsicMatrix(camera_).inverse() * ImageFromGroundLevelPx(pose, level)).inverse();
    cv::Mat map;
    RayMaps(rays_, g, 1, &map);
    cv::remap(pyramid_[level], out, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar::all(0));
    return;
  }
  const cv::Matx33d h = ToCv(ImageFromGroundLevelPx(pose, level));
  cv::warpPerspective(pyramid_[level], out, h, cv::Size(camera_.width_px, camera_.height_px),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

cv::Mat GroundRenderer::Render(const CameraPose& pose) const {
  cv::Mat out;
  Render(pose, out);
  return out;
}

double GroundRenderer::NoDataFraction(const CameraPose& pose) const {
  constexpr int kSub = 8;
  if (!rays_.empty()) {
    const Eigen::Matrix3d g =
        (IntrinsicMatrix(camera_).inverse() * ImageFromGroundLevelPx(pose, mask_level_)).inverse();
    cv::Mat map, view;
    RayMaps(rays_, g, kSub, &map);
    cv::remap(valid_mask_, view, map, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    return 1.0 - static_cast<double>(cv::countNonZero(view)) / static_cast<double>(view.total());
  }
  const int w = std::max(4, camera_.width_px / kSub), h = std::max(4, camera_.height_px / kSub);
  // Small camera with the same field of view: scale pixel coordinates by w / width.
  Eigen::Matrix3d scale = Eigen::Matrix3d::Identity();
  const double sx = static_cast<double>(w) / camera_.width_px;
  const double sy = static_cast<double>(h) / camera_.height_px;
  // Pixel centres: u_small = (u + 0.5) * s - 0.5.
  scale << sx, 0, 0.5 * sx - 0.5, 0, sy, 0.5 * sy - 0.5, 0, 0, 1;
  const Eigen::Matrix3d m = scale * ImageFromGroundLevelPx(pose, mask_level_);
  cv::Mat view;
  cv::warpPerspective(valid_mask_, view, ToCv(m), cv::Size(w, h), cv::INTER_NEAREST,
                      cv::BORDER_CONSTANT, cv::Scalar(0));
  return 1.0 - static_cast<double>(cv::countNonZero(view)) / (static_cast<double>(w) * h);
}

void Validate(const EffectsOptions& e) {
  if (!(e.illumination_k > 0.0 && e.illumination_k <= 1.0)) {
    throw InvalidArgument(
        fmt::format("EffectsOptions: illumination_k = {} must be in (0, 1]", e.illumination_k));
  }
  if (!(e.noise_sigma_dn >= 0.0 && e.noise_sigma_dn <= 100.0)) {
    throw InvalidArgument(
        fmt::format("EffectsOptions: noise_sigma_dn = {} must be in [0, 100]", e.noise_sigma_dn));
  }
  if (!(e.motion_blur_px >= 0.0 && e.motion_blur_px <= 200.0)) {
    throw InvalidArgument(
        fmt::format("EffectsOptions: motion_blur_px = {} must be in [0, 200]", e.motion_blur_px));
  }
  if (!(e.contrast > 0.0 && e.contrast <= 1.0)) {
    throw InvalidArgument(fmt::format("EffectsOptions: contrast = {} must be in (0, 1]", e.contrast));
  }
  if (!(e.optics_blur_sigma_px >= 0.0 && e.optics_blur_sigma_px <= 50.0)) {
    throw InvalidArgument(fmt::format("EffectsOptions: optics_blur_sigma_px = {} must be in [0, 50]",
                                      e.optics_blur_sigma_px));
  }
  if (!(e.vignetting_dn >= 0.0 && e.vignetting_dn <= 255.0)) {
    throw InvalidArgument(
        fmt::format("EffectsOptions: vignetting_dn = {} must be in [0, 255]", e.vignetting_dn));
  }
  if (!(e.fixed_pattern_dn >= 0.0 && e.fixed_pattern_dn <= 100.0)) {
    throw InvalidArgument(fmt::format("EffectsOptions: fixed_pattern_dn = {} must be in [0, 100]",
                                      e.fixed_pattern_dn));
  }
  if (e.jpeg_quality < 0 || e.jpeg_quality > 100) {
    throw InvalidArgument(fmt::format(
        "EffectsOptions: jpeg_quality = {} must be in [0, 100] (0 = none)", e.jpeg_quality));
  }
}

namespace {
// Normalised line kernel of the given length along `dir`, splatted bilinearly at sub-pixel
// samples so that non-integer lengths and any angle give a smooth kernel.
cv::Mat LineKernel(double length, Eigen::Vector2d dir) {
  if (dir.norm() < 1e-9) dir = Eigen::Vector2d(1, 0);
  dir.normalize();
  const int half = static_cast<int>(std::ceil(0.5 * length)) + 1;
  cv::Mat k(2 * half + 1, 2 * half + 1, CV_32F, cv::Scalar(0));
  const int n = std::max(2, static_cast<int>(std::ceil(length * 8)));
  for (int i = 0; i <= n; ++i) {
    const double t = (static_cast<double>(i) / n - 0.5) * length;
    const double x = half + t * dir.x(), y = half + t * dir.y();
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
    k.at<float>(y0, x0) += (1 - fx) * (1 - fy);
    k.at<float>(y0, x0 + 1) += fx * (1 - fy);
    k.at<float>(y0 + 1, x0) += (1 - fx) * fy;
    k.at<float>(y0 + 1, x0 + 1) += fx * fy;
  }
  k /= cv::sum(k)[0];
  return k;
}

// The static offset of the sensor (EffectsOptions::vignetting_dn, fixed_pattern_dn), DN, one
// float per pixel of a w x h frame: the same for every frame of a camera.
cv::Mat SensorPattern(int w, int h, const EffectsOptions& e) {
  cv::Mat pattern(h, w, CV_32F, cv::Scalar(0));
  if (e.fixed_pattern_dn > 0.0) {
    cv::RNG rng(e.fixed_pattern_seed);
    rng.fill(pattern, cv::RNG::NORMAL, 0.0, e.fixed_pattern_dn);
    cv::Mat column(1, w, CV_32F);
    rng.fill(column, cv::RNG::NORMAL, 0.0, e.fixed_pattern_dn);
    for (int y = 0; y < h; ++y) pattern.row(y) += column;
  }
  if (e.vignetting_dn > 0.0) {
    const double cx = 0.5 * (w - 1), cy = 0.5 * (h - 1), r2max = cx * cx + cy * cy;
    for (int y = 0; y < h; ++y) {
      float* row = pattern.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max;
        row[x] -= static_cast<float>(e.vignetting_dn * r2);
      }
    }
  }
  return pattern;
}

}  // namespace

void ApplyEffects(cv::Mat& frame, const EffectsOptions& e, const Eigen::Vector2d& motion_px,
                  std::uint64_t seed) {
  Validate(e);
  if (frame.empty() || frame.depth() != CV_8U) {
    throw InvalidArgument("ApplyEffects: the frame must be a non-empty 8-bit image");
  }
  if (e.grayscale && frame.channels() == 3) {
    cv::Mat grey;
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    cv::cvtColor(grey, frame, cv::COLOR_GRAY2BGR);
  }
  if (e.contrast != 1.0) {
    const cv::Scalar mean = cv::mean(frame);
    const double m = (mean[0] + mean[1] + mean[2]) / std::max(1, std::min(3, frame.channels()));
    frame.convertTo(frame, -1, e.contrast, (1.0 - e.contrast) * m);
  }
  if (e.optics_blur_sigma_px > 0.0) {
    cv::GaussianBlur(frame, frame, cv::Size(0, 0), e.optics_blur_sigma_px, e.optics_blur_sigma_px,
                     cv::BORDER_REFLECT101);
  }
  if (e.motion_blur_px > 0.0) {
    cv::filter2D(frame, frame, -1, LineKernel(e.motion_blur_px, motion_px), cv::Point(-1, -1), 0,
                 cv::BORDER_REFLECT101);
  }
  if (e.illumination_k != 1.0) frame.convertTo(frame, -1, e.illumination_k, 0.0);
  if (e.noise_sigma_dn > 0.0 || e.vignetting_dn > 0.0 || e.fixed_pattern_dn > 0.0) {
    cv::Mat noise(frame.size(), CV_32FC(frame.channels()), cv::Scalar::all(0));
    if (e.noise_sigma_dn > 0.0) {
      cv::RNG rng(seed);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, e.noise_sigma_dn);
    }
    if (e.vignetting_dn > 0.0 || e.fixed_pattern_dn > 0.0) {
      cv::Mat pattern = SensorPattern(frame.cols, frame.rows, e);
      if (frame.channels() > 1) cv::merge(std::vector<cv::Mat>(frame.channels(), pattern), pattern);
      noise += pattern;
    }
    cv::Mat f;
    frame.convertTo(f, CV_32F);
    f += noise;
    f.convertTo(frame, CV_8U);
  }
  if (e.jpeg_quality > 0) {
    std::vector<std::uint8_t> buf;
    imageio::Encode(".jpg", frame, buf, {cv::IMWRITE_JPEG_QUALITY, e.jpeg_quality});
    frame = imageio::Decode(buf, frame.channels() == 1 ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
  }
}

EffectsOptions ThermalEffects() {
  EffectsOptions e;
  e.grayscale = true;
  e.contrast = 0.15;
  e.optics_blur_sigma_px = 1.2;
  e.noise_sigma_dn = 1.5;
  e.vignetting_dn = 30.0;
  e.fixed_pattern_dn = 3.0;
  return e;
}

Eigen::Vector2d ImageMotionPx(const CameraModel& camera, const CameraPose& a, const CameraPose& b) {
  const Eigen::Vector2d centre(0.5 * (camera.width_px - 1), 0.5 * (camera.height_px - 1));
  const Eigen::Vector2d ground = BackProjectPixel(camera, a, centre);
  if (!ground.allFinite()) return Eigen::Vector2d::Zero();
  const Eigen::Vector2d p = ProjectGroundPoint(camera, b, ground);
  return p.allFinite() ? Eigen::Vector2d(p - centre) : Eigen::Vector2d::Zero();
}

}  // namespace aerovo::sim
