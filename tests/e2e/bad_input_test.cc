// The bad-input corpus of `aerovo run` (docs/inputs.md, "Bad inputs"): every case is generated
// here, in a temporary folder, and run through RunFlight (the `aerovo run` path). Each case asserts
// one of the two acceptable outcomes: an InputError whose message names the file and the problem,
// or a completed run whose damaged frames are flagged in frames.csv and whose trajectory is not
// silently wrong (no NaN, no jump, flagged frames bridged). docs/reliability.md lists the cases.
//
// Frames: 320x240 crops of the simulator's procedural terrain (0.25 m/px), seen by a nadir
// camera with focal 400 px at 100 m (so 1 px = 0.25 m), written as PNG photo folders (lossless,
// no EXIF: ordered by file name, time = rank).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
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

#include "aerovo/core/error.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/sim/terrain.h"
#include "e2e_testing.h"
#include "nadir_ground.h"

namespace aerovo::bad_input_test {
namespace {

namespace fs = std::filesystem;

using namespace e2e::nadir;  // kW, kH, kFocalPx, kHeightM, kGsd, Ground(), Config()

fs::path TempDir(const std::string& name) { return e2e::FreshTempDir("aerovo_bad_input", name); }

// A camera pose in the local frame of the ground's centre: x east, y north (m); heading = the
// image-up direction, rad counter-clockwise from north (the VO's heading convention).
struct Pose {
  double x_m = 0.0, y_m = 0.0, heading_rad = 0.0;
};

// The nadir frame at `pose`: ground pixel = centre + (x, -y) / gsd + R(-heading) (p - c).
cv::Mat Render(const Pose& pose) {
  return e2e::RenderNadir(Ground(), kGsd, pose.x_m, pose.y_m, pose.heading_rad, kW, kH);
}

// A straight eastward leg: n poses, 2 m (8 px) apart, starting at (x0, y0).
std::vector<Pose> Leg(int n, double x0_m = -120.0, double y0_m = 60.0, double step_m = 2.0) {
  std::vector<Pose> poses;
  for (int i = 0; i < n; ++i) poses.push_back({x0_m + i * step_m, y0_m, 0.0});
  return poses;
}

// Writes frames as frame_0000.png, ... into `dir`.
void WriteFolder(const fs::path& dir, const std::vector<cv::Mat>& frames) {
  fs::create_directories(dir);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("frame_{:04d}.png", i)).string(), frames[i]));
  }
}

std::vector<cv::Mat> RenderAll(const std::vector<Pose>& poses) {
  std::vector<cv::Mat> frames;
  for (const Pose& p : poses) frames.push_back(Render(p));
  return frames;
}

using e2e::ReadFramesCsv;

double Num(const std::map<std::string, std::string>& row, const std::string& key) {
  const auto it = row.find(key);
  if (it == row.end() || it->second.empty()) return std::nan("");
  return std::stod(it->second);
}

struct Track {
  std::vector<Eigen::Vector2d> xy_m;
  std::vector<std::string> status;
};

// The run's track from frames.csv; every coordinate must be a finite number.
Track ReadTrack(const fs::path& run_dir) {
  Track t;
  for (const auto& row : ReadFramesCsv(run_dir)) {
    const Eigen::Vector2d p(Num(row, "x_m"), Num(row, "y_m"));
    EXPECT_TRUE(p.allFinite()) << "frame " << row.at("frame") << ": position not finite";
    t.xy_m.push_back(p);
    t.status.push_back(row.at("status"));
  }
  return t;
}

// Runs `config` expecting an InputError whose message contains every one of `parts`.
void ExpectInputError(const RunConfig& config, const std::vector<std::string>& parts) {
  try {
    RunFlight(config);
    ADD_FAILURE() << "expected an InputError for " << config.input;
  } catch (const InputError& e) {
    const std::string m = e.what();
    for (const std::string& p : parts) EXPECT_NE(m.find(p), std::string::npos) << m;
  }
}

bool HasWarning(const RunSummary& s, const std::string& part) {
  return std::any_of(s.warnings.begin(), s.warnings.end(),
                     [&](const std::string& w) { return w.find(part) != std::string::npos; });
}

// ------------------------------------------------------------------------------- files

TEST(BadInput, ZeroByteVideoIsAnErrorNamingIt) {
  const fs::path dir = TempDir("zero");
  std::ofstream(dir / "flight.mp4").close();
  ExpectInputError(Config(dir / "flight.mp4", dir / "run"), {"flight.mp4", "empty (0 bytes)"});
  fs::remove_all(dir);
}

TEST(BadInput, TextFileNamedMp4IsAnErrorNamingIt) {
  const fs::path dir = TempDir("text");
  std::ofstream(dir / "notes.mp4") << "this is not a video\n";
  ExpectInputError(Config(dir / "notes.mp4", dir / "run"), {"notes.mp4", "cannot open video"});
  fs::remove_all(dir);
}

// A real short video (MPEG-4 Part 2 in MP4, 40 frames of a leg) cut in half.
TEST(BadInput, TruncatedMp4IsAnErrorNamingIt) {
  const fs::path dir = TempDir("trunc_mp4");
  const fs::path video = dir / "cut.mp4";
  {
    cv::VideoWriter w(video.string(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), 10.0,
                      cv::Size(kW, kH), false);
    ASSERT_TRUE(w.isOpened());
    for (const cv::Mat& f : RenderAll(Leg(40))) w.write(f);
  }
  const auto size = fs::file_size(video);
  ASSERT_GT(size, 1000u);
  fs::resize_file(video, size / 2);
  // The MP4 index (moov) is written at the end: half a file has frames but no index.
  ExpectInputError(Config(video, dir / "run"), {"cut.mp4", "damaged or truncated"});
  fs::remove_all(dir);
}

// The same with an AVI (MJPG), whose frames are readable in order without an index: the run
// keeps every frame that survived, and says the video ended early.
TEST(BadInput, TruncatedAviRunsTheSurvivingFramesWithAWarning) {
  const fs::path dir = TempDir("trunc_avi");
  const fs::path video = dir / "cut.avi";
  {
    cv::VideoWriter w(video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0,
                      cv::Size(kW, kH), false);
    ASSERT_TRUE(w.isOpened());
    for (const cv::Mat& f : RenderAll(Leg(40))) w.write(f);
  }
  fs::resize_file(video, fs::file_size(video) / 2);
  for (const int step : {1, 3}) {
    SCOPED_TRACE(step);
    RunConfig c = Config(video, dir / "run");
    c.step = step;
    const RunSummary s = RunFlight(c);
    EXPECT_GT(s.frames_processed, 10 / step);
    EXPECT_LT(s.frames_processed, 40 / step);
    EXPECT_TRUE(HasWarning(s, "truncated")) << fmt::format("{}", fmt::join(s.warnings, "\n"));
    EXPECT_EQ(s.frames_bridged, 0);
    const Track t = ReadTrack(dir / "run");
    ASSERT_EQ(static_cast<int>(t.xy_m.size()), s.frames_processed);
    // 2 m per video frame eastwards (x = first image right), to the last frame delivered: the
    // stale image FFmpeg makes of the cut packet would show as a step of 0.
    for (std::size_t i = 1; i < t.xy_m.size(); ++i) {
      EXPECT_NEAR(t.xy_m[i].x() - t.xy_m[i - 1].x(), 2.0 * step, 0.1) << i;
    }
  }
  fs::remove_all(dir);
}

TEST(BadInput, FolderWithANonImageFileSkipsItWithAWarning) {
  const fs::path dir = TempDir("nonimage");
  WriteFolder(dir / "photos", RenderAll(Leg(8)));
  std::ofstream(dir / "photos" / "flight_log.txt") << "battery 87%\n";
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 8);
  EXPECT_EQ(s.frames_bridged, 0);
  EXPECT_TRUE(HasWarning(s, "flight_log.txt")) << fmt::format("{}", fmt::join(s.warnings, "\n"));
  fs::remove_all(dir);
}

// Met mid-run: the error names the photo, and the frames before it are kept (outputs closed,
// summary.json written with the error).
TEST(BadInput, FolderWithAnUndecodablePhotoIsAnErrorNamingIt) {
  const fs::path dir = TempDir("undecodable");
  WriteFolder(dir / "photos", RenderAll(Leg(4)));
  std::ofstream(dir / "photos" / "frame_0002.png", std::ios::trunc) << "not a PNG";
  ExpectInputError(Config(dir / "photos", dir / "run"),
                   {"frame_0002.png", "cannot decode", "the run stopped there"});
  std::ifstream in(dir / "run" / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["frames_processed"], 2);
  EXPECT_NE(summary["error"].get<std::string>().find("frame_0002.png"), std::string::npos);
  EXPECT_EQ(ReadTrack(dir / "run").xy_m.size(), 2u);
  fs::remove_all(dir);
}

TEST(BadInput, FolderWithMixedResolutionsIsAnErrorNamingTheOddPhoto) {
  const fs::path dir = TempDir("mixed");
  std::vector<cv::Mat> frames = RenderAll(Leg(6));
  cv::resize(frames[3], frames[3], cv::Size(640, 480));
  WriteFolder(dir / "photos", frames);
  ExpectInputError(Config(dir / "photos", dir / "run"), {"frame_0003.png", "640x480", "320x240"});
  fs::remove_all(dir);
}

TEST(BadInput, FramesSmallerThanSurfsSmallestFilterAreAnErrorNamingTheFirst) {
  // 6x6 photos (and a 2x2 video, the same check on the first frame of any source): before,
  // SURF's own "Surf: the image is 2x2, smaller than the smallest SURF filter", naming no file.
  const fs::path dir = TempDir("tiny");
  std::vector<cv::Mat> frames = RenderAll(Leg(3));
  for (cv::Mat& f : frames) cv::resize(f, f, cv::Size(6, 6), 0, 0, cv::INTER_AREA);
  WriteFolder(dir / "photos", frames);
  ExpectInputError(Config(dir / "photos", dir / "run"),
                   {"frame_0000.png",
                    "the frames are 6x6 px: smaller than SURF's smallest filter "
                    "(9x9 px)"});
  fs::remove_all(dir);
}

TEST(BadInput, LensCoefficientsThatFoldTheFrameAreAnErrorNamingThem) {
  // k1 = -2 at focal 400 px: r_d(r) = r (1 - 2 r^2) peaks at r = 0.41 (163 px from the centre),
  // inside the 320x240 frame, so the undistortion folds the frame's outer part (before, the run
  // completed on folded frames). The same check as a calibration file's (camera/lens.h
  // FirstFoldedPixel). A mild lens (k1 = -0.05) runs.
  const fs::path dir = TempDir("fold");
  WriteFolder(dir / "photos", RenderAll(Leg(4)));
  RunConfig config = Config(dir / "photos", dir / "run");
  config.k1 = -2.0;
  ExpectInputError(config, {"frame_0000.png", "k1 k2 p1 p2 k3 (-2 0 0 0 0, focal 400.0 px)",
                            "turns back before the frame's edge"});
  config.k1 = -0.05;
  const RunSummary s = RunFlight(config);
  EXPECT_EQ(s.frames_processed, 4);
  fs::remove_all(dir);
}

// ------------------------------------------------------------------------------ frames

TEST(BadInput, AllBlackFramesAreFlaggedAndTheTrackDoesNotMove) {
  const fs::path dir = TempDir("black");
  WriteFolder(dir / "photos", std::vector<cv::Mat>(6, cv::Mat(kH, kW, CV_8UC1, cv::Scalar(0))));
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 6);
  EXPECT_EQ(s.frames_bridged, 5);
  EXPECT_TRUE(HasWarning(s, "no frame could be matched"))
      << fmt::format("{}", fmt::join(s.warnings, "\n"));
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.status.size(), 6u);
  for (std::size_t i = 1; i < t.status.size(); ++i) {
    // Identical black photos: also flagged as copies of the one before.
    EXPECT_EQ(t.status[i], "bridged:too-few-features+duplicate");
    EXPECT_EQ(t.xy_m[i].norm(), 0.0);
  }
  fs::remove_all(dir);
}

// A video that starts black (fade-in, lens cap): tracking must start at the first frame with
// features, not bridge the whole flight.
TEST(BadInput, BlackFirstFramesThenTheTrackStartsAtTheFirstTexturedFrame) {
  const fs::path dir = TempDir("black_start");
  std::vector<cv::Mat> frames = RenderAll(Leg(12));
  frames[0] = cv::Mat(kH, kW, CV_8UC1, cv::Scalar(0));
  frames[1] = cv::Mat(kH, kW, CV_8UC1, cv::Scalar(0));
  WriteFolder(dir / "photos", frames);
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 12);
  EXPECT_EQ(s.frames_bridged, 1);  // frame 1 (frame 0 is the first frame)
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.status.size(), 12u);
  EXPECT_EQ(t.status[1], "bridged:too-few-features+duplicate");  // frame 0's pixels again
  EXPECT_EQ(t.status[2], "first");
  for (int i = 3; i < 12; ++i) {
    EXPECT_EQ(t.status[i], "ok") << i;
    EXPECT_NEAR((t.xy_m[i] - t.xy_m[i - 1]).x(), 2.0, 0.1) << i;
  }
  EXPECT_NEAR(t.xy_m[11].x() - t.xy_m[2].x(), 18.0, 0.3);
  fs::remove_all(dir);
}

// The paper's illumination factor f_k = k f at k = 0.02: grey levels 0..5. With the paper's fixed
// threshold SURF finds (almost) nothing: frames are flagged, the track does not invent motion.
// The default's adaptive points track the leg (2 m east per frame, the truth).
TEST(BadInput, IlluminationK002IsFlaggedNotInvented) {
  const fs::path dir = TempDir("dark");
  std::vector<cv::Mat> frames = RenderAll(Leg(8));
  for (cv::Mat& f : frames) f.convertTo(f, CV_8U, 0.02);
  WriteFolder(dir / "photos", frames);
  {
    const RunSummary d = RunFlight(Config(dir / "photos", dir / "adaptive"));
    EXPECT_EQ(d.frames_bridged, 0);
    const Track t = ReadTrack(dir / "adaptive");
    ASSERT_EQ(t.status.size(), 8u);
    for (std::size_t i = 1; i < t.status.size(); ++i) {
      EXPECT_NEAR((t.xy_m[i] - t.xy_m[i - 1]).x(), 2.0, 0.1) << i;
    }
  }
  RunConfig paper = Config(dir / "photos", dir / "run");
  ApplyPaperPreset(paper);
  const RunSummary s = RunFlight(paper);
  EXPECT_EQ(s.frames_processed, 8);
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.status.size(), 8u);
  // Measured: SURF (threshold 1000) finds fewer than 20 points on every frame.
  for (std::size_t i = 1; i < t.status.size(); ++i) {
    EXPECT_EQ(t.status[i], "bridged:too-few-features") << i;
    EXPECT_EQ(t.xy_m[i].norm(), 0.0) << i;
  }
  EXPECT_TRUE(HasWarning(s, "no frame could be matched"));
  fs::remove_all(dir);
}

// One frame mid-flight replaced by `bad`: it must be flagged, bridged with the previous motion
// (2 m east), and the next frame re-acquired on the last good one; no jump anywhere.
void ExpectOneBadFrameBridged(const std::string& name, const cv::Mat& bad,
                              const std::string& expected_status_prefix,
                              const std::string& unexpected_status = "") {
  const fs::path dir = TempDir(name);
  std::vector<cv::Mat> frames = RenderAll(Leg(14));
  frames[7] = bad;
  WriteFolder(dir / "photos", frames);
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 14);
  EXPECT_EQ(s.frames_bridged, 1);
  // The leg's frames share most of their ground (8 px steps of a 320 px frame): a static ground,
  // not a sensor's pattern, and not removed (features/flat_field.h, the motion test).
  EXPECT_FALSE(s.flat_field.applied) << s.flat_field.why;
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.status.size(), 14u);
  EXPECT_EQ(t.status[7].rfind(expected_status_prefix, 0), 0u) << t.status[7];
  EXPECT_NE(t.status[7], unexpected_status);
  EXPECT_EQ(t.status[8], "reacquired");
  for (int i = 1; i < 14; ++i) {
    const Eigen::Vector2d step = t.xy_m[i] - t.xy_m[i - 1];
    EXPECT_NEAR(step.x(), 2.0, 0.15) << "frame " << i << " " << t.status[i];
    EXPECT_NEAR(step.y(), 0.0, 0.15) << "frame " << i << " " << t.status[i];
  }
  fs::remove_all(dir);
}

TEST(BadInput, UniformGreyFrameIsBridged) {
  ExpectOneBadFrameBridged("grey", cv::Mat(kH, kW, CV_8UC1, cv::Scalar(128)),
                           "bridged:too-few-features");
}

// Water: a rippled, glittering surface, full of SURF points (blobs at every scale) none of
// which is on the ground seen by the frames around it. The step must fail on matching, not
// on a lack of features, and must not be guessed from chance matches.
TEST(BadInput, WaterLikeNoiseFrameIsBridged) {
  cv::Mat water(kH, kW, CV_32F);
  cv::RNG rng(3);
  rng.fill(water, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(water, water, cv::Size(0, 0), 2.0);
  cv::normalize(water, water, 0.0, 255.0, cv::NORM_MINMAX);
  cv::Mat glitter(kH, kW, CV_32F);
  rng.fill(glitter, cv::RNG::UNIFORM, 0.0, 1.0);
  water.setTo(255.0, glitter > 0.995);
  water.convertTo(water, CV_8U);
  ExpectOneBadFrameBridged("water", water, "bridged:", "bridged:too-few-features");
}

// Photos copied under other names (each photo three times): the copies are measured as no
// motion and flagged 'duplicate' (a false standstill, not a real one), counted in summary.json
// and said on stderr naming the first copy.
TEST(BadInput, DuplicatedFramesDoNotMoveTheTrack) {
  const fs::path dir = TempDir("dup");
  std::vector<cv::Mat> frames;
  for (const cv::Mat& f : RenderAll(Leg(5))) {
    for (int k = 0; k < 3; ++k) frames.push_back(f.clone());  // each frame three times
  }
  WriteFolder(dir / "photos", frames);
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 15);
  EXPECT_EQ(s.frames_bridged, 0);
  ASSERT_EQ(s.frames_flagged.count("duplicate"), 1u);
  EXPECT_EQ(s.frames_flagged.at("duplicate"), 10);
  EXPECT_TRUE(std::any_of(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
    return w.find("10 of 15 frames flagged 'duplicate' (first: frame_0001.png)") !=
           std::string::npos;
  })) << fmt::format("{}", fmt::join(s.warnings, "\n"));
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.xy_m.size(), 15u);
  for (int i = 1; i < 15; ++i) {
    EXPECT_EQ(t.status[i], i % 3 != 0 ? "ok+duplicate" : "ok") << i;
    const double step = (t.xy_m[i] - t.xy_m[i - 1]).norm();
    if (i % 3 != 0) {
      EXPECT_LT(step, 0.01) << "duplicate frame " << i << " moved";
    } else {
      EXPECT_NEAR(step, 2.0, 0.1) << i;
    }
  }
  fs::remove_all(dir);
}

// Hovering, then the camera turns 180 degrees between two frames (a yaw spin no motion model
// predicts), then flies on: the step is measured (rotation-invariant SURF, unguided fallback)
// and the track neither jumps nor loses its heading.
TEST(BadInput, Yaw180TurnBetweenTwoFramesIsTracked) {
  const fs::path dir = TempDir("yaw180");
  std::vector<Pose> poses = Leg(8);
  Pose p = poses.back();
  p.heading_rad = M_PI;
  for (int i = 0; i < 6; ++i) {
    p.x_m += 2.0;  // still eastwards, now with the image upside down
    poses.push_back(p);
  }
  WriteFolder(dir / "photos", RenderAll(poses));
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 14);
  EXPECT_EQ(s.frames_bridged, 0);
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.xy_m.size(), 14u);
  for (int i = 1; i < 14; ++i) {
    EXPECT_EQ(t.status[i], "ok") << i;
    const Eigen::Vector2d step = t.xy_m[i] - t.xy_m[i - 1];
    EXPECT_NEAR(step.x(), 2.0, 0.15) << i;
    EXPECT_NEAR(step.y(), 0.0, 0.15) << i;
  }
  fs::remove_all(dir);
}

// Frames 0-9 over one place, frames 10-19 over another 200 m away (no overlap, never seen
// before): the jump frame is flagged and bridged with the previous motion, the flight goes on
// from there; the track shows no jump.
TEST(BadInput, JumpWithNoOverlapIsBridgedNotGuessed) {
  const fs::path dir = TempDir("jump");
  std::vector<Pose> poses = Leg(10, -120.0, 60.0);
  for (const Pose& q : Leg(10, -60.0, -140.0)) poses.push_back(q);
  WriteFolder(dir / "photos", RenderAll(poses));
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run"));
  EXPECT_EQ(s.frames_processed, 20);
  EXPECT_EQ(s.frames_bridged, 1);
  const Track t = ReadTrack(dir / "run");
  ASSERT_EQ(t.xy_m.size(), 20u);
  EXPECT_EQ(t.status[10].rfind("bridged", 0), 0u) << t.status[10];
  for (int i = 1; i < 20; ++i) {
    if (i != 10) {
      EXPECT_EQ(t.status[i], "ok") << i;
    }
    const Eigen::Vector2d step = t.xy_m[i] - t.xy_m[i - 1];
    EXPECT_NEAR(step.x(), 2.0, 0.15) << i;
    EXPECT_NEAR(step.y(), 0.0, 0.15) << i;
  }
  fs::remove_all(dir);
}

// --------------------------------------------------------------------------- telemetry

// The GPS of a leg: WGS84 of the poses (local x east, y north around a point near Lviv).
std::vector<GeoPoint> GeoOf(const std::vector<Pose>& poses) {
  const LocalEnu enu(49.84, 24.03, 300.0);
  std::vector<GeoPoint> out;
  for (const Pose& p : poses) out.push_back(enu.Reverse(p.x_m, p.y_m, kHeightM));
  return out;
}

// DJI SRT (bracketed format) with one block per frame; `edit(i, lines)` may damage block i.
std::string MakeSrt(const std::vector<GeoPoint>& fixes,
                    const std::function<void(int, std::vector<std::string>&)>& edit = {}) {
  std::string out;
  for (int i = 0; i < static_cast<int>(fixes.size()); ++i) {
    const int ms0 = i * 1000, ms1 = ms0 + 999;
    std::vector<std::string> lines = {
        std::to_string(i + 1),
        fmt::format("00:00:{:02d},{:03d} --> 00:00:{:02d},{:03d}", ms0 / 1000, ms0 % 1000,
                    ms1 / 1000, ms1 % 1000),
        fmt::format("<font size=\"28\">FrameCnt: {}, DiffTime: 1000ms", i + 1),
        fmt::format("2026-05-01 10:00:{:02d}.000", i),
        fmt::format("[latitude: {:.7f}] [longitude: {:.7f}] [rel_alt: {:.3f} abs_alt: 400.000]",
                    fixes[i].lat_deg, fixes[i].lon_deg, kHeightM),
        "</font>"};
    if (edit) edit(i, lines);
    for (const std::string& l : lines) out += l + "\n";
    out += "\n";
  }
  return out;
}

// GPX 1.1 with one trkpt per fix, one second apart; `edit(i, text)` may damage point i.
std::string MakeGpx(const std::vector<GeoPoint>& fixes,
                    const std::function<void(int, std::string&)>& edit = {}) {
  std::string out =
      "<?xml version=\"1.0\"?>\n<gpx version=\"1.1\" creator=\"test\" "
      "xmlns=\"http://www.topografix.com/GPX/1/1\">\n<trk><trkseg>\n";
  for (int i = 0; i < static_cast<int>(fixes.size()); ++i) {
    std::string pt = fmt::format(
        "<trkpt lat=\"{:.7f}\" lon=\"{:.7f}\"><ele>400.0</ele>"
        "<time>2026-05-01T10:00:{:02d}Z</time></trkpt>\n",
        fixes[i].lat_deg, fixes[i].lon_deg, i);
    if (edit) edit(i, pt);
    out += pt;
  }
  return out + "</trkseg></trk>\n</gpx>\n";
}

// A 12-frame leg with the given telemetry file; returns the folder's config.
RunConfig TelemetryCase(const fs::path& dir, const std::string& file, const std::string& text) {
  WriteFolder(dir / "photos", RenderAll(Leg(12)));
  std::ofstream(dir / file) << text;
  RunConfig c = Config(dir / "photos", dir / "run");
  c.telemetry = (dir / file).string();
  return c;
}

TEST(BadInput, TelemetryOfTheCorpusIsValidWhenUndamaged) {
  // The generators themselves: undamaged files give a run with a fix on every frame.
  for (const std::string file : {"ok.srt", "ok.gpx"}) {
    const fs::path dir = TempDir("telemetry_ok");
    const std::vector<GeoPoint> fixes = GeoOf(Leg(12));
    const RunConfig c =
        TelemetryCase(dir, file, file == "ok.srt" ? MakeSrt(fixes) : MakeGpx(fixes));
    const RunSummary s = RunFlight(c);
    EXPECT_EQ(s.frames_with_gps, 12) << file;
    ASSERT_TRUE(s.evaluation.has_value()) << file;
    EXPECT_LT(s.evaluation->se2.ate_m.rmse, 0.3) << file;
    fs::remove_all(dir);
  }
}

struct TelemetryDamage {
  const char* name;
  std::function<void(int, std::vector<std::string>&)> srt;
  std::function<void(int, std::string&)> gpx;
  std::vector<std::string> srt_message;  // parts of the expected error message
  std::vector<std::string> gpx_message;
};

std::vector<TelemetryDamage> Damages() {
  return {
      {"missing_fields",
       [](int i, std::vector<std::string>& l) {
         if (i == 5) l[4] = "[rel_alt: 100.000 abs_alt: 400.000]";  // no latitude/longitude
       },
       [](int i, std::string& p) {
         if (i == 5) p = "<trkpt lon=\"24.03\"><time>2026-05-01T10:00:05Z</time></trkpt>\n";
       },
       {":", "latitude"},
       {":", "lat"}},
      {"garbage_lines",
       [](int i, std::vector<std::string>& l) {
         if (i == 5) l[1] = "@@ garbage \x01\x02 line";
       },
       [](int i, std::string& p) {
         if (i == 5) p = "<trkpt lat=\"north\" lon=\"24.03\"><time>garbage</time></trkpt>\n";
       },
       {":"},
       {":"}},
      {"time_out_of_order",
       [](int i, std::vector<std::string>& l) {
         if (i == 5) l[1] = "00:00:01,000 --> 00:00:01,999";
       },
       [](int i, std::string& p) {
         if (i == 5) {
           const auto at = p.find("10:00:05");
           p.replace(at, 8, "10:00:01");
         }
       },
       {":", "time"},
       {":", "time"}},
      {"lat_95",
       [](int i, std::vector<std::string>& l) {
         if (i == 5)
           l[4] = "[latitude: 95.0] [longitude: 24.03] [rel_alt: 100.000 abs_alt: 400.000]";
       },
       [](int i, std::string& p) {
         if (i == 5)
           p = "<trkpt lat=\"95.0\" lon=\"24.03\"><time>2026-05-01T10:00:05Z</time></trkpt>\n";
       },
       {":", "latitude 95 out of range"},
       {":", "latitude 95 out of range"}},
      {"lon_200",
       [](int i, std::vector<std::string>& l) {
         if (i == 5)
           l[4] = "[latitude: 49.84] [longitude: 200.0] [rel_alt: 100.000 abs_alt: 400.000]";
       },
       [](int i, std::string& p) {
         if (i == 5)
           p = "<trkpt lat=\"49.84\" lon=\"200.0\"><time>2026-05-01T10:00:05Z</time></trkpt>\n";
       },
       {":", "longitude 200 out of range"},
       {":", "longitude 200 out of range"}},
  };
}

TEST(BadInput, DamagedSrtIsAnErrorNamingFileLineAndProblem) {
  for (const TelemetryDamage& d : Damages()) {
    SCOPED_TRACE(d.name);
    const fs::path dir = TempDir(std::string("srt_") + d.name);
    const std::string file = std::string(d.name) + ".srt";
    const RunConfig c = TelemetryCase(dir, file, MakeSrt(GeoOf(Leg(12)), d.srt));
    std::vector<std::string> parts = d.srt_message;
    parts.push_back(file);
    parts.push_back("--lenient-telemetry");
    ExpectInputError(c, parts);
    fs::remove_all(dir);
  }
}

TEST(BadInput, DamagedGpxIsAnErrorNamingFileLineAndProblem) {
  for (const TelemetryDamage& d : Damages()) {
    SCOPED_TRACE(d.name);
    const fs::path dir = TempDir(std::string("gpx_") + d.name);
    const std::string file = std::string(d.name) + ".gpx";
    const RunConfig c = TelemetryCase(dir, file, MakeGpx(GeoOf(Leg(12)), d.gpx));
    std::vector<std::string> parts = d.gpx_message;
    parts.push_back(file);
    parts.push_back("--lenient-telemetry");
    ExpectInputError(c, parts);
    fs::remove_all(dir);
  }
}

// The same damaged files with --lenient-telemetry: the bad record is skipped and reported, the
// run completes with the other fixes (the gap interpolated), and the comparison with GPS is as
// good as with clean telemetry.
TEST(BadInput, DamagedTelemetryWithLenientTelemetryIsSkippedAndReported) {
  for (const TelemetryDamage& d : Damages()) {
    for (const std::string ext : {".srt", ".gpx"}) {
      SCOPED_TRACE(std::string(d.name) + ext);
      const fs::path dir = TempDir(std::string("lenient_") + d.name);
      const std::string file = std::string(d.name) + ext;
      const std::vector<GeoPoint> fixes = GeoOf(Leg(12));
      RunConfig c =
          TelemetryCase(dir, file, ext == ".srt" ? MakeSrt(fixes, d.srt) : MakeGpx(fixes, d.gpx));
      c.lenient_telemetry = true;
      const RunSummary s = RunFlight(c);
      EXPECT_EQ(s.frames_processed, 12);
      EXPECT_EQ(s.frames_bridged, 0);
      // Frame 5 lost its record; its fix is interpolated between frames 4 and 6 (telemetry.h).
      EXPECT_EQ(s.frames_with_gps, 12);
      EXPECT_TRUE(HasWarning(s, "1 malformed telemetry record(s) skipped"))
          << fmt::format("{}", fmt::join(s.warnings, "\n"));
      EXPECT_TRUE(HasWarning(s, file + ":")) << fmt::format("{}", fmt::join(s.warnings, "\n"));
      ASSERT_TRUE(s.evaluation.has_value());
      EXPECT_LT(s.evaluation->se2.ate_m.rmse, 0.3);
      const Track t = ReadTrack(dir / "run");
      ASSERT_EQ(t.xy_m.size(), 12u);
      for (int i = 1; i < 12; ++i) EXPECT_NEAR((t.xy_m[i] - t.xy_m[i - 1]).norm(), 2.0, 0.1) << i;
      fs::remove_all(dir);
    }
  }
}

// Latitude and longitude swapped in the telemetry, both still in range (49.84 N 24.03 E read as
// 24.03 N 49.84 E): no alignment can fit the track to that GPS, and the figures alone would not
// say why. An L-shaped flight (a straight one is its own mirror image): the run completes and
// says the track matches GPS only as its mirror image; the right file says nothing of it.
TEST(BadInput, SwappedLatitudeAndLongitudeAreSaid) {
  std::vector<Pose> poses = Leg(10);
  for (int i = 1; i <= 10; ++i) poses.push_back({poses[9].x_m, 60.0 + 2.0 * i, 0.0});
  for (const bool swap : {false, true}) {
    SCOPED_TRACE(swap ? "swapped" : "as written");
    const fs::path dir = TempDir(swap ? "swapped_latlon" : "latlon");
    std::vector<GeoPoint> fixes = GeoOf(poses);
    if (swap) {
      for (GeoPoint& g : fixes) std::swap(g.lat_deg, g.lon_deg);
    }
    WriteFolder(dir / "photos", RenderAll(poses));
    std::ofstream(dir / "flight.srt") << MakeSrt(fixes);
    RunConfig c = Config(dir / "photos", dir / "run");
    c.telemetry = (dir / "flight.srt").string();
    const RunSummary s = RunFlight(c);
    EXPECT_EQ(s.frames_processed, 20);
    ASSERT_TRUE(s.evaluation.has_value());
    EXPECT_EQ(HasWarning(s, "matches the GPS track only as its mirror image"), swap)
        << fmt::format("{}", fmt::join(s.warnings, "\n"));
    if (swap) {
      EXPECT_TRUE(HasWarning(s, "latitude and longitude swapped in the telemetry"));
      EXPECT_GT(s.evaluation->sim2.ate_m.rmse, 3.0);
    } else {
      EXPECT_LT(s.evaluation->sim2.ate_m.rmse, 0.3);
    }
    fs::remove_all(dir);
  }
}

// Telemetry that puts a nadir camera at the horizon (a DJI gimbal pitch of 0 on every record):
// no nadir view of such a frame exists (its upper corners look above the horizon), so the frames
// are processed without the correction, said once, and the track stays right (before: the
// correction's homography sent them towards infinity, 99 m of ATE on a 60 m line).
TEST(BadInput, AnAttitudeWithTheHorizonInViewIsNotApplied) {
  const fs::path dir = TempDir("horizon_attitude");
  const std::vector<GeoPoint> fixes = GeoOf(Leg(12));
  RunConfig c =
      TelemetryCase(dir, "flight.srt", MakeSrt(fixes, [](int, std::vector<std::string>& l) {
                      l[4] += " [gb_pitch: 0.0 gb_roll: 0.0]";
                    }));
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 12);
  EXPECT_TRUE(HasWarning(s, "the gimbal angles put the camera 90.0 deg from nadir"))
      << fmt::format("{}", fmt::join(s.warnings, "\n"));
  EXPECT_TRUE(HasWarning(s, "above the horizon, where no nadir view of the frame exists"));
  ASSERT_TRUE(s.evaluation.has_value());
  EXPECT_LT(s.evaluation->se2.ate_m.rmse, 0.3);
  fs::remove_all(dir);
}

TEST(BadInput, ZeroByteTelemetryIsAnErrorNamingIt) {
  const fs::path dir = TempDir("zero_srt");
  const RunConfig c = TelemetryCase(dir, "empty.srt", "");
  ExpectInputError(c, {"empty.srt", "no telemetry"});
  fs::remove_all(dir);
}

// Telemetry that stops half-way: the run completes; frames after the last fix have no GPS
// (empty gps_* cells), the summary says how many, the trajectory stays continuous.
// SRT (matched by frame counter) and GPX (matched by time, never extrapolated).
TEST(BadInput, FewerFixesThanFramesCompletesAndSaysSo) {
  for (const std::string file : {"short.srt", "short.gpx"}) {
    SCOPED_TRACE(file);
    const fs::path dir = TempDir("few_fixes");
    const std::vector<GeoPoint> fixes = GeoOf(Leg(6));
    const RunConfig c =
        TelemetryCase(dir, file, file == "short.srt" ? MakeSrt(fixes) : MakeGpx(fixes));
    const RunSummary s = RunFlight(c);
    EXPECT_EQ(s.frames_processed, 12);
    EXPECT_EQ(s.frames_with_gps, 6);
    EXPECT_EQ(s.frames_bridged, 0);
    EXPECT_TRUE(HasWarning(s, "6 of 12 frames have no telemetry fix"))
        << fmt::format("{}", fmt::join(s.warnings, "\n"));
    const auto rows = ReadFramesCsv(dir / "run");
    ASSERT_EQ(rows.size(), 12u);
    for (int i = 0; i < 12; ++i) {
      EXPECT_EQ(std::isfinite(Num(rows[i], "gps_lat_deg")), i < 6) << i;
      EXPECT_TRUE(std::isfinite(Num(rows[i], "lat_deg"))) << i;  // VO geo-referenced throughout
    }
    const Track t = ReadTrack(dir / "run");
    for (int i = 1; i < 12; ++i) EXPECT_NEAR((t.xy_m[i] - t.xy_m[i - 1]).norm(), 2.0, 0.1) << i;
    fs::remove_all(dir);
  }
}

}  // namespace
}  // namespace aerovo::bad_input_test
