// Integral image (summed-area table) of an 8-bit image, the basis of SURF's box filters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "aerovo/core/image.h"

namespace aerovo {

/// Summed-area table with one extra zero row and column: at(x, y) is the sum of the pixels
/// [0, x) x [0, y), for 0 <= x <= width, 0 <= y <= height.
///
/// Entries are uint32 and wrap modulo 2^32 on very large images; box sums are computed as
/// differences in the same modular arithmetic, so they are exact whenever the true box sum is
/// below 2^32 (any box of fewer than 16.8 M pixels), independent of where the box lies and of the
/// image size: no drift on 4K frames or larger.
class IntegralImage {
 public:
  IntegralImage() = default;

  /// Recomputes the table for `image` (reuses the buffer when the size does not grow).
  /// Precondition: !image.empty().
  void Compute(const GrayImageView& image);

  int width() const { return width_; }    ///< Image width (the table has width + 1 columns).
  int height() const { return height_; }  ///< Image height (the table has height + 1 rows).
  /// Elements between consecutive table rows (>= width + 1).
  std::ptrdiff_t stride() const { return stride_; }
  const std::uint32_t* data() const { return table_.data(); }
  const std::uint32_t* row(int y) const { return table_.data() + y * stride_; }
  std::uint32_t at(int x, int y) const { return row(y)[x]; }

  /// Exact sum of the pixels in [x0, x1) x [y0, y1); requires 0 <= x0 <= x1 <= width and
  /// 0 <= y0 <= y1 <= height.
  std::uint32_t BoxSum(int x0, int y0, int x1, int y1) const {
    return at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
  }

 private:
  int width_ = 0;
  int height_ = 0;
  std::ptrdiff_t stride_ = 0;
  std::vector<std::uint32_t> table_;
};

}  // namespace aerovo
