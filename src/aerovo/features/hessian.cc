#include "aerovo/features/hessian.h"

#include <cmath>
#include <cstdint>

namespace aerovo::surf_detail {

BoxFilterLayout MakeBoxFilterLayout(int size, int step) {
  BoxFilterLayout l;
  l.size = size;
  l.step = step;
  l.border = (size - step) / 2;
  l.lobe = size / 3;
  // Round as the 9x9 pattern scaled by size/9; size*k/9 never has a fractional part of exactly
  // 0.5 for SURF sizes, so the rounding mode does not matter and the lobes stay symmetric.
  const auto scaled = [size](int k) { return static_cast<int>(std::lround(size * k / 9.0)); };
  l.band0 = scaled(2);
  l.band1 = scaled(7);
  l.xy0 = scaled(1);
  l.xy1 = scaled(4);
  l.xy2 = scaled(5);
  l.xy3 = scaled(8);
  l.inv_area_xx = 1.f / static_cast<float>(l.lobe * (l.band1 - l.band0));
  l.inv_area_xy = 1.f / static_cast<float>((l.xy1 - l.xy0) * (l.xy1 - l.xy0));
  return l;
}

namespace {

// Responses of one row of samples. Box sums are uint32 differences (exact modulo 2^32, see
// IntegralImage), combined in integer arithmetic and converted to float once. kStep > 0 fixes
// the sampling step at compile time so that the step-1 loop is contiguous and vectorises.
template <int kStep>
__attribute__((always_inline)) inline void HessianRow(const std::uint32_t* ii, std::ptrdiff_t s,
                                                      const BoxFilterLayout& l, int i, int j0,
                                                      int j1, float* out) {  // out[0] <- sample j0
  const std::ptrdiff_t p = kStep > 0 ? kStep : l.step;
  const std::uint32_t* base = ii + (p * i - l.border) * s - l.border;
  const std::ptrdiff_t S = l.size, L = l.lobe, L2 = 2 * l.lobe;
  const std::ptrdiff_t ya = l.band0, yb = l.band1;
  const std::ptrdiff_t a1 = l.xy0, b1 = l.xy1, a2 = l.xy2, b2 = l.xy3;
  // Dxx: rows ya, yb; columns 0, L, 2L, S.
  const std::uint32_t* xa = base + ya * s;
  const std::uint32_t* xb = base + yb * s;
  // Dyy: rows 0, L, 2L, S; columns ya, yb.
  const std::uint32_t* r0 = base;
  const std::uint32_t* r1 = base + L * s;
  const std::uint32_t* r2 = base + L2 * s;
  const std::uint32_t* r3 = base + S * s;
  // Dxy: rows and columns a1, b1, a2, b2.
  const std::uint32_t* q1 = base + a1 * s;
  const std::uint32_t* q2 = base + b1 * s;
  const std::uint32_t* q3 = base + a2 * s;
  const std::uint32_t* q4 = base + b2 * s;
  const float inv_xx = l.inv_area_xx, inv_xy = l.inv_area_xy;
  for (int j = j0; j < j1; ++j) {
    const std::ptrdiff_t x = p * j;
    const std::uint32_t all_xx = xb[x + S] - xa[x + S] - xb[x] + xa[x];
    const std::uint32_t mid_xx = xb[x + L2] - xa[x + L2] - xb[x + L] + xa[x + L];
    const std::uint32_t all_yy = r3[x + yb] - r0[x + yb] - r3[x + ya] + r0[x + ya];
    const std::uint32_t mid_yy = r2[x + yb] - r1[x + yb] - r2[x + ya] + r1[x + ya];
    const std::uint32_t tl = q2[x + b1] - q1[x + b1] - q2[x + a1] + q1[x + a1];
    const std::uint32_t tr = q2[x + b2] - q1[x + b2] - q2[x + a2] + q1[x + a2];
    const std::uint32_t bl = q4[x + b1] - q3[x + b1] - q4[x + a1] + q3[x + a1];
    const std::uint32_t br = q4[x + b2] - q3[x + b2] - q4[x + a2] + q3[x + a2];
    const float dxx = static_cast<float>(static_cast<std::int32_t>(all_xx - 3u * mid_xx)) * inv_xx;
    const float dyy = static_cast<float>(static_cast<std::int32_t>(all_yy - 3u * mid_yy)) * inv_xx;
    const float dxy = static_cast<float>(static_cast<std::int32_t>(tl - tr - bl + br)) * inv_xy;
    out[j - j0] = dxx * dyy - 0.81f * (dxy * dxy);
  }
}

__attribute__((always_inline)) inline void HessianRows(const IntegralImage& ii,
                                                       const BoxFilterLayout& l, int i0, int i1,
                                                       int j0, int j1, float* det,
                                                       std::ptrdiff_t det_stride) {
  for (int i = i0; i < i1; ++i) {
    float* out = det + (i - i0) * det_stride;  // det points at sample (i0, j0).
    switch (l.step) {
      case 1:
        HessianRow<1>(ii.data(), ii.stride(), l, i, j0, j1, out);
        break;
      case 2:
        HessianRow<2>(ii.data(), ii.stride(), l, i, j0, j1, out);
        break;
      case 4:
        HessianRow<4>(ii.data(), ii.stride(), l, i, j0, j1, out);
        break;
      default:
        HessianRow<0>(ii.data(), ii.stride(), l, i, j0, j1, out);
        break;
    }
  }
}

void HessianRowsDefault(const IntegralImage& ii, const BoxFilterLayout& l, int i0, int i1, int j0,
                        int j1, float* det, std::ptrdiff_t det_stride) {
  HessianRows(ii, l, i0, i1, j0, j1, det, det_stride);
}

#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("avx2,fma"))) void HessianRowsAvx2(const IntegralImage& ii,
                                                         const BoxFilterLayout& l, int i0, int i1,
                                                         int j0, int j1, float* det,
                                                         std::ptrdiff_t det_stride) {
  HessianRows(ii, l, i0, i1, j0, j1, det, det_stride);
}
#endif

using HessianRowsFn = void (*)(const IntegralImage&, const BoxFilterLayout&, int, int, int, int,
                               float*, std::ptrdiff_t);

HessianRowsFn SelectHessianRows() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return &HessianRowsAvx2;
#endif
  return &HessianRowsDefault;
}

}  // namespace

void ComputeHessianDeterminant(const IntegralImage& ii, const BoxFilterLayout& layout, int i0,
                               int i1, int j0, int j1, float* det, std::ptrdiff_t det_stride) {
  static const HessianRowsFn fn = SelectHessianRows();
  if (i1 <= i0 || j1 <= j0) return;
  fn(ii, layout, i0, i1, j0, j1, det + i0 * det_stride + j0, det_stride);
}

void ComputeHessianRow(const IntegralImage& ii, const BoxFilterLayout& layout, int i, int j0,
                       int j1, float* out) {
  static const HessianRowsFn fn = SelectHessianRows();
  if (j1 <= j0) return;
  fn(ii, layout, i, i + 1, j0, j1, out, 0);
}

float HessianDeterminant(const IntegralImage& ii, const BoxFilterLayout& l, int i, int j) {
  float out[1];
  HessianRow<0>(ii.data(), ii.stride(), l, i, j, j + 1, out);
  return out[0];
}

float HessianTrace(const IntegralImage& ii, const BoxFilterLayout& l, int i, int j) {
  const int x0 = l.step * j - l.border, y0 = l.step * i - l.border;
  const std::int32_t all_xx =
      static_cast<std::int32_t>(ii.BoxSum(x0, y0 + l.band0, x0 + l.size, y0 + l.band1));
  const std::int32_t mid_xx = static_cast<std::int32_t>(
      ii.BoxSum(x0 + l.lobe, y0 + l.band0, x0 + 2 * l.lobe, y0 + l.band1));
  const std::int32_t all_yy =
      static_cast<std::int32_t>(ii.BoxSum(x0 + l.band0, y0, x0 + l.band1, y0 + l.size));
  const std::int32_t mid_yy = static_cast<std::int32_t>(
      ii.BoxSum(x0 + l.band0, y0 + l.lobe, x0 + l.band1, y0 + 2 * l.lobe));
  return static_cast<float>((all_xx - 3 * mid_xx) + (all_yy - 3 * mid_yy)) * l.inv_area_xx;
}

}  // namespace aerovo::surf_detail
