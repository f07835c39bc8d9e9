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

// a - b into out (n floats).
void Difference(const float* a, const float* b, std::size_t n, float* out) {
  for (std::size_t i = 0; i < n; ++i) out[i] = a[i] - b[i];
}

}  // namespace

GroundMotion::GroundMotion(int grid_width, int grid_height) {
  if (grid_width <= 0 || grid_height <= 0) {
    throw InvalidArgument("GroundMotion: grid size " + std::to_string(grid_width) + "x" +
                          std::to_string(grid_height));
  }
  grid_width_ = grid_width;
  grid_height_ = grid_height;
  factor_ = (std::max(grid_width, grid_height) + kGroundMotionPixels - 1) / kGroundMotionPixels;
  width_ = std::max(1, grid_width / factor_);
  height_ = std::max(1, grid_height / factor_);
  binned_.assign(size(), 0.0f);
  const std::size_t table = static_cast<std::size_t>(width_ + 1) * (height_ + 1);
  for (std::vector<double>* t : {&sum_a_, &sq_a_, &sum_b_, &sq_b_}) t->assign(table, 0.0);
}

void GroundMotion::Coarse(const float* grid, float* out) {
  const int n = factor_, w = width_, h = height_;
  std::fill(binned_.begin(), binned_.end(), 0.0f);
  // A grid thinner than the factor in one direction (w or h clamped to 1) bins what it has.
  const int rows = std::min(h, grid_height_ / n) * n, cols = std::min(w, grid_width_ / n);
  for (int y = 0; y < rows; ++y) {
    const float* row = grid + static_cast<std::size_t>(y) * grid_width_;
    float* b = binned_.data() + static_cast<std::size_t>(y / n) * w;
    for (int cx = 0; cx < cols; ++cx, row += n) {
      float sum = 0.0f;
      for (int dx = 0; dx < n; ++dx) sum += row[dx];
      b[cx] += sum;
    }
  }
  // Band-pass: less the mean of the 5 x 5 window (clipped at the border).
  constexpr int kRadius = 2;
  for (int y = 0; y < h; ++y) {
    const int y0 = std::max(0, y - kRadius), y1 = std::min(h - 1, y + kRadius);
    for (int x = 0; x < w; ++x) {
      const int x0 = std::max(0, x - kRadius), x1 = std::min(w - 1, x + kRadius);
      float sum = 0.0f;
      for (int yy = y0; yy <= y1; ++yy) {
        const float* b = binned_.data() + static_cast<std::size_t>(yy) * w;
        for (int xx = x0; xx <= x1; ++xx) sum += b[xx];
      }
      const float mean = sum / static_cast<float>((y1 - y0 + 1) * (x1 - x0 + 1));
      out[static_cast<std::size_t>(y) * w + x] =
          (binned_[static_cast<std::size_t>(y) * w + x] - mean) / static_cast<float>(n * n);
    }
  }
}

void GroundMotion::Tables(const float* image, std::vector<double>* sum,
                          std::vector<double>* sum_sq) {
  const int w = width_;
  for (int y = 0; y < height_; ++y) {
    double row = 0.0, row_sq = 0.0;
    for (int x = 0; x < w; ++x) {
      const double v = image[static_cast<std::size_t>(y) * w + x];
      row += v;
      row_sq += v * v;
      const std::size_t i = static_cast<std::size_t>(y + 1) * (w + 1) + x + 1;
      (*sum)[i] = (*sum)[i - (w + 1)] + row;
      (*sum_sq)[i] = (*sum_sq)[i - (w + 1)] + row_sq;
    }
  }
}

GroundPeak GroundMotion::Best(const float* a, const float* b) {
  const int w = width_, h = height_;
  Tables(a, &sum_a_, &sq_a_);
  Tables(b, &sum_b_, &sq_b_);
  // The sum of an integral table over [x0, x1) x [y0, y1).
  const auto box = [w](const std::vector<double>& t, int x0, int y0, int x1, int y1) {
    const auto at = [&](int x, int y) { return t[static_cast<std::size_t>(y) * (w + 1) + x]; };
    return at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
  };
  GroundPeak best;
  best.ncc = -2.0;
  for (int dy = -h / 2; dy <= h / 2; ++dy) {
    for (int dx = -w / 2; dx <= w / 2; ++dx) {
      // b(x, y) against a(x + dx, y + dy), x in [bx0, bx1), y in [by0, by1).
      const int bx0 = std::max(0, -dx), bx1 = std::min(w, w - dx);
      const int by0 = std::max(0, -dy), by1 = std::min(h, h - dy);
      const int cols = bx1 - bx0;
      double ab = 0.0;
      for (int y = by0; y < by1; ++y) {
        const float* pa = a + static_cast<std::size_t>(y + dy) * w + bx0 + dx;
        const float* pb = b + static_cast<std::size_t>(y) * w + bx0;
        float row = 0.0f;
        for (int x = 0; x < cols; ++x) row += pa[x] * pb[x];
        ab += row;
      }
      const double n = static_cast<double>(cols) * (by1 - by0);
      const double sa = box(sum_a_, bx0 + dx, by0 + dy, bx1 + dx, by1 + dy);
      const double sb = box(sum_b_, bx0, by0, bx1, by1);
      const double va = box(sq_a_, bx0 + dx, by0 + dy, bx1 + dx, by1 + dy) - sa * sa / n;
      const double vb = box(sq_b_, bx0, by0, bx1, by1) - sb * sb / n;
      if (va <= 0.0 || vb <= 0.0) continue;
      const double ncc = (ab - sa * sb / n) / std::sqrt(va * vb);
      if (ncc > best.ncc) best = {ncc, dx, dy, n / (static_cast<double>(w) * h)};
    }
  }
  if (best.ncc < -1.0) best = GroundPeak{};
  return best;
}

double GroundMotion::StillCorrelation(const float* a, const float* b) {
  Tables(a, &sum_a_, &sq_a_);  // the whole image's sums are the tables' last entries
  Tables(b, &sum_b_, &sq_b_);
  const std::size_t last = sum_a_.size() - 1;
  const double n = static_cast<double>(size());
  double ab = 0.0;
  for (std::size_t i = 0; i < size(); ++i) ab += static_cast<double>(a[i]) * b[i];
  const double va = sq_a_[last] - sum_a_[last] * sum_a_[last] / n;
  const double vb = sq_b_[last] - sum_b_[last] * sum_b_[last] / n;
  if (va <= 0.0 || vb <= 0.0) return 0.0;
  return (ab - sum_a_[last] * sum_b_[last] / n) / std::sqrt(va * vb);
}

bool FlatFieldApplies(const FlatFieldEstimate& estimate, const FlatFieldOptions& options) {
  if (estimate.empty() || options.mode == FlatFieldMode::kOff) return false;
  return options.mode == FlatFieldMode::kOn ||
         (estimate.significance >= options.min_significance && estimate.ground_seen &&
          estimate.ground_overlap <= options.max_ground_overlap);
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

namespace {

// The motion test of a photo median (FlatFieldEstimate::ground_seen, ground_overlap): the k
// samples in flight order (sample-major in `values`, centred grids of e's grid), the medians of
// the first and the last `third` of them (`first`, `second`) and of all (e.pattern_dn). The
// frames of one part are taken less the other part's median (their ground stays, a sensor's
// pattern goes; a ground both parts share at the same place goes too, and then shows nowhere),
// paired in order (the j-th of each part). The ground is seen moving when a pair, or two
// successive samples less the median of all, correlate at a non-zero shift.
void TestMotion(const float* values, std::size_t k, std::size_t third,
                const std::vector<float>& first, const std::vector<float>& second,
                FlatFieldEstimate& e) {
  GroundMotion m(e.grid_width, e.grid_height);
  const std::size_t size = e.pattern_dn.size(), c = m.size();
  std::vector<float> p_first(c), p_second(c), p_all(c), a(c), b(c), ra(c), rb(c);
  m.Coarse(first.data(), p_first.data());
  m.Coarse(second.data(), p_second.data());
  m.Coarse(e.pattern_dn.data(), p_all.data());
  double overlap = 0.0;
  bool seen = false;
  for (std::size_t j = 0; j < third; ++j) {
    m.Coarse(values + j * size, a.data());
    m.Coarse(values + (k - third + j) * size, b.data());
    Difference(a.data(), p_second.data(), c, ra.data());
    Difference(b.data(), p_first.data(), c, rb.data());
    const GroundPeak peak = m.Best(ra.data(), rb.data());
    if (peak.clear()) {
      overlap = std::max(overlap, peak.overlap);
    } else if (m.Still(a.data(), b.data())) {
      overlap = 1.0;  // no peak as their common ground cancelled: it did not move
    }
    seen = seen || peak.moved();
  }
  e.ground_overlap = third > 0 ? overlap : 1.0;
  m.Coarse(values, a.data());
  Difference(a.data(), p_all.data(), c, ra.data());
  for (std::size_t i = 1; i < k && !seen; ++i) {
    m.Coarse(values + i * size, b.data());
    Difference(b.data(), p_all.data(), c, rb.data());
    seen = m.Best(ra.data(), rb.data()).moved();
    std::swap(ra, rb);
  }
  e.ground_seen = seen;
}

}  // namespace

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
  TestMotion(values_.data(), k, third, first, second, e);
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
  motion_ = GroundMotion(estimate_.grid_width, estimate_.grid_height);
  for (std::vector<float>* v : {&now_, &previous_, &pattern_, &ra_, &rb_}) {
    v->assign(motion_.size(), 0.0f);
  }
  snapshots_.assign(kSnapshots * motion_.size(), 0.0f);
}

void RunningFlatField::TestMotion(bool block_start) {
  FlatFieldEstimate& e = estimate_;
  const std::size_t c = motion_.size();
  motion_.Coarse(binned_.data(), now_.data());
  motion_.Coarse(e.pattern_dn.data(), pattern_.data());
  Difference(now_.data(), pattern_.data(), c, ra_.data());
  if (e.samples > 1 && !e.ground_seen) {
    Difference(previous_.data(), pattern_.data(), c, rb_.data());
    e.ground_seen = motion_.Best(rb_.data(), ra_.data()).moved();
  }
  const int kept = static_cast<int>(std::min<long>(snapshots_taken_, kSnapshots));
  if (kept > 0) {  // the oldest kept
    const long oldest = (snapshots_taken_ - kept) % kSnapshots;
    const float* old = snapshots_.data() + oldest * c;
    Difference(old, pattern_.data(), c, rb_.data());
    const GroundPeak peak = motion_.Best(rb_.data(), ra_.data());
    e.ground_overlap = peak.clear() ? peak.overlap : (motion_.Still(now_.data(), old) ? 1.0 : 0.0);
  }
  if (block_start) {
    const long slot = snapshots_taken_++ % kSnapshots;
    std::copy(now_.begin(), now_.end(), snapshots_.begin() + slot * c);
  }
  std::swap(previous_, now_);
}

void RunningFlatField::Add(const GrayImageView& frame) {
  FlatFieldEstimate& e = estimate_;
  CheckSize(frame, e.width_px, e.height_px, "RunningFlatField::Add");
  BinCentred(frame, e.factor, e.grid_width, e.grid_height, binned_.data());
  const int which = (e.samples / block_) % 2;  // alternate blocks of samples
  const bool block_start = e.samples % block_ == 0;
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
  TestMotion(block_start);
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
