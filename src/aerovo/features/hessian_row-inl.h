// The scalar Hessian row loop, shared by hessian.cc (compiled with the build's flags, and in
// an AVX2+FMA clone) and hessian_scalar.cc (compiled with -ffp-contract=off: the portable
// reference, rounding as Highway's kernel). Internal to features/.
#pragma once

#include <cstddef>
#include <cstdint>

#include "aerovo/features/hessian.h"
#include "aerovo/features/integral_image.h"

namespace aerovo::surf_detail::row_detail {
// Internal linkage: each including file gets its own copy, compiled with its own flags.
namespace {

// Responses of one row of samples. Box sums are uint32 differences (exact modulo 2^32, see
// IntegralImage), combined in integer arithmetic and converted to float once. kStep > 0 fixes
// the sampling step at compile time so that the step-1 loop is contiguous and vectorises.
template <int kStep>
__attribute__((always_inline)) inline void HessianRow(const std::uint32_t* ii, std::ptrdiff_t s,
                                                      const BoxFilterLayout& l, int i, int j0,
                                                      int j1, float* out) {  // out[0] <- sample j0
  const std::ptrdiff_t p = kStep > 0 ? kStep : l.step;
  const BoxFilterRows b = MakeBoxFilterRows(ii, s, l, p, i);
  const std::ptrdiff_t S = b.S, L = b.L, L2 = b.L2, ya = b.ya, yb = b.yb;
  const std::ptrdiff_t a1 = b.a1, b1 = b.b1, a2 = b.a2, b2 = b.b2;
  const std::uint32_t *xa = b.xa, *xb = b.xb, *r0 = b.r0, *r1 = b.r1, *r2 = b.r2, *r3 = b.r3;
  const std::uint32_t *q1 = b.q1, *q2 = b.q2, *q3 = b.q3, *q4 = b.q4;
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

}  // namespace
}  // namespace aerovo::surf_detail::row_detail
