#include "aerovo/features/hessian.h"

#include <cmath>
#include <cstdint>

#include "aerovo/core/simd.h"
#include "aerovo/features/hessian_row-inl.h"

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

using row_detail::HessianRow;
using row_detail::HessianRows;

#if defined(__x86_64__) || defined(__i386__)
// The same loop auto-vectorised for AVX2+FMA. GCC may contract dxx*dyy - 0.81*(dxy*dxy) into a
// fused multiply-add here (C++ defaults to -ffp-contract=fast), so values can differ from the
// scalar / Highway ones in the last bit; this is the path today's keypoints and the reference
// outputs were computed with, and it is faster than the Highway one (BENCHMARKS.md).
__attribute__((target("avx2,fma"))) void HessianRowsAvx2(const IntegralImage& ii,
                                                         const BoxFilterLayout& l, int i0, int i1,
                                                         int j0, int j1, float* det,
                                                         std::ptrdiff_t det_stride) {
  HessianRows(ii, l, i0, i1, j0, j1, det, det_stride);
}
#endif

using HessianRowsFn = void (*)(const IntegralImage&, const BoxFilterLayout&, int, int, int, int,
                               float*, std::ptrdiff_t);

HessianRowsFn SelectNativeHessianRows() {
#if defined(__x86_64__) || defined(__i386__)
  if (CpuHasAvx2Fma()) return &HessianRowsAvx2;
#endif
  return &HessianRowsHighway;
}

// The kernel of the active SimdMode (consulted at every call: one relaxed atomic load per row).
HessianRowsFn ActiveHessianRows() {
  static const HessianRowsFn native = SelectNativeHessianRows();
  switch (ActiveSimdMode()) {
    case SimdMode::kScalar:
      return &HessianRowsScalar;
    case SimdMode::kHighway:
      return &HessianRowsHighway;
    case SimdMode::kNative:
      break;
  }
  return native;
}

}  // namespace

void ComputeHessianDeterminant(const IntegralImage& ii, const BoxFilterLayout& layout, int i0,
                               int i1, int j0, int j1, float* det, std::ptrdiff_t det_stride) {
  if (i1 <= i0 || j1 <= j0) return;
  ActiveHessianRows()(ii, layout, i0, i1, j0, j1, det + i0 * det_stride + j0, det_stride);
}

void ComputeHessianRow(const IntegralImage& ii, const BoxFilterLayout& layout, int i, int j0,
                       int j1, float* out) {
  if (j1 <= j0) return;
  ActiveHessianRows()(ii, layout, i, i + 1, j0, j1, out, 0);
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
