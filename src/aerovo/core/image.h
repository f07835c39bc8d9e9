// Grey-level image containers shared by every module. The core of aerovo does no I/O: images
// arrive here already decoded (see aerovo/io for reading files, video and cameras).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace aerovo {

/// Non-owning view of an 8-bit single-channel image, row-major.
/// Preconditions: `data` points to `height` rows of at least `width` bytes, rows `stride` bytes
/// apart (stride >= width). Pixel (x, y) is column x, row y; (0, 0) is the top-left pixel and
/// pixel centres sit at integer coordinates.
struct GrayImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;  ///< Bytes between the starts of consecutive rows.

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  const std::uint8_t* row(int y) const { return data + static_cast<std::ptrdiff_t>(y) * stride; }
  std::uint8_t at(int x, int y) const { return row(y)[x]; }
};

/// Owning 8-bit single-channel image with contiguous rows (stride == width).
class GrayImage {
 public:
  GrayImage() = default;
  GrayImage(int width, int height, std::uint8_t fill = 0)
      : width_(width), height_(height), pixels_(static_cast<std::size_t>(width) * height, fill) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return pixels_.empty(); }
  std::uint8_t* data() { return pixels_.data(); }
  const std::uint8_t* data() const { return pixels_.data(); }
  std::uint8_t* row(int y) { return pixels_.data() + static_cast<std::size_t>(y) * width_; }
  const std::uint8_t* row(int y) const {
    return pixels_.data() + static_cast<std::size_t>(y) * width_;
  }
  std::uint8_t& at(int x, int y) { return row(y)[x]; }
  std::uint8_t at(int x, int y) const { return row(y)[x]; }

  GrayImageView view() const { return GrayImageView{pixels_.data(), width_, height_, width_}; }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<std::uint8_t> pixels_;
};

/// Axis-aligned rectangle in pixels: x in [x, x + width), y in [y, y + height).
struct RectI {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
  bool empty() const { return width <= 0 || height <= 0; }
  bool contains(double px, double py) const {
    return px >= x && py >= y && px < x + width && py < y + height;
  }
};

}  // namespace aerovo
