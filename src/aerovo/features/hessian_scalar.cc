// HessianRowsScalar: the plain C++ row loop, compiled with -ffp-contract=off (CMakeLists.txt)
// so that it rounds as written on every architecture (aarch64 would otherwise fuse the final
// multiply-add) and is bit-identical to the Highway kernel.
#include "aerovo/features/hessian.h"
#include "aerovo/features/hessian_row-inl.h"

namespace aerovo::surf_detail {

void HessianRowsScalar(const IntegralImage& ii, const BoxFilterLayout& l, int i0, int i1, int j0,
                       int j1, float* det, std::ptrdiff_t det_stride) {
  row_detail::HessianRows(ii, l, i0, i1, j0, j1, det, det_stride);
}

}  // namespace aerovo::surf_detail
