// Test helper (used by *_test.cc only): JPEGs with an EXIF segment laid out byte for byte as
// cameras write it (TIFF 6.0 structure, little-endian), for the places Exiv2 does not write
// (tag 0x02bc in IFD0 or in the Exif sub-IFD) and for tests that do not link Exiv2.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace aerovo::io_test {

/// One entry of a TIFF IFD as a camera writes it: tag, TIFF type (1 BYTE, 2 ASCII, 4 LONG,
/// 5 RATIONAL, 7 UNDEFINED), count and the value's bytes (little-endian), or a sub-IFD (Exif
/// 0x8769, GPS 0x8825: a LONG whose value is the offset of `sub`).
struct TiffEntry {
  unsigned tag, type, count;
  std::string bytes;
  std::vector<TiffEntry> sub;
};

inline std::string Le32(unsigned v) {
  std::string b;
  for (int k = 0; k < 4; ++k) b.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  return b;
}
inline std::string Rationals(std::initializer_list<std::pair<unsigned, unsigned>> r) {
  std::string b;
  for (const auto& [n, d] : r) b += Le32(n) + Le32(d);
  return b;
}
inline TiffEntry Ascii(unsigned tag, const std::string& text) {
  return {tag, 2, static_cast<unsigned>(text.size() + 1), text + '\0', {}};
}

/// Appends the IFD `entries` (sorted by tag, as TIFF 6.0 section 2 requires) at the end of `tiff`,
/// its sub-IFDs and out-of-line values after it, word aligned; no next IFD.
inline void AppendIfd(std::string& tiff, const std::vector<TiffEntry>& entries) {
  const std::size_t ifd = tiff.size();
  tiff.resize(ifd + 2 + 12 * entries.size() + 4, '\0');
  tiff[ifd] = static_cast<char>(entries.size() & 0xff);
  tiff[ifd + 1] = static_cast<char>(entries.size() >> 8);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const TiffEntry& e = entries[i];
    std::string value = e.bytes;
    if (!e.sub.empty()) {  // pointer to a sub-IFD written here
      if (tiff.size() % 2) tiff.push_back('\0');
      value = Le32(static_cast<unsigned>(tiff.size()));
      AppendIfd(tiff, e.sub);
    }
    std::string field;
    field += static_cast<char>(e.tag & 0xff);
    field += static_cast<char>(e.tag >> 8);
    field += static_cast<char>(e.type & 0xff);
    field += static_cast<char>(e.type >> 8);
    field += Le32(e.count);
    if (value.size() <= 4) {  // a value of up to 4 bytes sits in the entry itself
      value.resize(4, '\0');
      field += value;
    } else {
      if (tiff.size() % 2) tiff.push_back('\0');
      field += Le32(static_cast<unsigned>(tiff.size()));
      tiff += value;
    }
    tiff.replace(ifd + 2 + 12 * i, 12, field);
  }
}

/// A JPEG of `image` whose only metadata is one APP1 Exif segment right after the SOI, holding the
/// little-endian TIFF structure with IFD0 `ifd0` (no APP1 XMP segment). Exiv2 drops unknown and
/// 0x02bc tags when it writes a JPEG, so the segment is laid out here byte for byte, as the
/// cameras write it, and put into an OpenCV JPEG.
inline std::vector<std::uint8_t> JpegWithExif(const cv::Mat& image,
                                              const std::vector<TiffEntry>& ifd0) {
  std::string tiff = {'I', 'I', 42, 0, 8, 0, 0, 0};
  AppendIfd(tiff, ifd0);
  std::string app1 = {'\xff', '\xe1', 0, 0, 'E', 'x', 'i', 'f', 0, 0};
  app1 += tiff;
  const std::size_t len = app1.size() - 2;
  app1[2] = static_cast<char>(len >> 8);
  app1[3] = static_cast<char>(len & 0xff);
  std::vector<std::uint8_t> jpeg;
  cv::imencode(".jpg", image, jpeg);
  jpeg.insert(jpeg.begin() + 2, app1.begin(), app1.end());  // right after SOI (FF D8)
  return jpeg;
}

/// JpegWithExif written to `path`.
inline void WriteJpegWithExif(const std::filesystem::path& path, const cv::Mat& image,
                              const std::vector<TiffEntry>& ifd0) {
  const std::vector<std::uint8_t> jpeg = JpegWithExif(image, ifd0);
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
}

}  // namespace aerovo::io_test
