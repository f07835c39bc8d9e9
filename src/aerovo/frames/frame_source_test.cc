#include "aerovo/frames/frame_source.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/ffmpeg_test_util.h"
#include "aerovo/frames/image_test_util.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::frame_source_test {
namespace {

using io_test::ExpectInputError;
using io_test::HaveFfmpeg;
using io_test::RunFfmpeg;

using ::testing::HasSubstr;
namespace fs = std::filesystem;

double MeanGray(const GrayImage& g) {
  double sum = 0.0;
  for (int y = 0; y < g.height(); ++y) {
    for (int x = 0; x < g.width(); ++x) sum += g.at(x, y);
  }
  return sum / (static_cast<double>(g.width()) * g.height());
}

constexpr int kFrames = 20;
constexpr double kFps = 10.0;

// Frame i is uniform grey 10 + 10 i (so its index can be read back after lossy coding).
void WriteTestVideo(const std::filesystem::path& path, const char* fourcc) {
  cv::VideoWriter writer(path.string(), cv::CAP_FFMPEG,
                         cv::VideoWriter::fourcc(fourcc[0], fourcc[1], fourcc[2], fourcc[3]), kFps,
                         cv::Size(64, 48));
  ASSERT_TRUE(writer.isOpened()) << path;
  for (int i = 0; i < kFrames; ++i) {
    const int v = 10 + 10 * i;
    writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar(v, v, v)));
  }
}

void CheckStepTwo(const std::filesystem::path& path) {
  FrameSourceOptions o;
  o.step = 2;
  VideoFileSource src(path, o);
  EXPECT_EQ(src.width(), 64);
  EXPECT_EQ(src.height(), 48);
  EXPECT_NEAR(src.fps(), kFps, 1e-6);
  EXPECT_EQ(src.ExpectedFrameCount(), kFrames / 2);
  Frame f;
  std::vector<int> indices;
  while (src.Next(f)) {
    indices.push_back(f.index);
    EXPECT_NEAR(f.time_s, f.index / kFps, 1e-9);
    EXPECT_NEAR(MeanGray(f.gray), 10 + 10 * f.index, 3.0) << "frame " << f.index;
    EXPECT_EQ(f.gray.width(), 64);
    EXPECT_TRUE(f.color.empty());
    EXPECT_EQ(f.name, path.filename().string() + "#" + std::to_string(f.index));
  }
  EXPECT_EQ(indices, (std::vector<int>{0, 2, 4, 6, 8, 10, 12, 14, 16, 18}));
  EXPECT_FALSE(src.Next(f));  // stays at the end
  EXPECT_TRUE(src.warnings().empty());
}

TEST(VideoFileSource, MjpgAviStepTwo) {
  io_test::TempDir dir("aerovo_video");
  WriteTestVideo(dir / "clip.avi", "MJPG");
  CheckStepTwo(dir / "clip.avi");
}

TEST(VideoFileSource, Mp4vMp4StepTwo) {
  io_test::TempDir dir("aerovo_video");
  WriteTestVideo(dir / "clip.mp4", "mp4v");
  CheckStepTwo(dir / "clip.mp4");
}

TEST(VideoFileSource, StartEndTimesAndColour) {
  io_test::TempDir dir("aerovo_video");
  WriteTestVideo(dir / "clip.avi", "MJPG");
  FrameSourceOptions o;
  o.start_time_s = 0.5;
  o.end_time_s = 1.2;
  o.step = 3;
  o.keep_color = true;
  VideoFileSource src(dir / "clip.avi", o);
  EXPECT_EQ(src.ExpectedFrameCount(), 3);
  Frame f;
  std::vector<int> indices;
  while (src.Next(f)) {
    indices.push_back(f.index);
    EXPECT_NEAR(MeanGray(f.gray), 10 + 10 * f.index, 3.0);
    ASSERT_EQ(f.color.type(), CV_8UC3);
    EXPECT_NEAR(cv::mean(f.color)[0], 10 + 10 * f.index, 3.0);
  }
  EXPECT_EQ(indices, (std::vector<int>{5, 8, 11}));
}

TEST(VideoFileSource, BadFilesGiveClearErrors) {
  io_test::TempDir dir("aerovo_video_bad");
  std::ofstream(dir / "empty.mp4").close();
  ExpectInputError([&] { VideoFileSource s(dir / "empty.mp4"); },
                   {"cannot open video '", "empty.mp4': ", "empty (0 bytes)"});
  std::ofstream(dir / "text.mp4") << "this is a text file, not a video\n";
  ExpectInputError([&] { VideoFileSource s(dir / "text.mp4"); },
                   {"cannot open video '", "text.mp4': "});
  ExpectInputError([&] { VideoFileSource s(dir / "missing.mp4"); },
                   {"cannot open video '", "missing.mp4': no such file"});
  // A real MP4 cut in half: mp4v files keep their index (moov) at the end, so it is lost.
  WriteTestVideo(dir / "full.mp4", "mp4v");
  {
    std::ifstream in(dir / "full.mp4", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 1000u);
    std::ofstream(dir / "cut.mp4", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  ExpectInputError([&] { VideoFileSource s(dir / "cut.mp4"); },
                   {"cannot open video '", "cut.mp4': "});
  // An MJPG AVI cut in half keeps its header (frame count 20): it opens, delivers the frames
  // that are complete, then ends early with a warning.
  {
    cv::VideoWriter w((dir / "noise.avi").string(), cv::CAP_FFMPEG,
                      cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), kFps, cv::Size(64, 48));
    for (int i = 0; i < kFrames; ++i) w.write(io_test::TextureImage(64, 48, i));
  }
  {
    std::ifstream in(dir / "noise.avi", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.avi", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  VideoFileSource cut(dir / "cut.avi");
  EXPECT_EQ(cut.frame_count(), kFrames);
  Frame f;
  int n = 0;
  while (cut.Next(f)) {
    EXPECT_EQ(f.index, n);
    ++n;
  }
  EXPECT_GT(n, kFrames / 4);
  EXPECT_LT(n, kFrames * 3 / 4);
  ASSERT_EQ(cut.warnings().size(), 1u);
  EXPECT_THAT(cut.warnings()[0], HasSubstr("cut.avi"));
  EXPECT_THAT(cut.warnings()[0], HasSubstr("truncated"));
  WriteTestVideo(dir / "full.avi", "MJPG");
  FrameSourceOptions late;
  late.start_time_s = 100.0;
  ExpectInputError([&] { VideoFileSource s(dir / "full.avi", late); }, {"past the end"});
}

// An MJPG AVI of `frames` (64x48 BGR).
void WriteMjpg(const std::filesystem::path& path, const std::vector<cv::Mat>& frames) {
  cv::VideoWriter w(path.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                    kFps, cv::Size(64, 48));
  ASSERT_TRUE(w.isOpened()) << path;
  for (const cv::Mat& f : frames) w.write(f);
}

TEST(PixelHash, SamePixelsSameHashOnePixelChangesIt) {
  const GrayImage a = ToGrayImage(io_test::TextureImage(67, 31, 4));
  GrayImage b = a;
  EXPECT_EQ(PixelHash(a), PixelHash(b));
  for (const int x : {0, 7, 63, 66}) {  // in the 8-byte words and in the row tail
    b = a;
    b.at(x, 30) = static_cast<std::uint8_t>(b.at(x, 30) ^ 1);
    EXPECT_NE(PixelHash(a), PixelHash(b)) << x;
  }
  // Same bytes, other shape.
  const GrayImage c = ToGrayImage(io_test::TextureImage(32, 32, 1));
  GrayImage d(64, 16);
  std::memcpy(d.data(), c.data(), 32 * 32);
  EXPECT_NE(PixelHash(c), PixelHash(d));
}

// A repeated frame is flagged; a long run of them after motion (a decoder handing back its last
// image) stops the video with an error naming it and the frame where the image froze.
TEST(VideoFileSource, RepeatedFramesAreFlaggedAndAFrozenDecoderIsAnError) {
  io_test::TempDir dir("aerovo_video_dup");
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 12; ++i) {
    frames.push_back(io_test::TextureImage(64, 48, i));
    if (i == 4) frames.push_back(frames.back().clone());  // frame 5 repeats frame 4
  }
  WriteMjpg(dir / "dup.avi", frames);
  VideoFileSource src(dir / "dup.avi");
  Frame f;
  std::vector<int> flagged;
  int n = 0;
  while (src.Next(f)) {
    if (!f.flags.empty()) {
      EXPECT_EQ(f.flags, kFrameFlagDuplicate);
      flagged.push_back(f.index);
    }
    ++n;
  }
  EXPECT_EQ(n, 13);
  EXPECT_EQ(flagged, std::vector<int>{5});
  EXPECT_EQ(src.duplicate_frames(), 1);
  // A live source (a stream, here read from the file) flags it too: a frozen stream.
  LiveSource live((dir / "dup.avi").string());
  flagged.clear();
  while (live.Next(f)) {
    if (!f.flags.empty()) flagged.push_back(f.index);
  }
  EXPECT_EQ(flagged, std::vector<int>{5});

  // Step 2 compares delivered frames: 0 2 4 6 ... none repeats its predecessor.
  FrameSourceOptions two;
  two.step = 2;
  VideoFileSource stepped(dir / "dup.avi", two);
  while (stepped.Next(f)) EXPECT_TRUE(f.flags.empty()) << f.index;

  // Moving, then frozen: frames 6.. repeat frame 5.
  std::vector<cv::Mat> frozen;
  for (int i = 0; i < 15; ++i) frozen.push_back(io_test::TextureImage(64, 48, std::min(i, 5)));
  WriteMjpg(dir / "frozen.avi", frozen);
  VideoFileSource fs(dir / "frozen.avi");
  std::vector<int> delivered;
  ExpectInputError(
      [&] {
        while (fs.Next(f)) delivered.push_back(f.index);
      },
      {"frozen.avi", "frame 10", "same image since frame 5", "resolution change"});
  EXPECT_EQ(delivered, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_FALSE(fs.Next(f));

  // A video that never moves (a static test pattern) is flagged, not an error.
  WriteMjpg(dir / "still.avi", std::vector<cv::Mat>(10, io_test::TextureImage(64, 48, 9)));
  VideoFileSource still(dir / "still.avi");
  n = 0;
  while (still.Next(f)) {
    EXPECT_EQ(f.flags, n == 0 ? "" : kFrameFlagDuplicate) << n;
    ++n;
  }
  EXPECT_EQ(n, 10);
}

// Two recordings of different sizes concatenated into one MPEG-TS, each with its own clock.
// OpenCV keeps the first size: a larger second part comes out as copies of the first's last
// frame, a smaller one stretched to the first size. Both are an error at the join, where the
// stream's clock goes back; a video with B-frames (timestamps reordered inside the decoder)
// is not.
TEST(VideoFileSource, RecordingsJoinedIntoOneStreamAreAnErrorAtTheJoin) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_video_ts");
  const std::string small = (dir / "small.ts").string(), big = (dir / "big.ts").string();
  ASSERT_TRUE(RunFfmpeg({"-f", "lavfi", "-i", "testsrc=size=320x240:rate=10", "-t", "2", "-c:v",
                         "mpeg2video", small}));
  ASSERT_TRUE(RunFfmpeg({"-f", "lavfi", "-i", "testsrc=size=640x360:rate=10", "-t", "2", "-c:v",
                         "mpeg2video", big}));
  const auto join = [&](const std::string& name, const std::vector<std::string>& parts) {
    std::ofstream out(dir / name, std::ios::binary);
    for (const std::string& p : parts) {
      std::ifstream in(p, std::ios::binary);
      out << in.rdbuf();
    }
  };
  join("small_big.ts", {small, big});
  join("big_small.ts", {big, small});
  for (const char* name : {"small_big.ts", "big_small.ts"}) {
    VideoFileSource src(dir / name);
    Frame f;
    int n = 0;
    try {
      while (src.Next(f)) ++n;
      ADD_FAILURE() << name << ": no InputError after " << n << " frames";
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr(name));
      EXPECT_THAT(e.what(), HasSubstr("timestamps go back from 1."));
      EXPECT_THAT(e.what(), HasSubstr("recordings joined into one file"));
      // The first recording's 20 frames (FFmpeg may hold back its last one) came through.
      EXPECT_GE(n, 18) << name;
      EXPECT_LE(n, 20) << name;
    }
    EXPECT_FALSE(src.Next(f));
  }
  // H.264 with B-frames: the decoder reorders, and OpenCV reports 0 ms for its last frames; all
  // 30 frames come through.
  const std::string h264 = (dir / "bframes.mp4").string();
  if (RunFfmpeg({"-f", "lavfi", "-i", "testsrc=size=320x240:rate=10", "-t", "3", "-c:v",
                 "libx264", "-bf", "3", h264})) {
    VideoFileSource src(h264);
    Frame f;
    int n = 0;
    while (src.Next(f)) ++n;
    EXPECT_EQ(n, 30);
    EXPECT_TRUE(src.warnings().empty());
  }
}

// Rotation metadata: the frames stay as stored (not rotated to display), with a warning.
TEST(VideoFileSource, RotationMetadataIsWarnedNotApplied) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_video_rot");
  WriteTestVideo(dir / "plain.mp4", "mp4v");
  ASSERT_TRUE(RunFfmpeg({"-i", (dir / "plain.mp4").string(), "-c", "copy", "-metadata:s:v",
                         "rotate=90", (dir / "rot.mp4").string()}));
  VideoFileSource plain(dir / "plain.mp4");
  EXPECT_EQ(plain.rotation_deg(), 0);
  EXPECT_TRUE(plain.warnings().empty());
  VideoFileSource rot(dir / "rot.mp4");
  EXPECT_EQ(rot.rotation_deg(), 90);
  EXPECT_EQ(rot.width(), 64);
  EXPECT_EQ(rot.height(), 48);
  ASSERT_EQ(rot.warnings().size(), 1u);
  EXPECT_THAT(rot.warnings()[0], HasSubstr("rot.mp4"));
  EXPECT_THAT(rot.warnings()[0], HasSubstr("rotation metadata (90 degrees"));
  Frame f;
  int n = 0;
  while (rot.Next(f)) {
    EXPECT_EQ(f.gray.width(), 64);
    EXPECT_EQ(f.gray.height(), 48);
    ++n;
  }
  EXPECT_EQ(n, kFrames);
}

// Photos cut short, empty or not images: flagged or an error naming the photo and the problem.
TEST(ImageFolderSource, TruncatedEmptyAndForeignPhotos) {
  io_test::TempDir dir("aerovo_folder_cut");
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("p{}.jpg", i)).string(),
                            io_test::TextureImage(64, 48, i)));
  }
  {
    std::ifstream in(dir / "p1.jpg", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    std::ofstream(dir / "p1.jpg", std::ios::binary | std::ios::trunc)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 7 / 10));
  }
  {
    ImageFolderSource s(dir.path());
    const auto& w = s.warnings();
    EXPECT_TRUE(std::any_of(w.begin(), w.end(), [](const std::string& m) {
      return m.find("p1.jpg") != std::string::npos && m.find("truncated") != std::string::npos;
    }));
    Frame f;
    std::vector<std::string> flags;
    while (s.Next(f)) {
      flags.push_back(f.flags);
      EXPECT_EQ(f.gray.width(), 64);
    }
    EXPECT_EQ(flags, (std::vector<std::string>{"", kFrameFlagTruncated, ""}));
  }
  std::ofstream(dir / "p3.jpg").close();
  std::ofstream(dir / "p4.jpg") << "not really a jpeg";
  ImageFolderSource s(dir.path());
  Frame f;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(s.Next(f));
  ExpectInputError([&] { s.Next(f); }, {"cannot decode photo", "p3.jpg", "frame 3", "empty (0 bytes)"});
  ExpectInputError([&] { s.Next(f); }, {"cannot decode photo", "p4.jpg", "frame 4", "not an image"});
  // A PNG cut short does not decode: the error says why.
  std::filesystem::remove(dir / "p3.jpg");
  std::filesystem::remove(dir / "p4.jpg");
  io_test::TempDir png_dir("aerovo_folder_cut_png");
  ASSERT_TRUE(cv::imwrite((png_dir / "a.png").string(), io_test::TextureImage(64, 48, 1)));
  ASSERT_TRUE(cv::imwrite((png_dir / "b.png").string(), io_test::TextureImage(64, 48, 2)));
  std::filesystem::resize_file(png_dir / "b.png", std::filesystem::file_size(png_dir / "b.png") / 2);
  ImageFolderSource p(png_dir.path());
  ASSERT_TRUE(p.Next(f));
  ExpectInputError([&] { p.Next(f); }, {"cannot decode photo", "b.png", "frame 1", "truncated"});
}

// Opening a photo folder loads the image decoders (imageio/image_io.h), so that a missing
// plugin fails there and the run's frames do not pay for the loading. The images are written
// with OpenCV linked into this test, which does not load aerovo's plugin.
TEST(ImageFolderSource, OpeningTheFolderLoadsTheImageDecoders) {
  if (imageio::PluginLoaded()) GTEST_SKIP() << "an earlier test of this process loaded the plugin";
  io_test::TempDir dir("aerovo_folder_decoders");
  ASSERT_TRUE(cv::imwrite((dir / "a.png").string(), io_test::TextureImage(32, 24, 1)));
  ASSERT_TRUE(cv::imwrite((dir / "b.png").string(), io_test::TextureImage(32, 24, 2)));
  ASSERT_FALSE(imageio::PluginLoaded());
  ImageFolderSource s(dir.path());
  EXPECT_TRUE(imageio::PluginLoaded());
  Frame f;
  ASSERT_TRUE(s.Next(f));
  EXPECT_EQ(f.gray.width(), 32);
}

TEST(FrameSourceOptions, Validate) {
  FrameSourceOptions o;
  EXPECT_NO_THROW(Validate(o));
  o.step = 0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o = {};
  o.start_time_s = -1.0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o = {};
  o.start_time_s = 5.0;
  o.end_time_s = 4.0;
  EXPECT_THROW(Validate(o), InvalidArgument);
}

// Photos whose name order differs from their capture order: a.jpg 12:00:10, b.jpg 12:00:00,
// c.png (no EXIF from imwrite; tagged through Exiv2 too) ...
TEST(ImageFolderSource, OrdersByExifTimeThenName) {
  io_test::TempDir dir("aerovo_folder");
  const auto shade = [](int v) { return cv::Mat(30, 40, CV_8UC3, cv::Scalar(v, v, v)); };
  io_test::WriteJpegWithTags(dir / "a.jpg", shade(200),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:10"}});
  io_test::WriteJpegWithTags(dir / "b.jpg", shade(50),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:00"}});
  io_test::WriteJpegWithTags(dir / "c.jpg", shade(100),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:05"},
                              {"Exif.Photo.SubSecTimeOriginal", "5"}});
  io_test::WriteJpegWithTags(dir / "d.JPG", shade(150),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:05"},
                              {"Exif.Photo.SubSecTimeOriginal", "5"}});  // tie with c: by name
  std::ofstream(dir / "notes.txt") << "flight notes\n";
  std::ofstream(dir / "._a.jpg") << "AppleDouble resource fork";

  ImageFolderSource src(dir.path());
  ASSERT_EQ(src.paths().size(), 4u);
  EXPECT_EQ(src.skipped_files(), 2);
  ASSERT_EQ(src.warnings().size(), 2u);
  const std::string all_warnings = src.warnings()[0] + src.warnings()[1];
  EXPECT_THAT(all_warnings, HasSubstr("notes.txt"));
  EXPECT_THAT(all_warnings, HasSubstr("._a.jpg"));
  EXPECT_EQ(src.ExpectedFrameCount(), 4);
  Frame f;
  std::vector<std::string> names;
  std::vector<double> times, shades;
  while (src.Next(f)) {
    names.push_back(f.name);
    times.push_back(f.time_s);
    shades.push_back(MeanGray(f.gray));
    EXPECT_EQ(f.index, static_cast<int>(names.size()) - 1);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"b.jpg", "c.jpg", "d.JPG", "a.jpg"}));
  ASSERT_EQ(times.size(), 4u);
  EXPECT_DOUBLE_EQ(times[0], 0.0);
  EXPECT_DOUBLE_EQ(times[1], 5.5);
  // The same capture time to the tenth of a second (one SubSecTimeOriginal digit): spread
  // within that tenth (PhotoTimes), so no two frames have one time.
  EXPECT_NEAR(times[2], 5.55, 1e-9);
  EXPECT_DOUBLE_EQ(times[3], 10.0);
  EXPECT_NEAR(shades[0], 50, 2);
  EXPECT_NEAR(shades[3], 200, 2);

  FrameSourceOptions o;
  o.step = 2;
  ImageFolderSource stepped(dir.path(), o);
  EXPECT_EQ(stepped.ExpectedFrameCount(), 2);
  std::vector<int> idx;
  while (stepped.Next(f)) idx.push_back(f.index);
  EXPECT_EQ(idx, (std::vector<int>{0, 2}));

  o = {};
  o.start_time_s = 1.0;
  o.end_time_s = 6.0;
  ImageFolderSource windowed(dir.path(), o);
  names.clear();
  while (windowed.Next(f)) names.push_back(f.name);
  EXPECT_EQ(names, (std::vector<std::string>{"c.jpg", "d.JPG"}));

  o = {};
  o.skip_non_images = false;
  ExpectInputError([&] { ImageFolderSource s(dir.path(), o); }, {"notes.txt", "not a photo"});
}

// Two flights in one folder (survey data sets often ship like that): another camera, or a long
// gap between capture times, is refused naming both photos; --photo-flight K takes flight K.
TEST(ImageFolderSource, MixedFoldersAreRefusedOrSplit) {
  io_test::TempDir dir("aerovo_flights");
  const auto shade = [](int v) { return cv::Mat(30, 40, CV_8UC3, cv::Scalar(v, v, v)); };
  const auto photo = [&](const std::string& name, const std::string& time,
                         const std::string& model, const std::string& serial) {
    io_test::WriteJpegWithTags(dir / name, shade(100),
                               {{"Exif.Photo.DateTimeOriginal", time},
                                {"Exif.Image.Make", "DJI"},
                                {"Exif.Image.Model", model},
                                {"Exif.Photo.BodySerialNumber", serial}});
  };
  // Flight 1: 3 photos 2 s apart, then 20 minutes later flight 2, 2 photos.
  photo("a1.jpg", "2023:05:01 12:00:00", "FC300S", "A");
  photo("a2.jpg", "2023:05:01 12:00:02", "FC300S", "A");
  photo("a3.jpg", "2023:05:01 12:00:04", "FC300S", "A");
  photo("b1.jpg", "2023:05:01 12:20:04", "FC300S", "A");
  photo("b2.jpg", "2023:05:01 12:20:06", "FC300S", "A");
  ExpectInputError([&] { ImageFolderSource s(dir.path()); },
                   {"holds 2 flights", "'b1.jpg' was taken 1200 s after 'a3.jpg'",
                    "photo_gap_s 600", "flight 1: 3 photos, 'a1.jpg' to 'a3.jpg'",
                    "flight 2: 2 photos, 'b1.jpg' to 'b2.jpg'", "--photo-flight"});
  FrameSourceOptions o;
  o.photo_flight = 2;
  ImageFolderSource second(dir.path(), o);
  EXPECT_EQ(second.flight_count(), 2);
  Frame f;
  std::vector<std::string> names;
  std::vector<double> times;
  while (second.Next(f)) {
    names.push_back(f.name);
    times.push_back(f.time_s);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"b1.jpg", "b2.jpg"}));
  EXPECT_EQ(times, (std::vector<double>{0.0, 2.0}));  // from the flight's own first photo
  ASSERT_EQ(second.metadata().size(), 2u);
  o.photo_flight = 3;
  ExpectInputError([&] { ImageFolderSource s(dir.path(), o); }, {"photo_flight 3", "holds 2"});
  o.photo_flight = -1;
  EXPECT_EQ(ImageFolderSource(dir.path(), o).paths().size(), 5u);
  o = {};
  o.photo_gap_s = 0.0;  // no gap check: one flight
  EXPECT_EQ(ImageFolderSource(dir.path(), o).flight_count(), 1);
  o.photo_gap_s = 1500.0;  // a pause: chained, and said
  const ImageFolderSource paused(dir.path(), o);
  EXPECT_EQ(paused.flight_count(), 1);
  EXPECT_THAT(paused.warnings().back(), HasSubstr("'b1.jpg' was taken 1200 s after 'a3.jpg': chained"));

  // Another camera at the same time (a second aircraft, or the serial number differs).
  io_test::TempDir two("aerovo_cameras");
  const auto photo2 = [&](const std::string& name, const std::string& time,
                          const std::string& model, const std::string& serial) {
    io_test::WriteJpegWithTags(two / name, shade(100),
                               {{"Exif.Photo.DateTimeOriginal", time},
                                {"Exif.Image.Make", "DJI"},
                                {"Exif.Image.Model", model},
                                {"Exif.Photo.BodySerialNumber", serial}});
  };
  photo2("p1.jpg", "2023:05:01 12:00:00", "FC300S", "A");
  photo2("p2.jpg", "2023:05:01 12:00:02", "FC300S", "B");
  ExpectInputError([&] { ImageFolderSource s(two.path()); },
                   {"'p2.jpg' is from another camera (DJI FC300S serial B) than 'p1.jpg' "
                    "(DJI FC300S serial A)"});
  // A photo whose metadata names no camera splits nothing.
  io_test::TempDir three("aerovo_unknown_camera");
  io_test::WriteJpegWithTags(three / "q1.jpg", shade(100),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:00"},
                              {"Exif.Image.Model", "FC300S"}});
  io_test::WriteJpegWithTags(three / "q2.jpg", shade(100),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:02"}});
  io_test::WriteJpegWithTags(three / "q3.jpg", shade(100),
                             {{"Exif.Photo.DateTimeOriginal", "2023:05:01 12:00:04"},
                              {"Exif.Image.Model", "FC300S"}});
  EXPECT_EQ(ImageFolderSource(three.path()).flight_count(), 1);
}

// The XMP packets of a multispectral rig's photos, as the cameras write them: DJI P4
// Multispectral's attributes of one rdf:Description (its RGB JPEG: tests/../turin-p4m's
// DJI_0010.JPG, with drone-dji:CaptureUUID and the Camera namespace declared without its final
// slash; its band TIFFs add Camera:BandName), MicaSense's elements in one rdf:Description per
// namespace (io_test::MicaSenseBandPacket).
std::string P4mPacket(const std::string& capture, const std::string& band) {
  return std::string("<?xpacket begin=\"\xEF\xBB\xBF\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n") +
         "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\">\n"
         " <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n"
         "  <rdf:Description rdf:about=\"DJI Meta Data\"\n"
         "    xmlns:tiff=\"http://ns.adobe.com/tiff/1.0/\"\n"
         "    xmlns:drone-dji=\"http://www.dji.com/drone-dji/1.0/\"\n"
         "    xmlns:Camera=\"http://pix4d.com/camera/1.0\"\n"
         "   tiff:Make=\"DJI\"\n"
         "   tiff:Model=\"FC6360\"\n"
         "   drone-dji:RelativeAltitude=\"+44.47\"\n"
         "   drone-dji:GimbalPitchDegree=\"-90.00\"\n"
         "   drone-dji:CaptureUUID=\"" +
         capture + "\"\n" + (band.empty() ? "" : "   Camera:BandName=\"" + band + "\"\n") +
         "  >\n  </rdf:Description>\n </rdf:RDF>\n</x:xmpmeta>\n<?xpacket end=\"w\"?>";
}

std::string MicaSensePacket(const std::string& capture, const std::string& band, int index) {
  return io_test::MicaSenseBandPacket(capture, band, std::to_string(index));
}

// A band photo's 16-bit pixels: 12-bit texture (MicaSense shifts its 12 bits into 16; here they
// stay low, the harder case: OpenCV's own 8-bit conversion keeps only the high byte, 0-15).
cv::Mat TwelveBitTexture(int width, int height, unsigned seed) {
  cv::Mat eight;
  cv::cvtColor(io_test::TextureImage(width, height, seed), eight, cv::COLOR_BGR2GRAY);
  cv::Mat sixteen;
  eight.convertTo(sixteen, CV_16U, 16.0);  // 0-4080
  return sixteen;
}

// A DJI P4 Multispectral folder (per capture an RGB JPEG DJI_xxx0.JPG and five 16-bit TIFFs
// DJI_xxx1-5.TIF, all with one capture time and CaptureUUID) reads the RGB photos by default,
// another band on request, and names the captures that lack the band read.
TEST(ImageFolderSource, MultispectralRigReadsOneBand) {
  io_test::TempDir dir("aerovo_p4m_rig");
  const char* const bands[] = {"Blue", "Green", "Red", "RedEdge", "NIR"};
  for (int k = 0; k < 3; ++k) {
    const std::string time = fmt::format("2026:01:26 13:50:{:02d}", 17 + 2 * k);
    const std::string capture = fmt::format("27b14018528c11f08d087d2ed18fec7{}", k);
    const std::map<std::string, std::string> exif = {{"Exif.Photo.DateTimeOriginal", time},
                                                     {"Exif.Image.Make", "DJI"},
                                                     {"Exif.Image.Model", "FC6360"}};
    io_test::WriteJpegWithXmpPacket(dir / fmt::format("DJI_00{}0.JPG", k + 1),
                                    io_test::TextureImage(64, 52, k), P4mPacket(capture, ""));
    io_test::AddExifTags(dir / fmt::format("DJI_00{}0.JPG", k + 1), exif);
    for (int b = 0; b < 5; ++b) {
      io_test::WriteTiffWithXmpPacket(dir / fmt::format("DJI_00{}{}.TIF", k + 1, b + 1),
                                      TwelveBitTexture(64, 52, 10 * k + b), exif,
                                      P4mPacket(capture, bands[b]));
    }
  }
  {
    ImageFolderSource rgb(dir.path());
    EXPECT_EQ(rgb.band(), "RGB");
    std::vector<std::string> names;
    for (const auto& p : rgb.paths()) names.push_back(p.filename().string());
    EXPECT_EQ(names, (std::vector<std::string>{"DJI_0010.JPG", "DJI_0020.JPG", "DJI_0030.JPG"}));
    // One photo per capture: the capture times are the frames' times, two seconds apart.
    EXPECT_DOUBLE_EQ(rgb.TimeOf(1), 2.0);
    EXPECT_DOUBLE_EQ(rgb.TimeOf(2), 4.0);
    ASSERT_FALSE(rgb.warnings().empty());
    EXPECT_THAT(rgb.warnings().back(),
                HasSubstr("holds the photos of 6 cameras of one payload (their band or camera, "
                          "XMP Camera:BandName or drone-dji:ImageSource: RGB (3 photos), Blue (3 "
                          "photos), Green (3 photos), Red (3 photos), RedEdge (3 photos), NIR (3 "
                          "photos)): the 3 photos of RGB are read, the 15 of the others skipped "
                          "(photo_band chooses another)"));
  }
  FrameSourceOptions o;
  o.photo_band = "nir";
  ImageFolderSource nir(dir.path(), o);
  EXPECT_EQ(nir.band(), "NIR");
  std::vector<std::string> names;
  Frame f;
  while (nir.Next(f)) {
    names.push_back(f.name);
    // The 12-bit texture spans the 8 bits (ToEightBit), not OpenCV's high byte 0-15.
    cv::Mat gray(f.gray.height(), f.gray.width(), CV_8UC1, f.gray.data());
    double lo = 0, hi = 0;
    cv::minMaxLoc(gray, &lo, &hi);
    EXPECT_LE(lo, 1.0) << f.name;
    EXPECT_GE(hi, 254.0) << f.name;
  }
  EXPECT_EQ(names, (std::vector<std::string>{"DJI_0015.TIF", "DJI_0025.TIF", "DJI_0035.TIF"}));
  o.photo_band = "Red Edge";
  EXPECT_EQ(ImageFolderSource(dir.path(), o).paths().front().filename(), "DJI_0014.TIF");
  o.photo_band = "thermal";
  ExpectInputError([&] { ImageFolderSource s(dir.path(), o); },
                   {"photo_band 'thermal' is none of the bands or cameras its photos name",
                    "RGB (3 photos), Blue (3 photos)", "NIR (3 photos)"});

  // A capture without its RGB photo: not read, and said naming one of its photos.
  fs::remove(dir / "DJI_0020.JPG");
  ImageFolderSource gap(dir.path());
  EXPECT_EQ(gap.paths().size(), 2u);
  EXPECT_THAT(gap.warnings().back(), HasSubstr("1 capture has no photo of RGB and is not read (the "
                                               "capture of 'DJI_0021.TIF')"));
}

// MicaSense RedEdge: five TIFFs per capture IMG_xxxx_1-5.tif, no RGB camera: green is read by
// default, band names compare without case or spaces, the rig's order is Camera:RigCameraIndex.
// A folder of one camera has no band to choose.
TEST(ImageFolderSource, MicaSenseRigReadsGreenByDefault) {
  io_test::TempDir dir("aerovo_micasense_rig");
  const char* const bands[] = {"Blue", "Green", "Red", "NIR", "Red edge"};
  for (int k = 0; k < 2; ++k) {
    const std::map<std::string, std::string> exif = {
        {"Exif.Photo.DateTimeOriginal", fmt::format("2024:01:03 07:31:{:02d}", 35 + k)},
        {"Exif.Photo.SubSecTimeOriginal", "250"},
        {"Exif.Image.Make", "MicaSense"},
        {"Exif.Image.Model", "RedEdge-M"}};
    for (int b = 0; b < 5; ++b) {
      io_test::WriteTiffWithXmpPacket(
          dir / fmt::format("IMG_000{}_{}.tif", k, b + 1), TwelveBitTexture(48, 36, 10 * k + b),
          exif, MicaSensePacket(fmt::format("DFj0YDYQsRJd6hDUj7q{}", k), bands[b], b));
    }
  }
  const ImageFolderSource green(dir.path());
  EXPECT_EQ(green.band(), "Green");
  ASSERT_EQ(green.paths().size(), 2u);
  EXPECT_EQ(green.paths()[1].filename(), "IMG_0001_2.tif");
  EXPECT_EQ(green.metadata()[1].capture_id, "DFj0YDYQsRJd6hDUj7q1");
  EXPECT_THAT(green.warnings().back(),
              HasSubstr("Blue (2 photos), Green (2 photos), Red (2 photos), NIR (2 photos), Red "
                        "edge (2 photos)): the 2 photos of Green are read"));
  FrameSourceOptions o;
  o.photo_band = "REDEDGE";
  EXPECT_EQ(ImageFolderSource(dir.path(), o).paths()[0].filename(), "IMG_0000_5.tif");

  // A folder naming many bands (no camera has 15): the message lists the first 12.
  io_test::TempDir many("aerovo_many_bands");
  for (int b = 0; b < 15; ++b) {
    io_test::WriteTiffWithXmpPacket(many / fmt::format("IMG_0000_{:02d}.tif", b),
                                    TwelveBitTexture(16, 12, b), {},
                                    MicaSensePacket("c", fmt::format("band{}", b), b));
  }
  o.photo_band = "band14";
  const ImageFolderSource fifteen(many.path(), o);
  EXPECT_EQ(fifteen.band(), "band14");
  ASSERT_GE(fifteen.warnings().size(), 1u);
  EXPECT_THAT(fifteen.warnings().front(),
              HasSubstr("15 cameras of one payload (their band or camera, XMP Camera:BandName or "
                        "drone-dji:ImageSource: band0 (1 photo), band1 (1 photo)"));
  EXPECT_THAT(fifteen.warnings().front(), HasSubstr("band11 (1 photo) and 3 more)"));

  io_test::TempDir plain("aerovo_no_rig");
  io_test::WriteJpegWithTags(plain / "a.jpg", io_test::TextureImage(40, 30, 1),
                             {{"Exif.Photo.DateTimeOriginal", "2024:01:03 07:31:35"}});
  EXPECT_EQ(ImageFolderSource(plain.path()).band(), "");
  o.photo_band = "NIR";
  ExpectInputError([&] { ImageFolderSource s(plain.path(), o); },
                   {"photo_band 'NIR' but no photo names its band or camera", "one camera's"});
}

// A DJI payload of wide, zoom and thermal cameras (Zenmuse H20T, Matrice 30T, Mavic 3T): per
// capture DJI_<time>_<n>_W.JPG, _Z.JPG, _T.JPG of three sizes, each naming its camera in
// drone-dji:ImageSource. The wide camera is read by default (the build before refused the folder
// for its mixed sizes), the thermal one on request; a photo of another camera stays for the
// flight split to judge.
TEST(ImageFolderSource, DjiWideZoomThermalPayloadReadsTheWideCamera) {
  io_test::TempDir dir("aerovo_h20t");
  const auto packet = [](const std::string& source) {
    return std::string("<?xpacket begin=\"\xEF\xBB\xBF\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n") +
           "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\">\n"
           " <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n"
           "  <rdf:Description rdf:about=\"DJI Meta Data\"\n"
           "    xmlns:drone-dji=\"http://www.dji.com/drone-dji/1.0/\"\n"
           "   drone-dji:RelativeAltitude=\"+80.10\"\n"
           "   drone-dji:GimbalPitchDegree=\"-90.00\"\n"
           "   drone-dji:DroneModel=\"M30T\"\n"
           "   drone-dji:ImageSource=\"" +
           source + "\">\n  </rdf:Description>\n </rdf:RDF>\n</x:xmpmeta>\n<?xpacket end=\"w\"?>";
  };
  const struct {
    const char* suffix;
    const char* source;
    int width, height;
  } cameras[] = {
      {"W", "WideCamera", 64, 48}, {"Z", "ZoomCamera", 80, 60}, {"T", "InfraredCamera", 32, 26}};
  for (int k = 0; k < 3; ++k) {
    for (const auto& c : cameras) {
      const fs::path p = dir / fmt::format("DJI_20230401101500_000{}_{}.JPG", k + 1, c.suffix);
      io_test::WriteJpegWithXmpPacket(p, io_test::TextureImage(c.width, c.height, k),
                                      packet(c.source));
      io_test::AddExifTags(
          p, {{"Exif.Photo.DateTimeOriginal", fmt::format("2023:04:01 10:15:{:02d}", 2 * k)},
              {"Exif.Image.Make", "DJI"},
              {"Exif.Image.Model", "M30T"}});
    }
  }
  const ImageFolderSource wide(dir.path());
  EXPECT_EQ(wide.band(), "WideCamera");
  ASSERT_EQ(wide.paths().size(), 3u);
  EXPECT_EQ(wide.paths()[2].filename(), "DJI_20230401101500_0003_W.JPG");
  EXPECT_THAT(wide.warnings().back(),
              HasSubstr("InfraredCamera (3 photos), WideCamera (3 photos), ZoomCamera (3 "
                        "photos)): the 3 photos of WideCamera are read, the 6 of the others"));
  FrameSourceOptions o;
  o.photo_band = "thermal";
  ImageFolderSource thermal(dir.path(), o);
  Frame f;
  ASSERT_TRUE(thermal.Next(f));
  EXPECT_EQ(f.name, "DJI_20230401101500_0001_T.JPG");
  EXPECT_EQ(f.gray.width(), 32);
  o.photo_band = "Zoom Camera";
  EXPECT_EQ(ImageFolderSource(dir.path(), o).band(), "ZoomCamera");
  // A wide photo whose XMP was stripped: a group of its own, after the wide camera.
  io_test::WriteJpegWithTags(dir / "DJI_20230401101500_0004_W.JPG",
                             io_test::TextureImage(64, 48, 5),
                             {{"Exif.Photo.DateTimeOriginal", "2023:04:01 10:15:06"},
                              {"Exif.Image.Make", "DJI"},
                              {"Exif.Image.Model", "M30T"}});
  const ImageFolderSource stripped(dir.path());
  EXPECT_EQ(stripped.band(), "WideCamera");
  EXPECT_EQ(stripped.paths().size(), 3u);
  EXPECT_THAT(stripped.warnings().back(), HasSubstr("(no camera named) (1 photo)"));
  fs::remove(dir / "DJI_20230401101500_0004_W.JPG");

  // Another aircraft's photo in the folder is not the payload's: the flight split refuses it.
  io_test::WriteJpegWithTags(dir / "P0001.JPG", io_test::TextureImage(64, 48, 9),
                             {{"Exif.Photo.DateTimeOriginal", "2023:04:01 10:15:08"},
                              {"Exif.Image.Make", "Parrot"},
                              {"Exif.Image.Model", "ANAFI"}});
  ExpectInputError([&] { ImageFolderSource s(dir.path()); },
                   {"'P0001.JPG' is from another camera (Parrot ANAFI)"});
}

// A payload whose cameras do not name theirs (a Zenmuse XT2: a visible photo and a thermal one
// at each capture, of two sizes): refused for its mixed sizes, the message listing them and the
// way out; --photo-band WxH reads the photos of one size.
TEST(ImageFolderSource, UnnamedCamerasOfTwoSizesAreReadBySize) {
  io_test::TempDir dir("aerovo_xt2_sizes");
  for (int k = 0; k < 3; ++k) {
    const std::map<std::string, std::string> exif = {
        {"Exif.Photo.DateTimeOriginal", fmt::format("2023:04:01 10:15:{:02d}", 2 * k)},
        {"Exif.Image.Make", "DJI"},
        {"Exif.Image.Model", "XT2"}};
    io_test::WriteJpegWithTags(dir / fmt::format("DJI_{:04d}.JPG", 2 * k + 1),
                               io_test::TextureImage(64, 48, k), exif);
    io_test::WriteJpegWithTags(dir / fmt::format("DJI_{:04d}_R.JPG", 2 * k + 2),
                               io_test::TextureImage(32, 26, k), exif);
  }
  ExpectInputError([&] { ImageFolderSource s(dir.path()); },
                   {"mixed resolutions", "the folder has 64x48 (3 photos), 32x26 (3 photos)",
                    "Zenmuse XT2", "--photo-band WxH"});
  FrameSourceOptions o;
  o.photo_band = "32X26";
  ImageFolderSource thermal(dir.path(), o);
  EXPECT_EQ(thermal.band(), "32x26");
  std::vector<std::string> names;
  for (const auto& p : thermal.paths()) names.push_back(p.filename().string());
  EXPECT_EQ(names,
            (std::vector<std::string>{"DJI_0002_R.JPG", "DJI_0004_R.JPG", "DJI_0006_R.JPG"}));
  EXPECT_THAT(thermal.warnings().back(),
              HasSubstr("the 3 photos of 32x26 are read, the 3 of other sizes skipped"));
  o.photo_band = "640x512";
  ExpectInputError([&] { ImageFolderSource s(dir.path(), o); },
                   {"photo_band 640x512 but no photo has that size", "64x48 (3 photos)"});
  // Not a size: a band name, which these photos do not have.
  o.photo_band = "x512";
  ExpectInputError([&] { ImageFolderSource s(dir.path(), o); }, {"no photo names its band"});
}

TEST(ImageFolderSource, NameOrderWithoutExifAndPngTiff) {
  io_test::TempDir dir("aerovo_folder_plain");
  cv::imwrite((dir / "frame_2.png").string(), io_test::TextureImage(40, 30, 2));
  cv::imwrite((dir / "frame_1.tif").string(), io_test::TextureImage(40, 30, 1));
  cv::imwrite((dir / "frame_3.jpeg").string(), io_test::TextureImage(40, 30, 3));
  ImageFolderSource src(dir.path());
  Frame f;
  std::vector<std::string> names;
  std::vector<double> times;
  while (src.Next(f)) {
    names.push_back(f.name);
    times.push_back(f.time_s);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"frame_1.tif", "frame_2.png", "frame_3.jpeg"}));
  EXPECT_EQ(times, (std::vector<double>{0.0, 1.0, 2.0}));  // rank: no capture times
  // The TIFF is lossless: its grey values are exactly OpenCV's conversion of the texture.
  ImageFolderSource again(dir.path());
  ASSERT_TRUE(again.Next(f));
  cv::Mat expect;
  cv::cvtColor(io_test::TextureImage(40, 30, 1), expect, cv::COLOR_BGR2GRAY);
  int diffs = 0;
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) diffs += f.gray.at(x, y) != expect.at<std::uint8_t>(y, x);
  }
  EXPECT_EQ(diffs, 0);
}

TEST(ImageFolderSource, BadFolders) {
  io_test::TempDir dir("aerovo_folder_bad");
  ExpectInputError([&] { ImageFolderSource s(dir.path()); }, {"has no photos"});
  ExpectInputError([&] { ImageFolderSource s(dir / "nope"); }, {"not a directory"});
  cv::imwrite((dir / "a.jpg").string(), io_test::TextureImage(40, 30, 1));
  cv::imwrite((dir / "b.jpg").string(), io_test::TextureImage(64, 48, 2));
  ExpectInputError([&] { ImageFolderSource s(dir.path()); },
                   {"b.jpg", "64x48", "a.jpg", "40x30", "mixed resolutions"});
  std::filesystem::remove(dir / "b.jpg");
  std::ofstream(dir / "b.jpg") << "not really a jpeg";
  ImageFolderSource s(dir.path());  // metadata unreadable: warned, order by name
  EXPECT_FALSE(s.warnings().empty());
  Frame f;
  ASSERT_TRUE(s.Next(f));
  EXPECT_EQ(f.name, "a.jpg");
  ExpectInputError([&] { s.Next(f); }, {"cannot decode photo", "b.jpg", "frame 1"});
}

TEST(ImageFolderSource, TampaFolderOrderAndSize) {
  AEROVO_REQUIRE_SHARED(dir, "data/flights/tampa-phantom3");
  FrameSourceOptions o;
  o.end_time_s = 20.0;
  ImageFolderSource src(dir, o);
  EXPECT_EQ(src.paths().size(), 172u);
  EXPECT_EQ(src.skipped_files(), 0);
  // EXIF time order is the order of the names (README: names are in flight order).
  std::vector<std::filesystem::path> sorted = src.paths();
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(sorted, src.paths());
  Frame f;
  ASSERT_TRUE(src.Next(f));
  EXPECT_EQ(f.name, "DJI_0054.JPG");
  EXPECT_EQ(f.gray.width(), 800);
  EXPECT_EQ(f.gray.height(), 600);
  EXPECT_DOUBLE_EQ(f.time_s, 0.0);
}

// The photo-set telemetry built from the folder's metadata is indexed like the frames.
TEST(ImageFolderSource, TurinTelemetryMatchesFrames) {
  AEROVO_REQUIRE_SHARED(dir, "data/flights/turin-p4m");
  FrameSourceOptions o;
  o.step = 5;
  ImageFolderSource src(dir, o);
  ASSERT_EQ(src.paths().size(), 32u);
  const TelemetryReadResult tel = TelemetryFromImages(src.metadata());
  ASSERT_EQ(tel.records, 32);
  Frame f;
  int n = 0;
  while (src.Next(f)) {
    ++n;
    EXPECT_EQ(f.gray.width(), 1600);
    const auto fix = tel.telemetry.ForFrame(f.index, f.time_s);
    ASSERT_TRUE(fix);
    const ImageMetadata& m = src.metadata()[static_cast<std::size_t>(f.index)];
    EXPECT_EQ(std::filesystem::path(m.source).filename().string(), f.name);
    EXPECT_DOUBLE_EQ(fix->lat_deg, *m.lat_deg);
    EXPECT_DOUBLE_EQ(fix->lon_deg, *m.lon_deg);
    EXPECT_DOUBLE_EQ(fix->time_s, f.time_s);
    EXPECT_NEAR(*fix->rel_alt_m, 44.5, 0.5);
  }
  EXPECT_EQ(n, 7);  // photos 0, 5, ..., 30
}

TEST(LiveSource, StreamFromAFileAndFactory) {
  io_test::TempDir dir("aerovo_live");
  WriteTestVideo(dir / "cam.avi", "MJPG");
  FrameSourceOptions o;
  o.step = 4;
  LiveSource live((dir / "cam.avi").string(), o);
  Frame f;
  std::vector<int> idx;
  double last_t = -1.0;
  while (live.Next(f)) {
    idx.push_back(f.index);
    EXPECT_NEAR(MeanGray(f.gray), 10 + 10 * f.index, 3.0);
    // Read far faster than filmed: the frames keep the stream's spacing (4 frames), not the
    // reads'.
    if (last_t >= 0.0) {
      EXPECT_NEAR(f.time_s - last_t, 4.0 / kFps, 1e-6) << f.index;
    }
    last_t = f.time_s;
  }
  EXPECT_EQ(idx, (std::vector<int>{0, 4, 8, 12, 16}));
  ASSERT_EQ(live.warnings().size(), 1u);  // the "stream" stopped
  ExpectInputError([&] { LiveSource s(std::string("rtsp://127.0.0.1:1/none")); },
                   {"cannot open live source", "rtsp://127.0.0.1:1/none"});

  EXPECT_NE(dynamic_cast<VideoFileSource*>(OpenFrameSource((dir / "cam.avi").string()).get()),
            nullptr);
  cv::imwrite((dir / "p.png").string(), io_test::TextureImage(8, 8, 1));
  std::filesystem::create_directories(dir / "photos");
  cv::imwrite((dir / "photos" / "p.png").string(), io_test::TextureImage(8, 8, 1));
  EXPECT_NE(dynamic_cast<ImageFolderSource*>(OpenFrameSource((dir / "photos").string()).get()),
            nullptr);
  ExpectInputError([&] { OpenFrameSource((dir / "nothing").string()); },
                   {"nothing", "no such file or directory"});
  ExpectInputError([&] { OpenFrameSource(""); }, {"empty frame source"});
}

TEST(LiveFrameTimes, TheSourcesOwnStepsWhenTheyMoveForwardElseTheArrivals) {
  // A stream's start-up burst: frames 100 ms apart in the stream delivered within 2 ms, then at
  // their pace; the times keep the stream's spacing from the first arrival on.
  LiveFrameTimes burst;
  const double arrivals[] = {5.010, 5.011, 5.012, 5.100, 5.205};
  std::string why;
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR(burst.Next(arrivals[i], 40000.0 + 100.0 * i, &why), 5.010 + 0.1 * i, 1e-9) << i;
  }
  EXPECT_EQ(burst.arrival_steps(), 0);
  EXPECT_EQ(why, "");
  // No own time (OpenCV's 0 for a source without timestamps), one going back, one not finite,
  // one 1000 s ahead (a restarted sender): the arrival steps instead, each said.
  LiveFrameTimes none;
  EXPECT_DOUBLE_EQ(none.Next(1.0, 0.0, &why), 1.0);
  EXPECT_DOUBLE_EQ(none.Next(1.25, 0.0, &why), 1.25);
  EXPECT_NE(why.find("0.000 s after the previous frame's, arrived 0.250 s after it"),
            std::string::npos) << why;
  EXPECT_EQ(none.arrival_steps(), 1);
  LiveFrameTimes jumps;
  const double stream_ms[] = {0.0, 100.0, 50.0, std::nan(""), 160.0, 1e6 + 260.0, 1e6 + 360.0};
  const double expected[] = {2.0, 2.1, 2.2, 2.3, 2.4, 2.5, 2.6};  // arrivals 0.1 s apart
  for (int i = 0; i < 7; ++i) {
    EXPECT_NEAR(jumps.Next(2.0 + 0.1 * i, stream_ms[i], nullptr), expected[i], 1e-9) << i;
  }
  EXPECT_EQ(jumps.arrival_steps(), 4);  // back, NaN, 160 after NaN (not finite), the jump
}

TEST(ToGrayImage, ChannelsAndDepth) {
  cv::Mat bgr(2, 3, CV_8UC3, cv::Scalar(0, 0, 255));  // pure red
  GrayImage g = ToGrayImage(bgr);
  EXPECT_EQ(g.width(), 3);
  EXPECT_EQ(g.height(), 2);
  EXPECT_EQ(g.at(2, 1), 76);  // 0.299 * 255
  cv::Mat one(2, 2, CV_8UC1, cv::Scalar(7));
  EXPECT_EQ(ToGrayImage(one).at(1, 1), 7);
  EXPECT_THROW(ToGrayImage(cv::Mat(2, 2, CV_16UC1)), InvalidArgument);
  EXPECT_TRUE(ToGrayImage(cv::Mat()).empty());
  GrayImage reused(3, 2);
  const std::uint8_t* buffer = reused.data();
  ToGrayImage(bgr, reused);
  EXPECT_EQ(reused.data(), buffer);  // same size: storage reused
  EXPECT_EQ(reused.at(0, 0), 76);
  cv::Mat bgra(2, 3, CV_8UC4, cv::Scalar(255, 0, 0, 255));  // pure blue
  EXPECT_EQ(ToGrayImage(bgra).at(1, 1), 29);                // 0.114 * 255
}

}  // namespace
}  // namespace aerovo::frame_source_test
