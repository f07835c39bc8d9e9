#include "aerovo/features/surf.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/features/hessian.h"
#include "aerovo/features/integral_image.h"

namespace aerovo {

using surf_detail::BoxFilterLayout;
using surf_detail::MakeBoxFilterLayout;

namespace {

constexpr int kBaseSize = 9;       // Smallest box filter (Bay et al. 2008, Sec. 4.1).
constexpr int kSizeIncrement = 6;  // Filter size increment per layer in octave 0.
constexpr float kTwoPi = 6.28318530717958647692f;

// Orientation (Bay et al. 2008, Sec. 4.1; OpenCV): Haar responses of side 4s at the points of a
// disc of radius 6s sampled every s, Gaussian weights sigma 2.5s, sliding 60-degree window.
constexpr int kOriRadius = 6;
constexpr float kOriSigma = 2.5f;
constexpr int kOriBins = 72;        // 5-degree bins, as OpenCV's search increment.
constexpr int kOriWindowBins = 12;  // 60 degrees.
// Descriptor: 20s window, 4x4 sub-regions of 5x5 samples, Haar side 2s, Gaussian sigma 3.3s.
constexpr int kPatch = 20;
constexpr float kDescSigma = 3.3f;

struct OrientationSample {
  int i, j;  // Offset in units of s.
  float weight;
};

struct Tables {
  std::vector<OrientationSample> ori;
  std::array<float, kPatch * kPatch> desc_weight;
  Tables() {
    for (int i = -kOriRadius; i <= kOriRadius; ++i) {
      for (int j = -kOriRadius; j <= kOriRadius; ++j) {
        if (i * i + j * j > kOriRadius * kOriRadius) continue;
        ori.push_back({i, j, std::exp(-(i * i + j * j) / (2.f * kOriSigma * kOriSigma))});
      }
    }
    for (int r = 0; r < kPatch; ++r) {
      for (int c = 0; c < kPatch; ++c) {
        const float v = r - (kPatch - 1) * 0.5f, u = c - (kPatch - 1) * 0.5f;
        desc_weight[r * kPatch + c] = std::exp(-(u * u + v * v) / (2.f * kDescSigma * kDescSigma));
      }
    }
  }
};

const Tables& GetTables() {
  static const Tables tables;
  return tables;
}

// atan2 in [0, 2*pi) with about 1e-5 rad error (minimax polynomial for atan on [-1, 1]); only
// used to bin orientation samples, where libm's atan2 dominated the orientation cost.
inline float FastAtan2(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  if (mx == 0.f) return 0.f;
  const float z = mn / mx, z2 = z * z;
  float a =
      z * (0.99997726f +
           z2 * (-0.33262347f +
                 z2 * (0.19354346f + z2 * (-0.11643287f + z2 * (0.05265332f - z2 * 0.01172120f)))));
  if (ay > ax) a = 1.57079632679f - a;
  if (x < 0.f) a = 3.14159265359f - a;
  if (y < 0.f) a = kTwoPi - a;
  return a;
}

int ResolveThreads(int requested) {
  return requested == 0 ? std::max(1, omp_get_num_procs()) : requested;
}

void CheckImage(const GrayImageView& image) {
  if (image.data == nullptr || image.width <= 0 || image.height <= 0) {
    throw InvalidArgument("Surf: the image is empty (" + std::to_string(image.width) + "x" +
                          std::to_string(image.height) + ", data " + (image.data ? "set" : "null") +
                          ")");
  }
  if (image.stride < image.width) {
    throw InvalidArgument("Surf: image stride " + std::to_string(image.stride) +
                          " is smaller than its width " + std::to_string(image.width));
  }
  if (image.width < kBaseSize || image.height < kBaseSize) {
    throw InvalidArgument("Surf: the image is " + std::to_string(image.width) + "x" +
                          std::to_string(image.height) +
                          ", smaller than the smallest SURF filter (9x9)");
  }
}

// Sum over the 3x3x3 neighbourhood check and quadratic fit of one candidate. Returns false when
// the fit is singular or moves by more than one sample in any direction.
bool Interpolate(const float* lo, const float* mid, const float* hi, std::ptrdiff_t stride,
                 float offset[3]) {
  const double v = mid[0];
  const double dx = (mid[1] - mid[-1]) * 0.5, dy = (mid[stride] - mid[-stride]) * 0.5;
  const double ds = (hi[0] - lo[0]) * 0.5;
  const double dxx = mid[1] - 2 * v + mid[-1];
  const double dyy = mid[stride] - 2 * v + mid[-stride];
  const double dss = hi[0] - 2 * v + lo[0];
  const double dxy =
      (mid[stride + 1] - mid[stride - 1] - mid[-stride + 1] + mid[-stride - 1]) * 0.25;
  const double dxs = (hi[1] - hi[-1] - lo[1] + lo[-1]) * 0.25;
  const double dys = (hi[stride] - hi[-stride] - lo[stride] + lo[-stride]) * 0.25;
  // Solve H * o = -g by Cramer's rule (3x3, symmetric).
  const double c00 = dyy * dss - dys * dys, c01 = dxs * dys - dxy * dss,
               c02 = dxy * dys - dxs * dyy;
  const double det = dxx * c00 + dxy * c01 + dxs * c02;
  if (!(std::fabs(det) > 1e-30)) return false;
  const double c11 = dxx * dss - dxs * dxs, c12 = dxy * dxs - dxx * dys;
  const double c22 = dxx * dyy - dxy * dxy;
  const double inv = -1.0 / det;
  const double ox = (c00 * dx + c01 * dy + c02 * ds) * inv;
  const double oy = (c01 * dx + c11 * dy + c12 * ds) * inv;
  const double os = (c02 * dx + c12 * dy + c22 * ds) * inv;
  if (!(std::fabs(ox) <= 1.0 && std::fabs(oy) <= 1.0 && std::fabs(os) <= 1.0)) return false;
  offset[0] = static_cast<float>(ox);
  offset[1] = static_cast<float>(oy);
  offset[2] = static_cast<float>(os);
  return true;
}

inline bool IsMaximum(float v, const float* p, std::ptrdiff_t stride) {
  return v > p[-stride - 1] && v > p[-stride] && v > p[-stride + 1] && v > p[-1] && v > p[0] &&
         v > p[1] && v > p[stride - 1] && v > p[stride] && v > p[stride + 1];
}

inline bool IsMaximumExceptCentre(float v, const float* p, std::ptrdiff_t stride) {
  return v > p[-stride - 1] && v > p[-stride] && v > p[-stride + 1] && v > p[-1] && v > p[1] &&
         v > p[stride - 1] && v > p[stride] && v > p[stride + 1];
}

// Keypoints sorted by decreasing response; ties broken by position and scale so that the order
// is a total order (deterministic whatever the thread count).
bool StrongerFirst(const Keypoint& a, const Keypoint& b) {
  if (a.response != b.response) return a.response > b.response;
  if (a.y != b.y) return a.y < b.y;
  if (a.x != b.x) return a.x < b.x;
  return a.scale < b.scale;
}

}  // namespace

void Validate(const SurfOptions& o) {
  if (!std::isfinite(o.hessian_threshold) || o.hessian_threshold < 0) {
    throw InvalidArgument("SurfOptions::hessian_threshold must be finite and >= 0, got " +
                          std::to_string(o.hessian_threshold));
  }
  if (o.num_octaves < 1 || o.num_octaves > 10) {
    throw InvalidArgument("SurfOptions::num_octaves must be in [1, 10], got " +
                          std::to_string(o.num_octaves));
  }
  if (o.num_scale_levels < 3 || o.num_scale_levels > 16) {
    throw InvalidArgument("SurfOptions::num_scale_levels must be in [3, 16], got " +
                          std::to_string(o.num_scale_levels));
  }
  if (o.roi && (o.roi->x < 0 || o.roi->y < 0 || o.roi->width <= 0 || o.roi->height <= 0)) {
    throw InvalidArgument(
        "SurfOptions::roi must have x, y >= 0 and positive width and height, got (" +
        std::to_string(o.roi->x) + ", " + std::to_string(o.roi->y) + ", " +
        std::to_string(o.roi->width) + "x" + std::to_string(o.roi->height) + ")");
  }
  if (o.max_keypoints < 0) {
    throw InvalidArgument("SurfOptions::max_keypoints must be >= 0 (0 keeps all), got " +
                          std::to_string(o.max_keypoints));
  }
  if (o.num_threads < 0) {
    throw InvalidArgument("SurfOptions::num_threads must be >= 0 (0 = all cores), got " +
                          std::to_string(o.num_threads));
  }
}

float OpenCvKeypointSize(const Keypoint& kp) { return kp.scale * 9.f / 1.2f; }

struct Surf::Impl {
  SurfOptions options;
  IntegralImage ii;
  std::vector<float> det;  // Layers of the current octave, one grid after the other.
  std::vector<std::vector<Keypoint>> found;  // Per row block, merged after each octave.

  void Prepare(const GrayImageView& image) {
    CheckImage(image);
    if (options.roi) {
      const RectI& r = *options.roi;
      if (r.x + r.width > image.width || r.y + r.height > image.height) {
        throw InvalidArgument("SurfOptions::roi (" + std::to_string(r.x) + ", " +
                              std::to_string(r.y) + ", " + std::to_string(r.width) + "x" +
                              std::to_string(r.height) + ") does not lie inside the " +
                              std::to_string(image.width) + "x" + std::to_string(image.height) +
                              " image");
      }
    }
    ii.Compute(image);
  }

  std::vector<Keypoint> FastHessian();
  void Orient(std::vector<Keypoint>& kps) const;
  void DescribeAll(const std::vector<Keypoint>& kps, float* out, int dsize) const;
  float Orientation(const Keypoint& kp) const;
  void DescribeOne(const Keypoint& kp, float* out) const;
};

std::vector<Keypoint> Surf::Impl::FastHessian() {
  const int W = ii.width(), H = ii.height();
  const int levels = options.num_scale_levels;
  const int threads = ResolveThreads(options.num_threads);
  const float threshold = static_cast<float>(options.hessian_threshold);
  std::vector<Keypoint> keypoints;

  for (int octave = 0; octave < options.num_octaves; ++octave) {
    const int p = 1 << octave;
    std::vector<BoxFilterLayout> layouts(levels);
    for (int l = 0; l < levels; ++l) {
      layouts[l] = MakeBoxFilterLayout((kBaseSize + kSizeIncrement * l) * p, p);
    }
    // Sample (i, j) of this octave is centred on pixel (p*j + (p-1)/2, p*i + (p-1)/2) in every
    // layer. Its filter lies inside the image for j in [border/p, (W - size + border)/p].
    const auto lo_x = [&](int l) { return layouts[l].border / p; };
    const auto hi_x = [&](int l, int extent) {
      return (extent - layouts[l].size + layouts[l].border) / p;
    };
    // Candidate range of each middle layer (inclusive): neighbours in the next (larger) layer
    // must be inside the image; ROI limits centres to within one sample of the rectangle.
    std::vector<std::array<int, 4>> cand(levels);  // j0, j1, i0, i1 inclusive
    bool any = false;
    for (int l = 1; l + 1 < levels; ++l) {
      int j0 = lo_x(l + 1) + 1, j1 = hi_x(l + 1, W) - 1;
      int i0 = lo_x(l + 1) + 1, i1 = hi_x(l + 1, H) - 1;
      if (layouts[l + 1].size > W || layouts[l + 1].size > H) j1 = j0 - 1;
      if (options.roi) {
        const RectI& r = *options.roi;
        // centre c = p*j + (p-1)/2 moves by at most p in refinement.
        j0 = std::max(j0, (r.x - p) / p - 1);
        j1 = std::min(j1, (r.x + r.width + p) / p + 1);
        i0 = std::max(i0, (r.y - p) / p - 1);
        i1 = std::min(i1, (r.y + r.height + p) / p + 1);
      }
      cand[l] = {j0, j1, i0, i1};
      if (j0 <= j1 && i0 <= i1) any = true;
    }
    if (!any) continue;

    const int grid_w = W / p + 2, grid_h = H / p + 2;
    const std::size_t plane = static_cast<std::size_t>(grid_w) * grid_h;
    if (det.size() < plane * levels) det.resize(plane * levels);

    // Each layer is needed around the candidates of the middle layers next to it.
    for (int l = 0; l < levels; ++l) {
      int j0 = W, j1 = -1, i0 = H, i1 = -1;
      for (int m = std::max(1, l - 1); m <= std::min(levels - 2, l + 1); ++m) {
        if (cand[m][0] > cand[m][1] || cand[m][2] > cand[m][3]) continue;
        j0 = std::min(j0, cand[m][0] - 1);
        j1 = std::max(j1, cand[m][1] + 1);
        i0 = std::min(i0, cand[m][2] - 1);
        i1 = std::max(i1, cand[m][3] + 1);
      }
      if (j0 > j1 || i0 > i1) continue;
      j0 = std::max(j0, lo_x(l));
      j1 = std::min(j1, hi_x(l, W));
      i0 = std::max(i0, lo_x(l));
      i1 = std::min(i1, hi_x(l, H));
      float* out = det.data() + plane * l;
      const BoxFilterLayout& layout = layouts[l];
      const int rows = i1 - i0 + 1;
      // Blocks of rows so that threads share the work evenly.
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 8)
      for (int r = 0; r < rows; ++r) {
        surf_detail::ComputeHessianDeterminant(ii, layout, i0 + r, i0 + r + 1, j0, j1 + 1, out,
                                               grid_w);
      }
    }

    // Non-maximum suppression in 3x3x3 neighbourhoods (strictly greater) and refinement.
    for (int l = 1; l + 1 < levels; ++l) {
      const auto [j0, j1, i0, i1] = cand[l];
      if (j0 > j1 || i0 > i1) continue;
      const float* lo = det.data() + plane * (l - 1);
      const float* mid = det.data() + plane * l;
      const float* hi = det.data() + plane * (l + 1);
      const int rows = i1 - i0 + 1;
      const int blocks = threads > 1 ? std::min(rows, threads * 8) : 1;
      found.assign(blocks, {});
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 1)
      for (int b = 0; b < blocks; ++b) {
        const int ib = i0 + static_cast<int>(static_cast<long>(rows) * b / blocks);
        const int ie = i0 + static_cast<int>(static_cast<long>(rows) * (b + 1) / blocks);
        std::vector<Keypoint>& out = found[b];
        for (int i = ib; i < ie; ++i) {
          const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(i) * grid_w;
          for (int j = j0; j <= j1; ++j) {
            const float v = mid[row + j];
            if (!(v > threshold)) continue;
            const std::ptrdiff_t k = row + j;
            if (!IsMaximumExceptCentre(v, mid + k, grid_w) || !IsMaximum(v, lo + k, grid_w) ||
                !IsMaximum(v, hi + k, grid_w)) {
              continue;
            }
            float off[3];
            if (!Interpolate(lo + k, mid + k, hi + k, grid_w, off)) continue;
            Keypoint kp;
            const float centre_offset = (p - 1) * 0.5f;
            kp.x = p * (j + off[0]) + centre_offset;
            kp.y = p * (i + off[1]) + centre_offset;
            if (options.roi && !options.roi->contains(kp.x, kp.y)) continue;
            const float size = layouts[l].size + off[2] * (layouts[l].size - layouts[l - 1].size);
            kp.scale = 1.2f * size / kBaseSize;
            kp.response = v;
            kp.laplacian = surf_detail::HessianTrace(ii, layouts[l], i, j) >= 0.f ? 1 : -1;
            kp.octave = static_cast<std::int8_t>(octave);
            out.push_back(kp);
          }
        }
      }
      for (const auto& f : found) keypoints.insert(keypoints.end(), f.begin(), f.end());
    }
  }
  std::sort(keypoints.begin(), keypoints.end(), StrongerFirst);
  if (options.max_keypoints > 0 &&
      keypoints.size() > static_cast<std::size_t>(options.max_keypoints)) {
    keypoints.resize(options.max_keypoints);
  }
  return keypoints;
}

float Surf::Impl::Orientation(const Keypoint& kp) const {
  const Tables& t = GetTables();
  const int W = ii.width(), H = ii.height();
  const float s = kp.scale;
  const int half = std::max(1, static_cast<int>(std::lround(2.f * s)));  // Haar side 4s.
  const int side = 2 * half;
  const std::ptrdiff_t st = ii.stride();
  const std::uint32_t* base = ii.data();
  std::array<float, kOriBins> bx{}, by{};
  // Top-left of the wavelet centred on (x, y): round(x - (side - 1) / 2).
  const float cx = kp.x - (side - 1) * 0.5f, cy = kp.y - (side - 1) * 0.5f;
  int n = 0;
  for (const OrientationSample& a : t.ori) {
    const int x0 = static_cast<int>(std::floor(cx + a.i * s + 0.5f));
    const int y0 = static_cast<int>(std::floor(cy + a.j * s + 0.5f));
    if (x0 < 0 || y0 < 0 || x0 + side > W || y0 + side > H) continue;
    const std::uint32_t* r0 = base + y0 * st + x0;
    const std::uint32_t* r1 = r0 + half * st;
    const std::uint32_t* r2 = r0 + side * st;
    // dx = right half - left half; dy = bottom half - top half.
    const std::int32_t dx = static_cast<std::int32_t>((r2[side] - r0[side]) -
                                                      2u * (r2[half] - r0[half]) + (r2[0] - r0[0]));
    const std::int32_t dy = static_cast<std::int32_t>((r2[side] - r2[0]) - 2u * (r1[side] - r1[0]) +
                                                      (r0[side] - r0[0]));
    if (dx == 0 && dy == 0) continue;
    const float fx = dx * a.weight, fy = dy * a.weight;
    int bin = static_cast<int>(FastAtan2(fy, fx) * (kOriBins / kTwoPi));
    bin = std::min(bin, kOriBins - 1);
    bx[bin] += fx;
    by[bin] += fy;
    ++n;
  }
  if (n == 0) return 0.f;
  float sx = 0.f, sy = 0.f;
  for (int b = 0; b < kOriWindowBins; ++b) {
    sx += bx[b];
    sy += by[b];
  }
  float best = -1.f, best_x = 0.f, best_y = 0.f;
  for (int b = 0; b < kOriBins; ++b) {
    const float m = sx * sx + sy * sy;
    if (m > best) {
      best = m;
      best_x = sx;
      best_y = sy;
    }
    const int out = b, in = (b + kOriWindowBins) % kOriBins;
    sx += bx[in] - bx[out];
    sy += by[in] - by[out];
  }
  float angle = std::atan2(best_y, best_x);
  if (angle < 0.f) angle += kTwoPi;
  if (angle >= kTwoPi) angle = 0.f;
  return angle;
}

void Surf::Impl::Orient(std::vector<Keypoint>& kps) const {
  if (options.upright) {
    for (Keypoint& kp : kps) kp.orientation = 0.f;
    return;
  }
  const int threads = ResolveThreads(options.num_threads);
  const long n = static_cast<long>(kps.size());
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 32)
  for (long k = 0; k < n; ++k) kps[k].orientation = Orientation(kps[k]);
}

void Surf::Impl::DescribeOne(const Keypoint& kp, float* out) const {
  const Tables& t = GetTables();
  const bool extended = options.extended;
  const int dsize = extended ? 128 : 64;
  const int W = ii.width(), H = ii.height();
  const float s = kp.scale;
  const int half = std::max(1, static_cast<int>(std::lround(s)));  // Haar side 2s.
  const int side = 2 * half;
  const float co = std::cos(kp.orientation), si = std::sin(kp.orientation);
  const std::ptrdiff_t st = ii.stride();
  const std::uint32_t* base = ii.data();
  // Fast path when every wavelet lies inside the image.
  const float reach = (kPatch * 0.5f) * s * 1.4143f + side + 2.f;
  const bool inside =
      kp.x - reach >= 0.f && kp.y - reach >= 0.f && kp.x + reach <= W && kp.y + reach <= H;
  std::fill(out, out + dsize, 0.f);
  const float c0 = kp.x - (side - 1) * 0.5f, r0c = kp.y - (side - 1) * 0.5f;
  for (int r = 0; r < kPatch; ++r) {
    const float v = (r - (kPatch - 1) * 0.5f) * s;
    float* cell_row = out + (r / 5) * 4 * (extended ? 8 : 4);
    for (int c = 0; c < kPatch; ++c) {
      const float u = (c - (kPatch - 1) * 0.5f) * s;
      const float px = c0 + u * co - v * si, py = r0c + u * si + v * co;
      int x0 = static_cast<int>(std::floor(px + 0.5f));
      int y0 = static_cast<int>(std::floor(py + 0.5f));
      std::int32_t dx, dy;
      if (inside) {
        const std::uint32_t* a0 = base + y0 * st + x0;
        const std::uint32_t* a1 = a0 + half * st;
        const std::uint32_t* a2 = a0 + side * st;
        dx = static_cast<std::int32_t>((a2[side] - a0[side]) - 2u * (a2[half] - a0[half]) +
                                       (a2[0] - a0[0]));
        dy = static_cast<std::int32_t>((a2[side] - a2[0]) - 2u * (a1[side] - a1[0]) +
                                       (a0[side] - a0[0]));
      } else {
        // Clamp the wavelet's corners to the image: the parts outside contribute nothing.
        const int xs[3] = {std::clamp(x0, 0, W), std::clamp(x0 + half, 0, W),
                           std::clamp(x0 + side, 0, W)};
        const int ys[3] = {std::clamp(y0, 0, H), std::clamp(y0 + half, 0, H),
                           std::clamp(y0 + side, 0, H)};
        const auto A = [&](int yi, int xi) { return base[ys[yi] * st + xs[xi]]; };
        dx = static_cast<std::int32_t>((A(2, 2) - A(0, 2)) - 2u * (A(2, 1) - A(0, 1)) +
                                       (A(2, 0) - A(0, 0)));
        dy = static_cast<std::int32_t>((A(2, 2) - A(2, 0)) - 2u * (A(1, 2) - A(1, 0)) +
                                       (A(0, 2) - A(0, 0)));
      }
      const float w = t.desc_weight[r * kPatch + c];
      // Responses in the keypoint's frame (u along the orientation).
      const float ru = w * (dx * co + dy * si);
      const float rv = w * (dy * co - dx * si);
      if (!extended) {
        float* cell = cell_row + (c / 5) * 4;
        cell[0] += ru;
        cell[1] += rv;
        cell[2] += std::fabs(ru);
        cell[3] += std::fabs(rv);
      } else {
        float* cell = cell_row + (c / 5) * 8;
        // OpenCV's extended layout: sums of du split by the sign of dv, and of dv by du's sign.
        if (rv >= 0.f) {
          cell[0] += ru;
          cell[1] += std::fabs(ru);
        } else {
          cell[2] += ru;
          cell[3] += std::fabs(ru);
        }
        if (ru >= 0.f) {
          cell[4] += rv;
          cell[5] += std::fabs(rv);
        } else {
          cell[6] += rv;
          cell[7] += std::fabs(rv);
        }
      }
    }
  }
  float norm2 = 0.f;
  for (int k = 0; k < dsize; ++k) norm2 += out[k] * out[k];
  if (norm2 > 0.f) {
    const float inv = 1.f / std::sqrt(norm2);
    for (int k = 0; k < dsize; ++k) out[k] *= inv;
  }
}

void Surf::Impl::DescribeAll(const std::vector<Keypoint>& kps, float* out, int dsize) const {
  const int threads = ResolveThreads(options.num_threads);
  const long n = static_cast<long>(kps.size());
#pragma omp parallel for num_threads(threads) if (threads > 1) schedule(dynamic, 32)
  for (long k = 0; k < n; ++k) DescribeOne(kps[k], out + k * dsize);
}

Surf::Surf(const SurfOptions& options) : impl_(nullptr) {
  Validate(options);
  impl_ = new Impl;
  impl_->options = options;
}

Surf::~Surf() { delete impl_; }

Surf::Surf(Surf&& other) noexcept : impl_(other.impl_) { other.impl_ = nullptr; }

Surf& Surf::operator=(Surf&& other) noexcept {
  if (this != &other) {
    delete impl_;
    impl_ = other.impl_;
    other.impl_ = nullptr;
  }
  return *this;
}

const SurfOptions& Surf::options() const { return impl_->options; }

SurfResult Surf::DetectAndDescribe(const GrayImageView& image) {
  SurfResult result;
  Stopwatch watch;
  impl_->Prepare(image);
  std::vector<Keypoint> kps = impl_->FastHessian();
  impl_->Orient(kps);
  result.detect_ms = watch.elapsed_ms();
  watch.restart();
  FeatureSet& fs = result.features;
  fs.descriptor_size = impl_->options.extended ? 128 : 64;
  fs.descriptors.resize(kps.size() * fs.descriptor_size);
  impl_->DescribeAll(kps, fs.descriptors.data(), fs.descriptor_size);
  fs.keypoints = std::move(kps);
  result.describe_ms = watch.elapsed_ms();
  return result;
}

std::vector<Keypoint> Surf::Detect(const GrayImageView& image) {
  impl_->Prepare(image);
  std::vector<Keypoint> kps = impl_->FastHessian();
  impl_->Orient(kps);
  return kps;
}

FeatureSet Surf::Describe(const GrayImageView& image, std::vector<Keypoint> keypoints) {
  impl_->Prepare(image);
  FeatureSet fs;
  fs.descriptor_size = impl_->options.extended ? 128 : 64;
  fs.descriptors.resize(keypoints.size() * fs.descriptor_size);
  impl_->DescribeAll(keypoints, fs.descriptors.data(), fs.descriptor_size);
  fs.keypoints = std::move(keypoints);
  return fs;
}

}  // namespace aerovo
