#include "aerovo/frames/image_file.h"

#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::image_file_test {
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

// Writes the first `fraction` of `from`'s bytes to `to`.
void WriteCut(const std::filesystem::path& from, const std::filesystem::path& to, double fraction) {
  std::ifstream in(from, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(to, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * fraction));
}

TEST(ImageFile, CheckFindsEmptyForeignAndCutFiles) {
  TempDir dir("aerovo_image_check");
  cv::Mat bgr(120, 160, CV_8UC3);
  cv::RNG rng(5);
  rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
  for (const char* ext : {".jpg", ".png", ".tif"}) {
    const std::filesystem::path whole = dir / (std::string("whole") + ext);
    ASSERT_TRUE(cv::imwrite(whole.string(), bgr));
    const ImageFileCheck ok = CheckImageFile(whole);
    EXPECT_TRUE(ok.problem.empty()) << ext << ": " << ok.problem;
    EXPECT_FALSE(ok.truncated) << ext;
    EXPECT_EQ(ok.size_bytes, std::filesystem::file_size(whole));
    const std::filesystem::path cut = dir / (std::string("cut") + ext);
    WriteCut(whole, cut, 0.6);
    const ImageFileCheck c = CheckImageFile(cut);
    EXPECT_EQ(c.format, ok.format) << ext;
    if (std::string(ext) != ".tif") {  // TIFF has no end marker
      EXPECT_TRUE(c.truncated) << ext;
      EXPECT_NE(c.problem.find("truncated"), std::string::npos) << c.problem;
      // ReadGrayImage refuses a cut file instead of returning a grey-filled image.
      const std::string m = MessageOf(cut);
      EXPECT_NE(m.find(cut.string()), std::string::npos) << m;
      EXPECT_NE(m.find("truncated"), std::string::npos) << m;
    }
  }
  EXPECT_EQ(CheckImageFile(dir / "whole.jpg").format, "jpeg");
  EXPECT_EQ(CheckImageFile(dir / "whole.png").format, "png");
  EXPECT_EQ(CheckImageFile(dir / "whole.tif").format, "tiff");
  // A JPEG padded with zeros after its end marker (some cameras pad to a block) is whole.
  {
    std::ifstream in(dir / "whole.jpg", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    bytes.append(300, '\0');
    std::ofstream(dir / "padded.jpg", std::ios::binary) << bytes;
    EXPECT_TRUE(CheckImageFile(dir / "padded.jpg").problem.empty());
    // Data appended after the image (a phone's motion-photo video): whole, found by walking
    // the marker segments; the same cut inside the image is truncated.
    std::string appended = bytes.substr(0, bytes.size() - 300);
    appended += "ftypmp42 a video of 5000 bytes ";
    appended.append(5000, '\x5a');
    std::ofstream(dir / "motion.jpg", std::ios::binary) << appended;
    EXPECT_TRUE(CheckImageFile(dir / "motion.jpg").problem.empty())
        << CheckImageFile(dir / "motion.jpg").problem;
    std::string cut_inside = bytes.substr(0, bytes.size() * 2 / 3);
    cut_inside.append(5000, '\x5a');
    std::ofstream(dir / "cut_inside.jpg", std::ios::binary) << cut_inside;
    EXPECT_TRUE(CheckImageFile(dir / "cut_inside.jpg").truncated);
  }
  std::ofstream(dir / "empty.jpg").close();
  const ImageFileCheck e = CheckImageFile(dir / "empty.jpg");
  EXPECT_EQ(e.size_bytes, 0u);
  EXPECT_NE(e.problem.find("empty (0 bytes)"), std::string::npos) << e.problem;
  std::ofstream(dir / "text.jpg") << "GPS log, not a photo\n";
  const ImageFileCheck t = CheckImageFile(dir / "text.jpg");
  EXPECT_EQ(t.format, "");
  EXPECT_NE(t.problem.find("not an image"), std::string::npos) << t.problem;
  EXPECT_NE(MessageOf(dir / "empty.jpg").find("empty (0 bytes)"), std::string::npos);
  EXPECT_FALSE(CheckImageFile(dir / "missing.jpg").problem.empty());
}

}  // namespace
}  // namespace aerovo::image_file_test
