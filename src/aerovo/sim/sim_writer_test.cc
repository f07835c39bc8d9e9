// Files of a simulated flight: SRT, video, image folder, ground truth and sim.json.
#include "aerovo/sim/sim_writer.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>


#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/sim/simulator.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::sim::sim_writer_test {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  return ::aerovo::testing::UnusedTempPath("aerovo_sim_writer", name);
}

SimulationOptions SmallFlight() {
  SimulationOptions o;
  o.camera.width_px = 160;
  o.camera.height_px = 120;
  o.camera.hfov_deg = 60;
  o.flight.pattern = FlightPattern::kLine;
  o.flight.leg_length_m = 11;
  o.flight.heading_deg = 30;
  o.flight.height_m = 40;
  o.flight.speed_mps = 10;
  o.fps = 10;
  return o;
}

GroundImage SmallGround() {
  TerrainOptions t;
  t.width_px = 512;
  t.height_px = 512;
  t.seed = 4;
  return MakeTerrainGround(t, GeoPoint{43.54, 6.55, 250.0});
}

// Re-reads the SRT line by line: 5-line entries, frame counter, time stamps, and positions that
// agree with the exact ground truth (GPS noise 0) to the SRT's 6 decimals.
TEST(SimWriter, SrtMatchesGroundTruth) {
  const Simulator sim(SmallGround(), SmallFlight());
  ASSERT_EQ(sim.frame_count(), 12);
  std::stringstream srt;
  WriteDjiSrt(srt, sim, "2026-05-01T10:00:00");
  const std::regex pos_re(
      R"(\[latitude: (-?[0-9.]+)\] \[longitude: (-?[0-9.]+)\] \[rel_alt: ([0-9.]+) abs_alt: ([0-9.]+)\])");
  std::string line;
  int entries = 0;
  double worst_m = 0;
  const LocalEnu enu(sim.origin());
  while (std::getline(srt, line)) {
    if (line.empty()) continue;
    ASSERT_EQ(line, std::to_string(entries + 1)) << "entry index";
    std::string times, frame, stamp, fields;
    ASSERT_TRUE(std::getline(srt, times) && std::getline(srt, frame) && std::getline(srt, stamp) &&
                std::getline(srt, fields));
    EXPECT_EQ(frame,
              "<font size=\"28\">FrameCnt: " + std::to_string(entries + 1) + ", DiffTime: 100ms");
    if (entries == 3) {
      EXPECT_EQ(times, "00:00:00,300 --> 00:00:00,400");
      EXPECT_EQ(stamp, "2026-05-01 10:00:00.300");
    }
    std::smatch m;
    // focal_len: the 35 mm equivalent in the EXIF (diagonal) convention, which readers convert
    // back with f_px = f35 / 43.27 mm * diagonal_px: the simulator's focal to within 0.05 %.
    const std::regex focal_re(R"(\[focal_len: ([0-9.]+)\])");
    ASSERT_TRUE(std::regex_search(fields, m, focal_re)) << fields;
    const CameraModel& cam = sim.options().camera;
    const double focal_back_px =
        std::stod(m[1]) / 43.266615305567875 * std::hypot(cam.width_px, cam.height_px);
    EXPECT_NEAR(focal_back_px / FocalPx(cam), 1.0, 5e-4);
    ASSERT_TRUE(std::regex_search(fields, m, pos_re)) << fields;
    const GroundTruthFrame& gt = sim.ground_truth()[entries];
    const Eigen::Vector3d p = enu.Forward(std::stod(m[1]), std::stod(m[2]), gt.position.alt_m);
    worst_m = std::max(worst_m, (p - gt.enu_m).head<2>().norm());
    EXPECT_NEAR(std::stod(m[3]), 40.0, 1e-3);
    EXPECT_NEAR(std::stod(m[4]), 290.0, 1e-3);
    ++entries;
  }
  EXPECT_EQ(entries, 12);
  EXPECT_LT(worst_m, 0.1);  // 1e-6 deg quantisation: <= 0.06 m
  // The flight goes 10 m towards heading 30 deg: the last SRT fix is there.
  EXPECT_NEAR(sim.ground_truth().back().enu_m.x(), 11 * std::sin(30 * kDegToRad), 1e-3);
}

TEST(SimWriter, SrtCarriesGpsNoise) {
  SimulationOptions o = SmallFlight();
  o.gps.horizontal_sigma_m = 3.0;
  o.gps.rate_hz = 10;
  const Simulator sim(SmallGround(), o);
  const LocalEnu enu(sim.origin());
  double sum2 = 0;
  for (int i = 0; i < sim.frame_count(); ++i) {
    const GpsFix& f = sim.gps()[LatestFixIndex(sim.gps(), sim.ground_truth()[i].time_s)];
    const Eigen::Vector3d p = enu.Forward(f.position.lat_deg, f.position.lon_deg, 290);
    sum2 += (p - sim.ground_truth()[i].enu_m).head<2>().squaredNorm();
  }
  // 12 fixes x 2 axes of sigma 3 m: the RMS error is clearly non-zero and of the right size.
  const double rms = std::sqrt(sum2 / (2 * sim.frame_count()));
  EXPECT_GT(rms, 1.5);
  EXPECT_LT(rms, 5.0);
}

TEST(SimWriter, VideoReopensWithTheRightFrameCount) {
  const Simulator sim(SmallGround(), SmallFlight());
  const fs::path dir = TempDir("video");
  const SimulationOutput out = WriteSimulation(sim, WriterOptions{}, dir);
  ASSERT_FALSE(out.video_file.empty());
  EXPECT_EQ(out.frames_written, 12);
  cv::VideoCapture cap((dir / out.video_file).string());
  ASSERT_TRUE(cap.isOpened());
  int frames = 0;
  cv::Mat f;
  while (cap.read(f)) {
    EXPECT_EQ(f.cols, 160);
    EXPECT_EQ(f.rows, 120);
    ++frames;
  }
  EXPECT_EQ(frames, 12);

  // The manifest reads back with what the pipeline needs.
  const SimulationManifest m = ReadSimulationManifest(dir / "sim.json");
  EXPECT_EQ(m.frame_count, 12);
  EXPECT_EQ(m.fps, 10.0);
  EXPECT_EQ(m.width_px, 160);
  EXPECT_NEAR(m.focal_px, FocalPx(sim.options().camera), 1e-9);
  EXPECT_NEAR(m.height_above_ground_m, 40.0, 1e-12);
  EXPECT_NEAR(m.origin.lat_deg, sim.origin().lat_deg, 1e-12);
  EXPECT_EQ(m.video, dir / "video.mp4");
  EXPECT_TRUE(fs::exists(m.srt) && fs::exists(m.gpx) && fs::exists(m.tum) && fs::exists(m.csv));
  // TUM: one line per frame, first pose at (0, 0, height).
  std::ifstream tum(m.tum);
  double t, x, y, z;
  tum >> t >> x >> y >> z;
  EXPECT_NEAR(x, 0.0, 1e-6);
  EXPECT_NEAR(y, 0.0, 1e-6);
  EXPECT_NEAR(z, 40.0, 1e-6);
  fs::remove_all(dir);
}

// TUM and GPX go through outputs' writers: the TUM file has the simulator's format byte for byte
// ("%.6f" time and position, "%.9f" quaternion); the GPX reads back with telemetry's reader as the
// GPS fixes, with the UTC times of start_time_utc.
TEST(SimWriter, TumAndGpxThroughIoWriters) {
  const Simulator sim(SmallGround(), SmallFlight());
  const fs::path dir = TempDir("io_writers");
  fs::create_directories(dir);
  WriteTum(dir / "gt.tum", sim);
  std::string want;
  for (const GroundTruthFrame& g : sim.ground_truth()) {
    const Eigen::Quaterniond q(g.enu_from_camera);
    want += fmt::format("{:.6f} {:.6f} {:.6f} {:.6f} {:.9f} {:.9f} {:.9f} {:.9f}\n", g.time_s,
                        g.enu_m.x(), g.enu_m.y(), g.enu_m.z(), q.x(), q.y(), q.z(), q.w());
  }
  std::ifstream tum(dir / "gt.tum");
  std::stringstream got;
  got << tum.rdbuf();
  EXPECT_EQ(got.str(), want);

  WriteGpx(dir / "track.gpx", sim, "2026-05-01T10:00:00");
  const TelemetryReadResult r = ReadGpx(dir / "track.gpx");
  ASSERT_EQ(r.telemetry.size(), sim.gps().size());
  ASSERT_FALSE(sim.gps().empty());
  for (std::size_t i = 0; i < sim.gps().size(); ++i) {
    const GpsFix& f = sim.gps()[i];
    const TelemetrySample& s = r.telemetry.samples()[i];
    EXPECT_NEAR(s.lat_deg, f.position.lat_deg, 1e-9);
    EXPECT_NEAR(s.lon_deg, f.position.lon_deg, 1e-9);
    ASSERT_TRUE(s.abs_alt_m.has_value());
    EXPECT_NEAR(*s.abs_alt_m, f.position.alt_m, 1e-4);
    ASSERT_TRUE(s.unix_time_s.has_value());
    EXPECT_NEAR(*s.unix_time_s, 1777629600.0 + f.time_s, 1e-3);  // 2026-05-01T10:00:00Z
  }
  EXPECT_THROW(WriteTum(dir / "no" / "such" / "dir" / "gt.tum", sim), OutputError);
  fs::remove_all(dir);
}

TEST(SimWriter, FramesOnlyWritesOneImagePerFrame) {
  const Simulator sim(SmallGround(), SmallFlight());
  const fs::path dir = TempDir("frames");
  WriterOptions w;
  w.write_video = false;
  w.image_format = "png";
  const SimulationOutput out = WriteSimulation(sim, w, dir);
  EXPECT_TRUE(out.video_file.empty());
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir / out.frames_dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 12);
  // PNG is lossless: the file equals the in-memory render.
  const cv::Mat f5 = cv::imread((dir / "frames" / "frame_000005.png").string(), cv::IMREAD_COLOR);
  EXPECT_EQ(cv::norm(f5, sim.RenderFrame(5), cv::NORM_INF), 0.0);
  fs::remove_all(dir);
}

TEST(SimWriter, BadInputsAreNamed) {
  EXPECT_THROW(LoadOrthophoto("/nonexistent/ortho.jpg", 0.1, GeoPoint{43, 6, 0}), InputError);
  EXPECT_THROW(ReadSimulationManifest("/nonexistent/sim.json"), InputError);
  WriterOptions w;
  w.start_time_utc = "yesterday";
  EXPECT_THROW(Validate(w), InvalidArgument);
  const fs::path dir = TempDir("badjson");
  fs::create_directories(dir);
  std::ofstream(dir / "sim.json") << "{\"format\": \"aerovo-simulation\", \"version\": 1}";
  try {
    ReadSimulationManifest(dir / "sim.json");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing field 'files'"), std::string::npos) << e.what();
  }
  // Whole numbers are checked before any cast: get<int>() cast 1e300 into an int (undefined
  // behaviour) and wrapped 2^40 around. A whole manifest, then one value changed.
  const nlohmann::json valid = nlohmann::json::parse(R"({
    "format": "aerovo-simulation", "version": 1,
    "files": {"video": "flight.mp4", "frames_dir": null, "frame_pattern": null, "srt": null,
              "gpx": null, "ground_truth_tum": null, "ground_truth_csv": null},
    "frame_count": 10, "fps": 10,
    "camera": {"width_px": 640, "height_px": 480, "focal_px": 500, "cx_px": 320, "cy_px": 240,
               "hfov_deg": 65},
    "height_above_ground_m": 100, "gsd_m_per_px": 0.2, "ground_altitude_m": 0,
    "origin": {"lat_deg": 45, "lon_deg": 7, "alt_m": 0}, "distance_m": 100,
    "effects": {"illumination_k": 1}, "gps": {"horizontal_sigma_m": 0}, "seed": 1})");
  std::ofstream(dir / "sim.json") << valid.dump();
  EXPECT_EQ(ReadSimulationManifest(dir / "sim.json").frame_count, 10);
  const struct {
    nlohmann::json::json_pointer where;
    nlohmann::json value;
    std::string message;
  } kCases[] = {
      {nlohmann::json::json_pointer("/version"), 1e300, "'version' is not a whole number in ["},
      {nlohmann::json::json_pointer("/frame_count"), 1LL << 40,
       "'frame_count' is not a whole number in [1, 100000000]"},
      {nlohmann::json::json_pointer("/frame_count"), -3, "'frame_count' is not a whole number"},
      {nlohmann::json::json_pointer("/frame_count"), 2.5, "'frame_count' is not a whole number"},
      {nlohmann::json::json_pointer("/camera/width_px"), 1e300, "'width_px' is not a whole number"},
      {nlohmann::json::json_pointer("/seed"), -1, "'seed' is not a whole number >= 0"},
  };
  for (const auto& c : kCases) {
    nlohmann::json bad = valid;
    bad[c.where] = c.value;
    std::ofstream(dir / "sim.json") << bad.dump();
    try {
      ReadSimulationManifest(dir / "sim.json");
      ADD_FAILURE() << c.where.to_string() << " = " << c.value.dump() << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::sim::sim_writer_test
