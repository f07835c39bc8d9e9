#include "aerovo/imageio/image_io.h"

#include <dlfcn.h>
#include <gnu/libc-version.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>  // cv::IMREAD_*, cv::IMWRITE_* (not linked: the plugin is)
#include <opencv2/videoio.hpp>    // cv::CAP_*

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::imageio {
namespace {

namespace fs = std::filesystem;

std::string Maps() { return testing::ReadText("/proc/self/maps"); }

fs::path TempDir(const std::string& name) { return testing::FreshTempDir("aerovo_imageio", name); }

cv::Mat Texture(int w, int h, int seed) {
  cv::Mat m(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      m.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>((x * 7 + y * 3 + seed) & 255),
                                        static_cast<uchar>((x * y + seed * 11) & 255),
                                        static_cast<uchar>((x + y * 5 + seed * 29) & 255));
    }
  }
  return m;
}

// First in this file so that it runs before any other test of the process has loaded the
// plugin (each test is its own process under ctest's per-test registration).
TEST(ImageIo, OpenCvsCodecsAndVideoIoAreLoadedOnlyByTheFirstUse) {
  if (PluginLoaded()) GTEST_SKIP() << "an earlier test of this process loaded the plugin";
  // Constructing a capture or writer loads nothing.
  {
    VideoCapture capture;
    VideoWriter writer;
    EXPECT_FALSE(capture.isOpened());
    cv::Mat frame(2, 2, CV_8UC1);
    EXPECT_FALSE(capture.read(frame));
    EXPECT_TRUE(frame.empty());
    EXPECT_EQ(capture.get(cv::CAP_PROP_FPS), 0.0);
    EXPECT_FALSE(writer.isOpened());
  }
  std::string maps = Maps();
  EXPECT_FALSE(PluginLoaded());
  EXPECT_EQ(maps.find("libopencv_imgcodecs"), std::string::npos);
  EXPECT_EQ(maps.find("libopencv_videoio"), std::string::npos);
  EXPECT_EQ(maps.find("aerovo_imageio_opencv"), std::string::npos);

  std::vector<unsigned char> png;
  ASSERT_TRUE(Encode(".png", Texture(16, 8, 1), png));
  EXPECT_TRUE(PluginLoaded());
  maps = Maps();
  EXPECT_NE(maps.find("libopencv_imgcodecs"), std::string::npos);
  EXPECT_NE(maps.find(PluginPath()), std::string::npos) << PluginPath();
}

TEST(ImageIo, ImagesRoundTripAsWithOpenCv) {
  const fs::path dir = TempDir("images");
  const cv::Mat bgr = Texture(40, 30, 2);
  const std::string png = (dir / "a.png").string();
  ASSERT_TRUE(Write(png, bgr));
  const cv::Mat back = Read(png, cv::IMREAD_COLOR);
  ASSERT_EQ(back.size(), bgr.size());
  EXPECT_EQ(cv::norm(back, bgr, cv::NORM_INF), 0.0);  // PNG is lossless
  const cv::Mat grey = Read(png, cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(grey.type(), CV_8UC1);
  EXPECT_EQ(grey.size(), bgr.size());

  // JPEG through memory, at the quality asked: smaller at 10 than at 95, both decodable.
  std::vector<unsigned char> q10, q95;
  ASSERT_TRUE(Encode(".jpg", bgr, q10, {cv::IMWRITE_JPEG_QUALITY, 10}));
  ASSERT_TRUE(Encode(".jpg", bgr, q95, {cv::IMWRITE_JPEG_QUALITY, 95}));
  EXPECT_LT(q10.size(), q95.size());
  const cv::Mat jpg = Decode(q95, cv::IMREAD_COLOR);
  ASSERT_EQ(jpg.size(), bgr.size());
  EXPECT_LT(cv::norm(jpg, bgr, cv::NORM_L1) / bgr.total() / 3.0, 12.0);

  // Failures as OpenCV reports them: an empty image, false, and OpenCV's own exception for a
  // format it has no encoder for (thrown inside the plugin, caught here).
  EXPECT_TRUE(Read((dir / "missing.png").string(), cv::IMREAD_COLOR).empty());
  EXPECT_TRUE(Decode({1, 2, 3, 4}, cv::IMREAD_COLOR).empty());
  EXPECT_FALSE(Write((dir / "no_such_dir" / "b.png").string(), bgr));
  EXPECT_THROW(Write((dir / "c.not_an_image_format").string(), bgr), cv::Exception);
  fs::remove_all(dir);
}

TEST(ImageIo, VideoWrittenThenReadFrameByFrame) {
  const fs::path dir = TempDir("video");
  const std::string path = (dir / "clip.avi").string();
  const int n = 6;
  {
    VideoWriter writer;
    ASSERT_TRUE(writer.open(path, cv::CAP_FFMPEG, Fourcc('M', 'J', 'P', 'G'), 10.0,
                            cv::Size(64, 48), true));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < n; ++i)
      writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(30 + 35 * i)));
    writer.release();
  }
  // "MJPG" in file order, the first character in the low byte.
  EXPECT_EQ(Fourcc('M', 'J', 'P', 'G'), 0x47504A4D);

  VideoCapture capture;
  ASSERT_TRUE(capture.open(path, cv::CAP_FFMPEG));
  ASSERT_TRUE(capture.isOpened());
  EXPECT_EQ(capture.get(cv::CAP_PROP_FRAME_WIDTH), 64.0);
  EXPECT_EQ(capture.get(cv::CAP_PROP_FRAME_HEIGHT), 48.0);
  EXPECT_NEAR(capture.get(cv::CAP_PROP_FPS), 10.0, 1e-6);
  cv::Mat frame;
  int read = 0;
  // Frame 0 with read(), the others with grab() + retrieve(): both paths of the table.
  ASSERT_TRUE(capture.read(frame));
  EXPECT_NEAR(cv::mean(frame)[0], 30.0, 3.0);
  ++read;
  while (capture.grab()) {
    ASSERT_TRUE(capture.retrieve(frame));
    EXPECT_NEAR(cv::mean(frame)[0], 30.0 + 35.0 * read, 3.0) << "frame " << read;
    ++read;
  }
  EXPECT_EQ(read, n);
  // Seeking back through set().
  EXPECT_TRUE(capture.set(cv::CAP_PROP_POS_FRAMES, 2));
  ASSERT_TRUE(capture.read(frame));
  EXPECT_NEAR(cv::mean(frame)[0], 100.0, 3.0);

  // A capture moved keeps its stream; the moved-from one is closed.
  VideoCapture moved = std::move(capture);
  EXPECT_TRUE(moved.isOpened());
  EXPECT_FALSE(capture.isOpened());  // NOLINT(bugprone-use-after-move): the state after a move

  VideoCapture none;
  EXPECT_FALSE(none.open((dir / "missing.avi").string(), cv::CAP_FFMPEG));
  EXPECT_FALSE(none.isOpened());
  fs::remove_all(dir);
}

TEST(ImageIo, AMissingPluginIsAnErrorNamingEveryPathTriedAndWhy) {
  const fs::path dir = TempDir("plugin");
  const std::string text = (dir / "not_a_library.so").string();
  std::ofstream(text) << "not an ELF file\n";
  // A shared library that is not the plugin: the C library (by a function of its own that
  // the sanitizers do not intercept, so that its address is in libc).
  Dl_info info{};
  ASSERT_NE(::dladdr(reinterpret_cast<void*>(&::gnu_get_libc_version), &info), 0);
  const std::string libc = info.dli_fname;
  const std::string missing = (dir / "missing.so").string();
  try {
    detail::OpenPlugin({missing, text, libc}, nullptr);
    FAIL() << "no error";
  } catch (const InternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(missing + ": no such file"), std::string::npos) << what;
    EXPECT_NE(what.find(text + ": "), std::string::npos) << what;
    EXPECT_NE(what.find(libc + ": not an aerovo image I/O plugin"), std::string::npos) << what;
    EXPECT_NE(what.find("AEROVO_IMAGEIO_PLUGIN"), std::string::npos) << what;
  }
  // The first that loads wins, the failures before it ignored.
  std::string from;
  const std::string& plugin = PluginPath();
  EXPECT_NE(detail::OpenPlugin({missing, text, plugin}, &from), nullptr);
  EXPECT_EQ(from, plugin);
  fs::remove_all(dir);
}

TEST(ImageIo, TheEnvironmentVariableIsTriedFirstThenTheInstalledProgramsLayout) {
  ::setenv("AEROVO_IMAGEIO_PLUGIN", "/opt/elsewhere/plugin.so", 1);
  std::vector<std::string> c = detail::PluginCandidates();
  ::unsetenv("AEROVO_IMAGEIO_PLUGIN");
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c[0], "/opt/elsewhere/plugin.so");
  // Then beside the program (<bindir>/../<libdir>/aerovo), the build tree, the configured
  // prefix; each the same file name.
  const std::string name = fs::path(c[2]).filename().string();
  EXPECT_EQ(fs::path(c[1]).filename().string(), name);
  EXPECT_EQ(fs::path(c[3]).filename().string(), name);
  EXPECT_NE(c[1].find("/aerovo/" + name), std::string::npos) << c[1];
  EXPECT_EQ(detail::PluginCandidates().size(), 3u);  // without the variable
}

}  // namespace
}  // namespace aerovo::imageio
