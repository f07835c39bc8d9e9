#include "aerovo/odometry/map_match.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/estimation/models.h"
#include "aerovo/estimation/ransac.h"
#include "aerovo/features/surf.h"
#include "aerovo/matching/matcher.h"

namespace aerovo {

void Validate(const MapMatchOptions& options) {
  options::CheckRanges(options, "map_fix");
  // The start position and its radius go together (0, 0 is taken as no position given).
  const bool position = options.start_lat_deg != 0.0 || options.start_lon_deg != 0.0;
  if (options.start_radius_m > 0.0 && !position) {
    throw InvalidArgument(
        "map_fix.start_radius_m needs the start position it is around: map_fix.start_lat_deg "
        "and start_lon_deg (--map-fix-start-lat-deg, --map-fix-start-lon-deg)");
  }
  if (position && !(options.start_radius_m > 0.0)) {
    throw InvalidArgument(
        "map_fix.start_lat_deg and start_lon_deg need map_fix.start_radius_m > 0, how far around "
        "the start position to search (--map-fix-start-radius-m)");
  }
}

const char* ToString(MapFixStatus status) {
  switch (status) {
    case MapFixStatus::kFix:
      return "fix";
    case MapFixStatus::kNoMap:
      return "no_map";
    case MapFixStatus::kNoMapTexture:
      return "no_map_texture";
    case MapFixStatus::kNoFrameTexture:
      return "no_frame_texture";
    case MapFixStatus::kTooFewInliers:
      return "few_inliers";
    case MapFixStatus::kSpread:
      return "spread";
    case MapFixStatus::kScale:
      return "scale";
    case MapFixStatus::kGate:
      return "gate";
    case MapFixStatus::kAmbiguous:
      return "ambiguous";
    case MapFixStatus::kMapTooCoarse:
      return "map_too_coarse";
  }
  return "?";
}

int MapWindowSizePx(int frame_width_px, int frame_height_px, double gsd_m_per_px,
                    double search_radius_m, double m_per_px) {
  // The footprint's half-diagonal covers it at any heading.
  const double half_diagonal_m = 0.5 * std::hypot(frame_width_px, frame_height_px) * gsd_m_per_px;
  const double half_m = half_diagonal_m + search_radius_m;
  return std::max(16, static_cast<int>(std::ceil(2.0 * half_m / m_per_px)) + 1);
}

double MapMatchResolution(const MapMatchOptions& options, int frame_width_px, double gsd_m_per_px,
                          double map_m_per_px) {
  if (options.match_m_per_px > 0.0) return options.match_m_per_px;
  const double frame_at_width = gsd_m_per_px * frame_width_px / options.match_width_px;
  return std::max(map_m_per_px, frame_at_width);
}

double MapSearchResolution(const MapMatchOptions& options, int frame_width_px, double gsd_m_per_px,
                           double map_m_per_px) {
  return std::max(MapMatchResolution(options, frame_width_px, gsd_m_per_px, map_m_per_px),
                  gsd_m_per_px * frame_width_px / options.search_width_px);
}

MapMatchOptions MapRefineOptions(const MapMatchOptions& options, double coarse_m_per_px) {
  MapMatchOptions fine = options;
  fine.search_radius_m = std::max(10.0, 8.0 * coarse_m_per_px);
  fine.gate_m = 0.0;
  return fine;
}

double MapRobustRange(const std::array<std::int64_t, 256>& histogram) {
  std::int64_t n = 0;
  for (const std::int64_t c : histogram) n += c;
  if (n == 0) return 0.0;
  const std::int64_t lo_count = n / 100, hi_count = n - n / 100 - 1;
  int lo = 0, hi = 0;
  std::int64_t cumulative = 0;
  bool lo_set = false;
  for (int i = 0; i < 256; ++i) {
    cumulative += histogram[static_cast<std::size_t>(i)];
    if (!lo_set && cumulative > lo_count) {
      lo = i;
      lo_set = true;
    }
    if (cumulative > hi_count) {
      hi = i;
      break;
    }
  }
  return hi - lo;
}

double MapLadderResolution(double m_per_px) {
  return std::exp2(std::round(8.0 * std::log2(m_per_px)) / 8.0);
}

namespace {

double WrapPi(double a) { return std::remainder(a, 2.0 * kPi); }

// The frame's width on the ground, m: its pixels times its ground sampling distance.
double FrameWidthM(const MapMatchFrame& frame) {
  return frame.pixels.width * frame.height_m / frame.focal_px;
}

// The robust intensity range (1st to 99th percentile) of `image` where `valid` is non-zero
// (everywhere when valid is empty), grey levels; 0 with no valid pixel.
double RobustRange(const GrayImageView& image, const GrayImageView& valid) {
  std::array<std::int64_t, 256> histogram{};
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* p = image.row(y);
    const std::uint8_t* v = valid.empty() ? nullptr : valid.row(y);
    for (int x = 0; x < image.width; ++x) {
      if (v != nullptr && v[x] == 0) continue;
      ++histogram[p[x]];
    }
  }
  return MapRobustRange(histogram);
}

// Invalid pixels of `image` set to the mean of the valid ones (so that SURF sees no edge along
// the border of the data; the points near it are dropped anyway: KeepOnValid).
void FillInvalid(GrayImage& image, const GrayImage& valid) {
  std::int64_t sum = 0, n = 0;
  const std::size_t size = static_cast<std::size_t>(image.width()) * image.height();
  for (std::size_t i = 0; i < size; ++i) {
    if (valid.data()[i] != 0) {
      sum += image.data()[i];
      ++n;
    }
  }
  const auto mean = static_cast<std::uint8_t>(n > 0 ? sum / n : 128);
  for (std::size_t i = 0; i < size; ++i) {
    if (valid.data()[i] == 0) image.data()[i] = mean;
  }
}

// Drops the points whose descriptor region (a disc of 12 SURF scales: the 20 s square's
// half-diagonal is 14 s, its weight falls off outside 10 s) reaches an invalid pixel, checked at
// its centre and 8 points of its rim.
void KeepOnValid(const GrayImageView& valid, FeatureSet& features) {
  const auto ok = [&](double x, double y) {
    const int xi = static_cast<int>(std::lround(x)), yi = static_cast<int>(std::lround(y));
    return xi >= 0 && yi >= 0 && xi < valid.width && yi < valid.height && valid.at(xi, yi) != 0;
  };
  std::size_t kept = 0;
  const int d = features.descriptor_size;
  for (std::size_t i = 0; i < features.size(); ++i) {
    const Keypoint& k = features.keypoints[i];
    const double r = 12.0 * k.scale;
    bool inside = ok(k.x, k.y);
    for (int j = 0; j < 8 && inside; ++j) {
      const double a = j * kPi / 4.0;
      inside = ok(k.x + r * std::cos(a), k.y + r * std::sin(a));
    }
    if (!inside) continue;
    if (kept != i) {
      features.keypoints[kept] = k;
      std::copy_n(features.descriptor(i), d, features.descriptor(kept));
    }
    ++kept;
  }
  features.keypoints.resize(kept);
  features.descriptors.resize(kept * static_cast<std::size_t>(d));
}

std::size_t CountValid(const GrayImage& valid) {
  return static_cast<std::size_t>(std::count_if(
      valid.data(), valid.data() + static_cast<std::size_t>(valid.width()) * valid.height(),
      [](std::uint8_t v) { return v != 0; }));
}

// The frame brought to the window's geometry: warped pixel w = centre + warped_from_frame_linear
// (p - frame centre).
struct Warp {
  Eigen::Matrix2d warped_from_frame = Eigen::Matrix2d::Identity();  // s R(-heading)
  Eigen::Vector2d frame_centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d warped_centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d FrameOf(const Eigen::Vector2d& w) const {
    return frame_centre + warped_from_frame.inverse() * (w - warped_centre);
  }
};

// Samples `frame` through `warp` into `out` (box-averaged over k x k samples per pixel when the
// frame is reduced, k = ceil(1 / scale) up to 4) and marks `valid` where every sample is inside.
void WarpFrame(const GrayImageView& frame, const Warp& warp, int width, int height, GrayImage& out,
               GrayImage& valid) {
  out = GrayImage(width, height);
  valid = GrayImage(width, height);
  const double scale = std::sqrt(std::abs(warp.warped_from_frame.determinant()));
  const int k = std::clamp(static_cast<int>(std::ceil(1.0 / scale - 1e-9)), 1, 4);
  const Eigen::Matrix2d frame_from_warped = warp.warped_from_frame.inverse();
  const double max_x = frame.width - 1, max_y = frame.height - 1;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0.0;
      bool inside = true;
      for (int j = 0; j < k && inside; ++j) {
        for (int i = 0; i < k && inside; ++i) {
          const Eigen::Vector2d w(x + (i + 0.5) / k - 0.5, y + (j + 0.5) / k - 0.5);
          const Eigen::Vector2d p =
              warp.frame_centre + frame_from_warped * (w - warp.warped_centre);
          if (!(p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= max_x && p.y() <= max_y)) {
            inside = false;
            break;
          }
          const int x0 = std::min(static_cast<int>(p.x()), frame.width - 2);
          const int y0 = std::min(static_cast<int>(p.y()), frame.height - 2);
          const double fx = p.x() - x0, fy = p.y() - y0;
          const std::uint8_t* r0 = frame.row(y0);
          const std::uint8_t* r1 = frame.row(y0 + 1);
          sum += (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
                 fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
        }
      }
      if (!inside) continue;
      out.at(x, y) = static_cast<std::uint8_t>(std::lround(std::clamp(sum / (k * k), 0.0, 255.0)));
      valid.at(x, y) = 255;
    }
  }
}

// The warp of `frame` to `m_per_px`, north-up when its heading is known, and the size of the
// warped image that holds it.
Warp MakeWarp(const MapMatchFrame& frame, double m_per_px, int* width, int* height) {
  Warp warp;
  const double scale = frame.height_m / frame.focal_px / m_per_px;
  warp.warped_from_frame = scale * RotationMatrix2d(-frame.heading_rad.value_or(0.0));
  warp.frame_centre =
      Eigen::Vector2d((frame.pixels.width - 1) / 2.0, (frame.pixels.height - 1) / 2.0);
  Eigen::Vector2d extent = Eigen::Vector2d::Zero();
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      const Eigen::Vector2d corner(sx * warp.frame_centre.x(), sy * warp.frame_centre.y());
      extent = extent.cwiseMax((warp.warped_from_frame * corner).cwiseAbs());
    }
  }
  *width = 2 * static_cast<int>(std::ceil(extent.x())) + 1;
  *height = 2 * static_cast<int>(std::ceil(extent.y())) + 1;
  warp.warped_centre = Eigen::Vector2d((*width - 1) / 2.0, (*height - 1) / 2.0);
  return warp;
}

void CheckInputs(const MapMatchFrame& frame, const MapMatchWindow& window) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (frame.pixels.empty() || frame.pixels.width < 2 || frame.pixels.height < 2) {
    throw InvalidArgument("map fix: the frame is empty");
  }
  if (window.pixels.empty()) throw InvalidArgument("map fix: the map window is empty");
  if (window.valid.width != window.pixels.width || window.valid.height != window.pixels.height) {
    throw InvalidArgument("map fix: the window's valid mask is not the window's size");
  }
  if (!positive(frame.focal_px) || !positive(frame.height_m) || !positive(window.m_per_px)) {
    throw InvalidArgument("map fix: focal_px, height_m and m_per_px must be finite and > 0, got " +
                          std::to_string(frame.focal_px) + ", " + std::to_string(frame.height_m) +
                          ", " + std::to_string(window.m_per_px));
  }
  if (frame.heading_rad && !std::isfinite(*frame.heading_rad)) {
    throw InvalidArgument("map fix: the heading is not finite");
  }
}

}  // namespace

namespace {

// The size and resolution of the window a fit is in.
struct WindowGeometry {
  int width = 0, height = 0;
  double m_per_px = 0.0;
};

// Adaptive SURF on `image` (its invalid pixels already filled) with `target` points, the points
// whose descriptor reaches an invalid pixel or the border dropped (KeepOnValid).
FeatureSet DetectOn(const GrayImage& image, const GrayImage& valid, int target, bool upright) {
  SurfOptions surf;
  surf.adaptive = true;
  surf.target_points = std::max(16, target);
  surf.upright = upright;
  Surf engine(surf);
  if (image.width() < 32 || image.height() < 32) return {};
  FeatureSet features = engine.DetectAndDescribe(image.view()).features;
  KeepOnValid(valid.view(), features);
  return features;
}

}  // namespace

FeatureSet DetectMapFeatures(const GrayImageView& pixels, const GrayImageView& valid,
                             int target_points, bool upright) {
  if (valid.width != pixels.width || valid.height != pixels.height) {
    throw InvalidArgument("DetectMapFeatures: the valid mask is not the image's size");
  }
  GrayImage image(pixels.width, pixels.height), mask(pixels.width, pixels.height);
  for (int y = 0; y < pixels.height; ++y) {
    std::copy_n(pixels.row(y), pixels.width, image.row(y));
    std::copy_n(valid.row(y), pixels.width, mask.row(y));
  }
  FillInvalid(image, mask);
  return DetectOn(image, mask, target_points, upright);
}

struct MapMatcher::Impl {
  MapMatchOptions options;
  Matcher matcher;
  RansacWorkspace workspace;
  GrayImage warped, warped_valid, map, map_valid;
  Eigen::Matrix2Xd prev_px, curr_px;
  std::vector<float> quality;
  // The frame's side of the attempt in flight (PrepareFrame).
  Warp warp;
  int warped_w = 0, warped_h = 0;
  FeatureSet frame_features;
  std::size_t frame_valid = 1;

  explicit Impl(const MapMatchOptions& o) : options(o) {}

  void Fit(const FeatureSet& frame_features, const FeatureSet& map_features,
           const std::optional<Eigen::Matrix<double, 2, 3>>& prior, double guided_radius_px,
           RansacResult* fit, MapFix* out);
  void Judge(const RansacResult& fit, const Warp& warp, const MapMatchFrame& frame,
             const WindowGeometry& window, const Eigen::Vector2d& prior_enu_m, double gate_m,
             MapFix* out) const;
  int SecondInliers(const RansacResult& fit, const Warp& warp, int warped_w, int warped_h);
  MapFix Run(const MapMatchFrame& frame, const MapMatchWindow& window,
             const Eigen::Vector2d& prior_enu_m, double gate_m, bool search);
  std::optional<MapFixStatus> PrepareFrame(const MapMatchFrame& frame, double m_per_px);
  void FitAndJudge(const MapMatchFrame& frame, const FeatureSet& map_features,
                   const WindowGeometry& window, const Eigen::Vector2d& prior_enu_m,
                   double gate_m, bool search, MapFix* out);
  void Covariance(const RansacResult& fit, const Warp& warp, double m_per_px, MapFix* out) const;
};

void MapMatcher::Impl::Fit(const FeatureSet& frame_features, const FeatureSet& map_features,
                           const std::optional<Eigen::Matrix<double, 2, 3>>& prior,
                           double guided_radius_px, RansacResult* fit, MapFix* out) {
  MatchOptions match;
  // Another season, another sensor: descriptors differ more than between two frames of a
  // flight, so the absolute threshold is looser; the ratio test and the prior keep it selective.
  match.max_ratio = prior ? 0.85f : 0.75f;
  match.match_threshold_percent = 10.0f;
  match.guided_radius_px = static_cast<float>(guided_radius_px);
  matcher = Matcher(match);
  const MatchResult matched = matcher.Match(frame_features, map_features, {}, prior);
  const int n = static_cast<int>(matched.matches.size());
  out->matches = n;
  prev_px.resize(2, n);
  curr_px.resize(2, n);
  quality.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const aerovo::Match& m = matched.matches[static_cast<std::size_t>(i)];
    const Keypoint& p = frame_features.keypoints[static_cast<std::size_t>(m.prev_index)];
    const Keypoint& c = map_features.keypoints[static_cast<std::size_t>(m.curr_index)];
    prev_px.col(i) << p.x, p.y;
    curr_px.col(i) << c.x, c.y;
    quality[static_cast<std::size_t>(i)] = m.ssd;
  }
  if (n < MinSampleSize(MotionModel::kSimilarity)) return;
  RansacOptions ransac;
  ransac.max_num_trials = options.ransac_trials;
  ransac.max_distance_px = options.max_distance_px;
  ransac.seed = options.seed;
  *fit = EstimateTransform(MotionModel::kSimilarity, SamplerKind::kUniform, ransac, prev_px,
                           curr_px, quality.data(), workspace);
  out->inliers = fit->success ? fit->num_inliers : 0;
}

// The fit's covariance (parameters a, b, tx, ty of x' = a x - b y + tx, y' = b x + a y + ty
// over the inliers in warped pixels centred on the frame centre: sigma^2 (J'J)^-1, sigma^2
// the inliers' mean squared residual over 2 n - 4 degrees of freedom), propagated to the
// frame centre's ENU position and the heading.
void MapMatcher::Impl::Covariance(const RansacResult& fit, const Warp& warp, double m_per_px,
                                  MapFix* out) const {
  Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
  double sum_r2 = 0.0;
  int n = 0;
  for (int i = 0; i < prev_px.cols(); ++i) {
    if (fit.inlier_mask[static_cast<std::size_t>(i)] == 0) continue;
    const Eigen::Vector2d w = prev_px.col(i) - warp.warped_centre;
    Eigen::Matrix<double, 2, 4> j;
    j << w.x(), -w.y(), 1, 0, w.y(), w.x(), 0, 1;
    jtj += j.transpose() * j;
    sum_r2 += (TransformPoint(fit.curr_from_prev, prev_px.col(i)) - curr_px.col(i)).squaredNorm();
    ++n;
  }
  out->residual_m = n > 0 ? std::sqrt(sum_r2 / n) * m_per_px : 0.0;
  if (n < 3) return;
  const double sigma2 = sum_r2 / std::max(1, 2 * n - 4);
  const Eigen::Matrix4d cov = sigma2 * jtj.inverse();
  Eigen::Matrix2d flip = Eigen::Matrix2d::Identity();
  flip(1, 1) = -1.0;  // window y (south) -> north
  out->position_cov_m2 = flip * cov.bottomRightCorner<2, 2>() * flip * m_per_px * m_per_px;
  const double a = fit.curr_from_prev(0, 0), b = fit.curr_from_prev(1, 0);
  const Eigen::RowVector2d g(-b / (a * a + b * b), a / (a * a + b * b));
  out->heading_var_rad2 = g * cov.topLeftCorner<2, 2>() * g.transpose();
}

// Position, heading, scale, spread and the checks of a successful fit.
void MapMatcher::Impl::Judge(const RansacResult& fit, const Warp& warp, const MapMatchFrame& frame,
                             const WindowGeometry& window, const Eigen::Vector2d& prior_enu_m,
                             double gate_m, MapFix* out) const {
  const Eigen::Matrix2d a = fit.curr_from_prev.topLeftCorner<2, 2>();
  const Eigen::Vector2d q = TransformPoint(fit.curr_from_prev, warp.warped_centre);
  const double half = (window.width - 1) / 2.0, half_y = (window.height - 1) / 2.0;
  out->fitted = true;
  out->enu_m =
      Eigen::Vector2d((q.x() - half) * window.m_per_px, (half_y - q.y()) * window.m_per_px);
  const Eigen::Vector2d up = -(a * warp.warped_from_frame).col(1);  // image-up, window px
  out->heading_rad = std::atan2(-up.x(), -up.y());
  out->scale = std::sqrt(std::abs(a.determinant()));
  out->prior_distance_m = (out->enu_m - prior_enu_m).norm();
  // Spread of the inliers over the frame.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d second = Eigen::Matrix2d::Zero();
  int n = 0;
  for (int i = 0; i < prev_px.cols(); ++i) {
    if (fit.inlier_mask[static_cast<std::size_t>(i)] == 0) continue;
    const Eigen::Vector2d p = warp.FrameOf(prev_px.col(i));
    mean += p;
    second += p * p.transpose();
    ++n;
  }
  mean /= n;
  const Eigen::Matrix2d cov = second / n - mean * mean.transpose();
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()(0);
  out->spread =
      std::sqrt(std::max(0.0, smallest)) / std::min(frame.pixels.width, frame.pixels.height);
  Covariance(fit, warp, window.m_per_px, out);
  const bool heading_off =
      frame.heading_rad && std::abs(WrapPi(out->heading_rad - *frame.heading_rad)) >
                               options.max_heading_error_deg * kPi / 180.0;
  const double gate = gate_m;
  if (out->spread < options.min_spread) {
    out->status = MapFixStatus::kSpread;
  } else if (std::abs(std::log(out->scale)) > std::log1p(options.max_scale_error)) {
    out->status = MapFixStatus::kScale;
  } else if (out->prior_distance_m > gate || heading_off) {
    out->status = MapFixStatus::kGate;
  } else {
    out->status = MapFixStatus::kFix;
  }
}

MapMatcher::MapMatcher(const MapMatchOptions& options) {
  Validate(options);
  impl_ = std::make_unique<Impl>(options);
}
MapMatcher::~MapMatcher() = default;
MapMatcher::MapMatcher(MapMatcher&&) noexcept = default;
MapMatcher& MapMatcher::operator=(MapMatcher&&) noexcept = default;

const MapMatchOptions& MapMatcher::options() const { return impl_->options; }

MapFix MapMatcher::Match(const MapMatchFrame& frame, const MapMatchWindow& window,
                         const Eigen::Vector2d& prior_enu_m) {
  const MapMatchOptions& o = impl_->options;
  return impl_->Run(frame, window, prior_enu_m, o.gate_m > 0.0 ? o.gate_m : o.search_radius_m,
                    false);
}

MapFix MapMatcher::Search(const MapMatchFrame& frame, const MapMatchWindow& window,
                          const Eigen::Vector2d& prior_enu_m, double gate_m) {
  if (!(gate_m > 0.0)) throw InvalidArgument("map search: the gate must be > 0");
  return impl_->Run(frame, window, prior_enu_m, gate_m, true);
}

// The best fit at another place than `fit`'s: RANSAC over the matches whose map point lies
// outside the fitted frame's footprint (a disc of its half-diagonal around its centre), counted
// only when its scale is plausible (max_scale_error); its inliers, 0 when none.
int MapMatcher::Impl::SecondInliers(const RansacResult& fit, const Warp& warp, int warped_w,
                                    int warped_h) {
  const Eigen::Vector2d centre = TransformPoint(fit.curr_from_prev, warp.warped_centre);
  const double radius = 0.5 * std::hypot(warped_w, warped_h) *
                        std::sqrt(std::abs(fit.curr_from_prev.topLeftCorner<2, 2>().determinant()));
  int n = 0;
  for (int i = 0; i < curr_px.cols(); ++i) {
    if ((curr_px.col(i) - centre).norm() <= radius) continue;
    prev_px.col(n) = prev_px.col(i);
    curr_px.col(n) = curr_px.col(i);
    quality[static_cast<std::size_t>(n)] = quality[static_cast<std::size_t>(i)];
    ++n;
  }
  if (n < MinSampleSize(MotionModel::kSimilarity)) return 0;
  RansacOptions ransac;
  ransac.max_num_trials = options.ransac_trials;
  ransac.max_distance_px = options.max_distance_px;
  ransac.seed = options.seed + 1;
  const Eigen::Matrix2Xd prev = prev_px.leftCols(n), curr = curr_px.leftCols(n);
  const RansacResult second = EstimateTransform(MotionModel::kSimilarity, SamplerKind::kUniform,
                                                ransac, prev, curr, quality.data(), workspace);
  if (!second.success) return 0;
  const double scale =
      std::sqrt(std::abs(second.curr_from_prev.topLeftCorner<2, 2>().determinant()));
  if (std::abs(std::log(scale)) > std::log1p(options.max_scale_error)) return 0;
  return second.num_inliers;
}

MapFix MapMatcher::Impl::Run(const MapMatchFrame& frame, const MapMatchWindow& window,
                             const Eigen::Vector2d& prior_enu_m, double gate_m, bool search) {
  CheckInputs(frame, window);
  const Stopwatch watch;
  Impl& m = *this;
  const MapMatchOptions& o = m.options;
  MapFix out;
  out.m_per_px = window.m_per_px;
  out.frame_width_m = FrameWidthM(frame);
  // The map window: its data and texture.
  m.map = GrayImage(window.pixels.width, window.pixels.height);
  m.map_valid = GrayImage(window.pixels.width, window.pixels.height);
  for (int y = 0; y < window.pixels.height; ++y) {
    std::copy_n(window.pixels.row(y), window.pixels.width, m.map.row(y));
    std::copy_n(window.valid.row(y), window.pixels.width, m.map_valid.row(y));
  }
  const std::size_t map_valid = CountValid(m.map_valid);
  const double valid_fraction =
      static_cast<double>(map_valid) / (static_cast<double>(m.map.width()) * m.map.height());
  const auto done = [&](MapFixStatus status) {
    out.status = status;
    out.ms = watch.elapsed_ms();
    return out;
  };
  // A search's wide window may reach far beyond a small map: only an empty one is no map.
  if (search ? map_valid == 0 : valid_fraction < o.min_valid_fraction) {
    return done(MapFixStatus::kNoMap);
  }
  if (out.frame_width_m < o.min_frame_width_px * window.m_per_px) {
    return done(MapFixStatus::kMapTooCoarse);
  }
  if (RobustRange(window.pixels, window.valid) < o.min_contrast) {
    return done(MapFixStatus::kNoMapTexture);
  }
  FillInvalid(m.map, m.map_valid);
  if (const auto status = m.PrepareFrame(frame, window.m_per_px)) return done(*status);
  const double map_target = static_cast<double>(o.frame_points) * map_valid / m.frame_valid;
  const FeatureSet map_features =
      DetectOn(m.map, m.map_valid, static_cast<int>(std::min<double>(map_target, o.max_map_points)),
               frame.heading_rad.has_value());
  m.FitAndJudge(frame, map_features,
                WindowGeometry{window.pixels.width, window.pixels.height, window.m_per_px},
                prior_enu_m, gate_m, search, &out);
  out.ms = watch.elapsed_ms();
  return out;
}

// The frame at the window's resolution, north-up when the heading is known, and its SURF points
// (warp, warped_w/h, frame_features, frame_valid); a status when it has no texture.
std::optional<MapFixStatus> MapMatcher::Impl::PrepareFrame(const MapMatchFrame& frame,
                                                           double m_per_px) {
  warp = MakeWarp(frame, m_per_px, &warped_w, &warped_h);
  WarpFrame(frame.pixels, warp, warped_w, warped_h, warped, warped_valid);
  if (RobustRange(warped.view(), warped_valid.view()) < options.min_contrast) {
    return MapFixStatus::kNoFrameTexture;
  }
  FillInvalid(warped, warped_valid);
  frame_features =
      DetectOn(warped, warped_valid, options.frame_points, frame.heading_rad.has_value());
  frame_valid = std::max<std::size_t>(1, CountValid(warped_valid));
  return std::nullopt;
}

// The fit of the prepared frame's points to `map_features` (window pixels) and its checks.
void MapMatcher::Impl::FitAndJudge(const MapMatchFrame& frame, const FeatureSet& map_features,
                                   const WindowGeometry& window,
                                   const Eigen::Vector2d& prior_enu_m, double gate_m, bool search,
                                   MapFix* out) {
  const MapMatchOptions& o = options;
  out->frame_points = static_cast<int>(frame_features.size());
  out->map_points = static_cast<int>(map_features.size());
  if (out->map_points < o.min_inliers) {
    out->status = MapFixStatus::kNoMapTexture;
    return;
  }
  if (out->frame_points < o.min_inliers) {
    out->status = MapFixStatus::kNoFrameTexture;
    return;
  }
  // Guided around the prior when the heading is known (not in a search: the prior is weak):
  // the warped frame is then the window's geometry shifted to the prior.
  std::optional<Eigen::Matrix<double, 2, 3>> prior;
  const Eigen::Vector2d prior_px((window.width - 1) / 2.0 + prior_enu_m.x() / window.m_per_px,
                                 (window.height - 1) / 2.0 - prior_enu_m.y() / window.m_per_px);
  if (frame.heading_rad.has_value() && !search) {
    prior = Eigen::Matrix<double, 2, 3>::Zero();
    prior->leftCols<2>().setIdentity();
    prior->col(2) = prior_px - warp.warped_centre;
  }
  RansacResult fit;
  Fit(frame_features, map_features, prior, o.search_radius_m / window.m_per_px + 8.0, &fit, out);
  if (!fit.success || fit.num_inliers < o.min_inliers) {
    out->status = MapFixStatus::kTooFewInliers;
    return;
  }
  Judge(fit, warp, frame, window, prior_enu_m, gate_m, out);
  if (search) {
    out->second_inliers = SecondInliers(fit, warp, warped_w, warped_h);
    if (out->status == MapFixStatus::kFix && (out->inliers < o.min_margin * out->second_inliers ||
                                              out->inliers - out->second_inliers < o.min_inliers)) {
      out->status = MapFixStatus::kAmbiguous;
    }
  }
}

MapFix MapMatcher::MatchFeatures(const MapMatchFrame& frame, const MapWindowFeatures& map,
                                 const Eigen::Vector2d& prior_enu_m) {
  if (map.size_px < 2 || !(map.m_per_px > 0.0) || !std::isfinite(map.m_per_px)) {
    throw InvalidArgument("map fix: the map window's size must be >= 2 px and its m_per_px "
                          "finite and > 0");
  }
  GrayImage dummy(1, 1);
  CheckInputs(frame, MapMatchWindow{dummy.view(), dummy.view(), map.m_per_px});
  const Stopwatch watch;
  Impl& m = *impl_;
  const MapMatchOptions& o = m.options;
  MapFix out;
  out.m_per_px = map.m_per_px;
  out.frame_width_m = FrameWidthM(frame);
  const double area = static_cast<double>(map.size_px) * map.size_px;
  if (static_cast<double>(map.valid_px) / area < o.min_valid_fraction) {
    out.status = MapFixStatus::kNoMap;
  } else if (out.frame_width_m < o.min_frame_width_px * map.m_per_px) {
    out.status = MapFixStatus::kMapTooCoarse;
  } else if (map.contrast < o.min_contrast) {
    out.status = MapFixStatus::kNoMapTexture;
  } else if (const auto status = m.PrepareFrame(frame, map.m_per_px)) {
    out.status = *status;
  } else {
    m.FitAndJudge(frame, map.features, WindowGeometry{map.size_px, map.size_px, map.m_per_px},
                  prior_enu_m, o.gate_m > 0.0 ? o.gate_m : o.search_radius_m, false, &out);
  }
  out.ms = watch.elapsed_ms();
  return out;
}

}  // namespace aerovo
