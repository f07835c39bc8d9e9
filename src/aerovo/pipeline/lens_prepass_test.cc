#include "aerovo/pipeline/lens_prepass.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/core/error.h"
#include "aerovo/frames/image_test_util.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::run_steps::lens_prepass_test {
namespace {

TEST(LensPrepass, PairStartsAreSpreadOverTheFlight) {
  // (i + 0.5) / 5 of the way, each followed by the next frame.
  EXPECT_EQ(LensPrepassPairStarts(25, 5), (std::vector<int>{2, 7, 12, 17, 22}));
  // A short flight: the last pair ends on the last frame, no pair twice.
  EXPECT_EQ(LensPrepassPairStarts(6, 5), (std::vector<int>{0, 1, 3, 4}));
  EXPECT_EQ(LensPrepassPairStarts(2, 5), (std::vector<int>{0}));
  EXPECT_TRUE(LensPrepassPairStarts(1, 5).empty());
  EXPECT_TRUE(LensPrepassPairStarts(0, 5).empty());
}

TEST(LensPrepass, RunsOnlyWithoutALensAndOnAnInputReadTwice) {
  RunConfig c;
  c.input = std::filesystem::temp_directory_path().string();  // an existing folder
  EXPECT_EQ(LensPrepassSkipReason(c, false), "");
  // A live source (a URL, not a path) pairs its own frames as delivered (LivePairFeed).
  RunConfig url = c;
  url.input = "udp://127.0.0.1:5600";
  EXPECT_EQ(LensPrepassSkipReason(url, true), "");
  EXPECT_EQ(LensPrepassSkipReason(url, false),
            "the input is not a file or folder that can be read again");
  RunConfig off = c;
  off.lens_estimation = LensEstimationMode::kOff;
  EXPECT_EQ(LensPrepassSkipReason(off, false), "lens_estimation off");
  RunConfig cal = c;
  cal.calibration = "cameras.json";
  EXPECT_EQ(LensPrepassSkipReason(cal, false), "a calibration file is given");
  RunConfig k = c;
  k.p2 = 1e-4;
  EXPECT_EQ(LensPrepassSkipReason(k, false), "lens distortion coefficients are given");
  RunConfig missing = c;
  missing.input = "/nonexistent/aerovo/flight.mp4";
  EXPECT_EQ(LensPrepassSkipReason(missing, false),
            "the input is not a file or folder that can be read again");
  // The paper's pipeline has no self-calibration.
  EXPECT_EQ(PaperRunConfig().lens_estimation, LensEstimationMode::kOff);
  EXPECT_EQ(RunConfig().lens_estimation, LensEstimationMode::kAuto);
}

TEST(LensPrepass, EstimatesTheAttitudeOnlyWhenNothingGivesIt) {
  RunConfig c;
  c.input = std::filesystem::temp_directory_path().string();  // an existing folder
  EXPECT_EQ(AttitudePrepassSkipReason(c, false, false, std::nullopt), "");
  TelemetrySample plain;
  EXPECT_EQ(AttitudePrepassSkipReason(c, false, false, plain), "");
  EXPECT_EQ(AttitudePrepassSkipReason(c, true, false, plain), "a live source cannot be read twice");
  EXPECT_EQ(AttitudePrepassSkipReason(c, false, true, plain), "the autopilot's ATTITUDE gives it");
  TelemetrySample gimbal = plain;
  gimbal.gimbal_pitch_deg = -90.0;
  EXPECT_EQ(AttitudePrepassSkipReason(c, false, false, gimbal), "the telemetry gives it");
  TelemetrySample aircraft = plain;
  aircraft.roll_deg = 0.0;
  EXPECT_EQ(AttitudePrepassSkipReason(c, false, false, aircraft), "the telemetry gives it");
  RunConfig mount = c;
  mount.camera_mount_pitch_deg = 10.0;
  EXPECT_EQ(AttitudePrepassSkipReason(mount, false, false, plain), "a camera mount pitch is given");
  RunConfig off = c;
  off.attitude_estimation = AttitudeEstimationMode::kOff;
  EXPECT_EQ(AttitudePrepassSkipReason(off, false, false, plain), "attitude_estimation off");
  RunConfig no_attitude = c;
  no_attitude.attitude = AttitudeMode::kOff;
  EXPECT_EQ(AttitudePrepassSkipReason(no_attitude, false, false, plain), "attitude off");
  EXPECT_EQ(AttitudePrepassSkipReason(c, false, false, plain, /*photo_folder=*/false),
            "not a photo folder (a video's first pose does not wait for a tilt estimate; give "
            "--camera-mount-pitch-deg)");
  RunConfig missing = c;
  missing.input = "/nonexistent/aerovo/photos";
  EXPECT_EQ(AttitudePrepassSkipReason(missing, false, false, plain),
            "the input is not a file or folder that can be read again");
  // The paper's pipeline: a nadir camera, no estimate.
  EXPECT_EQ(PaperRunConfig().attitude_estimation, AttitudeEstimationMode::kOff);
  EXPECT_EQ(RunConfig().attitude_estimation, AttitudeEstimationMode::kAuto);
}

TEST(LensPrepass, AttitudeSummaryOfAnEstimate) {
  AttitudePrepass a;
  a.why = "attitude_estimation off";
  nlohmann::json j = ToJson(a);
  EXPECT_EQ(j["status"], "skipped");
  EXPECT_FALSE(j.contains("pitch_deg"));
  AttitudeEstimate e;
  e.pairs_used = 1;
  a.status = LensPrepassStatus::kNoEstimate;
  a.estimate = e;  // not valid: no attitude in the summary
  j = ToJson(a);
  EXPECT_EQ(j["status"], "no estimate");
  EXPECT_EQ(j["pairs_used"], 1);
  EXPECT_FALSE(j.contains("pitch_deg")) << j.dump();
  EXPECT_FALSE(j.contains("roll_deg")) << j.dump();
  e.valid = e.significant = true;
  e.attitude = {-0.25, 15.0};
  e.tilt_deg = 15.002;
  e.pair_attitude = {{0.0, 14.0}, {-0.5, 16.0}};
  a.status = LensPrepassStatus::kApplied;
  a.applied = true;
  a.estimate = e;
  j = ToJson(a);
  EXPECT_EQ(j["status"], "applied");
  EXPECT_EQ(j["pitch_deg"], 15.0);
  EXPECT_EQ(j["roll_deg"], -0.25);
  EXPECT_EQ(j["pair_pitch_deg"], (std::vector<double>{14.0, 16.0}));
}

TEST(LensPrepass, SkippedSummaryHasNoEstimate) {
  LensPrepass p;
  p.why = "lens_estimation off";
  const nlohmann::json j = ToJson(p);
  EXPECT_EQ(j["status"], "skipped");
  EXPECT_EQ(j["applied"], false);
  EXPECT_EQ(j["why"], "lens_estimation off");
  EXPECT_FALSE(j.contains("k"));
}

TEST(LensPrepass, LivePairFeedHandsOverInOrderUntilClosed) {
  LivePairFeed feed;
  const auto frame = [](int index) {
    Frame f;
    f.index = index;
    return f;
  };
  feed.Push(frame(0), frame(1));
  feed.Push(frame(3), frame(4));
  feed.Close();
  feed.Push(frame(6), frame(7));  // after Close: ignored
  std::pair<Frame, Frame> p;
  ASSERT_TRUE(feed.Pop(&p, nullptr));
  EXPECT_EQ(p.first.index, 0);
  EXPECT_EQ(p.second.index, 1);
  ASSERT_TRUE(feed.Pop(&p, nullptr));
  EXPECT_EQ(p.first.index, 3);
  EXPECT_FALSE(feed.Pop(&p, nullptr));
  // Waiting on an open, empty feed ends with the stop flag.
  LivePairFeed open;
  std::atomic<bool> stop{true};
  EXPECT_THROW(open.Pop(&p, &stop), Cancelled);
}

TEST(LensPrepass, BadFrameSizeIsAnError) {
  RunConfig c;
  c.input = std::filesystem::temp_directory_path().string();
  EXPECT_THROW(RunLensPrepass(c, 0, 480, 300.0), InvalidArgument);
  EXPECT_THROW(RunLensPrepass(c, 640, 480, 0.0), InvalidArgument);
}

// The task: the pre-pass's errors come out of Get(), which is called once.
TEST(LensPrepass, TaskRethrowsItsErrorAndIsTakenOnce) {
  RunConfig c;
  c.input = std::filesystem::temp_directory_path().string();
  LensPrepassTask task(c, 0, 480, 300.0);
  // Ready once its thread ended (at once here: a frame width of 0), until taken.
  for (int i = 0; i < 500 && !task.Ready(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(task.Ready());
  EXPECT_THROW(task.Get(nullptr), InvalidArgument);
  EXPECT_TRUE(task.taken());
  EXPECT_FALSE(task.Ready());
  EXPECT_THROW(task.Get(nullptr), InvalidArgument);
}

// A 60 s video (MJPG: every frame a key frame) whose pairs are 12 s apart, more than
// kLensPrepassSeekS: the FFmpeg path seeks to each pair, the OpenCV path reads every frame;
// both read the same 5 pairs (a texture panned 3 px per frame, an ideal pinhole: not
// significant).
TEST(LensPrepass, VideoPairsSeekedAreThePairsReadForward) {
  io_test::TempDir dir("aerovo_prepass_seek");
  const std::filesystem::path video = dir / "pan.avi";
  constexpr int kW = 320, kH = 240, kFrames = 120;
  {
    cv::Mat texture;
    cv::GaussianBlur(io_test::TextureImage(kW + 3 * kFrames, kH, 5), texture, cv::Size(0, 0), 1.5);
    cv::VideoWriter w(video.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                      2.0, cv::Size(kW, kH));
    ASSERT_TRUE(w.isOpened());
    for (int i = 0; i < kFrames; ++i) w.write(texture(cv::Rect(3 * i, 0, kW, kH)).clone());
  }
  ASSERT_GT(60.0 / kLensPrepassPairs, kLensPrepassSeekS);
  RunConfig c;
  c.input = video.string();
  c.video_decoder = VideoDecoderChoice::kFfmpeg;
  const LensPrepass seeked = RunLensPrepass(c, kW, kH, 300.0);
  c.video_decoder = VideoDecoderChoice::kOpenCv;
  const LensPrepass forward = RunLensPrepass(c, kW, kH, 300.0);
  EXPECT_EQ(seeked.pairs_read, kLensPrepassPairs) << seeked.why;
  EXPECT_EQ(forward.pairs_read, kLensPrepassPairs) << forward.why;
  ASSERT_TRUE(seeked.estimate && forward.estimate) << seeked.why;
  EXPECT_EQ(seeked.pair_frames, (std::vector<int>{12, 36, 60, 84, 108}));
  EXPECT_EQ(forward.pair_frames, seeked.pair_frames);
  EXPECT_EQ(seeked.estimate->pairs_used, forward.estimate->pairs_used);
  EXPECT_FALSE(seeked.applied) << seeked.why;
  // On its thread with the run's stop flag set: it stops before reading a frame.
  const std::atomic<bool> stop{true};
  c.video_decoder = VideoDecoderChoice::kFfmpeg;
  LensPrepassTask task(c, kW, kH, 300.0, &stop);
  const LensPrepass stopped = task.Get(nullptr);
  EXPECT_EQ(stopped.status, LensPrepassStatus::kFailed);
  EXPECT_EQ(stopped.why, "stopped: cancelled in the lens pre-pass");
  EXPECT_EQ(stopped.pairs_read, 0);
}

}  // namespace
}  // namespace aerovo::run_steps::lens_prepass_test
