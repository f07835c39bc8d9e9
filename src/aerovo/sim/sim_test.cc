// Geometry, rendering, effects, flight planning and GPS of the simulator.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/sim/camera.h"
#include "aerovo/sim/flight.h"
#include "aerovo/sim/gps.h"
#include "aerovo/sim/render.h"
#include "aerovo/sim/simulator.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::sim::sim_test {
namespace {

// A flat grey ground with one Gaussian blob (the marker) centred at ground pixel `at`.
GroundImage MarkerGround(Eigen::Vector2d at, double sigma_px, double mpp) {
  GroundImage g;
  g.image = cv::Mat(1500, 1500, CV_8UC1, cv::Scalar(40));
  for (int y = 0; y < g.image.rows; ++y) {
    for (int x = 0; x < g.image.cols; ++x) {
      const double d2 = (x - at.x()) * (x - at.x()) + (y - at.y()) * (y - at.y());
      if (d2 > 36 * sigma_px * sigma_px) continue;
      g.image.at<std::uint8_t>(y, x) =
          cv::saturate_cast<std::uint8_t>(40 + 200 * std::exp(-0.5 * d2 / (sigma_px * sigma_px)));
    }
  }
  g.metres_per_px = mpp;
  g.nw_corner = GeoPoint{49.84, 24.03, 300.0};
  g.source_kind = "test";
  return g;
}

// Intensity-weighted centroid of (image - background) in a window around `guess`.
Eigen::Vector2d BlobCentroid(const cv::Mat& img, Eigen::Vector2d guess, int radius) {
  double sw = 0, sx = 0, sy = 0;
  const int cx = static_cast<int>(std::lround(guess.x())),
            cy = static_cast<int>(std::lround(guess.y()));
  for (int y = cy - radius; y <= cy + radius; ++y) {
    for (int x = cx - radius; x <= cx + radius; ++x) {
      const double w = std::max(0, img.at<std::uint8_t>(y, x) - 40);
      sw += w;
      sx += w * x;
      sy += w * y;
    }
  }
  return {sx / sw, sy / sw};
}

struct MarkerCase {
  const char* name;
  double height_m, yaw_deg, pitch_deg, roll_deg, blob_sigma_px;
};

// A marker drawn into the ground appears where the projection predicts, within 0.5 px, for a
// nadir camera, a yawed one, a slightly tilted one (full perspective) and from a height that
// makes the renderer use a coarser pyramid level.
TEST(Render, MarkerAppearsAtPredictedPixel) {
  const double mpp = 0.1;
  const Eigen::Vector2d marker_px(700.3, 812.6);
  const Eigen::Vector2d marker_en((marker_px.x() + 0.5) * mpp, -(marker_px.y() + 0.5) * mpp);
  CameraModel cam;
  cam.width_px = 320;
  cam.height_px = 240;
  cam.focal_px = 300.0;
  const MarkerCase cases[] = {{"nadir", 30, 0, 0, 0, 2.5},
                              {"yawed", 30, 37, 0, 0, 2.5},
                              {"tilted", 30, 200, 5, -3, 2.5},
                              {"level2", 120, 63, 0, 0, 10.0}};
  for (const auto& c : cases) {
    const GroundRenderer renderer(MarkerGround(marker_px, c.blob_sigma_px, mpp), cam);
    CameraPose pose;
    // Camera centre a few metres away from the marker, so it is off the image centre.
    pose.position_m = Eigen::Vector3d(marker_en.x() + 2.1, marker_en.y() - 1.7, c.height_m);
    pose.yaw_deg = c.yaw_deg;
    pose.pitch_deg = c.pitch_deg;
    pose.roll_deg = c.roll_deg;
    const Eigen::Vector2d predicted = ProjectGroundPoint(cam, pose, marker_en);
    ASSERT_TRUE(predicted.allFinite()) << c.name;
    ASSERT_GT(predicted.x(), 30);
    ASSERT_LT(predicted.x(), cam.width_px - 30);
    ASSERT_GT(predicted.y(), 30);
    ASSERT_LT(predicted.y(), cam.height_px - 30);
    const cv::Mat img = renderer.Render(pose);
    if (std::string(c.name) == "level2") {
      EXPECT_EQ(renderer.LevelFor(pose), 2);
    }
    const Eigen::Vector2d found = BlobCentroid(img, predicted, 9);
    EXPECT_LT((found - predicted).norm(), 0.5)
        << c.name << ": predicted " << predicted.transpose() << " found " << found.transpose();
    // Back-projection inverts the projection.
    EXPECT_LT((BackProjectPixel(cam, pose, predicted) - marker_en).norm(), 1e-9) << c.name;
  }
}

// A fisheye camera (known k1..k4): a marker appears where the projection through the lens
// predicts, off-centre where the lens moves it visibly, and the back-projection inverts it.
TEST(Render, FisheyeMarkerAppearsWhereTheLensPutsIt) {
  const double mpp = 0.1;
  const Eigen::Vector2d marker_px(700.3, 812.6);
  const Eigen::Vector2d marker_en((marker_px.x() + 0.5) * mpp, -(marker_px.y() + 0.5) * mpp);
  CameraModel cam;
  cam.width_px = 320;
  cam.height_px = 240;
  cam.focal_px = 150.0;
  cam.lens = LensModel::kFisheye;
  cam.distortion = {-0.05, 0.01, -0.002, 0.0005};
  CameraModel pinhole = cam;
  pinhole.distortion.clear();
  const GroundRenderer renderer(MarkerGround(marker_px, 2.5, mpp), cam);
  CameraPose pose;
  pose.position_m = Eigen::Vector3d(marker_en.x() + 18.0, marker_en.y() - 12.0, 30.0);
  pose.yaw_deg = 20.0;
  const Eigen::Vector2d predicted = ProjectGroundPoint(cam, pose, marker_en);
  const Eigen::Vector2d ideal = ProjectGroundPoint(pinhole, pose, marker_en);
  ASSERT_TRUE(predicted.allFinite());
  EXPECT_GT((predicted - ideal).norm(), 5.0) << "the lens moves the marker visibly";
  const cv::Mat img = renderer.Render(pose);
  const Eigen::Vector2d found = BlobCentroid(img, predicted, 9);
  EXPECT_LT((found - predicted).norm(), 0.5)
      << "predicted " << predicted.transpose() << " found " << found.transpose();
  EXPECT_LT((BackProjectPixel(cam, pose, predicted) - marker_en).norm(), 1e-6);
  EXPECT_EQ(Intrinsics(cam).model, LensModel::kFisheye);
  cam.distortion = {0.1, 0.0};
  EXPECT_THROW(Validate(cam), InvalidArgument);
}

// Fixed wing: turns of radius v^2 / (g tan(max bank)), the camera rolled by -bank in the turn
// (right turns: to the image's left), level on the legs.
TEST(Flight, FixedWingBanksInTurns) {
  FlightPlan plan;
  plan.pattern = FlightPattern::kFixedWing;
  plan.legs = 2;
  plan.leg_length_m = 200.0;
  plan.turn_angle_deg = 90.0;
  plan.speed_mps = 22.0;
  plan.max_bank_deg = 20.0;
  const PlannedFlight f = PlanFlight(plan, 2.0, Eigen::Vector2d::Zero(), 1);
  const double radius = 22.0 * 22.0 / (9.80665 * std::tan(20.0 * kPi / 180.0));  // 135.6 m
  EXPECT_NEAR(f.path_length_m, 400.0 + 0.5 * kPi * radius, 1.0);
  double min_roll = 0.0, first_roll = 0.0, last_roll = 0.0;
  for (const CameraPose& p : f.poses) min_roll = std::min(min_roll, p.roll_deg);
  first_roll = f.poses[3].roll_deg;
  last_roll = f.poses[f.poses.size() - 4].roll_deg;
  EXPECT_NEAR(min_roll, -20.0, 0.05);
  EXPECT_NEAR(first_roll, 0.0, 1e-6);
  EXPECT_NEAR(last_roll, 0.0, 1e-6);
  // Mid-turn the full bank: the pose at half the path length.
  const std::size_t mid = static_cast<std::size_t>((200.0 + 0.25 * kPi * radius) / 11.0);
  EXPECT_NEAR(f.poses[mid].roll_deg, -20.0, 0.05);
  plan.max_bank_deg = 50.0;
  EXPECT_THROW(Validate(plan), InvalidArgument);
}

TEST(Camera, YawZeroIsNorthUpAndEastRight) {
  CameraModel cam;
  cam.width_px = 101;
  cam.height_px = 81;
  cam.focal_px = 100;
  CameraPose pose;
  pose.position_m = Eigen::Vector3d(0, 0, 50);
  const Eigen::Vector2d c(50, 40);
  // 5 m east at 50 m height with f = 100 px: 10 px to the right; 5 m north: 10 px up.
  EXPECT_LT((ProjectGroundPoint(cam, pose, {5, 0}) - (c + Eigen::Vector2d(10, 0))).norm(), 1e-9);
  EXPECT_LT((ProjectGroundPoint(cam, pose, {0, 5}) - (c + Eigen::Vector2d(0, -10))).norm(), 1e-9);
  pose.yaw_deg = 90;  // image top towards east: east appears up, north to the left
  EXPECT_LT((ProjectGroundPoint(cam, pose, {5, 0}) - (c + Eigen::Vector2d(0, -10))).norm(), 1e-9);
  EXPECT_LT((ProjectGroundPoint(cam, pose, {0, 5}) - (c + Eigen::Vector2d(-10, 0))).norm(), 1e-9);
  // Positive pitch tilts the optical axis forward (towards the image top direction).
  pose.yaw_deg = 0;
  pose.pitch_deg = 10;
  const Eigen::Vector2d centre_ground = BackProjectPixel(cam, pose, c);
  EXPECT_NEAR(centre_ground.y(), 50 * std::tan(10 * kPi / 180), 1e-9);
  EXPECT_NEAR(centre_ground.x(), 0, 1e-9);
  pose.pitch_deg = 0;
  pose.roll_deg = 10;  // towards the image right = east for yaw 0
  EXPECT_NEAR(BackProjectPixel(cam, pose, c).x(), 50 * std::tan(10 * kPi / 180), 1e-9);
}

TEST(Camera, FocalFromFieldOfView) {
  CameraModel cam;
  cam.width_px = 1920;
  cam.hfov_deg = 90;
  EXPECT_NEAR(FocalPx(cam), 960.0, 1e-9);
  cam.focal_px = 1000;
  EXPECT_NEAR(HorizontalFovDeg(cam), 2 * std::atan(0.96) * 180 / kPi, 1e-9);
  cam.hfov_deg = 0;
  EXPECT_NO_THROW(Validate(cam));
  cam.focal_px = 0;
  EXPECT_THROW(Validate(cam), InvalidArgument);
}

GroundImage SmallTerrainGround() {
  TerrainOptions t;
  t.width_px = 1024;
  t.height_px = 1024;
  t.seed = 11;
  GroundImage g;
  g.image = GenerateTerrain(t);
  g.metres_per_px = t.metres_per_px;
  g.nw_corner = GeoPoint{49.84, 24.03, 300.0};
  g.source_kind = "terrain";
  g.terrain_seed = t.seed;
  return g;
}

SimulationOptions LineFlight() {
  SimulationOptions o;
  o.camera.width_px = 320;
  o.camera.height_px = 240;
  o.camera.hfov_deg = 60;
  o.flight.pattern = FlightPattern::kLine;
  o.flight.leg_length_m = 30;
  o.flight.heading_deg = 90;
  o.flight.height_m = 40;
  o.flight.speed_mps = 10;
  o.fps = 10;
  return o;
}

// Flying forward with the yaw following the track, the ground moves down the image by
// speed * dt * f / h pixels per frame: exactly in the projection, and as measured by phase
// correlation on the rendered frames.
TEST(Simulator, FrameToFrameShiftIsSpeedTimesDtTimesFOverH) {
  const SimulationOptions o = LineFlight();
  const Simulator sim(SmallTerrainGround(), o);
  ASSERT_EQ(sim.frame_count(), 31);  // 30 m at 1 m per frame, both ends included
  const double f = FocalPx(o.camera);
  const double expected = o.flight.speed_mps / o.fps * f / o.flight.height_m;
  const Eigen::Vector2d ground(300.0, -250.0);
  const Eigen::Vector2d p0 = ProjectGroundPoint(o.camera, sim.poses()[4], ground);
  const Eigen::Vector2d p1 = ProjectGroundPoint(o.camera, sim.poses()[5], ground);
  EXPECT_NEAR(p1.x() - p0.x(), 0.0, 1e-9);
  EXPECT_NEAR(p1.y() - p0.y(), expected, 1e-9);

  for (int i : {3, 17}) {
    cv::Mat a, b;
    cv::cvtColor(sim.RenderCleanFrame(i), a, cv::COLOR_BGR2GRAY);
    cv::cvtColor(sim.RenderCleanFrame(i + 1), b, cv::COLOR_BGR2GRAY);
    a.convertTo(a, CV_64F);
    b.convertTo(b, CV_64F);
    cv::Mat window;
    cv::createHanningWindow(window, a.size(), CV_64F);
    const cv::Point2d shift = cv::phaseCorrelate(a, b, window);
    EXPECT_NEAR(shift.x, 0.0, 0.15) << "frame " << i;
    EXPECT_NEAR(shift.y, expected, 0.15) << "frame " << i << " expected " << expected;
  }
  EXPECT_TRUE(sim.warnings().empty());
  // Ground truth: starts at the GT ENU origin at flight height, moves east 1 m per frame.
  EXPECT_LT((sim.ground_truth()[0].enu_m - Eigen::Vector3d(0, 0, 40)).norm(), 1e-6);
  EXPECT_LT((sim.ground_truth()[10].enu_m - Eigen::Vector3d(10, 0, 40)).norm(), 2e-3);
  EXPECT_NEAR(sim.ground_truth()[10].yaw_deg, 90.0, 1e-9);
}

TEST(Simulator, IlluminationFactorScalesMeanBrightness) {
  SimulationOptions o = LineFlight();
  const GroundImage ground = SmallTerrainGround();
  const Simulator bright(ground, o);
  const double mean1 = cv::mean(bright.RenderFrame(5))[0];
  for (double k : {0.75, 0.5, 0.25, 0.1}) {
    o.effects.illumination_k = k;
    const Simulator dark(ground, o);
    const double mean_k = cv::mean(dark.RenderFrame(5))[0];
    EXPECT_NEAR(mean_k, k * mean1, 1.0) << "k = " << k;
  }
}

TEST(Effects, SensorNoiseHasRequestedSigmaAndFollowsSeed) {
  EffectsOptions e;
  e.noise_sigma_dn = 6.0;
  cv::Mat a(300, 300, CV_8UC1, cv::Scalar(128)), b = a.clone(), c = a.clone();
  ApplyEffects(a, e, {0, 0}, 5);
  ApplyEffects(b, e, {0, 0}, 5);
  ApplyEffects(c, e, {0, 0}, 6);
  cv::Scalar mean, sd;
  cv::meanStdDev(a, mean, sd);
  EXPECT_NEAR(sd[0], 6.0, 0.3);
  EXPECT_NEAR(mean[0], 128.0, 0.2);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0.0);
}

// The thermal preset's vignetting (30 DN at the corners, r^2) and fixed pattern (3 DN per pixel
// and per column) are the same in every frame whatever the frame's seed, and differ per
// fixed_pattern_seed.
TEST(Effects, VignettingAndFixedPatternAreStaticInTheFrame) {
  const EffectsOptions e = ThermalEffects();
  EXPECT_EQ(e.vignetting_dn, 30.0);
  EXPECT_EQ(e.fixed_pattern_dn, 3.0);
  EffectsOptions still = e;
  still.noise_sigma_dn = 0.0;
  still.contrast = 1.0;
  still.optics_blur_sigma_px = 0.0;
  cv::Mat a(512, 640, CV_8UC1, cv::Scalar(150)), b = a.clone(), c = a.clone();
  ApplyEffects(a, still, {0, 0}, 1);
  ApplyEffects(b, still, {0, 0}, 2);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << "the pattern does not follow the frame's seed";
  still.fixed_pattern_seed = 2;
  ApplyEffects(c, still, {0, 0}, 1);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0.0);
  // Centre against the corner block (32x32 px whose centre is (304, 240) px from the frame's, at
  // r^2 = 0.896 of the corner's): 30 x 0.896 = 26.9 DN of vignetting; the fixed pattern averages
  // to about 3 / sqrt(32) = 0.5 DN over a block (its column part).
  const double centre = cv::mean(a(cv::Rect(304, 240, 32, 32)))[0];
  const double corner = cv::mean(a(cv::Rect(0, 0, 32, 32)))[0];
  EXPECT_NEAR(centre, 150.0, 1.5);
  EXPECT_NEAR(centre - corner, 26.9, 2.0);
  cv::Mat diff;
  cv::absdiff(a(cv::Rect(304, 240, 32, 32)), cv::Scalar(150), diff);
  EXPECT_GT(cv::mean(diff)[0], 1.5) << "per-pixel fixed pattern present";
  EffectsOptions bad;
  bad.vignetting_dn = -1.0;
  EXPECT_THROW(Validate(bad), InvalidArgument);
}

TEST(Effects, MotionBlurSpreadsAlongTheMotionOnly) {
  EffectsOptions e;
  e.motion_blur_px = 9.0;
  for (const Eigen::Vector2d& dir : {Eigen::Vector2d(1, 0), Eigen::Vector2d(1, 1)}) {
    cv::Mat img(41, 41, CV_8UC1, cv::Scalar(0));
    img.at<std::uint8_t>(20, 20) = 255;
    cv::Mat f;
    ApplyEffects(img, e, dir * 3.0, 1);
    img.convertTo(f, CV_64F);
    const cv::Moments m = cv::moments(f);
    const Eigen::Vector2d u = dir.normalized();
    // Second moments along and across the motion direction.
    const double mxx = m.mu20 / m.m00, myy = m.mu02 / m.m00, mxy = m.mu11 / m.m00;
    const double along = u.x() * u.x() * mxx + 2 * u.x() * u.y() * mxy + u.y() * u.y() * myy;
    const double across = u.y() * u.y() * mxx - 2 * u.x() * u.y() * mxy + u.x() * u.x() * myy;
    EXPECT_NEAR(along, 81.0 / 12.0, 1.2) << dir.transpose();  // box of length 9: L^2 / 12
    EXPECT_LT(across, 0.5) << dir.transpose();
    EXPECT_NEAR(m.m10 / m.m00, 20.0, 0.2);
    EXPECT_NEAR(m.m01 / m.m00, 20.0, 0.2);
  }
}

TEST(Effects, JpegRoundTripKeepsTheImageClose) {
  const GroundImage g = SmallTerrainGround();
  cv::Mat frame = g.image(cv::Rect(0, 0, 256, 256)).clone();
  const cv::Mat before = frame.clone();
  EffectsOptions e;
  e.jpeg_quality = 40;
  ApplyEffects(frame, e, {0, 0}, 1);
  const double err = cv::norm(frame, before, cv::NORM_L1) / before.total() / 3;
  EXPECT_GT(err, 0.5);  // the compression did something
  EXPECT_LT(err, 12.0);
}

TEST(Gps, NoiseHasRequestedSigma) {
  std::vector<CameraPose> poses(2);
  poses[1].time_s = 2000.0;
  poses[0].position_m = Eigen::Vector3d(100, -100, 50);
  poses[1].position_m = Eigen::Vector3d(300, -100, 50);
  const LocalEnu map_enu(GeoPoint{43.5, 6.5, 200});
  GpsOptions o;
  o.rate_hz = 10;
  o.horizontal_sigma_m = 2.0;
  o.vertical_sigma_m = 3.0;
  const auto fixes = SimulateGps(poses, o, map_enu, 42);
  ASSERT_EQ(fixes.size(), 20001u);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  double worst = 0;
  for (const GpsFix& f : fixes) {
    const Eigen::Vector3d truth(100 + 0.1 * f.time_s, -100, 50);
    // Reported lat/lon are those of the ground point below; altitude = 200 m ground + height.
    Eigen::Vector3d err = map_enu.Forward(f.position.lat_deg, f.position.lon_deg, 200) - truth;
    err.z() = f.position.alt_m - 200 - truth.z();
    worst = std::max(worst, (err - f.error_enu_m).norm());
    sum += err;
    sum2 += err.cwiseProduct(err);
  }
  EXPECT_LT(worst, 1e-6);
  const double n = static_cast<double>(fixes.size());
  const Eigen::Vector3d mean = sum / n;
  const Eigen::Vector3d sd = (sum2 / n - mean.cwiseProduct(mean)).cwiseSqrt();
  EXPECT_NEAR(sd.x(), 2.0, 0.2);
  EXPECT_NEAR(sd.y(), 2.0, 0.2);
  EXPECT_NEAR(sd.z(), 3.0, 0.3);
  EXPECT_LT(mean.head<2>().norm(), 0.1);
  // Same seed, same fixes; another seed, other fixes.
  EXPECT_EQ(SimulateGps(poses, o, map_enu, 42)[77].position.lat_deg, fixes[77].position.lat_deg);
  EXPECT_NE(SimulateGps(poses, o, map_enu, 43)[77].position.lat_deg, fixes[77].position.lat_deg);
}

TEST(Gps, CorrelatedNoiseFollowsTheTimeConstant) {
  std::vector<CameraPose> poses(2);
  poses[1].time_s = 5000.0;
  const LocalEnu map_enu(GeoPoint{43.5, 6.5, 200});
  GpsOptions o;
  o.rate_hz = 1;
  o.horizontal_sigma_m = 1.5;
  o.correlation_time_s = 5.0;
  const auto fixes = SimulateGps(poses, o, map_enu, 7);
  double s0 = 0, s1 = 0;
  for (size_t i = 1; i < fixes.size(); ++i) {
    s0 += fixes[i].error_enu_m.x() * fixes[i].error_enu_m.x();
    s1 += fixes[i].error_enu_m.x() * fixes[i - 1].error_enu_m.x();
  }
  EXPECT_NEAR(std::sqrt(s0 / (fixes.size() - 1)), 1.5, 0.15);
  EXPECT_NEAR(s1 / s0, std::exp(-1.0 / 5.0), 0.05);
  EXPECT_EQ(LatestFixIndex(fixes, 10.5), 10u);
  EXPECT_EQ(LatestFixIndex(fixes, 10.0), 10u);
}

TEST(Flight, LawnmowerLengthLegsAndYaw) {
  FlightPlan p;
  p.pattern = FlightPattern::kLawnmower;
  p.leg_length_m = 200;
  p.legs = 3;
  p.spacing_m = 40;
  p.heading_deg = 90;
  p.speed_mps = 10;
  const PlannedFlight f = PlanFlight(p, 5.0, Eigen::Vector2d(1000, -1000), 1);
  const double expected = 3 * 200 + 2 * kPi * 20;
  EXPECT_NEAR(f.path_length_m, expected, 0.05);  // arcs are chords of <= 0.25 m
  EXPECT_EQ(static_cast<long>(f.poses.size()),
            static_cast<long>(std::floor(f.path_length_m / 2)) + 1);
  // First leg eastwards, second (after a right turn) westwards 40 m further south.
  EXPECT_NEAR(f.poses[5].yaw_deg, 90.0, 1e-6);
  const double leg2_s = 200 + kPi * 20 + 100;  // middle of leg 2
  const auto& mid2 = f.poses[static_cast<size_t>(leg2_s / 2)];
  EXPECT_NEAR(mid2.yaw_deg, 270.0, 1e-6);
  EXPECT_NEAR(mid2.position_m.y() - f.poses[5].position_m.y(), -40.0, 1e-6);
  // The pattern is centred on the reference point: legs at north -1040, -1000, -960.
  EXPECT_NEAR(f.poses[5].position_m.y(), -960.0, 1e-6);
  // Speed is constant along the path, including the turns.
  for (size_t i = 1; i < f.poses.size(); ++i) {
    EXPECT_NEAR((f.poses[i].position_m - f.poses[i - 1].position_m).norm(), 2.0, 0.01);
  }
}

TEST(Flight, WaypointCornersAreRoundedAndYawIsContinuous) {
  FlightPlan p;
  p.pattern = FlightPattern::kWaypoints;
  p.waypoints_m = {{0, 0}, {100, 0}, {100, 100}};
  p.turn_radius_m = 10;
  p.speed_mps = 5;
  const PlannedFlight f = PlanFlight(p, 10.0, Eigen::Vector2d::Zero(), 1);
  EXPECT_NEAR(f.path_length_m, 2 * 90 + kPi * 10 / 2, 0.01);
  for (size_t i = 1; i < f.poses.size(); ++i) {
    double d = std::abs(f.poses[i].yaw_deg - f.poses[i - 1].yaw_deg);
    d = std::min(d, 360 - d);
    EXPECT_LT(d, 3.0) << "frame " << i;  // 90 deg over a 15.7 m arc at 0.5 m per frame
  }
  EXPECT_NEAR(f.poses.back().position_m.x(), 100, 1e-6);
  EXPECT_NEAR(f.poses.back().position_m.y(), 100, 0.5);
}

TEST(Flight, ValidateNamesTheProblem) {
  FlightPlan p;
  p.speed_mps = -1;
  try {
    Validate(p);
    FAIL() << "no exception";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("speed_mps"), std::string::npos) << e.what();
  }
  p = FlightPlan{};
  p.pattern = FlightPattern::kWaypoints;
  EXPECT_THROW(Validate(p), InvalidArgument);
  EXPECT_THROW(ParseFlightPattern("spiral"), InvalidArgument);
  EXPECT_EQ(ParseFlightPattern("turns"), FlightPattern::kTurns);
}

TEST(Simulator, WarnsWhenTheViewLeavesTheGround) {
  SimulationOptions o = LineFlight();
  o.flight.leg_length_m = 300;  // the 1024 x 0.25 m = 256 m ground is too small
  o.flight.speed_mps = 30;
  const Simulator sim(SmallTerrainGround(), o);
  ASSERT_EQ(sim.warnings().size(), 1u);
  EXPECT_NE(sim.warnings()[0].find("without ground data"), std::string::npos);
  // The 300 m line is centred on the ground: both ends are off it, the middle is on it.
  ASSERT_EQ(sim.frame_count(), 101);
  EXPECT_GT(sim.ground_truth().front().nodata_fraction, 0.3);
  EXPECT_GT(sim.ground_truth().back().nodata_fraction, 0.3);
  EXPECT_LT(sim.ground_truth()[50].nodata_fraction, 0.01);
}

}  // namespace
}  // namespace aerovo::sim::sim_test

namespace aerovo::sim::sim_test {
namespace {

// The terrain fitted to a flight has the camera's resolution and holds every frame's view.
TEST(Simulator, FittedTerrainHoldsTheWholeFlight) {
  SimulationOptions o;
  o.camera.width_px = 200;
  o.camera.height_px = 120;
  o.camera.hfov_deg = 70;
  o.flight.pattern = FlightPattern::kTurns;
  o.flight.legs = 4;
  o.flight.leg_length_m = 60;
  o.flight.turn_radius_m = 10;
  o.flight.height_m = 50;
  o.flight.roll_deg = 3;
  o.flight.speed_mps = 8;
  o.fps = 2;
  const TerrainOptions t = FitTerrainToFlight(o);
  EXPECT_NEAR(t.metres_per_px, NadirGsdMetresPerPx(o.camera, 50), 1e-12);
  const Simulator sim(MakeTerrainGround(t), o);
  EXPECT_TRUE(sim.warnings().empty());
  double worst = 0;
  for (const auto& g : sim.ground_truth()) worst = std::max(worst, g.nodata_fraction);
  EXPECT_EQ(worst, 0.0);
  // Four right turns of 90 deg: the yaw has turned by 270 deg at the end of the last leg.
  EXPECT_NEAR(
      std::fmod(sim.ground_truth().back().yaw_deg - sim.ground_truth()[0].yaw_deg + 720, 360.0),
      270.0, 1.0);
}

}  // namespace
}  // namespace aerovo::sim::sim_test
