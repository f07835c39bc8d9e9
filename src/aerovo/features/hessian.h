// Box-filter approximation of the Hessian determinant (SURF's fast-Hessian), one scale layer at
// a time. Used by Surf; exposed for tests and benchmarks.
#pragma once

#include <cstddef>
#include <cstdint>

#include "aerovo/features/integral_image.h"

namespace aerovo::surf_detail {

/// Geometry of the SURF box filters for one layer: filter size `size` (9, 15, 21, ... times
/// 2^octave) sampled every `step` pixels. Lobe positions are the 9x9 pattern of Bay et al.
/// (2008, Fig. 1) scaled by size/9 and rounded as OpenCV does; each lobe's weight is divided by
/// its area (OpenCV's normalisation), so the determinant is in the units of OpenCV's
/// hessianThreshold / MATLAB's MetricThreshold on 0..255 images.
struct BoxFilterLayout {
  int size = 9;  ///< Filter side, pixels.
  int step = 1;  ///< Sampling step, pixels (2^octave).
  int border =
      4;  ///< Sample (i, j) has its filter's top-left pixel at (step*j - border, step*i - border).
  int lobe = 3;   ///< size / 3: width of each Dxx lobe (height of each Dyy lobe).
  int band0 = 2;  ///< Dxx lobes span rows [band0, band1) of the filter (Dyy: columns).
  int band1 = 7;
  int xy0 = 1;  ///< Dxy lobes span [xy0, xy1) and [xy2, xy3) in x and in y.
  int xy1 = 4;
  int xy2 = 5;
  int xy3 = 8;
  float inv_area_xx = 1.f / 15.f;  ///< 1 / area of one Dxx (Dyy) lobe.
  float inv_area_xy = 1.f / 9.f;   ///< 1 / area of one Dxy lobe.
};

/// Layout of the filter of side `size` (odd multiple of 3 times `step`, size >= 9*step) with
/// sampling step `step`.
BoxFilterLayout MakeBoxFilterLayout(int size, int step);

/// The integral-image rows and column offsets the box filters of one row of samples read: for
/// sample j (at x = step * j), a box with rows (lo, hi) and columns (c0, c1) is
/// hi[x + c1] - lo[x + c1] - hi[x + c0] + lo[x + c0]. Shared by the scalar and the Highway
/// kernels (hessian_row-inl.h, hessian_hwy.cc).
struct BoxFilterRows {
  // Dxx: rows band0 (xa) and band1 (xb); columns 0, lobe, 2 lobe, size.
  const std::uint32_t* xa;
  const std::uint32_t* xb;
  // Dyy: rows 0, lobe, 2 lobe, size; columns band0 (ya) and band1 (yb).
  const std::uint32_t* r0;
  const std::uint32_t* r1;
  const std::uint32_t* r2;
  const std::uint32_t* r3;
  // Dxy: rows and columns xy0 (a1), xy1 (b1), xy2 (a2), xy3 (b2).
  const std::uint32_t* q1;
  const std::uint32_t* q2;
  const std::uint32_t* q3;
  const std::uint32_t* q4;
  std::ptrdiff_t S, L, L2;  ///< size, lobe, 2 lobe
  std::ptrdiff_t ya, yb;    ///< band0, band1
  std::ptrdiff_t a1, b1, a2, b2;
};

/// The rows of sample row i at sampling step `step` (the layout's, or its compile-time value)
/// in the integral image `ii` of `stride` values per row.
inline BoxFilterRows MakeBoxFilterRows(const std::uint32_t* ii, std::ptrdiff_t stride,
                                       const BoxFilterLayout& l, std::ptrdiff_t step, int i) {
  const std::uint32_t* base = ii + (step * i - l.border) * stride - l.border;
  BoxFilterRows b;
  b.S = l.size;
  b.L = l.lobe;
  b.L2 = 2 * l.lobe;
  b.ya = l.band0;
  b.yb = l.band1;
  b.a1 = l.xy0;
  b.b1 = l.xy1;
  b.a2 = l.xy2;
  b.b2 = l.xy3;
  b.xa = base + b.ya * stride;
  b.xb = base + b.yb * stride;
  b.r0 = base;
  b.r1 = base + b.L * stride;
  b.r2 = base + b.L2 * stride;
  b.r3 = base + b.S * stride;
  b.q1 = base + b.a1 * stride;
  b.q2 = base + b.b1 * stride;
  b.q3 = base + b.a2 * stride;
  b.q4 = base + b.b2 * stride;
  return b;
}

/// Writes det = Dxx*Dyy - (0.9*Dxy)^2 for samples i in [i0, i1), j in [j0, j1) to
/// det[i * det_stride + j]. Preconditions: every filter lies inside the image, i.e.
/// step*j0 - border >= 0, step*(j1-1) - border + size <= width, and the same for rows.
/// Kernel: the active SimdMode's (core/simd.h): native = the AVX2 loop on x86 CPUs with
/// AVX2+FMA, else Highway's best target (SSE4, NEON, SVE, ...); highway; scalar. Results are
/// bit-identical between scalar and Highway; the AVX2 loop may fuse the final multiply-add
/// (a difference of at most a few ulp of Dxx*Dyy, tested in hessian_test.cc).
void ComputeHessianDeterminant(const IntegralImage& ii, const BoxFilterLayout& layout, int i0,
                               int i1, int j0, int j1, float* det, std::ptrdiff_t det_stride);

/// The same for one row i, samples j in [j0, j1), written to out[0 .. j1 - j0).
void ComputeHessianRow(const IntegralImage& ii, const BoxFilterLayout& layout, int i, int j0,
                       int j1, float* out);

/// ComputeHessianDeterminant's row loop (det points at sample (i0, j0)) in plain C++: the
/// portable reference (SimdMode::kScalar).
void HessianRowsScalar(const IntegralImage& ii, const BoxFilterLayout& layout, int i0, int i1,
                       int j0, int j1, float* det, std::ptrdiff_t det_stride);

/// The same loop written with Google Highway, on the best target of this CPU among those
/// compiled (hwy::SetSupportedTargetsForTest selects another one in tests).
void HessianRowsHighway(const IntegralImage& ii, const BoxFilterLayout& layout, int i0, int i1,
                        int j0, int j1, float* det, std::ptrdiff_t det_stride);

/// Dxx*Dyy - (0.9*Dxy)^2 at one sample (same preconditions), scalar.
float HessianDeterminant(const IntegralImage& ii, const BoxFilterLayout& layout, int i, int j);

/// Dxx + Dyy (the Laplacian, in the same normalisation) at one sample (same preconditions).
float HessianTrace(const IntegralImage& ii, const BoxFilterLayout& layout, int i, int j);

/// SURF's in-layer test over a row of responses: the first j in [j, end) with m1[j] >
/// threshold and m1[j] strictly greater than its eight neighbours m0[j-1..j+1], m1[j-1],
/// m1[j+1], m2[j-1..j+1] (rows i-1, i, i+1 of one layer); `end` if none. A NaN passes no
/// comparison. Precondition: the three rows are readable at [j - 1, end]. Every kernel returns
/// the same j (comparisons only: no rounding).
using InLayerMaximumFn = int (*)(const float* m0, const float* m1, const float* m2, int j, int end,
                                 float threshold);
/// The portable loop, one sample at a time (SimdMode::kScalar): the reference.
int NextInLayerMaximumScalar(const float* m0, const float* m1, const float* m2, int j, int end,
                             float threshold);
/// The kernel of the active SimdMode (core/simd.h): scalar for kScalar; otherwise the widest
/// hand-written one of this CPU (AVX2 8 samples per step, SSE2 or NEON 4; there is no Highway
/// version). Resolve once per image: one relaxed atomic load.
InLayerMaximumFn ActiveInLayerMaximum();
/// Every kernel compiled in and usable on this CPU, with its name (tests).
struct NamedInLayerMaximum {
  const char* name;
  InLayerMaximumFn fn;
};
int InLayerMaximumKernels(NamedInLayerMaximum out[4]);

}  // namespace aerovo::surf_detail
