// Reading one image file as 8-bit grey: the one helper of the CLI (aerovo features,
// aerovo correspondence) and the benchmarks. Runs read frames through frame_source.h instead.
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

namespace aerovo {

/// How a colour file becomes grey. The two differ by a grey level here and there on JPEGs, so
/// each caller keeps the one its figures were measured with.
enum class GrayFrom {
  /// Decode to BGR, then cv::cvtColor(COLOR_BGR2GRAY) (0.299 R + 0.587 G + 0.114 B, fixed
  /// point): what the frame sources do with video and photos.
  kColor,
  /// The decoder's own grey (cv::IMREAD_GRAYSCALE; for a JPEG its luma channel directly).
  kDecoder,
};

/// The image at `path` as a CV_8UC1 matrix (EXIF orientation applied, as cv::imread does).
/// Throws InputError naming the file when it is missing or cannot be decoded.
cv::Mat ReadGrayImage(const std::filesystem::path& path, GrayFrom how = GrayFrom::kColor);

}  // namespace aerovo
