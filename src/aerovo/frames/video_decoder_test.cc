// VideoDecoder (frames/video_decoder.h) and VideoFileSource with each decoder: resolution changes
// mid-stream, grey from the luma plane against an exact BT.601/709 conversion, rotation metadata,
// cut files. Inputs are made here with ffmpeg and OpenCV.
#include "aerovo/frames/video_decoder.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/core/error.h"
#include "aerovo/frames/ffmpeg_test_util.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/frames/image_test_util.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::video_decoder_test {
namespace {

using io_test::HaveFfmpeg;
using io_test::RunFfmpeg;
using ::testing::HasSubstr;

FrameSourceOptions WithDecoder(VideoDecoderChoice d) {
  FrameSourceOptions o;
  o.video_decoder = d;
  return o;
}

// Clip A then clip B (mpeg2video, 10 fps, 2 s = 20 frames each) in one MPEG-TS through
// ffmpeg's concat demuxer with stream copy: the clock runs on across the join (no restart),
// only the size changes (measured: the joined file keeps 19 of the first clip's 20 frames).
std::filesystem::path JoinWithoutClockRestart(const std::filesystem::path& dir, const char* a,
                                              const char* b) {
  const std::filesystem::path out = dir / fmt::format("{}_then_{}.ts", a, b);
  for (const char* size : {a, b}) {
    const std::filesystem::path clip = dir / fmt::format("{}.ts", size);
    if (std::filesystem::exists(clip)) continue;
    EXPECT_TRUE(RunFfmpeg({"-f", "lavfi", "-i", fmt::format("testsrc=size={}:rate=10", size), "-t",
                           "2", "-c:v", "mpeg2video", clip.string()}));
  }
  const std::filesystem::path list = dir / fmt::format("{}_{}.txt", a, b);
  std::ofstream(list) << fmt::format("file '{}.ts'\nfile '{}.ts'\n", a, b);
  EXPECT_TRUE(
      RunFfmpeg({"-f", "concat", "-safe", "0", "-i", list.string(), "-c", "copy", out.string()}));
  return out;
}

// A video that shrinks (or grows) mid-stream without a clock restart. Ours reports
// the frame where the size changes (the first of the second clip, counted by decoding the file
// with VideoDecoder); the first clip's frames come through first.
TEST(VideoDecoder, ResolutionChangeWithoutClockRestartIsAnErrorNamingFrameAndSizes) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_dec_size");
  struct Case {
    const char *a, *b;
  };
  for (const Case c : {Case{"640x360", "320x240"}, Case{"320x240", "640x360"}}) {
    const std::filesystem::path video = JoinWithoutClockRestart(dir.path(), c.a, c.b);
    int first_clip = 0;  // frames at size a
    // The decoder itself sees both sizes.
    {
      VideoDecoder dec(video, 1);
      std::vector<std::string> sizes;
      std::vector<int> counts;
      while (dec.Grab()) {
        const std::string s = fmt::format("{}x{}", dec.frame_width(), dec.frame_height());
        if (sizes.empty() || sizes.back() != s) {
          sizes.push_back(s);
          counts.push_back(0);
        }
        ++counts.back();
      }
      ASSERT_EQ(sizes, (std::vector<std::string>{c.a, c.b})) << video;
      first_clip = counts[0];
      EXPECT_GE(counts[0], 18);
      EXPECT_LE(counts[0], 20);
      EXPECT_EQ(counts[1], 20);
    }
    VideoFileSource src(video, WithDecoder(VideoDecoderChoice::kFfmpeg));
    EXPECT_EQ(src.decoder(), VideoDecoderChoice::kFfmpeg);
    Frame f;
    std::vector<int> delivered;
    try {
      while (src.Next(f)) delivered.push_back(f.index);
      ADD_FAILURE() << video << ": no InputError after " << delivered.size() << " frames";
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr(video.filename().string()));
      EXPECT_THAT(e.what(), HasSubstr(fmt::format("frame {}: size changed from {} to {}",
                                                  first_clip, c.a, c.b)));
    }
    ASSERT_EQ(static_cast<int>(delivered.size()), first_clip) << video;
    EXPECT_EQ(delivered.back(), first_clip - 1);
    EXPECT_FALSE(src.Next(f));
  }
}

// The same videos through OpenCV (video_decoder opencv): a larger second clip is caught (as
// copies of the last small frame: the repeated-frame error), a smaller one is delivered
// stretched to the first size with no error at all: the known limitation that made our decoder
// the default.
// A stream whose header asks for frames of more than kMaxImagePixels (image_file.h) is refused
// before any frame is decoded: an AVI of raw grey frames with its header's size (avih and the
// stream's BITMAPINFOHEADER) made 15000 x 15000 (225 MP, within FFmpeg's own limit of 2^31 / 8
// bytes); 14000 x 14000 (196 MP) passes the check and fails at its too-short packets.
TEST(VideoDecoder, AStreamAskingForMorePixelsThanAnyCameraIsRefusedBeforeDecoding) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_dec_huge");
  const std::filesystem::path small = dir / "small.avi";
  ASSERT_TRUE(RunFfmpeg({"-f", "lavfi", "-i", "testsrc=size=16x16:rate=4", "-frames:v", "2", "-c:v",
                         "rawvideo", "-pix_fmt", "gray", small.string()}));
  std::ifstream in(small, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto with_size = [&](const std::string& name, std::uint32_t side) {
    std::string b = bytes;
    const auto put = [&](std::size_t at) {
      for (int k = 0; k < 4; ++k) {
        b[at + static_cast<std::size_t>(k)] = static_cast<char>(side >> (8 * k));
        b[at + 4 + static_cast<std::size_t>(k)] = static_cast<char>(side >> (8 * k));
      }
    };
    const std::size_t avih = b.find("avih"), strf = b.find("strf");
    EXPECT_NE(avih, std::string::npos);
    EXPECT_NE(strf, std::string::npos);
    put(avih + 8 + 32);  // dwWidth, dwHeight
    put(strf + 8 + 4);   // biWidth, biHeight
    const std::filesystem::path p = dir / name;
    std::ofstream(p, std::ios::binary) << b;
    return p;
  };
  const std::filesystem::path huge = with_size("huge.avi", 15000);
  try {
    VideoDecoder decoder(huge, 1);
    ADD_FAILURE() << "opened";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot open video '" + huge.string() +
                                    "': its frames are 15000 x 15000 px (225 megapixels), more "
                                    "than the 200 megapixels aerovo decodes"));
  }
  const std::filesystem::path large = with_size("large.avi", 14000);
  VideoDecoder decoder(large, 1);
  EXPECT_EQ(decoder.width(), 14000);
  EXPECT_FALSE(decoder.Grab());  // 256-byte packets for 196 MP frames: nothing decodes
}

TEST(VideoDecoder, OpenCvMissesAShrinkWithoutClockRestartKnownLimitation) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_dec_size_cv");
  {
    VideoFileSource src(JoinWithoutClockRestart(dir.path(), "640x360", "320x240"),
                        WithDecoder(VideoDecoderChoice::kOpenCv));
    EXPECT_EQ(src.decoder(), VideoDecoderChoice::kOpenCv);
    Frame f;
    int n = 0;
    while (src.Next(f)) {
      EXPECT_EQ(f.gray.width(), 640);  // the 320x240 half stretched
      ++n;
    }
    EXPECT_GE(n, 37);  // 19 + 20 frames, the last one held back by the look-ahead
  }
  VideoFileSource src(JoinWithoutClockRestart(dir.path(), "320x240", "640x360"),
                      WithDecoder(VideoDecoderChoice::kOpenCv));
  Frame f;
  int n = 0;
  try {
    while (src.Next(f)) ++n;
    ADD_FAILURE() << "no InputError after " << n << " frames";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("320x240_then_640x360.ts"));
  }
  EXPECT_GE(n, 19);
  EXPECT_LE(n, 26);
}

// Full-range luma of an 8-bit BGR image with the matrix's weights (Kr, Kb; Kg = 1 - Kr - Kb).
cv::Mat1d Luma(const cv::Mat3b& bgr, double kr, double kb) {
  cv::Mat1d y(bgr.size());
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) {
      const cv::Vec3b p = bgr(r, c);
      y(r, c) = kr * p[2] + (1.0 - kr - kb) * p[1] + kb * p[0];
    }
  }
  return y;
}

struct GreyError {
  double mean_abs = 0.0;
  double max_abs = 0.0;
};

GreyError Compare(const GrayImage& g, const cv::Mat1d& expected) {
  GreyError e;
  for (int r = 0; r < expected.rows; ++r) {
    for (int c = 0; c < expected.cols; ++c) {
      const double d = std::abs(g.at(c, r) - expected(r, c));
      e.mean_abs += d;
      e.max_abs = std::max(e.max_abs, d);
    }
  }
  e.mean_abs /= static_cast<double>(expected.total());
  return e;
}

// A colourful PNG encoded losslessly (FFV1) as YUV with a stated matrix and range; our grey
// must be that matrix's luma of the PNG (computed here from its RGB), within the encoder's and
// our rounding: limited range stores 219 levels, so one level of the encoder's rounding is
// 255/219 = 1.16 of ours, plus our own rounding 0.5: at most 2. The other matrix's luma is far
// off, so the test tells the matrices apart.
TEST(VideoDecoder, GreyIsTheStreamsLumaBt601AndBt709FullAndLimitedRange) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_dec_grey");
  // Saturated colour bands, gradients and texture, 160x120.
  cv::Mat3b bgr(120, 160);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) {
      bgr(r, c) =
          cv::Vec3b(static_cast<uchar>((c * 255) / 159), static_cast<uchar>((r * 255) / 119),
                    static_cast<uchar>(((c / 8 + r / 8) % 2) * 200 + (c * r) % 55));
    }
  }
  const std::filesystem::path png = dir / "frame.png";
  ASSERT_TRUE(cv::imwrite(png.string(), bgr));
  const cv::Mat1d y601 = Luma(bgr, 0.299, 0.114), y709 = Luma(bgr, 0.2126, 0.0722);
  ASSERT_GT(cv::mean(cv::abs(y601 - y709))[0], 5.0);
  struct Case {
    const char* matrix;  // ffmpeg's name
    const char* range;   // tv / pc
    const cv::Mat1d* expected;
    const cv::Mat1d* other;
    double max_error;
  };
  for (const Case c :
       {Case{"bt601", "tv", &y601, &y709, 2.0}, Case{"bt709", "tv", &y709, &y601, 2.0},
        Case{"bt601", "pc", &y601, &y709, 1.0}, Case{"bt709", "pc", &y709, &y601, 1.0}}) {
    const std::string name = fmt::format("{}_{}.mkv", c.matrix, c.range);
    const std::string colorspace = std::string(c.matrix) == "bt601" ? "smpte170m" : "bt709";
    ASSERT_TRUE(RunFfmpeg(
        {"-loop", "1", "-i", png.string(), "-frames:v", "3", "-vf",
         fmt::format("scale=out_color_matrix={}:out_range={},format=yuv420p", c.matrix, c.range),
         "-colorspace", colorspace, "-color_range", c.range, "-c:v", "ffv1",
         (dir / name).string()}))
        << name;
    VideoFileSource src(dir / name, WithDecoder(VideoDecoderChoice::kFfmpeg));
    Frame f;
    int n = 0;
    while (src.Next(f)) {
      const GreyError e = Compare(f.gray, *c.expected);
      EXPECT_LE(e.max_abs, c.max_error) << name << " frame " << f.index;
      EXPECT_LT(e.mean_abs, 0.5) << name;
      EXPECT_GT(Compare(f.gray, *c.other).mean_abs, 4.0) << name;
      if (n == 0) {
        std::cout << fmt::format("{}: grey vs exact luma: mean {:.3f} max {:.0f} levels\n", name,
                                 e.mean_abs, e.max_abs);
      }
      ++n;
    }
    EXPECT_EQ(n, 3) << name;
  }
  // A 10-bit stream takes the swscale path (to GRAY8, source range honoured): same tolerance.
  ASSERT_TRUE(RunFfmpeg({"-loop", "1", "-i", png.string(), "-frames:v", "2", "-vf",
                         "scale=out_color_matrix=bt709:out_range=tv,format=yuv420p10le",
                         "-colorspace", "bt709", "-color_range", "tv", "-c:v", "ffv1",
                         (dir / "bt709_tv_10bit.mkv").string()}));
  VideoFileSource ten(dir / "bt709_tv_10bit.mkv", WithDecoder(VideoDecoderChoice::kFfmpeg));
  Frame f;
  int n = 0;
  while (ten.Next(f)) {
    const GreyError e = Compare(f.gray, y709);
    EXPECT_LE(e.max_abs, 2.0);
    EXPECT_LT(e.mean_abs, 0.5);
    if (n++ == 0) {
      std::cout << fmt::format("bt709_tv_10bit.mkv: mean {:.3f} max {:.0f}\n", e.mean_abs,
                               e.max_abs);
    }
  }
  EXPECT_EQ(n, 2);
}

// Rotation metadata, both decoders: the angle read, a warning, frames as stored.
TEST(VideoDecoder, RotationMetadataBothDecoders) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  io_test::TempDir dir("aerovo_dec_rot");
  const std::string plain = (dir / "plain.mp4").string();
  ASSERT_TRUE(RunFfmpeg(
      {"-f", "lavfi", "-i", "testsrc=size=96x64:rate=10", "-t", "1", "-c:v", "mpeg4", plain}));
  for (const int deg : {90, 180, 270}) {
    const std::filesystem::path rot = dir / fmt::format("rot{}.mp4", deg);
    ASSERT_TRUE(RunFfmpeg(
        {"-i", plain, "-c", "copy", "-metadata:s:v", fmt::format("rotate={}", deg), rot.string()}));
    for (const VideoDecoderChoice d : {VideoDecoderChoice::kFfmpeg, VideoDecoderChoice::kOpenCv}) {
      VideoFileSource src(rot, WithDecoder(d));
      EXPECT_EQ(src.rotation_deg(), deg) << ToString(d);
      ASSERT_EQ(src.warnings().size(), 1u);
      EXPECT_THAT(src.warnings()[0], HasSubstr(fmt::format("rotation metadata ({} degrees", deg)));
      Frame f;
      int n = 0;
      while (src.Next(f)) {
        EXPECT_EQ(f.gray.width(), 96);
        EXPECT_EQ(f.gray.height(), 64);
        ++n;
      }
      EXPECT_EQ(n, 10) << ToString(d);
    }
  }
  VideoDecoder dec(plain, 1);
  EXPECT_EQ(dec.rotation_deg(), 0);
}

// A cut file through both decoders: MJPG AVI (header: 20 frames) cut at 60 %: the frames
// delivered are exactly the full file's (the cut last one dropped), then a warning; an H.264
// MPEG-TS cut in half (no frame count in the header) ends without an error.
TEST(VideoDecoder, CutFilesEndWithAWarningAndOnlyCompleteFrames) {
  io_test::TempDir dir("aerovo_dec_cut");
  {
    cv::VideoWriter w((dir / "full.avi").string(), cv::CAP_FFMPEG,
                      cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(64, 48));
    ASSERT_TRUE(w.isOpened());
    for (int i = 0; i < 20; ++i) w.write(io_test::TextureImage(64, 48, i));
  }
  {
    std::ifstream in(dir / "full.avi", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.avi", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 6 / 10));
  }
  for (const VideoDecoderChoice d : {VideoDecoderChoice::kFfmpeg, VideoDecoderChoice::kOpenCv}) {
    std::vector<GrayImage> full;
    {
      VideoFileSource src(dir / "full.avi", WithDecoder(d));
      Frame f;
      while (src.Next(f)) full.push_back(f.gray);
    }
    ASSERT_EQ(full.size(), 20u) << ToString(d);
    VideoFileSource cut(dir / "cut.avi", WithDecoder(d));
    EXPECT_EQ(cut.frame_count(), 20);
    Frame f;
    int n = 0;
    while (cut.Next(f)) {
      ASSERT_EQ(f.index, n);
      EXPECT_EQ(PixelHash(f.gray), PixelHash(full[n])) << ToString(d) << " frame " << n;
      ++n;
    }
    EXPECT_GE(n, 8) << ToString(d);
    EXPECT_LE(n, 12) << ToString(d);
    ASSERT_EQ(cut.warnings().size(), 1u) << ToString(d);
    EXPECT_THAT(cut.warnings()[0], HasSubstr("cut.avi"));
    EXPECT_THAT(cut.warnings()[0], HasSubstr("truncated"));
  }
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH (the MPEG-TS case)";
  const std::string ts = (dir / "full.ts").string();
  if (!RunFfmpeg({"-f", "lavfi", "-i", "testsrc=size=320x240:rate=10", "-t", "4", "-c:v", "libx264",
                  ts})) {
    GTEST_SKIP() << "ffmpeg has no libx264";
  }
  {
    std::ifstream in(ts, std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.ts", std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  VideoFileSource cut(dir / "cut.ts", WithDecoder(VideoDecoderChoice::kFfmpeg));
  Frame f;
  int n = 0;
  while (cut.Next(f)) ++n;
  EXPECT_GT(n, 5);
  EXPECT_LT(n, 35);
}

// The two decoders agree on a plain clip: sizes, fps, count, indices, times, grey within 2
// levels and colour within 2 on average. MJPG is full-range BT.601 YUV, so OpenCV's BGR->grey
// (BT.601 weights) gives back Y' up to rounding where no colour clips; the frames are smooth
// (blurred texture): on raw noise, chroma interpolation pushes some pixels' RGB out of [0, 255]
// and OpenCV's grey then differs from the true luma by up to 17 levels (measured: 36 of 3072
// pixels over 2 levels, mean 0.9), which ours, read from the Y' plane, does not.
TEST(VideoDecoder, BothDecodersAgreeOnAPlainClip) {
  io_test::TempDir dir("aerovo_dec_agree");
  {
    cv::VideoWriter w((dir / "clip.avi").string(), cv::CAP_FFMPEG,
                      cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(64, 48));
    ASSERT_TRUE(w.isOpened());
    for (int i = 0; i < 12; ++i) {
      cv::Mat smooth;
      cv::GaussianBlur(io_test::TextureImage(64, 48, i), smooth, cv::Size(9, 9), 3.0);
      w.write(smooth);
    }
  }
  FrameSourceOptions o;
  o.step = 3;
  o.start_time_s = 0.2;
  o.keep_color = true;
  o.video_decoder = VideoDecoderChoice::kFfmpeg;
  VideoFileSource ours(dir / "clip.avi", o);
  o.video_decoder = VideoDecoderChoice::kOpenCv;
  VideoFileSource cv(dir / "clip.avi", o);
  EXPECT_EQ(ours.fps(), cv.fps());
  EXPECT_EQ(ours.frame_count(), cv.frame_count());
  EXPECT_EQ(ours.ExpectedFrameCount(), cv.ExpectedFrameCount());
  Frame a, b;
  int n = 0;
  while (ours.Next(a)) {
    ASSERT_TRUE(cv.Next(b));
    EXPECT_EQ(a.index, b.index);
    EXPECT_EQ(a.time_s, b.time_s);
    ASSERT_EQ(a.gray.width(), b.gray.width());
    double max_diff = 0.0;
    for (int y = 0; y < a.gray.height(); ++y) {
      for (int x = 0; x < a.gray.width(); ++x) {
        max_diff = std::max(max_diff, std::abs(double(a.gray.at(x, y)) - b.gray.at(x, y)));
      }
    }
    EXPECT_LE(max_diff, 2.0) << a.index;
    ASSERT_EQ(a.color.type(), CV_8UC3);
    EXPECT_LT(cv::norm(a.color, b.color, cv::NORM_L1) / a.color.total() / 3, 2.0);
    ++n;
  }
  EXPECT_FALSE(cv.Next(b));
  EXPECT_EQ(n, 4);  // 2 5 8 11
}

// SeekBefore lands on the key frame at or before the time asked (every frame of MJPG; in an
// MPEG-4 Part 2 stream written with -g 10, at most 10 frames apart: the encoder adds key frames
// at scene changes) and the frames from there are the ones read in order.
TEST(VideoDecoder, SeekBeforeAndSkippingNonReferenceFramesKeepTheFramesExact) {
  if (!io_test::HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not on PATH (writes the MPEG-4 clip)";
  io_test::TempDir dir("aerovo_dec_seek");
  {
    cv::VideoWriter w((dir / "clip.avi").string(), cv::CAP_FFMPEG,
                      cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(64, 48));
    ASSERT_TRUE(w.isOpened());
    for (int i = 0; i < 40; ++i) {
      cv::Mat smooth;
      cv::GaussianBlur(io_test::TextureImage(64, 48, i), smooth, cv::Size(9, 9), 3.0);
      w.write(smooth);
    }
  }
  ASSERT_TRUE(io_test::RunFfmpeg({"-i", (dir / "clip.avi").string(), "-c:v", "mpeg4", "-q:v",
                                  "2", "-g", "10", "-bf", "0", (dir / "clip.mp4").string()}));
  // Skipping the non-reference frames (B frames of a stream written with -bf 2): fewer frames
  // come out, each the frame of its timestamp exactly as decoded in full.
  ASSERT_TRUE(io_test::RunFfmpeg({"-i", (dir / "clip.avi").string(), "-c:v", "mpeg4", "-q:v",
                                  "2", "-g", "10", "-bf", "2", (dir / "clip_b.mp4").string()}));
  {
    std::vector<GrayImage> full;
    VideoDecoder all(dir / "clip_b.mp4", 1);
    while (all.Grab()) all.Gray(full.emplace_back());
    ASSERT_EQ(full.size(), 40u);
    VideoDecoder d(dir / "clip_b.mp4", 1);
    d.SkipNonReferenceFrames(true);
    int decoded = 0;
    while (d.Grab()) {
      const int i = static_cast<int>(std::lround(d.timestamp_ms() / 100.0));
      ASSERT_TRUE(i >= 0 && i < 40) << i;
      GrayImage g;
      d.Gray(g);
      EXPECT_TRUE(std::equal(g.data(), g.data() + g.width() * g.height(), full[i].data())) << i;
      ++decoded;
    }
    EXPECT_LT(decoded, 30);  // about a third: I and P frames
    EXPECT_GE(decoded, 4);   // the key frames at least
  }
  for (const auto& [file, key_every] : {std::pair<std::string, int>{"clip.avi", 1}, {"clip.mp4", 10}}) {
    std::vector<GrayImage> in_order;
    VideoDecoder all(dir / file, 1);
    while (all.Grab()) all.Gray(in_order.emplace_back());
    ASSERT_EQ(in_order.size(), 40u) << file;
    VideoDecoder d(dir / file, 1);
    for (int target : {25, 33, 7}) {  // forward, forward, back
      ASSERT_TRUE(d.SeekBefore(target / 10.0 + 0.01)) << file << " " << target;
      ASSERT_TRUE(d.Grab());
      const int landed = static_cast<int>(std::lround(d.timestamp_ms() / 100.0));
      EXPECT_LE(landed, target) << file;
      EXPECT_GT(landed, target - key_every) << file;
      for (int i = landed; i < landed + 3; ++i) {
        if (i > landed) {
          ASSERT_TRUE(d.Grab());
        }
        GrayImage g;
        d.Gray(g);
        ASSERT_EQ(g.width(), in_order[i].width());
        EXPECT_TRUE(std::equal(g.data(), g.data() + g.width() * g.height(), in_order[i].data()))
            << file << " frame " << i;
      }
    }
  }
}

TEST(VideoDecoder, LimitedToFullLumaIsTheRoundedRuleForAllValues) {
  for (int y = 0; y < 256; ++y) {
    const double exact = std::clamp((y - 16) * 255.0 / 219.0, 0.0, 255.0);
    EXPECT_EQ(VideoDecoder::LimitedToFullLuma(y), static_cast<int>(std::floor(exact + 0.5))) << y;
  }
  EXPECT_EQ(VideoDecoder::LimitedToFullLuma(16), 0);
  EXPECT_EQ(VideoDecoder::LimitedToFullLuma(235), 255);
  EXPECT_EQ(VideoDecoder::LimitedToFullLuma(126), 128);  // 110 * 255 / 219 = 128.08
}

TEST(VideoDecoder, OpenErrorsNameTheFileAndThreadsAreValidated) {
  io_test::TempDir dir("aerovo_dec_bad");
  std::ofstream(dir / "text.mp4") << "this is a text file, not a video\n";
  io_test::ExpectInputError([&] { VideoDecoder d(dir / "text.mp4", 1); },
                            {"cannot open video '", "text.mp4': ", "FFmpeg cannot read it"});
  FrameSourceOptions o;
  o.video_threads = -1;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o.video_threads = 65;
  EXPECT_THROW(Validate(o), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::video_decoder_test
