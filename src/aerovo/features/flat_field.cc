#include "aerovo/features/flat_field.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {

const char* ToString(FlatFieldMode mode) {
  switch (mode) {
    case FlatFieldMode::kAuto:
      return "auto";
    case FlatFieldMode::kOn:
      return "on";
    case FlatFieldMode::kOff:
      return "off";
  }
  return "?";
}

void Validate(const FlatFieldOptions& o) { options::CheckRanges(o, "flat_field"); }

int FlatFieldGridFactor(int width_px, int height_px) {
  if (width_px <= 0 || height_px <= 0) {
    throw InvalidArgument("FlatFieldGridFactor: frame size " + std::to_string(width_px) + "x" +
                          std::to_string(height_px));
  }
  int n = 1;
  while (static_cast<double>(width_px / n) * (height_px / n) > kFlatFieldGridMegapixels * 1e6) ++n;
  return n;
}

namespace {

// The median of v[0..n) (n >= 1; reorders v): the middle value, or the mean of the two middle
// values for an even n.
float Median(float* v, std::size_t n) {
  float* mid = v + n / 2;
  std::nth_element(v, mid, v + n);
  float m = *mid;
  if (n % 2 == 0) m = 0.5f * (m + *std::max_element(v, mid));
  return m;
}

FlatFieldEstimate EmptyEstimate(int width_px, int height_px) {
  FlatFieldEstimate e;
  e.factor = FlatFieldGridFactor(width_px, height_px);
  e.width_px = width_px;
  e.height_px = height_px;
  e.grid_width = width_px / e.factor;
  e.grid_height = height_px / e.factor;
  e.pattern_dn.assign(static_cast<std::size_t>(e.grid_width) * e.grid_height, 0.0f);
  return e;
}

void CheckSize(const GrayImageView& frame, int width_px, int height_px, const char* who) {
  if (frame.empty() || frame.width != width_px || frame.height != height_px) {
    throw InvalidArgument(std::string(who) + ": a " + std::to_string(frame.width) + "x" +
                          std::to_string(frame.height) + " frame, but the estimate is of " +
                          std::to_string(width_px) + "x" + std::to_string(height_px));
  }
}

// `frame` binned by `n` (n x n block means) into `grid` (gw x gh), less the mean of the grid;
// returns that mean, DN.
double BinCentred(const GrayImageView& frame, int n, int gw, int gh, float* grid) {
  const float inv = 1.0f / static_cast<float>(n * n);
  double sum = 0.0;
  for (int gy = 0; n == 1 && gy < gh; ++gy) {  // the frame's own pixels
    const std::uint8_t* row = frame.row(gy);
    float* out = grid + static_cast<std::size_t>(gy) * gw;
    std::uint32_t row_sum = 0;
    for (int gx = 0; gx < gw; ++gx) {
      out[gx] = row[gx];
      row_sum += row[gx];
    }
    sum += row_sum;
  }
  for (int gy = 0; n > 1 && gy < gh; ++gy) {
    float* out = grid + static_cast<std::size_t>(gy) * gw;
    std::fill(out, out + gw, 0.0f);
    for (int dy = 0; dy < n; ++dy) {
      const std::uint8_t* row = frame.row(gy * n + dy);
      for (int gx = 0; gx < gw; ++gx) {
        int s = 0;
        for (int dx = 0; dx < n; ++dx) s += row[gx * n + dx];
        out[gx] += static_cast<float>(s);
      }
    }
    double row_sum = 0.0;
    for (int gx = 0; gx < gw; ++gx) row_sum += (out[gx] *= inv);
    sum += row_sum;
  }
  const double mean = sum / (static_cast<double>(gw) * gh);
  const float m = static_cast<float>(mean);
  for (std::size_t i = 0, size = static_cast<std::size_t>(gw) * gh; i < size; ++i) grid[i] -= m;
  return mean;
}

// pattern_std_dn from two estimates `a` and `b` of disjoint samples (FlatFieldEstimate), the
// varying part from the frames' spatial variance `frame_var` (mean over the samples) less the
// pattern's, and the significance.
void Judge(FlatFieldEstimate& e, const float* a, const float* b, std::size_t n, double frame_var) {
  double sa = 0.0, sb = 0.0, sab = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sa += a[i];
    sb += b[i];
    sab += static_cast<double>(a[i]) * b[i];
  }
  const double nn = static_cast<double>(n);
  const double cov = std::max(0.0, sab / nn - (sa / nn) * (sb / nn));
  e.pattern_std_dn = std::sqrt(cov);
  e.varying_std_dn = std::sqrt(std::max(0.0, frame_var - cov));
  e.significance = e.varying_std_dn > 0.0 ? e.pattern_std_dn / e.varying_std_dn : 0.0;
}

}  // namespace

bool FlatFieldApplies(const FlatFieldEstimate& estimate, const FlatFieldOptions& options) {
  if (estimate.empty() || options.mode == FlatFieldMode::kOff) return false;
  return options.mode == FlatFieldMode::kOn || estimate.significance >= options.min_significance;
}

MedianFlatField::MedianFlatField(int width_px, int height_px, int capacity) {
  if (capacity < 3) {
    throw InvalidArgument("MedianFlatField: capacity " + std::to_string(capacity) + " < 3");
  }
  shape_ = EmptyEstimate(width_px, height_px);
  capacity_ = capacity;
  values_.resize(static_cast<std::size_t>(capacity) * shape_.pattern_dn.size());
}

void MedianFlatField::Add(const GrayImageView& frame) {
  CheckSize(frame, shape_.width_px, shape_.height_px, "MedianFlatField::Add");
  if (samples_ == capacity_) {
    throw InvalidArgument("MedianFlatField::Add: more than " + std::to_string(capacity_) +
                          " frames");
  }
  BinCentred(frame, shape_.factor, shape_.grid_width, shape_.grid_height,
             values_.data() + static_cast<std::size_t>(samples_) * shape_.pattern_dn.size());
  ++samples_;
}

FlatFieldEstimate MedianFlatField::Estimate() const {
  if (samples_ < 3) {
    throw InvalidArgument("MedianFlatField: " + std::to_string(samples_) +
                          " frames, at least 3 needed");
  }
  FlatFieldEstimate e = shape_;
  const std::size_t k = static_cast<std::size_t>(samples_), size = e.pattern_dn.size();
  std::vector<float> values(k), first(size), second(size);
  // The first and the last third of the samples (in flight order): the farthest apart on the
  // ground, so that what they share of it is least.
  const std::size_t third = k / 3;
  double frame_sq = 0.0;  // the samples are centred: their spatial variance
  for (std::size_t p = 0; p < size; ++p) {
    for (std::size_t i = 0; i < k; ++i) values[i] = values_[i * size + p];
    first[p] = Median(values.data(), third);
    second[p] = Median(values.data() + (k - third), third);
    for (std::size_t i = 0; i < k; ++i) values[i] = values_[i * size + p];
    const float median = Median(values.data(), k);
    e.pattern_dn[p] = median;
    for (std::size_t i = 0; i < k; ++i) {
      frame_sq += static_cast<double>(values[i]) * values[i];
    }
  }
  e.samples = samples_;
  Judge(e, first.data(), second.data(), size, frame_sq / (static_cast<double>(size) * k));
  return e;
}

FlatFieldEstimate EstimateFlatField(const std::vector<GrayImageView>& frames) {
  if (frames.size() < 3) {
    throw InvalidArgument("EstimateFlatField: " + std::to_string(frames.size()) +
                          " frames, at least 3 needed");
  }
  MedianFlatField median(frames.front().width, frames.front().height,
                         static_cast<int>(frames.size()));
  for (const GrayImageView& f : frames) median.Add(f);
  return median.Estimate();
}

RunningFlatField::RunningFlatField(int width_px, int height_px, int window_samples) {
  if (window_samples < 2) {
    throw InvalidArgument("RunningFlatField: window " + std::to_string(window_samples) + " < 2");
  }
  estimate_ = EmptyEstimate(width_px, height_px);
  window_ = window_samples;
  block_ = std::max(1, window_samples / 8);
  for (std::vector<float>& m : mean_) m.assign(estimate_.pattern_dn.size(), 0.0f);
  variance_.assign(estimate_.pattern_dn.size(), 0.0f);
  binned_.assign(estimate_.pattern_dn.size(), 0.0f);
}

void RunningFlatField::Add(const GrayImageView& frame) {
  FlatFieldEstimate& e = estimate_;
  CheckSize(frame, e.width_px, e.height_px, "RunningFlatField::Add");
  BinCentred(frame, e.factor, e.grid_width, e.grid_height, binned_.data());
  const int which = (e.samples / block_) % 2;  // alternate blocks of samples
  ++e.samples;
  const int count = ++count_[which];
  const float a = 1.0f / static_cast<float>(std::min(count, std::max(1, window_ / 2)));
  // Exponentially weighted mean and variance (West 1979, "Updating mean and variance estimates:
  // an improved method", Comm. ACM 22(9)): m += a d, v = (1 - a) (v + a d^2), d = x - m.
  float* m = mean_[which].data();
  const float* other = mean_[1 - which].data();
  const bool both = count_[1 - which] > 0;
  double variance_sum = 0.0, pattern_sq = 0.0;
  for (std::size_t i = 0, n = binned_.size(); i < n; ++i) {
    const float d = binned_[i] - m[i];
    m[i] += a * d;
    variance_[i] = (1.0f - a) * (variance_[i] + a * d * d);
    variance_sum += variance_[i];
    e.pattern_dn[i] = both ? 0.5f * (m[i] + other[i]) : m[i];
    pattern_sq += static_cast<double>(e.pattern_dn[i]) * e.pattern_dn[i];
  }
  // The frames' spatial variance: the running mean's (zero-mean: the frames are centred) plus
  // the mean temporal variance about it (the law of total variance).
  const double n = static_cast<double>(binned_.size());
  const double frame_var = (pattern_sq + variance_sum) / n;
  e.varying_std_dn = std::sqrt(frame_var);
  if (both) {
    Judge(e, mean_[0].data(), mean_[1].data(), binned_.size(), frame_var);
  } else {
    e.pattern_std_dn = 0.0;
    e.significance = 0.0;
  }
}

void FlatFieldCorrector::Set(const FlatFieldEstimate& e, const FlatFieldOptions& options) {
  if (e.empty()) throw InvalidArgument("FlatFieldCorrector::Set: an empty estimate");
  width_ = e.width_px;
  height_ = e.height_px;
  pattern_.resize(static_cast<std::size_t>(width_) * height_);
  const int n = e.factor, gw = e.grid_width, gh = e.grid_height;
  if (n == 1) std::copy(e.pattern_dn.begin(), e.pattern_dn.end(), pattern_.begin());
  // Grid pixel (gx, gy) is the mean of frame pixels n gx .. n gx + n - 1: its centre is at frame
  // x = n gx + (n - 1) / 2. Bilinear between grid centres, clamped at the border.
  const int interpolated_rows = n == 1 ? 0 : height_;
  for (int y = 0; y < interpolated_rows; ++y) {
    const double gy = std::clamp((y - 0.5 * (n - 1)) / n, 0.0, gh - 1.0);
    const int y0 = std::min(static_cast<int>(gy), gh - 1), y1 = std::min(y0 + 1, gh - 1);
    const float fy = static_cast<float>(gy - y0);
    const float* r0 = e.pattern_dn.data() + static_cast<std::size_t>(y0) * gw;
    const float* r1 = e.pattern_dn.data() + static_cast<std::size_t>(y1) * gw;
    float* out = pattern_.data() + static_cast<std::size_t>(y) * width_;
    for (int x = 0; x < width_; ++x) {
      const double gx = std::clamp((x - 0.5 * (n - 1)) / n, 0.0, gw - 1.0);
      const int x0 = std::min(static_cast<int>(gx), gw - 1), x1 = std::min(x0 + 1, gw - 1);
      const float fx = static_cast<float>(gx - x0);
      const float top = r0[x0] + fx * (r0[x1] - r0[x0]);
      const float bottom = r1[x0] + fx * (r1[x1] - r1[x0]);
      out[x] = top + fy * (bottom - top);
    }
  }
  gain_ = e.varying_std_dn > 0.0
              ? std::clamp(options.target_std_dn / e.varying_std_dn, 1.0, options.max_gain)
              : 1.0;
  ready_ = true;
}

GrayImageView FlatFieldCorrector::Apply(const GrayImageView& frame) {
  if (!ready_) throw InvalidArgument("FlatFieldCorrector::Apply before Set");
  CheckSize(frame, width_, height_, "FlatFieldCorrector::Apply");
  if (out_.width() != width_ || out_.height() != height_) out_ = GrayImage(width_, height_);
  double sum = 0.0;
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* in = frame.row(y);
    const float* p = pattern_.data() + static_cast<std::size_t>(y) * width_;
    float row_sum = 0.0f;
    for (int x = 0; x < width_; ++x) row_sum += static_cast<float>(in[x]) - p[x];
    sum += row_sum;
  }
  const float g = static_cast<float>(gain_);
  // out = 128 + g (in - p - mean) + 0.5 rounding, as one offset.
  const float offset =
      128.5f - g * static_cast<float>(sum / (static_cast<double>(width_) * height_));
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* in = frame.row(y);
    const float* p = pattern_.data() + static_cast<std::size_t>(y) * width_;
    std::uint8_t* out = out_.row(y);
    for (int x = 0; x < width_; ++x) {
      const float v = offset + g * (static_cast<float>(in[x]) - p[x]);
      out[x] = static_cast<std::uint8_t>(std::clamp(v, 0.0f, 255.0f));
    }
  }
  return out_.view();
}

}  // namespace aerovo
