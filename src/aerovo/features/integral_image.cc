#include "aerovo/features/integral_image.h"

namespace aerovo {

void IntegralImage::Compute(const GrayImageView& image) {
  width_ = image.width;
  height_ = image.height;
  // Round rows up to 16 elements (64 bytes) so that rows start on cache-line boundaries.
  stride_ = (static_cast<std::ptrdiff_t>(width_) + 1 + 15) & ~static_cast<std::ptrdiff_t>(15);
  const std::size_t needed = static_cast<std::size_t>(stride_) * (height_ + 1);
  if (table_.size() < needed) table_.resize(needed);
  std::uint32_t* t = table_.data();
  for (std::ptrdiff_t x = 0; x <= width_; ++x) t[x] = 0;
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* src = image.row(y);
    const std::uint32_t* above = t + y * stride_;
    std::uint32_t* out = t + (y + 1) * stride_;
    out[0] = 0;
    // Row prefix sum first (a serial chain), then the vectorisable add of the row above.
    std::uint32_t run = 0;
    for (int x = 0; x < width_; ++x) {
      run += src[x];
      out[x + 1] = run;
    }
    for (int x = 1; x <= width_; ++x) out[x] += above[x];
  }
}

}  // namespace aerovo
