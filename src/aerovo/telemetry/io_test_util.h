// Test helpers of the io module (used by *_test.cc only): temporary folders, JPEGs with
// EXIF/XMP tags written through Exiv2, and checking the message of an InputError.
#pragma once

#include <filesystem>
#include <initializer_list>
#include <map>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#include <exiv2/exiv2.hpp>

#include "aerovo/core/error.h"

namespace aerovo::io_test {

/// A fresh empty folder under the system temp dir, removed on destruction.
class TempDir {
 public:
  explicit TempDir(const std::string& name) {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            (name + "_" + std::to_string(rd()) + "_" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// Expects `fn` to throw InputError whose message contains every fragment (a non-fatal
/// failure otherwise, so a test goes on to its other cases).
template <typename Fn>
void ExpectInputError(Fn fn, std::initializer_list<const char*> fragments) {
  try {
    fn();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const char* f : fragments) EXPECT_THAT(e.what(), ::testing::HasSubstr(f));
  }
}

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
