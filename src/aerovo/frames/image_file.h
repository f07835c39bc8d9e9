// Reading one image file as 8-bit grey: the one helper of the CLI (aerovo features,
// aerovo correspondence) and the benchmarks. Runs read frames through frame_source.h instead.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

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

/// What the bytes of an image file say before it is decoded (its first 8 and last 4096 bytes:
/// a few microseconds whatever the file's size; the whole file only for a JPEG that does not
/// end with FF D9).
struct ImageFileCheck {
  /// "jpeg", "png", "tiff" from the file's signature; "" when it is none of them.
  std::string format;
  std::uintmax_t size_bytes = 0;
  /// The file ends before its format's end: a JPEG without the end-of-image marker FF D9 of its
  /// main image (its last bytes, trailing zero padding ignored, are checked; only when they are
  /// not FF D9, e.g. data appended after the image as in phones' motion photos, is the file read
  /// and its marker segments walked), a PNG without its IEND chunk at the end.
  /// Decoders fill the missing part (libjpeg: grey, after its own unnamed "Premature end of
  /// JPEG file") or fail (libpng). TIFF has no end marker: a cut TIFF fails to decode.
  bool truncated = false;
  /// The pixel size the header gives (JPEG: the main image's SOFn frame header; PNG: IHDR; TIFF:
  /// the first IFD's ImageWidth and ImageLength); 0 when the header does not say it where read.
  std::uint32_t width_px = 0, height_px = 0;
  /// "" when the file looks whole, else what is wrong: "the file is empty (0 bytes)", "not an
  /// image (no JPEG, PNG or TIFF signature)", "truncated (...)", "cannot be read".
  std::string problem;
};

/// The most pixels a photo or a video frame may have: 200 megapixels, above the largest camera
/// flown on UAVs (Phase One iXM-RS150F, 14204 x 10652 = 151 MP, Phase One's data sheet). A
/// photo whose header says more is not decoded (CheckImageFile's problem), nor a video whose
/// stream says more (frames/video_decoder.h): the header of a PNG of a few hundred kilobytes of
/// compressed zeros can ask for gigabytes (a decompression bomb; BENCHMARKS.md "Hostile inputs:
/// maps, videos and photo headers" has what one cost before this check).
inline constexpr double kMaxImagePixels = 200e6;

/// Checks the file at `path` (see ImageFileCheck); `problem` also says a pixel size over
/// kMaxImagePixels. Never throws for a bad file.
ImageFileCheck CheckImageFile(const std::filesystem::path& path);

/// An image of more than 8 bits per sample as 8 bits (the same channels): a photo of a
/// multispectral band or a radiometric thermal camera (16-bit TIFFs: MicaSense writes 12 bits
/// shifted into 16, a thermal frame spans a few hundred counts of 65536). Its own range from
/// the 0.1 % to the 99.9 % quantile of its samples is mapped linearly onto 0-255 (clipped), so
/// that a few saturated or dead pixels do not set it; NaN samples become the low end, an image
/// of one value all 0. OpenCV's own conversion (cv::imread without IMREAD_ANYDEPTH) keeps the
/// high byte, which leaves such photos nearly uniform. A CV_8U image is returned as it is.
cv::Mat ToEightBit(const cv::Mat& image);

/// The image at `path` as a CV_8UC1 matrix (EXIF orientation applied, as cv::imread does; more
/// than 8 bits per sample through ToEightBit).
/// Throws InputError naming the file when it is missing, empty, not an image, cut short
/// (CheckImageFile: a truncated file is an error here, not a grey-filled image) or cannot be
/// decoded.
cv::Mat ReadGrayImage(const std::filesystem::path& path, GrayFrom how = GrayFrom::kColor);

}  // namespace aerovo
