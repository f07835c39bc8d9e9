// The text track of a video as telemetry (frames/video_text_track.h): timed-text samples byte by
// byte as 3GPP TS 26.245 section 5.17 lays them out, and videos whose DJI captions ffmpeg muxed in
// as MP4/MOV timed text (mov_text, what DJI aircraft write) and Matroska SubRip, read back and
// compared with the same captions read from the .SRT.
#include "aerovo/frames/video_text_track.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/ffmpeg_test_util.h"

namespace aerovo::video_text_track_test {
namespace {

namespace fs = std::filesystem;
using io_test::HaveFfmpeg;
using io_test::RunFfmpeg;
using ::testing::HasSubstr;

std::string Sample(const std::string& text, const std::string& boxes = "") {
  std::string s = {static_cast<char>(text.size() >> 8), static_cast<char>(text.size() & 0xFF)};
  return s + text + boxes;
}

std::string Text(const std::string& sample) {
  return TimedTextSampleText(reinterpret_cast<const std::uint8_t*>(sample.data()), sample.size(),
                             "v.mp4 (sample 3)");
}

TEST(VideoTextTrack, TimedTextSamplesAsTheStandardLaysThemOut) {
  // The text, then a modifier box ("styl": size 22, one style record) that is not text.
  const std::string styl(
      "\x00\x00\x00\x16styl\x00\x01\x00\x00\x00\x05\x00\x01\x00\x12\xFF\xFF\xFF\xFF", 22);
  EXPECT_EQ(Text(Sample("FrameCnt: 1\r\n[iso: 100]\r", styl)), "FrameCnt: 1\n[iso: 100]\n");
  EXPECT_EQ(Text(Sample("")), "");  // an empty sample: a gap between cues
  EXPECT_EQ(Text(Sample("\xEF\xBB\xBFGPS")), "GPS");
  // UTF-16 big- and little-endian after a byte order mark; a degree sign and a surrogate pair.
  EXPECT_EQ(Text(Sample(std::string("\xFE\xFF\x00G\x00\xB0\xD8\x3D\xDE\x00\x00\n", 12))),
            "G\xC2\xB0\xF0\x9F\x98\x80\n");
  EXPECT_EQ(Text(Sample(std::string("\xFF\xFEG\x00\xB0\x00", 6))), "G\xC2\xB0");
  // A damaged sample names the video and the sample.
  try {
    Text(
        std::string("\x00\x10"
                    "abc",
                    5));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("v.mp4 (sample 3): the timed-text sample says its text is 16 "
                                    "bytes, but the sample holds 3"));
  }
  EXPECT_THROW(Text(std::string("\x00", 1)), InputError);
  // Text without the count (some cameras' QuickTime text samples): "F/" reads as a count of
  // 17967, beyond the sample, and every byte is text.
  EXPECT_EQ(Text("F/2.8, SS 1000, ISO 100, EV 0, GPS (8.6499, 53.1665, 18), D 24.26m\r\n"),
            "F/2.8, SS 1000, ISO 100, EV 0, GPS (8.6499, 53.1665, 18), D 24.26m\n");
  EXPECT_THROW(Text(Sample(std::string("\xFE\xFF\x00", 3))), InputError);
}

// DJI captions of a 10 fps video (a Mini 4 Pro's line layout), one per frame, the position
// moving north-east.
std::string DjiCaptions(int frames) {
  std::string srt;
  for (int k = 0; k < frames; ++k) {
    srt += fmt::format(
        "{}\n00:00:{:02},{:03} --> 00:00:{:02},{:03}\n<font size=\"28\">FrameCnt: {}, DiffTime: "
        "100ms\n2024-05-01 12:00:{:02}.{:03}\n[iso: 100] [shutter: 1/1000.0] [fnum: 1.7] [ev: 0] "
        "[color_md: default] [focal_len: 24.00] [latitude: {:.6f}] [longitude: {:.6f}] [rel_alt: "
        "{:.3f} abs_alt: 512.300] [ct: 5500] </font>\n\n",
        k + 1, k / 10, (k % 10) * 100, (k + 1) / 10, ((k + 1) % 10) * 100, k + 1, k / 10,
        (k % 10) * 100, 47.5 + 1e-5 * k, 8.25 + 2e-5 * k, 60.0 + 0.1 * k);
  }
  return srt;
}

class VideoTextTrackFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
    dir_ = testing::FreshTempDir("aerovo_video_text_track", "files");
    video_ = dir_ / "plain.mp4";
    srt_ = dir_ / "DJI_0001.SRT";
    ASSERT_TRUE(RunFfmpeg({"-f", "lavfi", "-i", "testsrc=size=160x120:rate=10", "-t", "2", "-c:v",
                           "mpeg4", video_.string()}));
    std::ofstream(srt_) << DjiCaptions(20);
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  // The video with `srt` muxed in as a subtitle track of `codec`.
  fs::path WithTrack(const std::string& name, const std::string& codec, const fs::path& srt) {
    const fs::path out = dir_ / name;
    EXPECT_TRUE(RunFfmpeg({"-i", video_.string(), "-i", srt.string(), "-map", "0:v", "-map", "1",
                           "-c:v", "copy", "-c:s", codec, out.string()}));
    return out;
  }

  fs::path dir_, video_, srt_;
};

// What DJI aircraft write (MP4 and MOV timed text) and a Matroska SubRip track: each read back
// gives the .SRT's samples (positions, heights, frame counters, times).
TEST_F(VideoTextTrackFiles, CaptionsInAVideoAreTheSrtsTelemetry) {
  const TelemetryReadResult from_srt = ReadDjiSrt(srt_);
  ASSERT_EQ(from_srt.records, 20);
  for (const auto& [name, codec] : {std::pair<std::string, std::string>{"DJI_0001.MP4", "mov_text"},
                                    {"DJI_0001.MOV", "mov_text"},
                                    {"DJI_0001.mkv", "srt"}}) {
    SCOPED_TRACE(name);
    const fs::path v = WithTrack(name, codec, srt_);
    const std::optional<VideoTextTrackInfo> info = FindVideoTextTrack(v);
    ASSERT_TRUE(info.has_value());
    EXPECT_EQ(info->stream_index, 1);
    EXPECT_EQ(info->subtitle_index, 0);
    EXPECT_EQ(info->codec, codec == "srt" ? "subrip" : "mov_text");
    const VideoTextTrack track = ReadVideoTextTrack(v);
    EXPECT_EQ(track.cues, 20);
    EXPECT_THAT(track.srt, HasSubstr("20\n00:00:01,900 --> 00:00:02,000\n"));
    const TelemetryReadResult r = ReadTelemetryInput(v);
    ASSERT_EQ(r.records, 20);
    for (int k = 0; k < 20; ++k) {
      const TelemetrySample& a = r.telemetry.samples()[static_cast<std::size_t>(k)];
      const TelemetrySample& b = from_srt.telemetry.samples()[static_cast<std::size_t>(k)];
      EXPECT_NEAR(a.time_s, 0.1 * k, 1e-3) << k;
      EXPECT_NEAR(a.time_s, b.time_s, 1e-3) << k;
      EXPECT_EQ(a.lat_deg, b.lat_deg) << k;
      EXPECT_EQ(a.lon_deg, b.lon_deg) << k;
      EXPECT_NEAR(a.lat_deg, 47.5 + 1e-5 * k, 1e-9);
      ASSERT_TRUE(a.rel_alt_m.has_value());
      EXPECT_NEAR(*a.rel_alt_m, 60.0 + 0.1 * k, 1e-9);
      ASSERT_TRUE(a.frame_index.has_value());
      EXPECT_EQ(*a.frame_index, k);
      EXPECT_EQ(a.focal_length_35mm_mm, b.focal_length_35mm_mm);
    }
  }
  // An .SRT given to ReadTelemetryInput is read as before.
  EXPECT_EQ(ReadTelemetryInput(srt_).records, 20);
}

TEST_F(VideoTextTrackFiles, AVideoWithoutCaptionsSaysSo) {
  EXPECT_FALSE(FindVideoTextTrack(video_).has_value());
  EXPECT_FALSE(FindVideoTextTrack(dir_ / "missing.mp4").has_value());
  try {
    ReadTelemetryInput(video_);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("plain.mp4' has no subtitle track aerovo reads"));
  }
  // Subtitles that are not DJI captions: the SRT reader's error, naming the video and the line
  // of the track as SRT.
  const fs::path words = dir_ / "words.srt";
  std::ofstream(words) << "1\n00:00:00,000 --> 00:00:01,000\nHello\n\n2\n00:00:01,000 --> "
                          "00:00:02,000\nthere\n";
  const fs::path v = WithTrack("film.mp4", "mov_text", words);
  ASSERT_TRUE(FindVideoTextTrack(v).has_value());
  try {
    ReadTelemetryInput(v);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("film.mp4 (subtitle track 0 as SRT):"));
  }
  // A damaged sample (its count beyond its bytes, which are not text): strict, an error naming
  // the video and the sample (a malformed record: --lenient-telemetry skips it); lenient,
  // skipped, counted and named, the other captions read.
  {
    std::string bytes = testing::ReadText(WithTrack("damaged.mp4", "mov_text", srt_));
    std::size_t at = 0;
    for (int k = 0; k < 3; ++k) at = bytes.find("FrameCnt: ", at + 1);  // the third caption
    ASSERT_NE(at, std::string::npos);
    bytes[at - 2] = '\xFF';  // the sample's count, then its first byte of text
    bytes[at - 1] = '\xFF';
    bytes[at] = '\x01';
    const fs::path damaged = dir_ / "damaged2.mp4";
    std::ofstream(damaged, std::ios::binary) << bytes;
    try {
      ReadTelemetryInput(damaged);
      ADD_FAILURE() << "no error";
    } catch (const MalformedRecordError& e) {
      EXPECT_THAT(e.what(), HasSubstr("damaged2.mp4 (subtitle track, sample 3): the timed-text "
                                      "sample says its text is 65535 bytes"));
    }
    TelemetryReadOptions lenient;
    lenient.lenient = true;
    const TelemetryReadResult r = ReadTelemetryInput(damaged, lenient);
    EXPECT_EQ(r.records, 19);
    EXPECT_EQ(r.skipped_records, 1);
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_THAT(r.warnings[0], HasSubstr("sample 3): the timed-text sample says"));
    EXPECT_EQ(*r.telemetry.samples()[2].frame_index, 3);  // frame 2's caption is the one skipped
    // Samples 3 and 6 damaged (sample 3's "FrameCnt" is no longer found) and caption 8 without
    // its latitude: the three skipped records
    // share max_warnings' messages, the damaged samples first (found by fuzz_video: the
    // damaged samples were listed beyond max_warnings).
    at = 0;
    for (int k = 0; k < 5; ++k) at = bytes.find("FrameCnt: ", at + 1);
    bytes[at - 2] = '\xFF';
    bytes[at - 1] = '\xFF';
    bytes[at] = '\x01';
    for (int k = 0; k < 2; ++k) at = bytes.find("FrameCnt: ", at + 1);
    at = bytes.find("latitude", at);
    ASSERT_NE(at, std::string::npos);
    bytes[at] = 'X';
    const fs::path three = dir_ / "damaged3.mp4";
    std::ofstream(three, std::ios::binary) << bytes;
    for (const int max_warnings : {0, 1, 2, 3, 10}) {
      lenient.max_warnings = max_warnings;
      const TelemetryReadResult t = ReadTelemetryInput(three, lenient);
      EXPECT_EQ(t.records, 17);
      EXPECT_EQ(t.skipped_records, 3);
      ASSERT_EQ(t.warnings.size(), static_cast<std::size_t>(std::min(max_warnings, 3)));
      if (max_warnings >= 1) EXPECT_THAT(t.warnings[0], HasSubstr("sample 3): the timed-text"));
      if (max_warnings >= 2) EXPECT_THAT(t.warnings[1], HasSubstr("sample 6): the timed-text"));
      if (max_warnings >= 3) EXPECT_THAT(t.warnings[2], HasSubstr("has no latitude"));
    }
  }
  // A damaged file: FFmpeg's reason, naming it.
  const fs::path cut = dir_ / "cut.mp4";
  std::ofstream(cut) << std::string(
      "\x00\x00\x00\x20"
      "ftypisom",
      12);
  try {
    ReadTelemetryInput(cut);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cut.mp4"));
  }
}

}  // namespace
}  // namespace aerovo::video_text_track_test
