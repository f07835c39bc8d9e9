#include "aerovo/frames/image_file.h"

#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/frame_source.h"
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

// More than 8 bits per sample: the image's own 0.1-99.9 % range onto 0-255, linearly.
TEST(ImageFile, ToEightBitMapsTheImagesOwnRange) {
  // A thermal-like 16-bit frame: 10000 samples 7000..7399 (25 of each value) and one hot pixel.
  cv::Mat thermal(100, 100, CV_16UC1);
  for (int i = 0; i < 10000; ++i) thermal.at<std::uint16_t>(i / 100, i % 100) = 7000 + i % 400;
  thermal.at<std::uint16_t>(0, 0) = 65000;
  const cv::Mat t8 = ToEightBit(thermal);
  ASSERT_EQ(t8.type(), CV_8UC1);
  // The 0.1 % quantile is the 10th sample (value 7000), the 99.9 % the 9990th (7399): the hot
  // pixel is clipped, not the top of the range.
  EXPECT_EQ(t8.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(t8.at<std::uint8_t>(0, 1), 1);  // 7001: round(255 / 399)
  EXPECT_EQ(t8.at<std::uint8_t>(0, 2), 1);
  EXPECT_EQ(t8.at<std::uint8_t>(2, 0), 128);   // 7200: round(200 * 255 / 399) = 127.8
  EXPECT_EQ(t8.at<std::uint8_t>(3, 99), 255);  // 7399
  // OpenCV's own conversion (the high byte) left this frame at 27-28 (and the hot pixel 253).
  cv::Mat high_byte;
  thermal.convertTo(high_byte, CV_8U, 1.0 / 256.0);
  double lo = 0, hi = 0;
  cv::minMaxLoc(high_byte(cv::Rect(1, 1, 99, 99)), &lo, &hi);
  EXPECT_GE(lo, 27.0);
  EXPECT_LE(hi, 29.0);

  // Three channels share one range; float samples with NaN (the low end) and one value.
  cv::Mat colour(1, 1000, CV_16UC3);
  for (int i = 0; i < 1000; ++i) colour.at<cv::Vec3w>(0, i) = cv::Vec3w(100, 100 + i, 1099);
  const cv::Mat c8 = ToEightBit(colour);
  ASSERT_EQ(c8.type(), CV_8UC3);
  EXPECT_EQ(c8.at<cv::Vec3b>(0, 500), cv::Vec3b(0, 128, 255));
  cv::Mat f(1, 1001, CV_32FC1);
  for (int i = 0; i < 1001; ++i) f.at<float>(0, i) = 20.0f + 0.01f * static_cast<float>(i);
  f.at<float>(0, 7) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat f8 = ToEightBit(f);
  ASSERT_EQ(f8.type(), CV_8UC1);
  EXPECT_EQ(f8.at<std::uint8_t>(0, 7), 0);
  EXPECT_EQ(f8.at<std::uint8_t>(0, 500), 128);
  EXPECT_EQ(cv::countNonZero(ToEightBit(cv::Mat(5, 5, CV_16UC1, cv::Scalar(4000)))), 0);
  const cv::Mat eight(3, 3, CV_8UC1, cv::Scalar(7));
  EXPECT_EQ(ToEightBit(eight).data, eight.data);  // 8 bits: the same matrix
}

// A 16-bit TIFF with 12 bits of data, read as grey: its range, not the high byte (0-15).
TEST(ImageFile, SixteenBitTiffReadsAsItsOwnRange) {
  TempDir dir("aerovo_image_16bit");
  cv::Mat ramp(16, 256, CV_16UC1);
  for (int x = 0; x < 256; ++x) ramp.col(x).setTo(16 * x);
  ASSERT_TRUE(cv::imwrite((dir / "band.tif").string(), ramp));
  for (const GrayFrom how : {GrayFrom::kColor, GrayFrom::kDecoder}) {
    const cv::Mat g = ReadGrayImage(dir / "band.tif", how);
    ASSERT_EQ(g.type(), CV_8UC1);
    EXPECT_LE(g.at<std::uint8_t>(0, 1), 1);
    EXPECT_EQ(g.at<std::uint8_t>(0, 128), 128);
    EXPECT_EQ(g.at<std::uint8_t>(0, 255), 255);
  }
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
    EXPECT_EQ(ok.width_px, 160u) << ext;
    EXPECT_EQ(ok.height_px, 120u) << ext;
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

// The bytes of a PNG whose IHDR says w x h, with an empty IDAT and its IEND: what the header
// check reads, not a decodable image.
std::string PngHeader(std::uint32_t w, std::uint32_t h) {
  const auto be32 = [](std::uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  std::string png("\x89PNG\r\n\x1a\n", 8);
  png += be32(13) + "IHDR" + be32(w) + be32(h) + std::string("\x08\x00\x00\x00\x00", 5) + be32(0);
  png += be32(0) + "IDAT" + be32(0);
  png += be32(0) + "IEND" + std::string("\xae\x42\x60\x82", 4);
  return png;
}

// A TIFF header and a first IFD of ImageWidth and ImageLength (LONG), in either byte order.
std::string TiffHeader(std::uint32_t w, std::uint32_t h, bool big_endian) {
  const auto put = [big_endian](std::uint32_t v, int n) {
    std::string b(static_cast<std::size_t>(n), '\0');
    for (int k = 0; k < n; ++k) {
      b[static_cast<std::size_t>(big_endian ? n - 1 - k : k)] = static_cast<char>(v >> (8 * k));
    }
    return b;
  };
  std::string t = big_endian ? std::string("MM") : std::string("II");
  t += put(42, 2) + put(8, 4) + put(2, 2);
  t += put(256, 2) + put(4, 2) + put(1, 4) + put(w, 4);
  t += put(257, 2) + put(4, 2) + put(1, 4) + put(h, 4);
  return t + put(0, 4);
}

TEST(ImageFile, AHeaderAskingForMorePixelsThanAnyCameraIsRefusedBeforeDecoding) {
  TempDir dir("aerovo_image_bomb");
  const auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir / name, std::ios::binary) << bytes;
    return dir / name;
  };
  // A PNG of 30000 x 30000 (900 MP): two of them, 875 KB each of compressed zeros, took the
  // build before this check 81 s and 8 GB to run. The header alone is refused.
  const auto png = write("bomb.png", PngHeader(30000, 30000));
  const ImageFileCheck p = CheckImageFile(png);
  EXPECT_EQ(p.width_px, 30000u);
  EXPECT_EQ(p.height_px, 30000u);
  EXPECT_NE(p.problem.find("its header says 30000 x 30000 px (900 megapixels), more than the "
                           "200 megapixels aerovo decodes"),
            std::string::npos)
      << p.problem;
  const std::string m = MessageOf(png);
  EXPECT_NE(m.find(png.string()), std::string::npos) << m;
  EXPECT_NE(m.find("900 megapixels"), std::string::npos) << m;
  // The largest UAV camera's size is not refused by the check (its header, no pixels).
  const ImageFileCheck large = CheckImageFile(write("iXM.png", PngHeader(14204, 10652)));
  EXPECT_TRUE(large.problem.empty()) << large.problem;
  EXPECT_EQ(large.width_px, 14204u);

  // A JPEG whose frame header (SOF0) says 65000 x 65000, after its APP segments.
  cv::Mat bgr(48, 64, CV_8UC3, cv::Scalar(40, 90, 160));
  std::vector<unsigned char> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg));
  const std::string whole(jpeg.begin(), jpeg.end());
  const ImageFileCheck j = CheckImageFile(write("small.jpg", whole));
  EXPECT_EQ(j.width_px, 64u);
  EXPECT_EQ(j.height_px, 48u);
  std::string huge = whole;
  const std::size_t sof = huge.find("\xff\xc0");
  ASSERT_NE(sof, std::string::npos);
  huge.replace(sof + 5, 4, std::string("\xfd\xe8\xfd\xe8", 4));  // height, width 65000
  const ImageFileCheck hj = CheckImageFile(write("huge.jpg", huge));
  EXPECT_EQ(hj.width_px, 65000u);
  EXPECT_NE(hj.problem.find("65000 x 65000 px (4225 megapixels)"), std::string::npos) << hj.problem;

  // TIFF, little- and big-endian.
  for (const bool big : {false, true}) {
    const ImageFileCheck t = CheckImageFile(write("huge.tif", TiffHeader(100000, 20000, big)));
    EXPECT_EQ(t.format, "tiff");
    EXPECT_EQ(t.width_px, 100000u) << big;
    EXPECT_EQ(t.height_px, 20000u) << big;
    EXPECT_NE(t.problem.find("(2000 megapixels)"), std::string::npos) << t.problem;
  }

  // A folder holding one is refused when it is opened, naming it, before any photo is decoded.
  const std::filesystem::path folder = dir / "flight";
  std::filesystem::create_directory(folder);
  ASSERT_TRUE(cv::imwrite((folder / "DJI_0001.JPG").string(), bgr));
  std::filesystem::copy_file(png, folder / "DJI_0002.PNG");
  try {
    ImageFolderSource source(folder);
    ADD_FAILURE() << "the folder was opened";
  } catch (const InputError& e) {
    const std::string f = e.what();
    EXPECT_NE(f.find("photo '" + (folder / "DJI_0002.PNG").string() +
                     "': its header says 30000 "
                     "x 30000 px"),
              std::string::npos)
        << f;
  }
}

TEST(ImageFile, HeaderSizeOfRealPhotosIsTheirDecodedSize) {
  AEROVO_REQUIRE_SHARED(flights, "data/flights");
  AEROVO_REQUIRE_SHARED(graf, "data/oxford/graf/img1.png");
  std::vector<std::filesystem::path> photos = {graf};
  for (const char* p : {"brighton-phantom3-16x9/DJI_0018.JPG", "tampa-phantom3/DJI_0054.JPG",
                        "turin-p4m/DJI_0010.JPG"}) {
    photos.push_back(flights / p);
  }
  for (const auto& p : photos) {
    ASSERT_TRUE(std::filesystem::exists(p)) << p;
    const ImageFileCheck c = CheckImageFile(p);
    const cv::Mat decoded =
        cv::imread(p.string(), cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION);
    EXPECT_TRUE(c.problem.empty()) << p << ": " << c.problem;
    EXPECT_EQ(c.width_px, static_cast<std::uint32_t>(decoded.cols)) << p;
    EXPECT_EQ(c.height_px, static_cast<std::uint32_t>(decoded.rows)) << p;
  }
}

}  // namespace
}  // namespace aerovo::image_file_test
