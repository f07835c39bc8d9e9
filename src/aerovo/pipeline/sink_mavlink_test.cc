// The MAVLink sink's GPS_INPUT (RunConfig::mavlink_gps_input), frame by frame on a loopback
// link: nothing before the track is geo-referenced, then each frame's geographic position, its
// velocity from the frames' own times, an accuracy that grows with the distance flown until the
// fix is dropped, a stage's absolute fix sent instead of the pose, and summary.json's counts.
// A synthetic straight flight north with known truth; aerovo's own decoder reads the packets
// (its bytes are checked against node-mavlink in messages_test.cc and tests/mavlink/).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "aerovo/core/angles.h"
#include "aerovo/mavlink/gps_input.h"
#include "aerovo/mavlink/transport.h"
#include "aerovo/pipeline/frame_loop.h"

namespace aerovo::run_steps::sink_mavlink_test {
namespace {

// A loopback UDP socket that aerovo's link (udp:127.0.0.1:PORT) sends to.
struct Receiver {
  Receiver() {
    fd = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    socklen_t len = sizeof(a);
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~Receiver() { close(fd); }
  // The GPS_INPUTs and ODOMETRYs that arrive within `wait_ms` of the last datagram.
  struct Received {
    std::vector<mavlink::GpsInput> gps;
    std::vector<mavlink::Odometry> odometry;
  };
  Received TakeAll(int wait_ms = 300) {
    Received out;
    uint8_t buf[2048];
    pollfd p{fd, POLLIN, 0};
    while (poll(&p, 1, wait_ms) > 0) {
      const ssize_t n = recv(fd, buf, sizeof(buf), 0);
      if (n <= 0) break;
      parser.Feed(buf, static_cast<std::size_t>(n), [&](const mavlink::Packet& k) {
        if (auto g = mavlink::Decode<mavlink::GpsInput>(k)) out.gps.push_back(*g);
        if (auto o = mavlink::Decode<mavlink::Odometry>(k)) out.odometry.push_back(*o);
      });
    }
    return out;
  }
  std::vector<mavlink::GpsInput> Take(int wait_ms = 300) { return TakeAll(wait_ms).gps; }
  int fd = -1;
  int port = 0;
  mavlink::Parser parser;
};

constexpr double kUnix0 = 1764806400.0;  // 2025-12-04 00:00 UTC
constexpr double kDt = 0.5, kStepM = 5.0;  // 10 m/s north

struct SinkRun {
  SinkRun() : state(Config()) {
    config = Config();
    config.mavlink = "udp:127.0.0.1:" + std::to_string(receiver.port);
    link = std::make_unique<mavlink::AutopilotLink>(
        mavlink::OpenTransport(mavlink::ParseLinkUrl(config.mavlink)),
        mavlink::AutopilotLink::Options{});
    run.config = &config;
    run.link = link.get();
    run.state = &state;
    run.summary = &summary;
    sink = MakeMavlinkSink();
  }
  static RunConfig Config() {
    RunConfig c;
    c.mavlink_gps_input = true;
    c.mavlink_time = mavlink::TimestampClock::kUnix;
    c.mavlink_gps_input_max_sigma_m = 0.3;
    c.mavlink_gps_input_drift = 0.01;
    return c;
  }
  // Frame k: 5 m north of frame k-1 (local +y, the image's up facing north), 0.5 s later, 60 m
  // above the ground; the geo-reference not told.
  static FrameState Bare(int k) {
    FrameState f;
    f.frame.index = k;
    f.result.position_m = Eigen::Vector2d(0.0, kStepM * k);
    f.result.heading_rad = 0.0;
    f.result.status = k == 0 ? FrameStatus::kFirst : FrameStatus::kOk;
    f.result.n_inliers = 200;
    f.result.gsd_m_per_px = 0.05;
    f.frame_mono_s = 1000.0 + kDt * k;
    f.frame_unix_s = kUnix0 + kDt * k;
    f.height_m = 60.0;
    return f;
  }
  // Bare(k), with its GPS fix and the camera's yaw (north) given to the geo-reference first, as
  // the stages do.
  FrameState Frame(int k) {
    FrameState f = Bare(k);
    const double north_deg = kStepM * k / 6378137.0 * kRadToDeg;
    state.georef.Observe(f.result.position_m, GeoPoint{45.0 + north_deg, 6.0, 500.0}, 0.0);
    return f;
  }
  Receiver receiver;
  RunConfig config;
  RunState state;
  RunSummary summary;
  std::unique_ptr<mavlink::AutopilotLink> link;
  RunContext run;
  std::unique_ptr<FrameSink> sink;
};

TEST(MavlinkSink, GpsInputFromTheGeoReferencedPoses) {
  SinkRun r;
  std::vector<bool> ready;
  for (int k = 0; k < 12; ++k) {
    FrameState f = r.Frame(k);
    ready.push_back(r.state.georef.ready());
    r.sink->Write(f, r.run);
  }
  const std::vector<mavlink::GpsInput> got = r.receiver.Take();
  // Nothing while the heading waits for the first fixes to agree (GpsCheckOptions::min_chain).
  int first = 0;
  while (first < 12 && !ready[first]) ++first;
  ASSERT_GE(first, 1);
  ASSERT_EQ(got.size(), static_cast<std::size_t>(12 - first));
  double previous_hacc = -1.0;
  int fixes = 0;
  for (std::size_t j = 0; j < got.size(); ++j) {
    const int k = first + static_cast<int>(j);
    const mavlink::GpsInput& g = got[j];
    SCOPED_TRACE("frame " + std::to_string(k));
    const GeoPoint want = r.state.georef.Wgs84FromLocal({0.0, kStepM * k});
    EXPECT_NEAR(g.lat, want.lat_deg * 1e7, 0.5);
    EXPECT_NEAR(g.lon, want.lon_deg * 1e7, 0.5);
    EXPECT_NEAR(g.alt, 500.0, 1e-3);  // the origin fix's altitude, no height gained
    const auto t = mavlink::GpsTimeOfUnix(kUnix0 + kDt * k);
    EXPECT_EQ(g.time_week, t->week);
    EXPECT_EQ(g.time_week_ms, t->ms);
    EXPECT_EQ(g.time_usec, static_cast<uint64_t>(std::llround((kUnix0 + kDt * k) * 1e6)));
    EXPECT_EQ(g.ignore_flags & mavlink::kGpsInputIgnoreVelHoriz, 0);  // a frame before it
    EXPECT_NEAR(g.vn, kStepM / kDt, 1e-3);
    EXPECT_NEAR(g.ve, 0.0, 1e-3);
    EXPECT_EQ(g.yaw, 36000);  // the nose north
    // The accuracy: the drift (1 % of the distance from the first frame) and the model.
    const double distance = kStepM * k;
    EXPECT_GE(g.horiz_accuracy, 0.01 * distance - 1e-4);
    EXPECT_LE(g.horiz_accuracy, 0.01 * distance + 0.01);
    EXPECT_GT(g.horiz_accuracy, previous_hacc);
    previous_hacc = g.horiz_accuracy;
    EXPECT_EQ(g.fix_type == mavlink::kGpsFixType3d, g.horiz_accuracy <= 0.3f);
    if (g.fix_type == mavlink::kGpsFixType3d) ++fixes;
  }
  EXPECT_GE(fixes, 3);
  EXPECT_LT(fixes, static_cast<int>(got.size()));  // the drift passed the 0.3 m limit
  r.sink->End(LoopEnd{}, &r.run);
  const nlohmann::json& counts = r.summary.mavlink["gps_input"];
  EXPECT_EQ(counts["sent"], got.size());
  EXPECT_EQ(counts["with_fix"], fixes);
  EXPECT_EQ(counts["without_fix"], static_cast<int>(got.size()) - fixes);
}

// No GPS ever: a map's fix seeds the geo-reference at frame 6 (GeoReferencer::SeedFromFix, the
// fix's variance 0.04 m² in FrameState::map_seed_var_m2, as stage_map_fix.cc does). GPS_INPUT
// starts there, never with an altitude (none is known: the ALT ignore flag, alt 0), and its
// accuracy restarts there: sqrt(0.04 + the step model + (1 % of the distance from frame 6)²),
// not the 30 m flown from frame 0 (0.3 m of drift: the seed frame's past the 0.3 m limit).
TEST(MavlinkSink, GpsInputAfterAMapSeedHasNoAltitudeAndItsDriftStartsAtTheSeed) {
  SinkRun r;
  constexpr int kSeed = 6;
  constexpr double kSeedVar = 0.04;
  for (int k = 0; k < 12; ++k) {
    FrameState f = SinkRun::Bare(k);
    r.state.georef.Observe(f.result.position_m, std::nullopt, std::nullopt);
    if (k == kSeed) {  // the image's x axis east (heading pi/2 - pi/2 = 0 in ENU): +y north
      r.state.georef.SeedFromFix(f.result.position_m, 0.0, GeoPoint{45.0, 6.0, 0.0}, 0.0);
      f.map_seed_var_m2 = kSeedVar;
    }
    r.sink->Write(f, r.run);
  }
  const std::vector<mavlink::GpsInput> got = r.receiver.Take();
  ASSERT_EQ(got.size(), static_cast<std::size_t>(12 - kSeed));
  for (std::size_t j = 0; j < got.size(); ++j) {
    const int k = kSeed + static_cast<int>(j);
    const mavlink::GpsInput& g = got[j];
    SCOPED_TRACE("frame " + std::to_string(k));
    EXPECT_NE(g.ignore_flags & mavlink::kGpsInputIgnoreAlt, 0);
    EXPECT_EQ(g.alt, 0.0f);
    const double drift = 0.01 * kStepM * (k - kSeed);
    const double floor = std::sqrt(kSeedVar + drift * drift);
    EXPECT_GE(g.horiz_accuracy, floor - 1e-4);
    EXPECT_LE(g.horiz_accuracy, floor + 0.01);
    EXPECT_EQ(g.fix_type == mavlink::kGpsFixType3d, g.horiz_accuracy <= 0.3f);
  }
  EXPECT_EQ(got[0].fix_type, mavlink::kGpsFixType3d);  // 0.2 m at the seed
}

TEST(MavlinkSink, AnAbsoluteFixOfTheFrameIsSentInsteadOfThePose) {
  SinkRun r;
  for (int k = 0; k < 4; ++k) {
    FrameState f = r.Frame(k);
    r.sink->Write(f, r.run);
  }
  r.receiver.Take();
  FrameState f = r.Frame(4);
  mavlink::GeoFix fix;  // a map fix: another position, its own accuracy and time
  fix.unix_time_s = f.frame_unix_s;
  fix.time_usec = 42;
  fix.lat_deg = 45.001;
  fix.lon_deg = 6.002;
  fix.sigma_horizontal_m = 0.2;
  f.absolute_fix = fix;
  r.sink->Write(f, r.run);
  const std::vector<mavlink::GpsInput> got = r.receiver.Take();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].lat, 450010000);
  EXPECT_EQ(got[0].lon, 60020000);
  EXPECT_FLOAT_EQ(got[0].horiz_accuracy, 0.2f);
  EXPECT_EQ(got[0].fix_type, mavlink::kGpsFixType3d);
  EXPECT_EQ(got[0].time_usec, 42u);
  // Unknown to the fix: velocity, altitude and yaw ignored or unknown, not the pose's.
  EXPECT_NE(got[0].ignore_flags & mavlink::kGpsInputIgnoreVelHoriz, 0);
  EXPECT_NE(got[0].ignore_flags & mavlink::kGpsInputIgnoreAlt, 0);
  EXPECT_EQ(got[0].yaw, 0);
}

// A jump of the live pose (FrameState::pose_reset, set by the window stage at a loop closure's
// whole-graph solve) is a reset: reset_counter + 1 at that frame only, the step model's variance
// restarted there, no velocity across it (ODOMETRY NaN, GPS_INPUT's ignored); the online
// window's covariance (local frame) in ODOMETRY turned into FRD, and in GPS_INPUT's accuracy.
TEST(MavlinkSink, APoseJumpIsAResetAndTheWindowsCovarianceIsSent) {
  SinkRun r;
  constexpr int kJump = 6, kWindowFrom = 3;
  const Eigen::Vector2d jump(2.0, -1.5);  // local, m
  WindowedPose w;
  w.has_covariance = true;
  w.covariance << 0.04, 0.01, 0.002, 0.0,  // x: 0.2 m across the image
      0.01, 0.09, -0.003, 0.0,             // y: 0.3 m along it (north)
      0.002, -0.003, 0.0004, 0.0,          // heading: 0.02 rad
      0.0, 0.0, 0.0, 1e-6;
  for (int k = 0; k < 10; ++k) {
    FrameState f = r.Frame(k);
    f.frame.time_s = kDt * k;  // the velocities' time differences
    if (k >= kJump) f.result.position_m += jump;
    if (k == kJump) f.pose_reset.cause = PoseReset::Cause::kLoopClosure;
    if (k >= kWindowFrom) f.window = w;
    r.sink->Write(f, r.run);
  }
  const Receiver::Received got = r.receiver.TakeAll();
  ASSERT_EQ(got.odometry.size(), 10u);
  const auto& o = got.odometry;
  const double step = o[2].pose_covariance[0] / 2.0;  // the model's, per frame
  ASSERT_GT(step, 0.0);
  for (int k = 0; k < 10; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    EXPECT_EQ(o[k].reset_counter, k >= kJump ? 1 : 0);
    const auto& pc = o[k].pose_covariance;
    const double model = step * (k >= kJump ? k - kJump : k);  // restarted at the jump
    const double window_x = k >= kWindowFrom ? 0.09 : 0.0, window_y = k >= kWindowFrom ? 0.04 : 0.0;
    EXPECT_NEAR(pc[mavlink::UpperTriangleIndex(0, 0)], model + window_x, 1e-6);  // x_frd: north
    EXPECT_NEAR(pc[mavlink::UpperTriangleIndex(1, 1)], model + window_y, 1e-6);
    EXPECT_NEAR(pc[mavlink::UpperTriangleIndex(0, 1)], k >= kWindowFrom ? 0.01 : 0.0, 1e-7);
    EXPECT_NEAR(pc[mavlink::UpperTriangleIndex(0, 5)], k >= kWindowFrom ? 0.003 : 0.0, 1e-7);
    EXPECT_NEAR(pc[mavlink::UpperTriangleIndex(1, 5)], k >= kWindowFrom ? -0.002 : 0.0, 1e-7);
    EXPECT_EQ(std::isnan(o[k].vx), k == 0 || k == kJump);
  }
  EXPECT_FLOAT_EQ(o[kJump].x, static_cast<float>(kStepM * kJump + jump.y()));
  EXPECT_FLOAT_EQ(o[kJump].y, static_cast<float>(jump.x()));
  // GPS_INPUT: no velocity at the jump; the distance flown leaves the jump out; the accuracy is
  // the larger axis of ODOMETRY's x/y block and the drift.
  ASSERT_FALSE(got.gps.empty());
  const int first = 10 - static_cast<int>(got.gps.size());
  ASSERT_LT(first, kJump);
  for (std::size_t j = 0; j < got.gps.size(); ++j) {
    const int k = first + static_cast<int>(j);
    SCOPED_TRACE("frame " + std::to_string(k));
    const mavlink::GpsInput& g = got.gps[j];
    EXPECT_EQ((g.ignore_flags & mavlink::kGpsInputIgnoreVelHoriz) != 0, k == kJump);
    const auto& pc = o[k].pose_covariance;
    Eigen::Matrix2d xy;
    xy << pc[0], pc[1], pc[1], pc[mavlink::UpperTriangleIndex(1, 1)];
    const double distance = kStepM * (k > kJump ? k - 1 : std::min(k, kJump - 1));
    const double want = std::sqrt(
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(xy).eigenvalues().maxCoeff() +
        std::pow(0.01 * distance, 2));
    EXPECT_NEAR(g.horiz_accuracy, want, 1e-4);
  }
}

// The window stage's jump test (FrameState::pose_reset): only at a whole-graph solve, against
// the causal prediction (the previous windowed pose moved by the causal step, turned by the
// windowed heading), beyond 5 x max(0.1 m, the pose's own standard deviation).
TEST(MavlinkSink, TheWindowStagesJumpTest) {
  using backend::Similarity2;
  const Similarity2 previous_causal{{0.0, 10.0}, 0.0, 0.0}, causal{{0.0, 15.0}, 0.0, 0.0};
  const Similarity2 previous_windowed{{1.0, 10.0}, 0.0, 0.0};  // predicted: (1, 15)
  WindowedPose w;
  w.full_solve = true;
  // The windowed pose at (x, y) with the predicted heading (the causal step turns nothing).
  const auto jumped = [&](double x, double y, const Similarity2* prev = nullptr) {
    const Similarity2& p = prev ? *prev : previous_windowed;
    w.local_from_frame = Similarity2{{x, y}, p.heading_rad, 0.0};
    return PoseJumped(w, causal, previous_causal, p);
  };
  EXPECT_FALSE(jumped(1.0, 15.0));
  EXPECT_FALSE(jumped(1.3, 15.3));  // 0.42 m: under 0.5 m, an ordinary measurement
  EXPECT_TRUE(jumped(1.4, 15.4));   // 0.57 m
  EXPECT_TRUE(jumped(-2.0, 11.0));  // 5 m
  w.full_solve = false;             // the window's own solve: never a reset
  EXPECT_FALSE(jumped(-2.0, 11.0));
  w.full_solve = true;
  // The pose's own uncertainty widens the gate: 0.2 m (x) -> 1 m.
  w.has_covariance = true;
  w.covariance = Eigen::Matrix4d::Identity() * 1e-4;
  w.covariance(0, 0) = 0.04;
  EXPECT_FALSE(jumped(1.9, 15.0));
  EXPECT_TRUE(jumped(2.1, 15.0));
  w.has_covariance = false;
  // The causal step (5 m along the frame's up) turned by the previous windowed heading (90 deg
  // counter-clockwise): predicted (1, 10) + (-5, 0).
  const Similarity2 turned{{1.0, 10.0}, M_PI / 2, 0.0};
  EXPECT_FALSE(jumped(-4.0, 10.0, &turned));
  EXPECT_TRUE(jumped(1.0, 15.0, &turned));
  EXPECT_FALSE(jumped(1.0, 15.0).heading_only);
}

// A jump of the heading alone: past 2.6 x max(0.2 rad, the heading's own standard deviation)
// of the causal prediction's heading, wrapped (mavlink::HeadingJumpResetThresholdRad), at a
// whole-graph solve only.
TEST(MavlinkSink, TheWindowStagesHeadingJumpTest) {
  using backend::Similarity2;
  const Similarity2 previous_causal{{0.0, 10.0}, 0.3, 0.0}, causal{{0.0, 15.0}, 0.4, 0.0};
  const Similarity2 previous_windowed{{0.0, 10.0}, 0.3, 0.0};  // predicted heading 0.4 rad
  const Eigen::Vector2d predicted = (previous_windowed * Between(previous_causal, causal))
                                        .translation_m;
  WindowedPose w;
  w.full_solve = true;
  const auto jumped = [&](double heading_rad) {
    w.local_from_frame = Similarity2{predicted, heading_rad, 0.0};
    return PoseJumped(w, causal, previous_causal, previous_windowed);
  };
  EXPECT_FALSE(jumped(0.4));
  EXPECT_FALSE(jumped(0.4 + 0.50));  // under 0.52 rad: the EKFs fuse it
  EXPECT_FALSE(jumped(0.4 - 0.50));
  const PoseReset r = jumped(0.4 + 0.54);
  EXPECT_TRUE(r);
  EXPECT_TRUE(r.heading_only);
  EXPECT_EQ(r.cause, PoseReset::Cause::kLoopClosure);
  EXPECT_TRUE(jumped(0.4 - 0.54));
  // Across +-pi: 0.4 - 2 pi + 0.1 is 0.1 rad from the prediction.
  EXPECT_FALSE(jumped(0.4 + 0.1 - 2.0 * M_PI));
  // The heading's own uncertainty widens the gate: 0.3 rad -> 0.78 rad.
  w.has_covariance = true;
  w.covariance = Eigen::Matrix4d::Identity() * 1e-4;
  w.covariance(2, 2) = 0.09;
  EXPECT_FALSE(jumped(0.4 + 0.75));
  EXPECT_TRUE(jumped(0.4 + 0.81));
  w.full_solve = false;  // the window's own solve: never a reset
  EXPECT_FALSE(jumped(0.4 + 2.0));
}

TEST(MavlinkSink, NoGpsInputUnlessAskedFor) {
  SinkRun r;
  r.config.mavlink_gps_input = false;
  for (int k = 0; k < 6; ++k) {
    FrameState f = r.Frame(k);
    r.sink->Write(f, r.run);
  }
  EXPECT_TRUE(r.receiver.Take().empty());
  r.sink->End(LoopEnd{}, &r.run);
  EXPECT_FALSE(r.summary.mavlink.contains("gps_input"));
}

}  // namespace
}  // namespace aerovo::run_steps::sink_mavlink_test
