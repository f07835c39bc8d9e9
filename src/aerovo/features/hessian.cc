#include "aerovo/features/hessian.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#elif defined(__ARM_NEON) && defined(__aarch64__)
#include <arm_neon.h>
#endif

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

int NextInLayerMaximumScalar(const float* m0, const float* m1, const float* m2, int j, int end,
                             float threshold) {
  for (; j < end; ++j) {
    const float v = m1[j];
    if (v > threshold && v > m1[j - 1] && v > m1[j + 1] && v > m0[j - 1] && v > m0[j] &&
        v > m0[j + 1] && v > m2[j - 1] && v > m2[j] && v > m2[j + 1]) {
      return j;
    }
  }
  return end;
}

namespace {

// The SIMD kernels: a vector of samples is first compared with the threshold alone (most
// samples are below it: one compare per vector); only a vector with a sample above it gets the
// eight neighbour compares, and its first lane passing all nine is the answer. The tail is the
// scalar loop. Ordered compares (false on NaN), as the scalar `>`.
#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("avx2"))) inline __m256 GreaterAvx2(__m256 v, const float* p) {
  return _mm256_cmp_ps(v, _mm256_loadu_ps(p), _CMP_GT_OQ);
}

__attribute__((target("avx2"))) int NextInLayerMaximumAvx2(const float* m0, const float* m1,
                                                           const float* m2, int j, int end,
                                                           float threshold) {
  const __m256 t = _mm256_set1_ps(threshold);
  for (; j + 8 <= end; j += 8) {
    const __m256 v = _mm256_loadu_ps(m1 + j);
    __m256 m = _mm256_cmp_ps(v, t, _CMP_GT_OQ);
    if (_mm256_movemask_ps(m) == 0) continue;
    m = _mm256_and_ps(m, _mm256_and_ps(GreaterAvx2(v, m1 + j - 1), GreaterAvx2(v, m1 + j + 1)));
    m = _mm256_and_ps(m, _mm256_and_ps(GreaterAvx2(v, m0 + j - 1), GreaterAvx2(v, m0 + j)));
    m = _mm256_and_ps(m, _mm256_and_ps(GreaterAvx2(v, m0 + j + 1), GreaterAvx2(v, m2 + j - 1)));
    m = _mm256_and_ps(m, _mm256_and_ps(GreaterAvx2(v, m2 + j), GreaterAvx2(v, m2 + j + 1)));
    const int bits = _mm256_movemask_ps(m);
    if (bits != 0) return j + __builtin_ctz(static_cast<unsigned>(bits));
  }
  return NextInLayerMaximumScalar(m0, m1, m2, j, end, threshold);
}
#endif

#if defined(__SSE2__)
int NextInLayerMaximumSse2(const float* m0, const float* m1, const float* m2, int j, int end,
                           float threshold) {
  const __m128 t = _mm_set1_ps(threshold);
  for (; j + 4 <= end; j += 4) {
    const __m128 v = _mm_loadu_ps(m1 + j);
    __m128 m = _mm_cmpgt_ps(v, t);
    if (_mm_movemask_ps(m) == 0) continue;
    const auto gt = [&v](const float* p) { return _mm_cmpgt_ps(v, _mm_loadu_ps(p)); };
    m = _mm_and_ps(m, _mm_and_ps(gt(m1 + j - 1), gt(m1 + j + 1)));
    m = _mm_and_ps(m, _mm_and_ps(gt(m0 + j - 1), gt(m0 + j)));
    m = _mm_and_ps(m, _mm_and_ps(gt(m0 + j + 1), gt(m2 + j - 1)));
    m = _mm_and_ps(m, _mm_and_ps(gt(m2 + j), gt(m2 + j + 1)));
    const int bits = _mm_movemask_ps(m);
    if (bits != 0) return j + __builtin_ctz(static_cast<unsigned>(bits));
  }
  return NextInLayerMaximumScalar(m0, m1, m2, j, end, threshold);
}
#elif defined(__ARM_NEON) && defined(__aarch64__)
int NextInLayerMaximumNeon(const float* m0, const float* m1, const float* m2, int j, int end,
                           float threshold) {
  const float32x4_t t = vdupq_n_f32(threshold);
  for (; j + 4 <= end; j += 4) {
    const float32x4_t v = vld1q_f32(m1 + j);
    uint32x4_t m = vcgtq_f32(v, t);
    if (vmaxvq_u32(m) == 0) continue;
    const auto gt = [&v](const float* p) { return vcgtq_f32(v, vld1q_f32(p)); };
    m = vandq_u32(m, vandq_u32(gt(m1 + j - 1), gt(m1 + j + 1)));
    m = vandq_u32(m, vandq_u32(gt(m0 + j - 1), gt(m0 + j)));
    m = vandq_u32(m, vandq_u32(gt(m0 + j + 1), gt(m2 + j - 1)));
    m = vandq_u32(m, vandq_u32(gt(m2 + j), gt(m2 + j + 1)));
    if (vmaxvq_u32(m) == 0) continue;
    std::uint32_t lanes[4];
    vst1q_u32(lanes, m);
    for (int k = 0; k < 4; ++k) {
      if (lanes[k] != 0) return j + k;
    }
  }
  return NextInLayerMaximumScalar(m0, m1, m2, j, end, threshold);
}
#endif

InLayerMaximumFn SelectNativeInLayerMaximum() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2")) return &NextInLayerMaximumAvx2;
#endif
#if defined(__SSE2__)
  return &NextInLayerMaximumSse2;
#elif defined(__ARM_NEON) && defined(__aarch64__)
  return &NextInLayerMaximumNeon;
#else
  return &NextInLayerMaximumScalar;
#endif
}

}  // namespace

InLayerMaximumFn ActiveInLayerMaximum() {
  static const InLayerMaximumFn native = SelectNativeInLayerMaximum();
  return ActiveSimdMode() == SimdMode::kScalar ? &NextInLayerMaximumScalar : native;
}

int InLayerMaximumKernels(NamedInLayerMaximum out[4]) {
  int n = 0;
  out[n++] = {"scalar", &NextInLayerMaximumScalar};
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2")) out[n++] = {"avx2", &NextInLayerMaximumAvx2};
#endif
#if defined(__SSE2__)
  out[n++] = {"sse2", &NextInLayerMaximumSse2};
#elif defined(__ARM_NEON) && defined(__aarch64__)
  out[n++] = {"neon", &NextInLayerMaximumNeon};
#endif
  return n;
}

}  // namespace aerovo::surf_detail
