#include "aerovo/frames/image_file.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <system_error>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/imageio/image_io.h"

namespace aerovo {
namespace {

// Walks the JPEG's marker segments from the start (done only for a file whose last bytes are
// not FF D9: data appended after the image, such as a phone's motion-photo video, or a cut
// file): true when the main image's end-of-image marker comes before the end of the file.
bool JpegReachesEndOfImage(std::ifstream& in, std::uintmax_t size) {
  std::vector<unsigned char> d(static_cast<std::size_t>(size));
  in.clear();
  in.seekg(0);
  in.read(reinterpret_cast<char*>(d.data()), static_cast<std::streamsize>(d.size()));
  if (static_cast<std::size_t>(in.gcount()) != d.size()) return false;
  std::size_t i = 2;  // after SOI
  while (true) {
    if (i >= d.size() || d[i] != 0xFF) return false;  // not at a marker: damaged or cut
    while (i < d.size() && d[i] == 0xFF) ++i;         // fill bytes
    if (i >= d.size()) return false;
    const unsigned char code = d[i++];
    if (code == 0xD9) return true;                                // EOI
    if (code == 0x01 || (code >= 0xD0 && code <= 0xD7)) continue;  // TEM, RSTn: no length
    if (i + 2 > d.size()) return false;
    const std::size_t length = (static_cast<std::size_t>(d[i]) << 8) | d[i + 1];
    if (length < 2) return false;
    i += length;
    if (code == 0xDA) {
      // Entropy-coded data after SOS: up to the next marker that is neither a stuffed FF 00 nor
      // a restart marker (FF D0..D7); that marker is read by the loop.
      while (i + 1 < d.size()) {
        if (d[i] == 0xFF && d[i + 1] != 0x00 && !(d[i + 1] >= 0xD0 && d[i + 1] <= 0xD7)) break;
        ++i;
      }
      if (i + 1 >= d.size()) return false;
    }
  }
}

// Big-endian (`big`) or little-endian unsigned integer of `n` bytes at `p`.
std::uint32_t Unsigned(const unsigned char* p, int n, bool big) {
  std::uint32_t v = 0;
  for (int k = 0; k < n; ++k)
    v |= static_cast<std::uint32_t>(p[big ? k : n - 1 - k]) << (8 * (n - 1 - k));
  return v;
}

// `n` bytes at `offset`; false when the file has not that many there.
bool ReadAt(std::ifstream& in, std::uintmax_t offset, unsigned char* out, std::size_t n) {
  in.clear();
  in.seekg(static_cast<std::streamoff>(offset));
  in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
  return static_cast<std::size_t>(in.gcount()) == n;
}

// The pixel size in the header of a file of `format` (ITU-T T.81 B.2.2 SOFn: height, width after
// the precision byte; PNG specification 11.2.2 IHDR; TIFF 6.0 section 2 IFD0 tags 256 and 257,
// SHORT or LONG): 0 x 0 when not found. The JPEG's marker segments before its first frame
// header are stepped over by their lengths (at most 256: EXIF, XMP, ICC, MPF, makers' APPn).
void ReadPixelSize(std::ifstream& in, ImageFileCheck* c) {
  std::array<unsigned char, 24> b{};
  if (c->format == "png") {
    if (ReadAt(in, 8, b.data(), 24) && std::memcmp(b.data() + 4, "IHDR", 4) == 0) {
      c->width_px = Unsigned(b.data() + 8, 4, true);
      c->height_px = Unsigned(b.data() + 12, 4, true);
    }
  } else if (c->format == "jpeg") {
    std::uintmax_t at = 2;  // after SOI
    for (int segment = 0; segment < 256 && ReadAt(in, at, b.data(), 2) && b[0] == 0xFF; ++segment) {
      const unsigned char code = b[1];
      if (code == 0xFF) {  // a fill byte
        ++at;
        continue;
      }
      if (code == 0x01 || (code >= 0xD0 && code <= 0xD8)) {  // TEM, RSTn, SOI: no length
        at += 2;
        continue;
      }
      if (code == 0xDA || code == 0xD9) return;  // a scan or the end before any frame header
      if (!ReadAt(in, at + 2, b.data(), 7)) return;
      const bool sof = code >= 0xC0 && code <= 0xCF && code != 0xC4 && code != 0xC8 &&
                       code != 0xCC;  // not DHT, JPG, DAC
      if (sof) {
        c->height_px = Unsigned(b.data() + 3, 2, true);
        c->width_px = Unsigned(b.data() + 5, 2, true);
        return;
      }
      at += 2 + Unsigned(b.data(), 2, true);
    }
  } else if (c->format == "tiff") {
    if (!ReadAt(in, 0, b.data(), 8)) return;
    const bool big = b[0] == 'M';
    const std::uint32_t ifd = Unsigned(b.data() + 4, 4, big);
    if (!ReadAt(in, ifd, b.data(), 2)) return;
    const std::uint32_t n = std::min<std::uint32_t>(Unsigned(b.data(), 2, big), 1024);
    for (std::uint32_t k = 0; k < n && ReadAt(in, ifd + 2 + 12ull * k, b.data(), 12); ++k) {
      const std::uint32_t tag = Unsigned(b.data(), 2, big), type = Unsigned(b.data() + 2, 2, big);
      if ((tag != 256 && tag != 257) || (type != 3 && type != 4)) continue;
      const std::uint32_t v =
          type == 3 ? Unsigned(b.data() + 8, 2, big) : Unsigned(b.data() + 8, 4, big);
      (tag == 256 ? c->width_px : c->height_px) = v;
    }
  }
}

}  // namespace

ImageFileCheck CheckImageFile(const std::filesystem::path& path) {
  ImageFileCheck c;
  std::error_code ec;
  c.size_bytes = std::filesystem::file_size(path, ec);
  if (ec) {
    c.problem = "cannot be read (" + ec.message() + ")";
    return c;
  }
  if (c.size_bytes == 0) {
    c.problem = "the file is empty (0 bytes)";
    return c;
  }
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 8> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  const std::size_t got = static_cast<std::size_t>(in.gcount());
  if (!in && got == 0) {
    c.problem = "cannot be read";
    return c;
  }
  static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (got >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF) {
    c.format = "jpeg";
  } else if (got >= 8 && std::memcmp(head.data(), kPng, 8) == 0) {
    c.format = "png";
  } else if (got >= 4 && ((head[0] == 'I' && head[1] == 'I' && head[2] == 42 && head[3] == 0) ||
                          (head[0] == 'M' && head[1] == 'M' && head[2] == 0 && head[3] == 42))) {
    c.format = "tiff";
  } else {
    c.problem = "not an image (no JPEG, PNG or TIFF signature at its start)";
    return c;
  }
  ReadPixelSize(in, &c);
  const double pixels = static_cast<double>(c.width_px) * c.height_px;
  if (pixels > kMaxImagePixels) {
    c.problem = fmt::format(
        "its header says {} x {} px ({:.0f} megapixels), more than the {:.0f} megapixels aerovo "
        "decodes (kMaxImagePixels; the largest UAV camera's photos have 151): not a camera's "
        "photo",
        c.width_px, c.height_px, pixels / 1e6, kMaxImagePixels / 1e6);
    return c;
  }
  if (c.format == "tiff") return c;
  // The last 4 KiB: enough for a JPEG's zero padding (some cameras pad to a block size) and
  // for the 12-byte IEND chunk.
  const std::uintmax_t tail_size = std::min<std::uintmax_t>(c.size_bytes, 4096);
  std::vector<unsigned char> tail(static_cast<std::size_t>(tail_size));
  in.clear();
  in.seekg(static_cast<std::streamoff>(c.size_bytes - tail_size));
  in.read(reinterpret_cast<char*>(tail.data()), static_cast<std::streamsize>(tail.size()));
  if (static_cast<std::size_t>(in.gcount()) != tail.size()) {
    c.problem = "cannot be read to its end";
    return c;
  }
  std::size_t end = tail.size();
  if (c.format == "jpeg") {
    while (end > 0 && tail[end - 1] == 0x00) --end;
    if ((end < 2 || tail[end - 2] != 0xFF || tail[end - 1] != 0xD9) &&
        !JpegReachesEndOfImage(in, c.size_bytes)) {
      c.truncated = true;
      c.problem = "truncated (the JPEG ends before its end-of-image marker FF D9)";
    }
  } else {  // png: ... length 0, "IEND", CRC AE 42 60 82
    static constexpr unsigned char kIend[8] = {'I', 'E', 'N', 'D', 0xAE, 0x42, 0x60, 0x82};
    if (end < 8 || std::memcmp(tail.data() + end - 8, kIend, 8) != 0) {
      c.truncated = true;
      c.problem = "truncated (the PNG does not end with its IEND chunk)";
    }
  }
  return c;
}

cv::Mat ToEightBit(const cv::Mat& image) {
  if (image.empty() || image.depth() == CV_8U) return image;
  constexpr double kLowQuantile = 0.001, kHighQuantile = 0.999;
  double lo = 0.0, hi = 0.0;
  cv::Mat values = image;
  if (image.depth() == CV_16U) {
    // A histogram of the 65536 values (one pass over the samples; the mapping is the second).
    std::vector<std::uint32_t> histogram(65536, 0);
    const int row_samples = image.cols * image.channels();
    for (int y = 0; y < image.rows; ++y) {
      const auto* row = image.ptr<std::uint16_t>(y);
      for (int x = 0; x < row_samples; ++x) ++histogram[row[x]];
    }
    const double total = static_cast<double>(image.total()) * image.channels();
    const double low_count = kLowQuantile * total, high_count = kHighQuantile * total;
    double seen = 0.0;
    bool have_lo = false;
    for (int v = 0; v < 65536; ++v) {
      seen += histogram[v];
      if (!have_lo && seen > low_count) {
        lo = v;
        have_lo = true;
      }
      if (seen >= high_count) {
        hi = v;
        break;
      }
    }
  } else {
    image.convertTo(values, CV_MAKETYPE(CV_32F, image.channels()));
    std::vector<float> finite;
    finite.reserve(values.total() * values.channels());
    for (int y = 0; y < values.rows; ++y) {
      const float* row = values.ptr<float>(y);
      for (int x = 0; x < values.cols * values.channels(); ++x) {
        if (std::isfinite(row[x])) finite.push_back(row[x]);
      }
    }
    if (!finite.empty()) {
      const auto at = [&](double q) {
        const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(finite.size() - 1));
        std::nth_element(finite.begin(), finite.begin() + k, finite.end());
        return static_cast<double>(finite[static_cast<std::size_t>(k)]);
      };
      lo = at(kLowQuantile);
      hi = at(kHighQuantile);
    }
    cv::patchNaNs(values, lo);
  }
  cv::Mat out;
  if (hi > lo) {
    const double scale = 255.0 / (hi - lo);
    values.convertTo(out, CV_MAKETYPE(CV_8U, image.channels()), scale, -lo * scale);
  } else {
    out = cv::Mat::zeros(image.size(), CV_MAKETYPE(CV_8U, image.channels()));
  }
  return out;
}

cv::Mat ReadGrayImage(const std::filesystem::path& path, GrayFrom how) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(path.string() + ": cannot read image (no such file)");
  }
  const ImageFileCheck check = CheckImageFile(path);
  if (!check.problem.empty()) {
    throw InputError(path.string() + ": cannot read image (not decodable): " + check.problem);
  }
  cv::Mat gray;
  if (how == GrayFrom::kDecoder) {
    gray = ToEightBit(imageio::Read(path.string(), cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH));
  } else {
    const cv::Mat bgr =
        ToEightBit(imageio::Read(path.string(), cv::IMREAD_COLOR | cv::IMREAD_ANYDEPTH));
    if (!bgr.empty()) cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  }
  if (gray.empty()) {
    throw InputError(path.string() + ": cannot read image (not decodable)");
  }
  return gray;
}

}  // namespace aerovo
