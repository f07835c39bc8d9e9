// The Hessian row loop of hessian.cc written once with Google Highway and compiled for every
// target Highway offers on this architecture (x86: SSSE3/SSE4, AVX2, AVX3 = AVX-512; aarch64:
// NEON, SVE, SVE2, SVE_256, SVE2_128), the best one chosen at run time (HWY_DYNAMIC_DISPATCH).
// Same integer box sums and the same float expression as the scalar loop, without fused
// multiply-adds (this file is compiled with -ffp-contract=off): bit-identical to it.
#include <cstddef>
#include <cstdint>

#include "aerovo/features/hessian.h"
#include "aerovo/features/integral_image.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "aerovo/features/hessian_hwy.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace aerovo {
namespace surf_detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Lanes of ii[k * kStep] for k = 0 .. Lanes-1 (reads kStep * Lanes values from p).
template <int kStep, class D>
HWY_INLINE hn::VFromD<D> LoadStrided(D d, const std::uint32_t* HWY_RESTRICT p) {
  if constexpr (kStep == 1) {
    return hn::LoadU(d, p);
  } else if constexpr (kStep == 2) {
    hn::VFromD<D> v0, v1;
    hn::LoadInterleaved2(d, p, v0, v1);
    return v0;
  } else {
    static_assert(kStep == 4, "steps 1, 2, 4");
    hn::VFromD<D> v0, v1, v2, v3;
    hn::LoadInterleaved4(d, p, v0, v1, v2, v3);
    return v0;
  }
}

// One row of samples j in [j0, j1) at sampling step kStep, out[0] <- sample j0. Whole vectors
// only where every value they read belongs to the row's filters (the strided loads read
// kStep - 1 values past the last sample's); the rest through the scalar loop.
template <int kStep>
HWY_INLINE void Row(const IntegralImage& img, const BoxFilterLayout& l, int i, int j0, int j1,
                    float* HWY_RESTRICT out) {
  const hn::ScalableTag<std::uint32_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const hn::RebindToFloat<decltype(du)> df;
  const int n = static_cast<int>(hn::Lanes(du));
  const std::ptrdiff_t s = img.stride();
  const BoxFilterRows b = MakeBoxFilterRows(img.data(), s, l, kStep, i);
  const std::ptrdiff_t S = b.S, L = b.L, L2 = b.L2, ya = b.ya, yb = b.yb;
  const std::ptrdiff_t a1 = b.a1, b1 = b.b1, a2 = b.a2, b2 = b.b2;
  const std::uint32_t *xa = b.xa, *xb = b.xb, *r0 = b.r0, *r1 = b.r1, *r2 = b.r2, *r3 = b.r3;
  const std::uint32_t *q1 = b.q1, *q2 = b.q2, *q3 = b.q3, *q4 = b.q4;
  const auto inv_xx = hn::Set(df, l.inv_area_xx);
  const auto inv_xy = hn::Set(df, l.inv_area_xy);
  const auto k081 = hn::Set(df, 0.81f);
  // Last j at which a whole vector may start.
  const int last = kStep == 1 ? j1 - n : j1 - n - 1;
  int j = j0;
  for (; j <= last; j += n) {
    const std::ptrdiff_t x = static_cast<std::ptrdiff_t>(kStep) * j;
#define AEROVO_BOX(hi, lo, c0, c1)                                         \
  hn::Add(hn::Sub(hn::Sub(LoadStrided<kStep>(du, hi + x + (c1)),           \
                          LoadStrided<kStep>(du, lo + x + (c1))),          \
                  LoadStrided<kStep>(du, hi + x + (c0))),                  \
          LoadStrided<kStep>(du, lo + x + (c0)))
    const auto all_xx = AEROVO_BOX(xb, xa, 0, S);
    const auto mid_xx = AEROVO_BOX(xb, xa, L, L2);
    const auto all_yy = AEROVO_BOX(r3, r0, ya, yb);
    const auto mid_yy = AEROVO_BOX(r2, r1, ya, yb);
    const auto tl = AEROVO_BOX(q2, q1, a1, b1);
    const auto tr = AEROVO_BOX(q2, q1, a2, b2);
    const auto bl = AEROVO_BOX(q4, q3, a1, b1);
    const auto br = AEROVO_BOX(q4, q3, a2, b2);
#undef AEROVO_BOX
    // all - 3 * mid, modulo 2^32 as the scalar loop.
    const auto ixx = hn::Sub(all_xx, hn::Add(hn::ShiftLeft<1>(mid_xx), mid_xx));
    const auto iyy = hn::Sub(all_yy, hn::Add(hn::ShiftLeft<1>(mid_yy), mid_yy));
    const auto ixy = hn::Add(hn::Sub(hn::Sub(tl, tr), bl), br);
    const auto dxx = hn::Mul(hn::ConvertTo(df, hn::BitCast(di, ixx)), inv_xx);
    const auto dyy = hn::Mul(hn::ConvertTo(df, hn::BitCast(di, iyy)), inv_xx);
    const auto dxy = hn::Mul(hn::ConvertTo(df, hn::BitCast(di, ixy)), inv_xy);
    hn::StoreU(hn::Sub(hn::Mul(dxx, dyy), hn::Mul(k081, hn::Mul(dxy, dxy))), df, out + (j - j0));
  }
  if (j < j1) HessianRowsScalar(img, l, i, i + 1, j, j1, out + (j - j0), 0);
}

void HessianRowsImpl(const IntegralImage& ii, const BoxFilterLayout& l, int i0, int i1, int j0,
                     int j1, float* det, std::ptrdiff_t det_stride) {
  for (int i = i0; i < i1; ++i) {
    float* out = det + (i - i0) * det_stride;
    switch (l.step) {
      case 1:
        Row<1>(ii, l, i, j0, j1, out);
        break;
      case 2:
        Row<2>(ii, l, i, j0, j1, out);
        break;
      case 4:
        Row<4>(ii, l, i, j0, j1, out);
        break;
      default:
        HessianRowsScalar(ii, l, i, i + 1, j0, j1, out, 0);
        break;
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace surf_detail
}  // namespace aerovo
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace aerovo::surf_detail {

HWY_EXPORT(HessianRowsImpl);

void HessianRowsHighway(const IntegralImage& ii, const BoxFilterLayout& layout, int i0, int i1,
                        int j0, int j1, float* det, std::ptrdiff_t det_stride) {
  HWY_DYNAMIC_DISPATCH(HessianRowsImpl)(ii, layout, i0, i1, j0, j1, det, det_stride);
}

}  // namespace aerovo::surf_detail
#endif  // HWY_ONCE
