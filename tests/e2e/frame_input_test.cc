// Frames that lie (docs/inputs.md, "Frames that are not what the camera saw"): inputs whose decoded
// frames are not what the camera saw, or are too large to process, each generated here and run
// through RunFlight (the `aerovo run` path):
//  - a video whose resolution changes mid-stream (two MPEG-TS clips concatenated): OpenCV hands
//    back the last frame of the first size; the run stops with an error naming the video and the
//    frame instead of a frozen track of "ok" frames;
//  - a video with a repeated frame: flagged "duplicate" in frames.csv and summary.json;
//  - a video with rotation metadata: processed as stored (not rotated), with a warning, so the
//    focal length from the field of view and the track are those of the same video without it;
//  - photos cut short (flagged "truncated", named before libjpeg's unnamed message), empty or
//    not images (an error naming the photo and the problem);
//  - a pair of 12000 x 12000 photos: reduced to the 24 MP budget before SURF, the step still
//    measured in metres.
// Frames: crops of the simulator's procedural terrain seen by a nadir camera with focal 400 px
// at 100 m (1 px = 0.25 m), as in bad_input_test.cc.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/frames/ffmpeg_test_util.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/sim/terrain.h"
#include "e2e_testing.h"
#include "nadir_ground.h"

namespace aerovo::frame_input_test {
namespace {

namespace fs = std::filesystem;
using io_test::HaveFfmpeg;
using io_test::RunFfmpeg;

using namespace e2e::nadir;  // kW, kH, kFocalPx, kHeightM, kGsd, Ground(), Config()

fs::path TempDir(const std::string& name) { return e2e::FreshTempDir("aerovo_frame_input", name); }

// Frame i of an eastward leg: 2 m (8 px) per frame, `scale` times the 320x240 size (the same
// ground seen by a sensor with `scale` times the pixels).
cv::Mat Render(int i, int scale = 1) {
  return e2e::RenderNadir(Ground(), kGsd, -120.0 + 2.0 * i, 60.0, 0.0, kW, kH, scale);
}

struct Row {
  double x_m = 0.0, y_m = 0.0;
  std::string status;
};

std::vector<Row> ReadFrames(const fs::path& run_dir) {
  std::ifstream in(run_dir / "frames.csv");
  std::string line;
  std::vector<Row> rows;
  if (!std::getline(in, line)) return rows;
  std::vector<std::string> header;
  std::stringstream hs(line);
  for (std::string f; std::getline(hs, f, ',');) header.push_back(f);
  while (std::getline(in, line)) {
    std::map<std::string, std::string> cell;
    std::stringstream ls(line);
    std::string f;
    for (std::size_t i = 0; i < header.size() && std::getline(ls, f, ','); ++i) cell[header[i]] = f;
    rows.push_back({std::stod(cell.at("x_m")), std::stod(cell.at("y_m")), cell.at("status")});
  }
  return rows;
}

using e2e::ReadJson;

bool HasWarning(const RunSummary& s, const std::string& part) {
  for (const std::string& w : s.warnings) {
    if (w.find(part) != std::string::npos) return true;
  }
  return false;
}

std::string Warnings(const RunSummary& s) { return fmt::format("{}", fmt::join(s.warnings, "\n")); }

// frame_0000.png ... of frames first..first+n-1 at `scale`.
void WritePngs(const fs::path& dir, int first, int n, int scale = 1) {
  fs::create_directories(dir);
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("frame_{:04d}.png", i)).string(),
                            Render(first + i, scale)));
  }
}

// ------------------------------------------------------------------------------- video

// Two recordings concatenated into one MPEG-TS, 320x240 then 640x480: OpenCV decodes the second
// as copies of the first's last frame. Before: every frame "ok", the track frozen. Now: the run
// stops at the join (the stream's clock restarts) with an error naming the video and the frame,
// the frames before it kept.
TEST(FrameInput, ResolutionChangeMidStreamStopsTheRunNamingTheVideoAndFrame) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  const fs::path dir = TempDir("ts");
  WritePngs(dir / "a", 0, 12);
  WritePngs(dir / "b", 12, 12, 2);
  for (const char* part : {"a", "b"}) {
    ASSERT_TRUE(RunFfmpeg({"-framerate", "10", "-i", (dir / part / "frame_%04d.png").string(),
                           "-c:v", "mpeg2video", "-q:v", "2", (dir / (part + std::string(".ts"))).string()}));
  }
  {
    std::ofstream out(dir / "flight.ts", std::ios::binary);
    for (const char* part : {"a.ts", "b.ts"}) {
      std::ifstream in(dir / part, std::ios::binary);
      out << in.rdbuf();
    }
  }
  try {
    RunFlight(Config(dir / "flight.ts", dir / "run"));
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("flight.ts"), std::string::npos) << m;
    // Frame 11, the first clip's last, is held back by the MPEG-2 decoder and lost at the join.
    EXPECT_NE(m.find("frame 11: the stream's timestamps go back from 1.000 s to 0.000 s"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("recordings joined into one file"), std::string::npos) << m;
  }
  const nlohmann::json summary = ReadJson(dir / "run" / "summary.json");
  EXPECT_NE(summary["error"].get<std::string>().find("flight.ts"), std::string::npos);
  const std::vector<Row> rows = ReadFrames(dir / "run");
  // The first clip's frames 0-10, 2 m apart; none of the second's.
  ASSERT_EQ(rows.size(), 11u);
  EXPECT_NEAR(std::hypot(rows[10].x_m - rows[0].x_m, rows[10].y_m - rows[0].y_m), 20.0, 0.5);
  for (std::size_t i = 1; i < rows.size(); ++i) EXPECT_EQ(rows[i].status, "ok") << i;
  fs::remove_all(dir);
}

// One frame written twice: flagged "duplicate" (frames.csv status, summary.json count, a warning
// naming it); the run completes and the track still reaches the right end.
TEST(FrameInput, RepeatedVideoFrameIsFlaggedAndCounted) {
  const fs::path dir = TempDir("dup");
  {
    cv::VideoWriter w((dir / "flight.avi").string(), cv::CAP_FFMPEG,
                      cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(kW, kH), false);
    ASSERT_TRUE(w.isOpened());
    for (int i = 0; i < 8; ++i) {
      const cv::Mat f = Render(i);
      w.write(f);
      if (i == 4) w.write(f);  // video frame 5 repeats frame 4
    }
  }
  const RunSummary s = RunFlight(Config(dir / "flight.avi", dir / "run"));
  EXPECT_EQ(s.frames_processed, 9);
  ASSERT_EQ(s.frames_flagged.count("duplicate"), 1u);
  EXPECT_EQ(s.frames_flagged.at("duplicate"), 1);
  EXPECT_TRUE(HasWarning(s, "1 of 9 frames flagged 'duplicate' (first: flight.avi#5)"))
      << Warnings(s);
  const std::vector<Row> rows = ReadFrames(dir / "run");
  ASSERT_EQ(rows.size(), 9u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].status.find("+duplicate") != std::string::npos, i == 5) << i;
  }
  EXPECT_EQ(rows[5].status, "ok+duplicate");
  EXPECT_NE(FormatRunSummary(s).find("flagged by the input: duplicate 1"), std::string::npos)
      << FormatRunSummary(s);
  EXPECT_NEAR(std::hypot(rows[8].x_m, rows[8].y_m), 14.0, 0.5);
  EXPECT_EQ(ReadJson(dir / "run" / "summary.json")["frames_flagged"]["duplicate"], 1);
  fs::remove_all(dir);
}

// Rotation metadata (a phone or gimbal recording in portrait): OpenCV 4.6 would rotate the
// frames (240x320), making the focal length from the field of view 25 % short and turning the
// image axes 90 degrees against the heading. The frames are processed as stored: the same
// camera, track and step lengths as the same video without the metadata, and a warning.
TEST(FrameInput, RotatedVideoIsProcessedAsStoredWithTheRightFocalAndTrack) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  const fs::path dir = TempDir("rot");
  WritePngs(dir / "png", 0, 10);
  const fs::path plain = dir / "plain.mp4", rotated = dir / "rotated.mp4";
  ASSERT_TRUE(RunFfmpeg({"-framerate", "10", "-i", (dir / "png" / "frame_%04d.png").string(),
                         "-c:v", "mpeg4", "-q:v", "2", plain.string()}));
  ASSERT_TRUE(RunFfmpeg(
      {"-i", plain.string(), "-c", "copy", "-metadata:s:v", "rotate=90", rotated.string()}));
  auto config = [&](const fs::path& video, const std::string& out) {
    RunConfig c = Config(video, dir / out);
    c.focal_px = 0.0;
    c.hfov_deg = 2.0 * std::atan(0.5 * kW / kFocalPx) * kRadToDeg;  // focal 400 px at 320 px
    return c;
  };
  const RunSummary a = RunFlight(config(plain, "run_plain"));
  const RunSummary b = RunFlight(config(rotated, "run_rotated"));
  EXPECT_NEAR(b.focal_px, kFocalPx, 1e-6);
  EXPECT_EQ(b.focal_source, "hfov");
  EXPECT_EQ(b.processed_width_px, kW);
  EXPECT_EQ(b.processed_height_px, kH);
  EXPECT_TRUE(HasWarning(b, "rotation metadata (90 degrees")) << Warnings(b);
  EXPECT_FALSE(HasWarning(a, "rotation metadata")) << Warnings(a);
  const std::vector<Row> ra = ReadFrames(dir / "run_plain"), rb = ReadFrames(dir / "run_rotated");
  ASSERT_EQ(ra.size(), 10u);
  ASSERT_EQ(rb.size(), ra.size());
  for (std::size_t i = 0; i < ra.size(); ++i) {
    EXPECT_EQ(rb[i].x_m, ra[i].x_m) << i;
    EXPECT_EQ(rb[i].y_m, ra[i].y_m) << i;
  }
  // 9 steps of 2 m: the right scale (a 240-px-wide rotated frame would give 2.67 m steps).
  EXPECT_NEAR(std::hypot(rb[9].x_m, rb[9].y_m), 18.0, 0.5);
  fs::remove_all(dir);
}

// ------------------------------------------------------------------------------ photos

// A JPEG cut short decodes with its lower part grey: flagged, counted, named on stderr before
// libjpeg's own unnamed "Premature end of JPEG file".
TEST(FrameInput, TruncatedJpegIsNamedFlaggedAndCounted) {
  const fs::path dir = TempDir("cut_jpg");
  fs::create_directories(dir / "photos");
  for (int i = 0; i < 8; ++i) {
    ASSERT_TRUE(cv::imwrite((dir / "photos" / fmt::format("frame_{:04d}.jpg", i)).string(),
                            Render(i), {cv::IMWRITE_JPEG_QUALITY, 95}));
  }
  const fs::path cut = dir / "photos" / "frame_0003.jpg";
  fs::resize_file(cut, fs::file_size(cut) * 8 / 10);
  ::testing::internal::CaptureStderr();
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(s.frames_processed, 8);
  ASSERT_EQ(s.frames_flagged.count("truncated"), 1u);
  EXPECT_EQ(s.frames_flagged.at("truncated"), 1);
  EXPECT_TRUE(HasWarning(s, "frame_0003.jpg' is truncated")) << Warnings(s);
  EXPECT_TRUE(HasWarning(s, "1 of 8 frames flagged 'truncated' (first: frame_0003.jpg)"))
      << Warnings(s);
  const std::size_t named = err.find("frame_0003.jpg' is truncated");
  ASSERT_NE(named, std::string::npos) << err;
  const std::size_t libjpeg = err.find("Premature end of JPEG file");
  if (libjpeg != std::string::npos) {
    EXPECT_LT(named, libjpeg) << err;
  }
  const std::vector<Row> rows = ReadFrames(dir / "run");
  ASSERT_EQ(rows.size(), 8u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].status.find("+truncated") != std::string::npos, i == 3) << rows[i].status;
  }
  EXPECT_EQ(ReadJson(dir / "run" / "summary.json")["frames_flagged"]["truncated"], 1);
  fs::remove_all(dir);
}

// An empty file or a text file with a photo's name: an error naming it and the problem.
TEST(FrameInput, EmptyOrForeignPhotoIsAnErrorNamingItAndTheProblem) {
  const fs::path dir = TempDir("empty_jpg");
  WritePngs(dir / "photos", 0, 4);
  std::ofstream(dir / "photos" / "frame_0002.png", std::ios::trunc).close();
  try {
    RunFlight(Config(dir / "photos", dir / "run"));
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("frame_0002.png"), std::string::npos) << m;
    EXPECT_NE(m.find("empty (0 bytes)"), std::string::npos) << m;
  }
  std::ofstream(dir / "photos" / "frame_0000.png", std::ios::trunc) << "lat,lon\n1,2\n";
  try {
    RunFlight(Config(dir / "photos", dir / "run2"));
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("frame_0000.png"), std::string::npos) << m;
    EXPECT_NE(m.find("not an image"), std::string::npos) << m;
  }
  fs::remove_all(dir);
}

// Two 12000 x 12000 photos (144 MP each; before, on a multi-scale texture: 940 000 points per
// frame, 70 s and 2.1 GB for the pair, BENCHMARKS.md "Large frames"). Now reduced to the 24 MP
// budget (4898 x 4898) before SURF: the step is measured in metres with the focal length scaled.
TEST(FrameInput, HugePhotosAreReducedToThePixelBudget) {
  const fs::path dir = TempDir("huge");
  fs::create_directories(dir / "photos");
  constexpr int kSide = 12000, kShiftPx = 96;
  {
    // Texture: smoothed noise, blobs of about 20 full-frame pixels; the second photo sees it
    // shifted by kShiftPx rows.
    cv::Mat noise(kSide / 12 + 8, kSide / 12, CV_8UC1);
    cv::RNG rng(15);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 0.8);
    cv::Mat big;
    cv::resize(noise, big, cv::Size(kSide, kSide + 96), 0, 0, cv::INTER_CUBIC);
    ASSERT_TRUE(cv::imwrite((dir / "photos" / "a.jpg").string(), big.rowRange(0, kSide),
                            {cv::IMWRITE_JPEG_QUALITY, 90}));
    ASSERT_TRUE(cv::imwrite((dir / "photos" / "b.jpg").string(),
                            big.rowRange(kShiftPx, kShiftPx + kSide),
                            {cv::IMWRITE_JPEG_QUALITY, 90}));
  }
  RunConfig c = Config(dir / "photos", dir / "run");
  c.focal_px = 10000.0;  // full-frame pixels: 1 px = 1 cm at 100 m
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 2);
  EXPECT_EQ(s.processed_width_px, 4898);
  EXPECT_EQ(s.processed_height_px, 4898);
  EXPECT_NEAR(s.frame_scale, 4898.0 / kSide, 1e-12);
  EXPECT_NEAR(s.focal_px, 10000.0, 1e-9);  // the camera's, in full-frame pixels
  const std::vector<Row> rows = ReadFrames(dir / "run");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].status.rfind("ok", 0), 0u) << rows[1].status;
  // 96 px at 1 cm/px.
  EXPECT_NEAR(std::hypot(rows[1].x_m - rows[0].x_m, rows[1].y_m - rows[0].y_m), 0.96, 0.03);
  const nlohmann::json summary = ReadJson(dir / "run" / "summary.json");
  EXPECT_EQ(summary["processed_width_px"], 4898);
  // transforms.csv in full-frame pixels: frame 1 is 96 rows from frame 0.
  std::ifstream t(dir / "run" / "transforms.csv");
  std::string header, row0, row1;
  ASSERT_TRUE(std::getline(t, header) && std::getline(t, row0) && std::getline(t, row1));
  std::vector<double> cells;
  std::stringstream rs(row1);
  for (std::string cell; std::getline(rs, cell, ',');) cells.push_back(std::stod(cell));
  ASSERT_EQ(cells.size(), 7u);  // frame, a11, a12, tx, a21, a22, ty
  EXPECT_NEAR(std::hypot(cells[3], cells[6]), kShiftPx, 0.5);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::frame_input_test
