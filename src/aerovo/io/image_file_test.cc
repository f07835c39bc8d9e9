#include "aerovo/io/image_file.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/io/io_test_util.h"

namespace aerovo {
namespace {

using io_test::TempDir;

std::string MessageOf(const std::filesystem::path& path) {
  try {
    ReadGrayImage(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(ImageFile, ReadsGreyBothWays) {
  TempDir dir("aerovo_image_file");
  cv::Mat bgr(40, 60, CV_8UC3);
  cv::RNG rng(3);
  rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
  const std::filesystem::path png = dir / "a.png", jpg = dir / "a.jpg";
  ASSERT_TRUE(cv::imwrite(png.string(), bgr));
  ASSERT_TRUE(cv::imwrite(jpg.string(), bgr));
  // PNG is lossless: kColor is exactly cvtColor of the written pixels.
  cv::Mat want;
  cv::cvtColor(bgr, want, cv::COLOR_BGR2GRAY);
  const cv::Mat g = ReadGrayImage(png);
  ASSERT_EQ(g.type(), CV_8UC1);
  ASSERT_EQ(g.size(), bgr.size());
  EXPECT_EQ(cv::norm(g, want, cv::NORM_INF), 0.0);
  // Each way is the OpenCV call it names, on a JPEG too.
  cv::Mat jpg_color;
  cv::cvtColor(cv::imread(jpg.string(), cv::IMREAD_COLOR), jpg_color, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(ReadGrayImage(jpg, GrayFrom::kColor), jpg_color, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(ReadGrayImage(jpg, GrayFrom::kDecoder),
                     cv::imread(jpg.string(), cv::IMREAD_GRAYSCALE), cv::NORM_INF),
            0.0);
}

TEST(ImageFile, ErrorsNameTheFile) {
  TempDir dir("aerovo_image_file");
  const std::filesystem::path missing = dir / "missing.jpg";
  std::string m = MessageOf(missing);
  EXPECT_NE(m.find(missing.string()), std::string::npos) << m;
  EXPECT_NE(m.find("no such file"), std::string::npos) << m;
  const std::filesystem::path junk = dir / "junk.jpg";
  std::ofstream(junk) << "not an image";
  m = MessageOf(junk);
  EXPECT_NE(m.find(junk.string()), std::string::npos) << m;
  EXPECT_NE(m.find("not decodable"), std::string::npos) << m;
  EXPECT_THROW(ReadGrayImage(junk, GrayFrom::kDecoder), InputError);
  EXPECT_THROW(ReadGrayImage(dir.path()), InputError);  // a folder
}

}  // namespace
}  // namespace aerovo
