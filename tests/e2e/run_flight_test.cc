// `aerovo run` on the real flights in $AEROVO_SHARED (tampa-phantom3, turin-p4m,
// brighton-phantom3-16x9), a flight with a black frame, and a run interrupted by SIGINT. The
// accuracy targets are asserted with a margin, and the default runs' figures against the stored
// real-flight table bench/real_flights.tsv within its seed-to-seed spread (BENCHMARKS.md, "Real
// flights: the benchmark").
#include "aerovo/frames/camera.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/frames/image_metadata.h"
#include "aerovo/pipeline/runner.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/image_test_util.h"

#include "e2e_testing.h"

namespace aerovo::run_flight_test {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return e2e::FreshTempDir("aerovo_runner_test", name); }

using e2e::ReadText;

// Every CSV row complete: as many fields as the header (no quoted commas in our rows).
int CheckCsvRows(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  EXPECT_TRUE(std::getline(in, line));
  const auto fields = [](const std::string& l) { return std::count(l.begin(), l.end(), ',') + 1; };
  const long n = fields(line);
  int rows = 0;
  while (std::getline(in, line)) {
    EXPECT_EQ(fields(line), n) << p << " row " << rows + 1 << ": " << line;
    ++rows;
  }
  return rows;
}

// Minimal XML well-formedness check for our KML: balanced, properly nested tags.
bool XmlWellFormed(const std::string& xml) {
  static const std::regex tag(R"(<(/?)([A-Za-z_][\w:.-]*)[^>]*?(/?)>)");
  std::vector<std::string> stack;
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator();
       ++it) {
    const std::smatch& m = *it;
    if (m[3].length() > 0) continue;  // <x/>
    if (m[1].length() == 0) {
      stack.push_back(m[2]);
    } else {
      if (stack.empty() || stack.back() != m[2]) return false;
      stack.pop_back();
    }
  }
  return stack.empty();
}

void CheckOutputs(const fs::path& dir, int expected_rows) {
  EXPECT_EQ(CheckCsvRows(dir / "frames.csv"), expected_rows);
  for (const char* f :
       {"vo.geojson", "gps.geojson", "vo_frames.geojson", "summary.json", "config.json"}) {
    nlohmann::json parsed;
    EXPECT_NO_THROW(parsed = nlohmann::json::parse(ReadText(dir / f))) << f;
  }
  for (const char* f : {"vo.kml", "gps.kml", "vo.gpx", "gps.gpx"}) {
    const std::string text = ReadText(dir / f);
    EXPECT_TRUE(XmlWellFormed(text)) << f;
  }
  std::ifstream tum(dir / "vo.tum");
  std::string line;
  int poses = 0;
  while (std::getline(tum, line)) {
    std::istringstream ls(line);
    double v[8];
    for (double& x : v) ASSERT_TRUE(static_cast<bool>(ls >> x)) << line;
    ++poses;
  }
  EXPECT_EQ(poses, expected_rows);
}

// One figure of a flight in the stored real-flight table (bench/real_flights.tsv, written by
// scripts/bench-flights.sh --write): the default run (RANSAC seed 1) and the mean, min and max
// over the seeds the table was measured with.
struct StoredFigure {
  double seed1 = 0, mean = 0, min = 0, max = 0;
};

fs::path RealFlightsTable() { return fs::path(AEROVO_SOURCE_DIR) / "bench" / "real_flights.tsv"; }

// The figures of `flight` in the stored table, by name (sim2_ate_m, se2_ate_m, ...); empty when
// the table has no row for it.
std::map<std::string, StoredFigure> StoredFigures(const std::string& flight) {
  std::ifstream in(RealFlightsTable());
  EXPECT_TRUE(in.good()) << "cannot read " << RealFlightsTable();
  std::map<std::string, StoredFigure> out;
  std::string line;
  bool header = true;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {  // flight flags figure seed1 mean min max
      header = false;
      continue;
    }
    std::vector<std::string> f;
    std::istringstream ls(line);
    for (std::string cell; std::getline(ls, cell, '\t');) f.push_back(cell);
    EXPECT_EQ(f.size(), 7u) << RealFlightsTable() << ":" << n << ": " << line;
    if (f.size() != 7 || f[0] != flight) continue;
    out[f[2]] = {std::stod(f[3]), std::stod(f[4]), std::stod(f[5]), std::stod(f[6])};
  }
  return out;
}

// A default run (seed 1) of `flight` against the stored table: each accuracy figure within the
// table's seed-to-seed spread (max - min over its seeds) of the stored seed-1 figure, and the
// frame counts as stored within their spread. A build that moves a figure further has changed
// the results: re-run scripts/bench-flights.sh --write and update README.md and BENCHMARKS.md.
// fps and CPU per frame depend on the machine and are not compared. The figures are those of the
// optimised x86-64 build: an instrumented build (-O1, other rounding) only checks the table reads.
void ExpectTheStoredFigures(const std::string& flight, const RunSummary& s) {
  const std::map<std::string, StoredFigure> stored = StoredFigures(flight);
  ASSERT_FALSE(stored.empty()) << RealFlightsTable() << " has no row for " << flight;
  ASSERT_TRUE(s.evaluation.has_value());
  const TrajectoryComparison& e = *s.evaluation;
  const std::vector<std::pair<std::string, double>> measured = {
      {"frames", s.frames_processed},
      {"distance_m", e.se2.distance_flown_m},
      {"sim2_ate_m", e.sim2.ate_m.rmse},
      {"se2_ate_m", e.se2.ate_m.rmse},
      {"se2_end_m", e.se2.end_point_error_m},
      {"end_unaligned_m", e.se2.end_point_error_unaligned_m},
      {"bridged", s.frames_bridged},
      {"reacquired", s.frames_reacquired}};
  for (const auto& [name, value] : measured) {
    ASSERT_TRUE(stored.count(name)) << RealFlightsTable() << ": no " << name << " for " << flight;
#ifndef AEROVO_INSTRUMENTED_BUILD
    const StoredFigure& f = stored.at(name);
    const double spread = f.max - f.min;
    // 1e-3 of slack: the table's figures have 6 significant digits.
    EXPECT_LE(std::abs(value - f.seed1), spread + 1e-3 * std::max(1.0, std::abs(f.seed1)))
        << flight << " " << name << ": this build " << value << ", the stored table "
        << f.seed1 << " (seed 1; spread over its seeds " << f.min << "-" << f.max
        << "): re-run scripts/bench-flights.sh --seeds 10 --write bench/real_flights.tsv and "
           "update README.md and BENCHMARKS.md";
#endif
  }
}

TEST(Runner, TampaPhantom3MeetsTheOnePercentTarget) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/tampa-phantom3/DJI_0054.JPG");
  RunConfig c;
  c.input = flight.parent_path().string();
  c.out = TempDir("tampa").string();
  c.altitude_m = 57.0;  // not in the EXIF; flown at about 55-60 m above the ground
  c.quiet = true;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 172);
  EXPECT_EQ(s.frames_with_gps, 172);
  // The 79 m jump DJI_0134 -> DJI_0135 (frame 81, a 90 deg turn back over the start) is
  // recovered by relocalisation on a keyframe instead of being bridged blindly.
  EXPECT_GE(s.frames_reacquired, 1);
  EXPECT_LE(s.frames_bridged, 1);
  ASSERT_TRUE(s.evaluation.has_value());
  const TrajectoryComparison& e = *s.evaluation;
  EXPECT_NEAR(e.sim2.distance_flown_m, 1558.2, 1.0);
  // Measured (BENCHMARKS.md), RANSAC seeds 1-6: Sim(2) ATE RMSE 8.13-9.13 m (seed 1: 8.70 m,
  // 0.558 %), SE(2) 10.5-11.2 m, end-point Sim(2) 12.2-14.2 m, SE(2) 5.7-7.6 m (0.37-0.49 %);
  // seed 1 after the 2026-11-24 refinement changes: Sim(2) 8.77 m, SE(2) 11.12 m, end-point
  // SE(2) 7.31 m (0.47 %), Sim(2) 13.6 m.
  // Adaptive interest points, the default since 2026-12-02: Sim(2) 10.76 m, SE(2)
  // 12.92 m (0.83 %), end-point SE(2) 7.64 m (0.49 %).
  // The camera's tilt estimated from the flight (its photos carry no attitude; docs/attitude.md
  // "Estimated from the flight"): pitch 15.1 deg; Sim(2) 1.34 m, SE(2) 5.37 m (the 57 m height
  // is a guess: Sim(2) scale 1.105), end-point SE(2) 5.51 m (0.35 %), Sim(2) 3.67 m, unaligned
  // 15.2 m (0.98 %).
  const nlohmann::json attitude =
      nlohmann::json::parse(ReadText(fs::path(c.out) / "summary.json"))["attitude_estimate"];
  EXPECT_EQ(attitude["status"], "applied") << attitude.dump();
  EXPECT_NEAR(attitude["pitch_deg"].get<double>(), 15.1, 1.0) << attitude.dump();
  EXPECT_NEAR(attitude["roll_deg"].get<double>(), 0.0, 1.0) << attitude.dump();
  // Target: Sim(2) ATE RMSE < 0.15 % of the distance flown.
  EXPECT_LT(e.sim2.ate_m.rmse, 2.0);
  EXPECT_LT(e.sim2.ate_m.rmse, 0.0015 * e.sim2.distance_flown_m);
  EXPECT_LT(e.se2.ate_m.rmse, 6.0);
  EXPECT_LT(e.sim2.end_point_error_m, 5.0);
  EXPECT_LT(e.se2.end_point_error_percent, 0.45);
  EXPECT_LT(e.se2.end_point_error_unaligned_percent, 1.2);
  ExpectTheStoredFigures("tampa-phantom3", s);
  CheckOutputs(c.out, 172);
  const nlohmann::json summary = nlohmann::json::parse(ReadText(fs::path(c.out) / "summary.json"));
  EXPECT_EQ(summary["frames_processed"], 172);
  EXPECT_FALSE(summary["interrupted"].get<bool>());
  fs::remove_all(c.out);
}

// The relocalisation over the 79 m jump (DJI_0134 -> DJI_0135) has 13-20 true matches among
// many; with uniform sampling it depended on the RANSAC seed (seed 2 bridged the jump: ATE
// 47 m). With PROSAC on keyframe attempts (OdometryOptions::relocalize_sampler) every seed
// relocalises; seeds 2 and 5 here (1 is the test above).
TEST(Runner, TampaRelocalisationDoesNotDependOnTheSeed) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/tampa-phantom3/DJI_0054.JPG");
  for (std::uint64_t seed : {2u, 5u}) {
    RunConfig c;
    c.input = flight.parent_path().string();
    c.out = TempDir("tampa_seed").string();
    c.altitude_m = 57.0;
    c.odometry.correspondence.ransac.seed = seed;
    c.quiet = true;
    const RunSummary s = RunFlight(c);
    EXPECT_GE(s.frames_reacquired, 1) << "seed " << seed;
    EXPECT_EQ(s.frames_bridged, 0) << "seed " << seed;
    ASSERT_TRUE(s.evaluation.has_value());
    // Seeds 1-10 with the estimated camera tilt: 1.31-1.60 m (bench/real_flights.tsv).
    EXPECT_LT(s.evaluation->sim2.ate_m.rmse, 2.0) << "seed " << seed;
    fs::remove_all(c.out);
  }
}

// The last pose of vo.tum (x, y in metres).
Eigen::Vector2d LastTumPosition(const fs::path& tum) {
  std::ifstream in(tum);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  std::istringstream ls(last);
  double t = 0, x = 0, y = 0;
  ls >> t >> x >> y;
  return {x, y};
}

// ransac.polish_iterations reaches every RANSAC fit of the pipeline: with it the track no longer
// depends on the RANSAC seed (tampa, non-planar scene: without it seeds 1 and 2 end apart).
TEST(Runner, PolishMakesTheTrackIndependentOfTheSeed) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/tampa-phantom3/DJI_0054.JPG");
  const auto end_point = [&](std::uint64_t seed, int polish) {
    RunConfig c;
    c.input = flight.parent_path().string();
    c.out = TempDir("polish").string();
    c.altitude_m = 57.0;
    c.max_frames = 40;
    c.odometry.correspondence.ransac.seed = seed;
    c.odometry.correspondence.ransac.polish_iterations = polish;
    // As a nadir camera (its 15 deg tilt not estimated): the affine model's mismatch with the
    // tilted views is what lets two seeds' fits end apart (with the tilt corrected they end
    // 0.10 m apart without the polish).
    c.attitude_estimation = AttitudeEstimationMode::kOff;
    c.quiet = true;
    c.odometry.surf.num_threads = 1;
    c.odometry.correspondence.match.num_threads = 1;
    RunFlight(c);
    const Eigen::Vector2d p = LastTumPosition(fs::path(c.out) / "vo.tum");
    fs::remove_all(c.out);
    return p;
  };
  const double plain = (end_point(1, 0) - end_point(2, 0)).norm();
  const double polished = (end_point(1, 20) - end_point(2, 20)).norm();
  EXPECT_GT(plain, 0.5) << "the seeds already agree: the test no longer tests the polish";
  // Measured: 3.05 m apart without, 1 mm with (the polish stops at 1e-4 px moves per fit).
  EXPECT_LT(polished, 0.01) << "without polish: " << plain << " m";
}

TEST(Runner, TurinP4mWithXmpAltitudeAndYaw) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/turin-p4m/DJI_0010.JPG");
  RunConfig c;
  c.input = flight.parent_path().string();
  c.out = TempDir("turin").string();
  c.quiet = true;
  std::ostringstream poses;
  RunCallbacks cb;
  cb.poses = &poses;
  const RunSummary s = RunFlight(c, cb);
  EXPECT_EQ(s.frames_processed, 32);
  // Streaming output: one line per frame, geo-referenced at once (heading from yaw).
  std::istringstream pl(poses.str());
  std::string pose_line;
  int n_poses = 0;
  while (std::getline(pl, pose_line)) {
    std::istringstream f(pose_line);
    int frame;
    double t, x, y, lat, lon;
    std::string status;
    ASSERT_TRUE(static_cast<bool>(f >> frame >> t >> x >> y >> lat >> lon >> status)) << pose_line;
    EXPECT_EQ(frame, n_poses);
    EXPECT_NEAR(lat, 45.0, 1.0);
    ++n_poses;
  }
  EXPECT_EQ(n_poses, 32);
  EXPECT_EQ(s.frames_bridged, 0);
  EXPECT_EQ(s.height_source, "telemetry");
  EXPECT_EQ(s.heading_source, "telemetry-yaw");
  ASSERT_TRUE(s.evaluation.has_value());
  // Measured: SE(2) ATE RMSE 0.48 m, Sim(2) 0.48 m over 110 m, end-point 0.72 m (2026-11-24;
  // before the spread refinement kept the cell's matches: 0.750 / 0.733 / 0.42 m).
  EXPECT_LT(s.evaluation->se2.ate_m.rmse, 1.0);
  EXPECT_LT(s.evaluation->sim2.ate_m.rmse, 1.0);
  // Adaptive points (2026-12-02): end-point 0.93 m.
  EXPECT_LT(s.evaluation->se2.end_point_error_m, 1.0);
  // Geo-referenced with the first yaw and fix only (no alignment): within 2 % at the end.
  EXPECT_LT(s.evaluation->se2.end_point_error_unaligned_percent, 2.0);
  ExpectTheStoredFigures("turin-p4m", s);
  CheckOutputs(c.out, 32);
  fs::remove_all(c.out);
}

// turin-p4m as the P4 Multispectral writes it: per capture its RGB JPEG (the photos of
// ../shared) and five 16-bit band TIFFs DJI_xxx1-5.TIF with the JPEG's EXIF and CaptureUUID, and
// Camera:BandName (frames/frame_source_test.cc has the layout). The first 6 captures: the
// run reads the RGB photos and gives the track of the JPEGs alone, byte for byte; `--photo-band
// NIR` reads the NIR TIFFs.
TEST(Runner, TurinAsTheMultispectralCameraWritesItReadsItsRgbPhotos) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/turin-p4m/DJI_0010.JPG");
  const fs::path dir = TempDir("turin_rig");
  const fs::path rgb = dir / "rgb", rig = dir / "rig";
  fs::create_directories(rgb);
  fs::create_directories(rig);
  std::vector<fs::path> all;
  for (const auto& e : fs::directory_iterator(flight.parent_path())) {
    if (e.path().extension() == ".JPG") all.push_back(e.path());
  }
  std::sort(all.begin(), all.end());
  constexpr std::size_t kCaptures = 6;
  ASSERT_GE(all.size(), kCaptures);
  all.resize(kCaptures);
  const char* const bands[] = {"Blue", "Green", "Red", "RedEdge", "NIR"};
  for (const fs::path& p : all) {
    fs::create_symlink(p, rgb / p.filename());
    fs::create_symlink(p, rig / p.filename());
    const ImageMetadata m = ReadImageMetadata(p);
    ASSERT_FALSE(m.capture_id.empty()) << p;
    std::map<std::string, std::string> exif;
    {
      auto image = Exiv2::ImageFactory::open(p.string());
      image->readMetadata();
      for (const auto& d : image->exifData()) {
        const std::string key = d.key();
        if (key.rfind("Exif.GPSInfo.", 0) == 0 || key == "Exif.Image.Make" ||
            key == "Exif.Image.Model" || key == "Exif.Photo.DateTimeOriginal" ||
            key == "Exif.Photo.SubSecTimeOriginal" || key == "Exif.Photo.FocalLength" ||
            key == "Exif.Photo.FocalLengthIn35mmFilm" || key == "Exif.Photo.BodySerialNumber") {
          exif[key] = d.toString();
        }
      }
    }
    cv::Mat bgr = cv::imread(p.string(), cv::IMREAD_COLOR), channels[3];
    cv::split(bgr, channels);
    const std::string stem = p.stem().string();  // DJI_0010
    for (int b = 0; b < 5; ++b) {
      cv::Mat band;
      channels[std::min(b, 2)].convertTo(band, CV_16U, 16.0 + b);
      const std::string packet =
          std::string("<?xpacket begin=\"\xEF\xBB\xBF\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n") +
          "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\">\n"
          " <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n"
          "  <rdf:Description rdf:about=\"DJI Meta Data\"\n"
          "    xmlns:drone-dji=\"http://www.dji.com/drone-dji/1.0/\"\n"
          "    xmlns:Camera=\"http://pix4d.com/camera/1.0\"\n" +
          fmt::format("   drone-dji:RelativeAltitude=\"{:+.2f}\"\n", *m.rel_alt_m) +
          fmt::format("   drone-dji:GimbalYawDegree=\"{:+.2f}\"\n", *m.gimbal_yaw_deg) +
          "   drone-dji:GimbalPitchDegree=\"-90.00\"\n" +
          fmt::format("   drone-dji:CaptureUUID=\"{}\"\n", m.capture_id) +
          fmt::format("   Camera:BandName=\"{}\">\n", bands[b]) +
          "  </rdf:Description>\n </rdf:RDF>\n</x:xmpmeta>\n<?xpacket end=\"w\"?>";
      io_test::WriteTiffWithXmpPacket(
          rig / fmt::format("{}{}.TIF", stem.substr(0, stem.size() - 1), b + 1), band, exif,
          packet);
    }
  }
  RunConfig base;
  base.quiet = true;
  RunConfig a = base;
  a.input = rgb.string();
  a.out = (dir / "out_rgb").string();
  const RunSummary alone = RunFlight(a);
  RunConfig b = base;
  b.input = rig.string();
  b.out = (dir / "out_rig").string();
  const RunSummary from_rig = RunFlight(b);
  EXPECT_EQ(from_rig.frames_processed, static_cast<int>(kCaptures));
  EXPECT_EQ(alone.frames_processed, static_cast<int>(kCaptures));
  EXPECT_EQ(ReadText(dir / "out_rig" / "vo.tum"), ReadText(dir / "out_rgb" / "vo.tum"));
  ASSERT_TRUE(alone.evaluation && from_rig.evaluation);
  EXPECT_EQ(from_rig.evaluation->sim2.ate_m.rmse, alone.evaluation->sim2.ate_m.rmse);
  EXPECT_NE(ReadText(dir / "out_rig" / "summary.json")
                .find("the 6 photos of RGB are read, the 30 of the others skipped"),
            std::string::npos);

  // `aerovo telemetry` on one band photo names its band and capture.
  const fs::path log = dir / "telemetry.txt";
  ASSERT_EQ(e2e::RunCli(fmt::format("telemetry {}", (rig / "DJI_0015.TIF").string()), log), 0);
  EXPECT_NE(ReadText(log).find(fmt::format("payload      band NIR, capture {}",
                                           ReadImageMetadata(all[0]).capture_id)),
            std::string::npos)
      << ReadText(log);

  // Another band through the command line: its TIFFs, the frames' names say so.
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --photo-band NIR --no-report --quiet -o {}",
                                    rig.string(), (dir / "out_nir").string())),
            0);
  const auto rows = e2e::ReadFramesCsv(dir / "out_nir");
  ASSERT_EQ(rows.size(), kCaptures);
  EXPECT_NE(ReadText(dir / "out_nir" / "summary.json").find("photos of NIR are read"),
            std::string::npos);
  fs::remove_all(dir);
}

// A survey camera the autopilot triggers: the photos take the fixes of the ArduPilot log's CAM
// messages, one per photo, not their own EXIF (docs/inputs.md "Photos and the autopilot's camera
// triggers"). The first 6 photos of turin-p4m, and a log (Mission Planner's text form) whose
// CAM messages carry the photos' own EXIF fixes moved 100 m north (and as the aircraft's yaw the
// camera's, the gimbal's in the XMP, as a camera fixed to the airframe has): the same odometry,
// every GPS fix 100 m north, the same errors after alignment.
TEST(Runner, PhotosTakeTheCameraTriggersOfAnArduPilotLog) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/turin-p4m/DJI_0010.JPG");
  const fs::path dir = TempDir("camera_triggers");
  const fs::path photos = dir / "photos";
  fs::create_directories(photos);
  std::vector<fs::path> all;
  for (const auto& e : fs::directory_iterator(flight.parent_path())) {
    if (e.path().extension() == ".JPG") all.push_back(e.path());
  }
  std::sort(all.begin(), all.end());
  constexpr std::size_t kPhotos = 6;
  ASSERT_GE(all.size(), kPhotos);
  all.resize(kPhotos);
  for (const fs::path& p : all) fs::create_symlink(p, photos / p.filename());
  const Telemetry exif = TelemetryFromImages(ImageFolderSource(photos).metadata()).telemetry;
  ASSERT_EQ(exif.size(), kPhotos);
  constexpr double kNorthDeg = 100.0 / 111132.0;  // 100 m of latitude at 45 deg, about
  constexpr double kBootS = 300.0;                // the log's time of the first photo
  std::string log =
      "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n"
      "FMT, 130, 51, GPS, QBBIHBcLLeffffB, "
      "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U\n"
      "FMT, 133, 46, CAM, QBHIHLLeeeccC, "
      "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y\n";
  for (std::size_t k = 0; k < exif.size(); ++k) {
    const TelemetrySample& s = exif[k];
    const auto us = [&](double dt) { return std::llround((kBootS + s.time_s + dt) * 1e6); };
    log += fmt::format("GPS, {}, 0, 3, 0, 0, 14, 0.8, {:.9f}, {:.9f}, {:.2f}, 5, 0, 0, 0, 1\n",
                       us(0.0), s.lat_deg + kNorthDeg, s.lon_deg, *s.abs_alt_m);
    log +=
        fmt::format("CAM, {}, 0, {}, 0, 0, {:.9f}, {:.9f}, {:.2f}, {:.2f}, {:.2f}, 0, 0, {:.2f}\n",
                    us(0.2), k + 1, s.lat_deg + kNorthDeg, s.lon_deg, *s.abs_alt_m, *s.rel_alt_m,
                    *s.abs_alt_m, *s.CameraYawDeg());
  }
  std::ofstream(dir / "flight.log") << log;
  RunConfig base;
  base.input = photos.string();
  base.quiet = true;
  RunConfig a = base;
  a.out = (dir / "exif").string();
  const RunSummary by_exif = RunFlight(a);
  RunConfig b = base;
  b.out = (dir / "cam").string();
  b.telemetry = (dir / "flight.log").string();
  b.telemetry_auto_offset = true;  // keeps the pairing: no offset applies to paired photos
  const RunSummary by_cam = RunFlight(b);
  EXPECT_FALSE(by_exif.telemetry_camera_triggers);
  EXPECT_TRUE(by_cam.telemetry_camera_triggers);
  EXPECT_EQ(by_cam.telemetry_offset_s, 0.0);
  EXPECT_TRUE(e2e::ReadJson(dir / "cam" / "summary.json")["telemetry_camera_triggers"].get<bool>());
  EXPECT_EQ(by_cam.frames_with_gps, static_cast<int>(kPhotos));
  const auto rows_exif = e2e::ReadFramesCsv(dir / "exif");
  const auto rows_cam = e2e::ReadFramesCsv(dir / "cam");
  ASSERT_EQ(rows_exif.size(), kPhotos);
  ASSERT_EQ(rows_cam.size(), kPhotos);
  for (std::size_t k = 0; k < kPhotos; ++k) {
    SCOPED_TRACE(k);
    EXPECT_NEAR(std::stod(rows_cam[k].at("gps_lat_deg")),
                std::stod(rows_exif[k].at("gps_lat_deg")) + kNorthDeg, 2e-9);
    EXPECT_EQ(rows_cam[k].at("gps_lon_deg"), rows_exif[k].at("gps_lon_deg"));
    EXPECT_EQ(rows_cam[k].at("height_m"), rows_exif[k].at("height_m"));
    EXPECT_EQ(rows_cam[k].at("x_m"), rows_exif[k].at("x_m"));
    EXPECT_EQ(rows_cam[k].at("y_m"), rows_exif[k].at("y_m"));
  }
  ASSERT_TRUE(by_exif.evaluation && by_cam.evaluation);
  EXPECT_NEAR(by_cam.evaluation->sim2.ate_m.rmse, by_exif.evaluation->sim2.ate_m.rmse, 1e-3);
  EXPECT_NEAR(by_cam.evaluation->se2.ate_m.rmse, by_exif.evaluation->se2.ate_m.rmse, 1e-3);

  // With the offset given, the photos find their fixes by time on the log's GPS track instead.
  RunConfig c = b;
  c.out = (dir / "offset").string();
  c.telemetry_offset_s = kBootS;
  c.telemetry_auto_offset = false;
  c.altitude_m = 44.5;  // the log's GPS messages give no height above home (no POS)
  const RunSummary by_time = RunFlight(c);
  EXPECT_FALSE(by_time.telemetry_camera_triggers);
  EXPECT_EQ(by_time.frames_with_gps, static_cast<int>(kPhotos));
  fs::remove_all(dir);
}

// 16:9 photos of a 4:3 sensor (the EXIF 35 mm equivalent is the 4:3 frame's), height from XMP
// RelativeAltitude, beach and dunes.
TEST(Runner, BrightonPhantom3SixteenByNineHoldsTheStoredFigures) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/brighton-phantom3-16x9/DJI_0018.JPG");
  RunConfig c;
  c.input = flight.parent_path().string();
  c.out = TempDir("brighton").string();
  c.quiet = true;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 18);
  EXPECT_EQ(s.frames_bridged, 0);
  EXPECT_EQ(s.height_source, "telemetry");
  ASSERT_TRUE(s.evaluation.has_value());
  // Measured (bench/real_flights.tsv): Sim(2) ATE 1.43 m (0.56 %) over 256 m.
  EXPECT_LT(s.evaluation->sim2.ate_m.rmse, 0.01 * s.evaluation->sim2.distance_flown_m);
  ExpectTheStoredFigures("brighton-phantom3-16x9", s);
  fs::remove_all(c.out);
}

// README.md's real-flight rows (Results) quote the stored table: each figure as the table's
// seed-1 run gives it, to the digits README.md prints; the last column is the Sim(2) ATE's range
// over the table's seeds. `scripts/bench-flights.sh --quote bench/real_flights.tsv` prints them.
TEST(RealFlights, ReadmeQuotesTheStoredTable) {
  const std::string readme = ReadText(fs::path(AEROVO_SOURCE_DIR) / "README.md");
  const std::string num = R"(([\d.]+))";
  for (const std::string flight : {"tampa-phantom3", "turin-p4m", "brighton-phantom3-16x9"}) {
    SCOPED_TRACE(flight);
    const std::map<std::string, StoredFigure> f = StoredFigures(flight);
    ASSERT_FALSE(f.empty()) << RealFlightsTable() << " has no row for " << flight;
    const std::regex row("\\| " + flight + R"([^|]*\| (\d+) \| )" + num + " m \\| " + num +
                         " m \\(" + num + " %\\) \\| \\*\\*" + num + " m \\(" + num +
                         " %\\)\\*\\* \\| " + num + " m \\(" + num + " %\\) \\| " + num +
                         " m \\(" + num + " %\\) \\| " + num + "-" + num + " m \\|");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(readme, m, row)) << "README.md has no Results row for " << flight;
    const std::vector<double> stored = {
        f.at("frames").seed1,          f.at("distance_m").seed1,
        f.at("se2_ate_m").seed1,       f.at("se2_ate_percent").seed1,
        f.at("sim2_ate_m").seed1,      f.at("sim2_ate_percent").seed1,
        f.at("se2_end_m").seed1,       f.at("se2_end_percent").seed1,
        f.at("end_unaligned_m").seed1, f.at("end_unaligned_percent").seed1,
        f.at("sim2_ate_m").min,        f.at("sim2_ate_m").max};
    for (std::size_t k = 0; k < stored.size(); ++k) {
      const std::string quoted = m[k + 1].str();
      const std::size_t dot = quoted.find('.');
      const int decimals = dot == std::string::npos ? 0 : static_cast<int>(quoted.size() - dot - 1);
      // Rounded to the printed digits (half a unit of the last one, plus float slack).
      EXPECT_LE(std::abs(std::stod(quoted) - stored[k]), 0.5 * std::pow(10.0, -decimals) + 1e-9)
          << "README.md quotes " << quoted << " (column " << k + 2 << "), the table has "
          << stored[k];
    }
  }
}

TEST(Runner, BlackFrameMidFlightIsFlaggedAndTheRunCompletes) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/tampa-phantom3/DJI_0054.JPG");
  // The first 30 photos (one leg) copied to a temporary folder, the 15th replaced by a black
  // image without EXIF (the folder is then ordered by file name, the flight's order).
  const fs::path dir = TempDir("black_in");
  std::vector<fs::path> photos;
  for (const auto& e : fs::directory_iterator(flight.parent_path())) photos.push_back(e.path());
  std::sort(photos.begin(), photos.end());
  photos.resize(30);
  for (std::size_t i = 0; i < photos.size(); ++i) {
    if (i == 15) {
      cv::imwrite((dir / photos[i].filename()).string(), cv::Mat(600, 800, CV_8UC3, cv::Scalar(0)));
    } else {
      fs::copy_file(photos[i], dir / photos[i].filename());
    }
  }
  RunConfig c;
  c.input = dir.string();
  c.out = TempDir("black_out").string();
  c.altitude_m = 57.0;
  c.quiet = true;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 30);
  EXPECT_EQ(s.frames_bridged, 1);
  EXPECT_GE(s.frames_reacquired, 1);
  std::ifstream csv(fs::path(c.out) / "frames.csv");
  std::string line;
  std::getline(csv, line);
  std::vector<std::string> rows;
  while (std::getline(csv, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 30u);
  EXPECT_NE(rows[15].find("bridged:too-few-features"), std::string::npos) << rows[15];
  EXPECT_NE(rows[16].find(",reacquired,"), std::string::npos) << rows[16];
  ASSERT_TRUE(s.evaluation.has_value());
  // One straight 240 m leg: the black frame costs nothing measurable (full-flight figures
  // above); SE(2) ATE stays within a few metres.
  EXPECT_LT(s.evaluation->sim2.ate_m.rmse, 3.0);
  CheckOutputs(c.out, 30);
  fs::remove_all(dir);
  fs::remove_all(c.out);
}

// Regression (found by fuzzing, fuzz/): numbers that do not fit the field were static_cast by
// nlohmann's get<int>() (1e300 into an int is undefined behaviour; -1 into the uint64 seed and
// 4294967297 into an int wrapped silently). Now they are errors naming the key.
TEST(RunnerConfigRegression, OutOfRangeNumbersAreErrorsNotCasts) {
  const auto expect_invalid = [](std::string_view text, RunConfigFormat format, const char* what) {
    try {
      ParseRunConfig(text, format, RunConfig{}, "c.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("c.json"), std::string::npos) << e.what();
    }
  };
  expect_invalid(R"({"input": "a.mp4", "step": 1e300})", RunConfigFormat::kJson,
                 "'step' must be an integer");
  expect_invalid(R"({"step": 2.5})", RunConfigFormat::kJson, "'step' must be an integer");
  expect_invalid(R"({"seed": -1})", RunConfigFormat::kJson, "'seed' value -1 is out of range");
  expect_invalid(R"({"threads": 4294967297})", RunConfigFormat::kJson,
                 "'threads' value 4294967297 is out of range");
  expect_invalid(R"({"max_frames": -2147483649})", RunConfigFormat::kJson, "out of range");
  expect_invalid("step: 1e300\n", RunConfigFormat::kYaml, "'step' must be an integer");
  expect_invalid("seed: 99999999999999999999\n", RunConfigFormat::kYaml, "'seed'");
  // In-range values still pass, the largest seed included.
  const RunConfig c = ParseRunConfig(R"({"seed": 18446744073709551615, "threads": 2147483647,
                                         "max_frames": -2147483648})",
                                     RunConfigFormat::kJson, RunConfig{});
  EXPECT_EQ(c.odometry.correspondence.ransac.seed, 18446744073709551615ull);
  EXPECT_EQ(c.odometry.surf.num_threads, 2147483647);
  EXPECT_EQ(c.odometry.correspondence.match.num_threads, 2147483647);
  EXPECT_EQ(c.max_frames, -2147483647 - 1);
  EXPECT_THROW(ParseRunConfig("{\"step\": ", RunConfigFormat::kJson, RunConfig{}), InputError);
  // Found by fuzz_config_json: a number beyond double's range made nlohmann throw out_of_range
  // (not parse_error), which escaped as a non-InputError exception.
  try {
    ParseRunConfig("{\"input\": \"a.mp4\", \"step\": 1e340}\n", RunConfigFormat::kJson, RunConfig{},
                   "c.json");
    ADD_FAILURE() << "1e340 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("c.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("number overflow"), std::string::npos) << e.what();
  }
}

TEST(Runner, ConfigJsonRoundTripAndErrors) {
  RunConfig c;
  c.input = "x.mp4";
  c.step = 3;
  c.odometry.correspondence.method = CorrespondenceMethod::kStandard;
  c.odometry.correspondence.ransac.polish_iterations = 20;
  const RunConfig d = RunConfigFromJson(ToJson(c), RunConfig{});
  EXPECT_EQ(ToJson(d), ToJson(c));
  EXPECT_EQ(d.odometry.correspondence.ransac.polish_iterations, 20);
  RunConfig negative = c;
  negative.odometry.correspondence.ransac.polish_iterations = -1;
  EXPECT_THROW(Validate(negative), InvalidArgument);
  EXPECT_THROW(RunConfigFromJson(nlohmann::json{{"stepp", 2}}, c), InvalidArgument);
  EXPECT_THROW(RunConfigFromJson(nlohmann::json{{"step", "two"}}, c), InvalidArgument);
  RunConfig kd = c;
  kd.odometry.correspondence.match.algorithm = MatchAlgorithm::kKdForest;
  EXPECT_EQ(RunConfigFromJson(ToJson(kd), RunConfig{}).odometry.correspondence.match.algorithm,
            MatchAlgorithm::kKdForest);
  EXPECT_EQ(RunConfigFromJson(ToJson(c), RunConfig{}).odometry.correspondence.match.algorithm,
            MatchAlgorithm::kExhaustive);  // the default
  // A name that is no algorithm is refused where it is read, naming the key.
  try {
    RunConfigFromJson(nlohmann::json{{"matcher", "flann"}}, c);
    ADD_FAILURE() << "matcher 'flann' accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("'matcher'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(RunConfigFromJson(nlohmann::json{{"mode", "fast"}}, c), InvalidArgument);
  EXPECT_THROW(RunFlight(RunConfig{}), InvalidArgument);  // no input
  RunConfig missing;
  missing.input = "/nonexistent/flight.mp4";
  missing.out = TempDir("missing").string();
  missing.quiet = true;
  EXPECT_THROW(RunFlight(missing), InputError);
  fs::remove_all(missing.out);
  // YAML config file: flat key: value, same keys; errors name the file and line.
  const fs::path dir = TempDir("yaml");
  std::ofstream(dir / "run.yaml") << "# a run\ninput: flight.mp4\nstep: 4\naltitude_m: 57.5\n"
                                     "guided: false\nmode: \"standard\"\nout: '123'\n";
  const RunConfig y = LoadRunConfig(dir / "run.yaml", RunConfig{});
  EXPECT_EQ(y.input, "flight.mp4");
  EXPECT_EQ(y.step, 4);
  EXPECT_DOUBLE_EQ(y.altitude_m, 57.5);
  EXPECT_FALSE(y.odometry.correspondence.guided_matching);
  EXPECT_EQ(y.odometry.correspondence.method, CorrespondenceMethod::kStandard);
  EXPECT_EQ(y.out, "123");  // quoted: stays a string
  // A list where the option takes one value: a bad value (as `--mode a --mode b`), naming the
  // file and the line.
  std::ofstream(dir / "bad.yaml") << "step: 2\nmode: [a, b]\n";
  try {
    LoadRunConfig(dir / "bad.yaml", RunConfig{});
    ADD_FAILURE() << "a list must be rejected";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "typo.yml") << "stepp: 2\n";
  EXPECT_THROW(LoadRunConfig(dir / "typo.yml", RunConfig{}), InvalidArgument);
  fs::remove_all(dir);
  // 35 mm-equivalent focal: 20 mm on 800x600 -> 20 * 1000 / 43.27 = 462.2 px.
  EXPECT_NEAR(FocalPxFrom35mm(20.0, 800, 600), 462.25, 0.01);
  EXPECT_NEAR(FocalPxFromHorizontalFov(90.0, 800), 400.0, 1e-9);
}

#ifdef AEROVO_CLI_PATH
TEST(Runner, VideoWithDjiSrtFromTheSimulator) {
  // A 150 m straight flight at 100 m over the built-in terrain, rendered by `aerovo simulate`
  // as H.264 video + DJI SRT; every 5th frame processed.
  const fs::path sim = TempDir("sim");
  const std::string cmd = std::string(AEROVO_CLI_PATH) +
                          " simulate --pattern line --length-m 150 --legs 1 --width 640 --height "
                          "480 --fps 10 --hfov-deg 73.7 --out " +
                          sim.string() + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  RunConfig c;
  c.input = (sim / "video.mp4").string();
  c.telemetry = (sim / "telemetry.srt").string();
  c.step = 5;
  c.hfov_deg = 73.7;                              // the simulator's camera
  c.truth = (sim / "ground_truth.tum").string();  // TUM: no frame column, matched by time
  c.out = (sim / "run").string();
  c.quiet = true;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 31);  // frames 0, 5, ..., 150 of 151
  EXPECT_EQ(s.frames_bridged, 0);
  EXPECT_EQ(s.height_source, "telemetry");  // SRT rel_alt
  ASSERT_TRUE(s.evaluation.has_value());
  // Measured 0.02 m over 300 m; the SRT GPS of the simulator is exact (no noise by default).
  EXPECT_LT(s.evaluation->se2.ate_m.rmse, 0.3);
  EXPECT_NEAR(s.evaluation->se2.distance_flown_m, 150.0, 1.0);
  EXPECT_EQ(s.focal_source, "hfov");  // an explicit setting wins over sim.json
  EXPECT_EQ(s.frames_with_truth, 31);
  ASSERT_TRUE(s.truth_evaluation.has_value());
  EXPECT_NEAR(s.truth_evaluation->se2.distance_flown_m, 150.0, 1.0);
  EXPECT_LT(s.truth_evaluation->se2.ate_m.rmse, 0.3);
  EXPECT_LT(s.truth_evaluation->se2.end_point_error_unaligned_m, 0.5);  // same ENU origin
  CheckOutputs(c.out, 31);
  fs::remove_all(sim);
}

TEST(Runner, SimulatedCallasFlightAgainstExactTruth) {
  // A lawnmower flight (2 x 150 m legs, 40 m apart, 362 m) at 100 m over the Callas
  // orthophoto, 960x540 at 5 fps, GPS noise 1.5 m. `run` is given only the video: telemetry
  // (SRT), the exact focal length and the truth (ground_truth.csv) come from sim.json. The
  // full-size flight (1080p, 1040 m) is in BENCHMARKS.md. About 20 s on the loaded 2-core VM.
  AEROVO_REQUIRE_SHARED(ortho, "data/ortho/callas-quarry.jpg");
  const fs::path sim = TempDir("callas");
  const std::string cmd =
      std::string(AEROVO_CLI_PATH) + " simulate --ortho " + ortho.string() +
      " --mpp 0.1082 --nw-lat 43.539340 --nw-lon 6.551628 --ground-alt-m 300 --pattern lawnmower "
      "--length-m 150 --legs 2 --spacing-m 40 --height-m 100 --width 960 --height 540 --fps 5 "
      "--gps-noise-m 1.5 --centre-north-m 80 --quiet --out " +
      sim.string() + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  RunConfig c;
  c.input = (sim / "video.mp4").string();
  c.out = (sim / "run").string();
  c.quiet = true;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.sim_manifest, (sim / "sim.json").string());
  EXPECT_EQ(s.focal_source, "sim.json");
  EXPECT_NEAR(s.focal_px, 640.5, 0.1);  // 73.7 deg hfov at 960 px
  EXPECT_EQ(s.frames_processed, 182);
  EXPECT_EQ(s.frames_bridged, 0);
  EXPECT_EQ(s.frames_with_truth, 182);
  ASSERT_TRUE(s.truth_evaluation.has_value());
  const TrajectoryErrors& se2 = s.truth_evaluation->se2;
  EXPECT_NEAR(se2.distance_flown_m, 362.0, 1.0);
  // Measured: end-point error 0.112 m = 0.031 % (SE(2) aligned), 0.725 m = 0.20 % as
  // geo-referenced (first GPS fix + heading from the noisy GPS); ATE RMSE 0.051 m; Sim(2)
  // scale 0.9997 (a 35 mm-width focal convention would give 0.954).
  EXPECT_LT(se2.end_point_error_percent, 1.0);
  EXPECT_LT(se2.end_point_error_unaligned_percent, 1.0);
  EXPECT_LT(se2.ate_m.rmse, 0.5);
  EXPECT_NEAR(s.truth_evaluation->sim2.alignment.enu_from_vo.scale, 1.0, 0.005);
  const nlohmann::json summary = nlohmann::json::parse(ReadText(sim / "run" / "summary.json"));
  EXPECT_TRUE(summary["truth_evaluation"].is_object());
  EXPECT_EQ(summary["truth"].get<std::string>(), (sim / "ground_truth.csv").string());
  fs::remove_all(sim);
}

TEST(Runner, SigintLeavesValidOutputs) {
  AEROVO_REQUIRE_SHARED(flight, "data/flights/tampa-phantom3/DJI_0054.JPG");
  const fs::path out = TempDir("sigint");
  const std::string input = flight.parent_path().string();
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int devnull = ::open("/dev/null", O_WRONLY);
    ::dup2(devnull, 1);
    ::dup2(devnull, 2);
    ::execl(AEROVO_CLI_PATH, AEROVO_CLI_PATH, "run", input.c_str(), "--altitude", "57", "--threads",
            "1", "--quiet", "-o", out.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Wait until some frames are written (or the run ends first), then interrupt. No fixed
  // guess of the time that takes: on a loaded machine or an instrumented build the first rows
  // come minutes later, and a signal before them would test nothing.
  std::error_code ec;
  int status = 0;
  pid_t ended = 0;
  const auto start = std::chrono::steady_clock::now();
  while ((ended = ::waitpid(pid, &status, WNOHANG)) == 0 &&
         !(fs::file_size(out / "frames.csv", ec) > 2000 && !ec)) {
    if (std::chrono::steady_clock::now() - start > std::chrono::minutes(10)) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      FAIL() << "no frame written to " << (out / "frames.csv") << " in 10 minutes";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (ended == 0) {
    ASSERT_EQ(::kill(pid, SIGINT), 0);
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  }
  ASSERT_TRUE(WIFEXITED(status)) << "the CLI must exit cleanly on SIGINT, not die of it";
  const nlohmann::json summary = nlohmann::json::parse(ReadText(out / "summary.json"));
  const int frames = summary["frames_processed"];
  if (WEXITSTATUS(status) == 130) {
    EXPECT_TRUE(summary["interrupted"].get<bool>());
    EXPECT_LT(frames, 172);
  } else {
    EXPECT_EQ(WEXITSTATUS(status), 0);  // finished before the signal arrived (loaded machine)
    EXPECT_EQ(frames, 172);
  }
  EXPECT_GT(frames, 0);
  CheckOutputs(out, frames);
  fs::remove_all(out);
}
#endif

}  // namespace
}  // namespace aerovo::run_flight_test
