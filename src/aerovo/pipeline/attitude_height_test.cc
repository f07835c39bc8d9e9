// Heights (which one, from where) and attitude (docs/attitude.md) in the run's steps: the height
// above ground from a relative altitude plus the take-off point's height, or from an altitude
// above sea level minus the ground's (photos the test writes with only a GPS altitude), and the
// camera attitude of a frame from its telemetry (gimbal, aircraft, autopilot, mount).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/frames/image_test_util.h"
#include "aerovo/pipeline/run_steps.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::run_steps::attitude_height_test {
namespace {

namespace fs = std::filesystem;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TelemetrySample Sample(std::optional<double> rel_alt_m, std::optional<double> abs_alt_m) {
  TelemetrySample s;
  s.lat_deg = 45.0;
  s.lon_deg = 7.0;
  s.rel_alt_m = rel_alt_m;
  s.abs_alt_m = abs_alt_m;
  return s;
}

TEST(Height, RelativeAltitudePlusTheTakeOffPointsHeight) {
  std::vector<std::string> warnings;
  HeightProvider plain(0.0);
  plain.set_ground(kNaN, 0.0, "f.srt");
  EXPECT_EQ(plain.HeightOf("f0", Sample(80.0, 400.0), &warnings), 80.0);
  EXPECT_EQ(plain.last_source(), "telemetry");  // as before the option existed
  HeightProvider roof(0.0);
  roof.set_ground(kNaN, 12.0, "f.srt");
  EXPECT_EQ(roof.HeightOf("f0", Sample(80.0, 400.0), &warnings), 92.0);
  EXPECT_EQ(roof.last_source(), "telemetry_rel_alt+takeoff_height");
  // A relative altitude wins over the altitude above sea level even with a ground elevation.
  HeightProvider both(0.0);
  both.set_ground(300.0, 0.0, "f.srt");
  EXPECT_EQ(both.HeightOf("f0", Sample(80.0, 400.0), &warnings), 80.0);
  EXPECT_TRUE(warnings.empty());
}

TEST(Height, AltitudeAboveSeaLevelNeedsTheGroundsElevation) {
  std::vector<std::string> warnings;
  HeightProvider h(0.0);
  h.set_ground(312.5, 0.0, "flight.srt");
  EXPECT_DOUBLE_EQ(h.HeightOf("frame 0", Sample(std::nullopt, 412.0), &warnings), 99.5);
  EXPECT_EQ(h.last_source(), "telemetry_abs_alt-ground_elevation");
  io_test::ExpectInputError(
      [&] {
        HeightProvider none(0.0);
        none.set_ground(kNaN, 0.0, "flight.srt");
        none.HeightOf("frame 0", Sample(std::nullopt, 412.0), &warnings);
      },
      {"frame 0: no height above ground", "flight.srt gives only an altitude above sea level",
       "412.0 m", "--ground-elevation-m"});
  io_test::ExpectInputError(
      [&] {
        HeightProvider below(0.0);
        below.set_ground(500.0, 0.0, "flight.srt");
        below.HeightOf("frame 0", Sample(std::nullopt, 412.0), &warnings);
      },
      {"frame 0", "412.0 m minus ground_elevation_m 500.0 m is -88.0 m"});
}

// Photos the test writes with a GPS position and a GPSAltitude only (no DJI XMP): the error
// names the photo; with the ground's elevation the height is their difference.
TEST(Height, PhotosWithOnlyAGpsAltitude) {
  const fs::path dir = fs::temp_directory_path() / ("aerovo_amsl_photos_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (int i = 0; i < 3; ++i) {
    io_test::WriteJpegWithTags(dir / ("IMG_000" + std::to_string(i) + ".JPG"),
                               io_test::TextureImage(320, 240, 7 + i),
                               {{"Exif.GPSInfo.GPSLatitude", "45/1 3/1 " + std::to_string(i) + "/1"},
                                {"Exif.GPSInfo.GPSLatitudeRef", "N"},
                                {"Exif.GPSInfo.GPSLongitude", "7/1 40/1 0/1"},
                                {"Exif.GPSInfo.GPSLongitudeRef", "E"},
                                {"Exif.GPSInfo.GPSAltitude", "3455/10"},
                                {"Exif.GPSInfo.GPSAltitudeRef", "0"},
                                {"Exif.Photo.DateTimeOriginal",
                                 "2024:06:01 10:00:0" + std::to_string(2 * i)}});
  }
  std::vector<std::string> warnings;
  const ImageFolderSource photos(dir);
  const RunTelemetry t = RunTelemetry::Load("", false, &photos, &warnings);
  Frame f;
  f.index = 0;
  const std::optional<TelemetrySample> s = t.SampleOf(f);
  ASSERT_TRUE(s.has_value());
  ASSERT_TRUE(s->abs_alt_m.has_value());
  EXPECT_FALSE(s->rel_alt_m.has_value());
  io_test::ExpectInputError(
      [&] {
        HeightProvider h(0.0);
        h.set_ground(kNaN, 0.0, "the photo's EXIF");
        h.HeightOf("IMG_0000.JPG", s, &warnings);
      },
      {"IMG_0000.JPG: no height above ground", "only an altitude above sea level (345.5 m)",
       "--ground-elevation-m"});
  HeightProvider h(0.0);
  h.set_ground(265.5, 0.0, "the photo's EXIF");
  EXPECT_NEAR(h.HeightOf("IMG_0000.JPG", s, &warnings), 80.0, 1e-9);
  EXPECT_EQ(h.last_source(), "telemetry_abs_alt-ground_elevation");
  fs::remove_all(dir);
}

TEST(CameraAttitude, FromTheGimbalTheAircraftTheAutopilotOrTheMount) {
  RunConfig c;
  TelemetrySample s = Sample(80.0, std::nullopt);
  // DJI gimbal: -90 = nadir; camera pitch = gimbal pitch + 90. The gimbal wins over the
  // aircraft's angles (a gimbal camera does not follow the airframe).
  s.gimbal_pitch_deg = -75.0;
  s.gimbal_roll_deg = 2.0;
  s.pitch_deg = -8.0;
  s.roll_deg = 4.0;
  FrameAttitude a = CameraAttitudeOf(c, s, std::nullopt);
  ASSERT_TRUE(a.camera.has_value());
  EXPECT_EQ(a.source, AttitudeSource::kGimbal);
  EXPECT_NEAR(a.camera->pitch_deg, 15.0, 1e-12);
  EXPECT_NEAR(a.camera->roll_deg, 2.0, 1e-12);
  // A camera fixed under the aircraft: the aircraft's angles.
  s.gimbal_pitch_deg.reset();
  s.gimbal_roll_deg.reset();
  a = CameraAttitudeOf(c, s, std::nullopt);
  EXPECT_EQ(a.source, AttitudeSource::kFlight);
  EXPECT_NEAR(a.camera->pitch_deg, -8.0, 1e-9);
  EXPECT_NEAR(a.camera->roll_deg, 4.0, 1e-9);
  // The autopilot's ATTITUDE over MAVLink wins over the telemetry file's aircraft angles.
  mavlink::AutopilotAttitude link;
  link.roll_rad = 3.0 * kDegToRad;
  link.pitch_rad = 5.0 * kDegToRad;
  a = CameraAttitudeOf(c, s, link);
  EXPECT_EQ(a.source, AttitudeSource::kMavlink);
  EXPECT_NEAR(a.camera->pitch_deg, 5.0, 1e-9);
  EXPECT_NEAR(a.camera->roll_deg, 3.0, 1e-9);
  // A mount tilt adds to a level aircraft's pitch.
  c.camera_mount_pitch_deg = 20.0;
  a = CameraAttitudeOf(c, Sample(80.0, std::nullopt), std::nullopt);
  EXPECT_EQ(a.source, AttitudeSource::kMount);
  EXPECT_NEAR(a.camera->pitch_deg, 20.0, 1e-9);
  link.roll_rad = 0.0;
  a = CameraAttitudeOf(c, std::nullopt, link);
  EXPECT_NEAR(a.camera->pitch_deg, 25.0, 1e-9);
  // Nearly nadir (DJI's -89.9) is nadir: nothing is given to the odometry.
  c = RunConfig{};
  s = Sample(80.0, std::nullopt);
  s.gimbal_pitch_deg = -89.9;
  a = CameraAttitudeOf(c, s, std::nullopt);
  EXPECT_FALSE(a.camera.has_value());
  ASSERT_TRUE(a.reported.has_value());
  // attitude = off: reported, not used.
  c.attitude = AttitudeMode::kOff;
  s.gimbal_pitch_deg = -70.0;
  a = CameraAttitudeOf(c, s, std::nullopt);
  EXPECT_FALSE(a.camera.has_value());
  EXPECT_NEAR(a.reported->pitch_deg, 20.0, 1e-12);
  // No attitude anywhere.
  EXPECT_FALSE(CameraAttitudeOf(RunConfig{}, Sample(80.0, std::nullopt), std::nullopt).reported);
}

TEST(CameraAttitude, TheFlightsOwnEstimateOnlyWhereNothingElseGivesOne) {
  const CameraAttitude estimated{-0.5, 15.0};
  RunConfig c;
  FrameAttitude a = CameraAttitudeOf(c, Sample(80.0, std::nullopt), std::nullopt, estimated);
  EXPECT_EQ(a.source, AttitudeSource::kEstimated);
  ASSERT_TRUE(a.camera.has_value());
  EXPECT_EQ(a.camera->pitch_deg, 15.0);
  EXPECT_EQ(a.camera->roll_deg, -0.5);
  EXPECT_STREQ(ToString(a.source), "estimated");
  // The telemetry's gimbal wins.
  TelemetrySample s = Sample(80.0, std::nullopt);
  s.gimbal_pitch_deg = -80.0;
  a = CameraAttitudeOf(c, s, std::nullopt, estimated);
  EXPECT_EQ(a.source, AttitudeSource::kGimbal);
  EXPECT_NEAR(a.camera->pitch_deg, 10.0, 1e-12);
  // A mount pitch given wins.
  c.camera_mount_pitch_deg = 5.0;
  a = CameraAttitudeOf(c, Sample(80.0, std::nullopt), std::nullopt, estimated);
  EXPECT_EQ(a.source, AttitudeSource::kMount);
  // attitude = off: reported, not used.
  c = RunConfig{};
  c.attitude = AttitudeMode::kOff;
  a = CameraAttitudeOf(c, std::nullopt, std::nullopt, estimated);
  EXPECT_FALSE(a.camera.has_value());
  EXPECT_EQ(a.source, AttitudeSource::kEstimated);
}

}  // namespace
}  // namespace aerovo::run_steps::attitude_height_test
