#include "aerovo/io/image_file.h"

#include <system_error>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"

namespace aerovo {

cv::Mat ReadGrayImage(const std::filesystem::path& path, GrayFrom how) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(path.string() + ": cannot read image (no such file)");
  }
  cv::Mat gray;
  if (how == GrayFrom::kDecoder) {
    gray = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  } else {
    const cv::Mat bgr = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (!bgr.empty()) cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  }
  if (gray.empty()) {
    throw InputError(path.string() + ": cannot read image (not decodable)");
  }
  return gray;
}

}  // namespace aerovo
