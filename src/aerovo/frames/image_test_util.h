// Test helpers of the frames module (used by *_test.cc only): random-texture images and JPEGs
// with EXIF/XMP tags written through Exiv2. Temporary folders and InputError checks:
// telemetry/io_test_util.h.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>

namespace aerovo::io_test {

/// Random-texture BGR image (deterministic for a seed).
inline cv::Mat TextureImage(int width, int height, unsigned seed) {
  cv::Mat m(height, width, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

/// Writes `image` as a JPEG at `path`, then sets the given EXIF tags (key -> value text in
/// Exiv2's notation, e.g. {"Exif.GPSInfo.GPSLatitude", "43/1 30/1 0/1"}) and XMP tags.
inline void WriteJpegWithTags(const std::filesystem::path& path, const cv::Mat& image,
                              const std::map<std::string, std::string>& exif_tags,
                              const std::map<std::string, std::string>& xmp_tags = {}) {
  cv::imwrite(path.string(), image);
  auto img = Exiv2::ImageFactory::open(path.string());
  img->readMetadata();
  Exiv2::ExifData exif = img->exifData();
  for (const auto& [k, v] : exif_tags) exif[k] = v;
  img->setExifData(exif);
  if (!xmp_tags.empty()) {
    Exiv2::XmpProperties::registerNs("http://www.dji.com/drone-dji/1.0/", "drone-dji");
    Exiv2::XmpData xmp = img->xmpData();
    for (const auto& [k, v] : xmp_tags) xmp[k] = v;
    img->setXmpData(xmp);
  }
  img->writeMetadata();
}

}  // namespace aerovo::io_test

#pragma GCC diagnostic pop
