#include "aerovo/eval/oxford_dataset.h"

#include <gtest/gtest.h>

#include <fstream>
#include <functional>

#include <opencv2/imgcodecs.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::oxford_dataset_test {
namespace {

namespace fs = std::filesystem;

class OxfordDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() /
        ("aerovo_oxford_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "seq");
  }
  void TearDown() override { fs::remove_all(dir_); }

  void WriteFile(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }
  void WriteImage(int n, int w, int h) {
    cv::Mat img(h, w, CV_8UC3, cv::Scalar(10, 20, 30));
    ASSERT_TRUE(cv::imwrite((dir_ / "seq" / ("img" + std::to_string(n) + ".png")).string(), img));
  }
  static std::string Message(const std::function<void()>& f) {
    try {
      f();
    } catch (const InputError& e) {
      return e.what();
    }
    return "(no InputError)";
  }

  fs::path dir_;
};

TEST_F(OxfordDatasetTest, ReadsHomographyRowMajorAndNormalises) {
  WriteFile(dir_ / "H", "  2 0 10\n0 2 -4\n0 0 2\n");
  const cv::Matx33d h = ReadOxfordHomography(dir_ / "H");
  EXPECT_DOUBLE_EQ(h(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(h(0, 2), 5.0);
  EXPECT_DOUBLE_EQ(h(1, 2), -2.0);
  EXPECT_DOUBLE_EQ(h(2, 2), 1.0);
}

TEST_F(OxfordDatasetTest, MalformedHomographiesNameFileAndProblem) {
  WriteFile(dir_ / "H8", "1 0 0 0 1 0 0 0\n");
  EXPECT_NE(Message([&] { ReadOxfordHomography(dir_ / "H8"); }).find("found 8"), std::string::npos);
  WriteFile(dir_ / "Hx", "1 0 0 0 1 zero 0 0 1\n");
  const std::string m = Message([&] { ReadOxfordHomography(dir_ / "Hx"); });
  EXPECT_NE(m.find("Hx"), std::string::npos) << m;
  EXPECT_NE(m.find("value 6"), std::string::npos) << m;
  WriteFile(dir_ / "Hs", "1 2 3 2 4 6 0 0 1\n");
  EXPECT_NE(Message([&] { ReadOxfordHomography(dir_ / "Hs"); }).find("singular"),
            std::string::npos);
  EXPECT_NE(Message([&] { ReadOxfordHomography(dir_ / "none"); }).find("not found"),
            std::string::npos);
}

TEST_F(OxfordDatasetTest, LoadsSequenceAndReportsMissingFiles) {
  WriteImage(1, 40, 30);
  WriteImage(3, 40, 30);
  WriteFile(dir_ / "seq" / "H1to3p", "1 0 3\n0 1 4\n0 0 1\n");
  const OxfordSequence s = LoadOxfordSequence(dir_ / "seq", {3});
  EXPECT_EQ(s.name, "seq");
  ASSERT_EQ(s.images.size(), 2u);
  EXPECT_EQ(s.images[0].type(), CV_8UC1);
  EXPECT_EQ(s.images[1].cols, 40);
  ASSERT_EQ(s.h_from_img1.size(), 1u);
  EXPECT_DOUBLE_EQ(s.h_from_img1[0](1, 2), 4.0);
  // img2 is missing; H1to4p is missing; target 7 is invalid; the folder may be absent.
  EXPECT_NE(Message([&] { LoadOxfordSequence(dir_ / "seq", {2}); }).find("img2.png"),
            std::string::npos);
  WriteImage(4, 40, 30);
  EXPECT_NE(Message([&] { LoadOxfordSequence(dir_ / "seq", {4}); }).find("H1to4p"),
            std::string::npos);
  EXPECT_THROW(LoadOxfordSequence(dir_ / "seq", {7}), InvalidArgument);
  EXPECT_NE(Message([&] { LoadOxfordSequence(dir_ / "absent"); }).find("folder not found"),
            std::string::npos);
  WriteFile(dir_ / "seq" / "img5.png", "not a png");
  WriteFile(dir_ / "seq" / "H1to5p", "1 0 0 0 1 0 0 0 1");
  EXPECT_NE(Message([&] { LoadOxfordSequence(dir_ / "seq", {5}); }).find("cannot decode"),
            std::string::npos);
}

TEST(OxfordDatasetShared, LoadsGraf) {
  AEROVO_REQUIRE_SHARED(graf, "data/oxford/graf/img1.png");
  const OxfordSequence s = LoadOxfordSequence(graf.parent_path());
  EXPECT_EQ(s.images.size(), 6u);
  EXPECT_EQ(s.images[0].cols, 800);
  EXPECT_EQ(s.images[0].rows, 640);
  // Values from graf/H1to2p.
  EXPECT_NEAR(s.h_from_img1[0](0, 0), 0.87976964, 1e-9);
  EXPECT_NEAR(s.h_from_img1[0](1, 2), 153.15784, 1e-6);
}

}  // namespace
}  // namespace aerovo::oxford_dataset_test
