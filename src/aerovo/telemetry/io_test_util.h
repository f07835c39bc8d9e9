// Test helpers of the modules that read and write files (telemetry, frames, outputs,
// camera_files, pipeline; used by *_test.cc only): temporary folders and checking the message of
// an InputError. Test images with EXIF/XMP tags: frames/image_test_util.h.
#pragma once

#include <filesystem>
#include <initializer_list>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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

}  // namespace aerovo::io_test
