// The steps of a run (run_steps.h) on synthetic inputs: sim.json resolution, telemetry lookup,
// the camera's focal chain, the height provider, the outputs, the totals and summary (the frame
// loop: frame_loop_test.cc). RunFlight end to end: tests/e2e.
#include "aerovo/pipeline/run_steps.h"

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"
#include "aerovo/frames/camera.h"
#include "aerovo/frames/ffmpeg_test_util.h"
#include "aerovo/frames/image_test_util.h"
#include "aerovo/pipeline/autopilot_attitude.h"

namespace aerovo::run_steps::run_steps_test {
namespace {

namespace fs = std::filesystem;

using ::aerovo::testing::Lines;
using ::aerovo::testing::ReadText;

fs::path TempDir(const std::string& name) {
  return ::aerovo::testing::FreshTempDir("aerovo_run_steps", name);
}

void WriteText(const fs::path& p, const std::string& text) {
  std::ofstream out(p);
  out << text;
}

// Rows of a CSV file after its header.
int CsvRows(const fs::path& p) { return static_cast<int>(Lines(ReadText(p)).size()) - 1; }

TelemetrySample Fix(double time_s, std::optional<double> rel_alt_m) {
  TelemetrySample s;
  s.time_s = time_s;
  s.lat_deg = 45.0;
  s.lon_deg = 7.0;
  s.rel_alt_m = rel_alt_m;
  return s;
}

// ---------------------------------------------------------------------------------------------
// 1. Inputs

// A minimal sim.json of `aerovo simulate` (schema: sim/sim_writer.h) for a frames folder.
void WriteSimJson(const fs::path& dir, const std::string& frames_dir, double focal_px) {
  nlohmann::json j = {{"format", "aerovo-simulation"},
                      {"version", 1},
                      {"files",
                       {{"video", nullptr},
                        {"frames_dir", frames_dir},
                        {"frame_pattern", "frame_%06d.jpg"},
                        {"srt", "telemetry.srt"},
                        {"gpx", "track.gpx"},
                        {"ground_truth_tum", "ground_truth.tum"},
                        {"ground_truth_csv", "ground_truth.csv"}}},
                      {"frame_count", 3},
                      {"fps", 10.0},
                      {"camera",
                       {{"width_px", 320},
                        {"height_px", 240},
                        {"focal_px", focal_px},
                        {"cx_px", 159.5},
                        {"cy_px", 119.5},
                        {"hfov_deg", 60.0}}},
                      {"height_above_ground_m", 100.0},
                      {"gsd_m_per_px", 0.25},
                      {"ground_altitude_m", 0.0},
                      {"origin", {{"lat_deg", 45.0}, {"lon_deg", 7.0}, {"alt_m", 0.0}}},
                      {"distance_m", 10.0},
                      {"effects", {{"illumination_k", 1.0}}},
                      {"gps", {{"horizontal_sigma_m", 1.5}}},
                      {"seed", 1}};
  WriteText(dir / "sim.json", j.dump(2));
}

const char* kTruthCsv =
    "frame,time_s,lat_deg,lon_deg\n0,0.0,45.0,7.0\n1,0.1,45.00001,7.0\n2,0.2,45.00002,7.0\n";

TEST(RunSteps, SimJsonFillsInWhatWasNotGiven) {
  const fs::path dir = TempDir("sim");
  fs::create_directories(dir / "frames");
  WriteSimJson(dir, "frames", 277.1);
  WriteText(dir / "ground_truth.csv", kTruthCsv);
  RunConfig given;
  given.input = (dir / "frames").string();
  std::vector<std::string> warnings;
  const RunInputs in = ResolveInputs(given, &warnings);
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(in.sim_manifest, (fs::absolute(dir) / "sim.json").string());
  EXPECT_EQ(fs::path(in.config.telemetry).filename(), "telemetry.srt");
  EXPECT_EQ(fs::path(in.config.truth).filename(), "ground_truth.csv");
  EXPECT_EQ(in.config.focal_px, 277.1);
  EXPECT_TRUE(in.focal_from_sim);
  ASSERT_TRUE(in.truth.has_value());
  EXPECT_EQ(in.truth->points.size(), 3u);
  // "frames/" names the same folder.
  given.input = (dir / "frames").string() + "/";
  EXPECT_EQ(ResolveInputs(given, &warnings).sim_manifest, in.sim_manifest);
  fs::remove_all(dir);
}

TEST(RunSteps, ExplicitSettingsWinOverSimJson) {
  const fs::path dir = TempDir("sim_explicit");
  fs::create_directories(dir / "frames");
  WriteSimJson(dir, "frames", 277.1);
  WriteText(dir / "ground_truth.csv", kTruthCsv);
  WriteText(dir / "mine.csv", kTruthCsv);
  RunConfig given;
  given.input = (dir / "frames").string();
  given.telemetry = (dir / "my.srt").string();
  given.truth = (dir / "mine.csv").string();
  given.hfov_deg = 70.0;
  std::vector<std::string> warnings;
  RunInputs in = ResolveInputs(given, &warnings);
  EXPECT_FALSE(in.sim_manifest.empty());
  EXPECT_EQ(in.config.telemetry, given.telemetry);
  EXPECT_EQ(in.config.truth, given.truth);
  EXPECT_EQ(in.config.focal_px, 0.0);  // the hfov is used, not sim.json's focal
  EXPECT_FALSE(in.focal_from_sim);
  // An explicit focal length too.
  given.hfov_deg = 0.0;
  given.focal_px = 300.0;
  in = ResolveInputs(given, &warnings);
  EXPECT_EQ(in.config.focal_px, 300.0);
  EXPECT_FALSE(in.focal_from_sim);
  EXPECT_TRUE(warnings.empty());
  fs::remove_all(dir);
}

TEST(RunSteps, ForeignOrBrokenSimJsonIsIgnored) {
  const fs::path dir = TempDir("sim_foreign");
  fs::create_directories(dir / "frames");
  fs::create_directories(dir / "other");
  WriteSimJson(dir, "other", 277.1);  // describes another folder
  RunConfig given;
  given.input = (dir / "frames").string();
  std::vector<std::string> warnings;
  RunInputs in = ResolveInputs(given, &warnings);
  EXPECT_TRUE(in.sim_manifest.empty());
  EXPECT_TRUE(in.config.telemetry.empty());
  EXPECT_EQ(in.config.focal_px, 0.0);
  EXPECT_TRUE(warnings.empty());

  WriteText(dir / "sim.json", "{\"format\": \"aerovo-simulation\"");  // truncated
  in = ResolveInputs(given, &warnings);
  EXPECT_TRUE(in.sim_manifest.empty());
  EXPECT_TRUE(in.config.telemetry.empty());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("ignored " + (dir / "sim.json").string() + ": ", 0), 0u)
      << warnings[0];
  fs::remove_all(dir);
}

// A DJI aircraft records DJI_0042.MP4 and DJI_0042.SRT side by side: a video run without
// --telemetry uses the SRT of the same name (any case of its extension), and says so; not when
// telemetry is given or "none", not for a folder, and not when two files could be it.
// ResolveInputs of a run of `input` with RunConfig::telemetry = `telemetry`.
RunInputs ResolveWithTelemetry(const fs::path& input, const std::string& telemetry,
                               std::vector<std::string>* warnings) {
  RunConfig given;
  given.input = input.string();
  given.telemetry = telemetry;
  return ResolveInputs(given, warnings);
}

TEST(RunSteps, TheSrtBesideAVideoIsItsTelemetry) {
  const fs::path dir = TempDir("beside");
  fs::create_directories(dir / "photos");
  WriteText(dir / "DJI_0042.MP4", "video");
  WriteText(dir / "DJI_0042.SRT", "1\n");
  WriteText(dir / "DJI_0043.MP4", "video");
  WriteText(dir / "DJI_0043.srt", "1\n");
  WriteText(dir / "DJI_0044.MP4", "video");
  WriteText(dir / "DJI_0044.SRT", "1\n");
  WriteText(dir / "DJI_0044.srt", "1\n");
  WriteText(dir / "DJI_0045.MP4", "video");
  WriteText(dir / "DJI_0045.gpx", "<gpx/>");
  WriteText(dir / "photos" / "DJI_0046.SRT", "1\n");
  std::vector<std::string> warnings;
  const auto resolved = [&](const fs::path& input, const std::string& telemetry) {
    return ResolveWithTelemetry(input, telemetry, &warnings);
  };
  RunInputs in = resolved(dir / "DJI_0042.MP4", "");
  EXPECT_EQ(in.config.telemetry, (dir / "DJI_0042.SRT").string());
  EXPECT_TRUE(in.telemetry_beside);
  in = resolved(dir / "DJI_0043.MP4", "");
  EXPECT_EQ(in.config.telemetry, (dir / "DJI_0043.srt").string());
  EXPECT_TRUE(in.telemetry_beside);
  for (const auto& [input, telemetry, expected] :
       {std::tuple{dir / "DJI_0044.MP4", std::string(), std::string()},  // two: not a guess
        std::tuple{dir / "DJI_0045.MP4", std::string(), std::string()},  // only a .gpx
        std::tuple{dir / "photos", std::string(), std::string()},        // a folder
        std::tuple{dir / "DJI_0042.MP4", std::string("none"), std::string("none")},
        std::tuple{dir / "DJI_0042.MP4", (dir / "DJI_0045.gpx").string(),
                   (dir / "DJI_0045.gpx").string()}}) {
    in = resolved(input, telemetry);
    EXPECT_EQ(in.config.telemetry, expected) << input;
    EXPECT_FALSE(in.telemetry_beside) << input;
  }
  EXPECT_TRUE(warnings.empty());
  fs::remove_all(dir);
}

// A video with a subtitle track (a DJI video's captions, muxed as MP4 timed text by ffmpeg) and
// no .SRT beside it is its own telemetry; an .SRT beside it wins (the same captions, read
// without demuxing the video); `none` reads neither; a video without a track has none.
TEST(RunSteps, AVideosOwnCaptionsAreItsTelemetryWhenNoSrtIsBeside) {
  if (!io_test::HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  const fs::path dir = TempDir("in_video");
  const fs::path captions = dir / "captions.srt";
  WriteText(captions,
            "1\n00:00:00,000 --> 00:00:01,000\nFrameCnt: 1, DiffTime: 1000ms\n"
            "[latitude: 45.000000] [longitude: 7.000000] [rel_alt: 60.000 abs_alt: 300.000]\n\n"
            "2\n00:00:01,000 --> 00:00:02,000\nFrameCnt: 2, DiffTime: 1000ms\n"
            "[latitude: 45.000100] [longitude: 7.000000] [rel_alt: 60.000 abs_alt: 300.000]\n");
  const std::vector<std::string> clip = {"-f", "lavfi", "-i", "color=c=gray:size=64x64:rate=2:d=2"};
  std::vector<std::string> with_track = clip;
  with_track.insert(with_track.end(), {"-i", captions.string(), "-map", "0:v", "-map", "1", "-c:s",
                                       "mov_text", (dir / "DJI_0050.MP4").string()});
  ASSERT_TRUE(io_test::RunFfmpeg(with_track));
  std::vector<std::string> without = clip;
  without.push_back((dir / "DJI_0051.MP4").string());
  ASSERT_TRUE(io_test::RunFfmpeg(without));
  std::vector<std::string> warnings;
  const auto resolved = [&](const fs::path& input, const std::string& telemetry) {
    return ResolveWithTelemetry(input, telemetry, &warnings);
  };
  RunInputs in = resolved(dir / "DJI_0050.MP4", "");
  EXPECT_EQ(in.config.telemetry, (dir / "DJI_0050.MP4").string());
  EXPECT_TRUE(in.telemetry_in_video);
  EXPECT_FALSE(in.telemetry_beside);
  in = resolved(dir / "DJI_0051.MP4", "");
  EXPECT_EQ(in.config.telemetry, "");
  EXPECT_FALSE(in.telemetry_in_video);
  in = resolved(dir / "DJI_0050.MP4", "none");
  EXPECT_EQ(in.config.telemetry, "none");
  EXPECT_FALSE(in.telemetry_in_video);
  fs::copy_file(captions, dir / "DJI_0050.SRT");
  in = resolved(dir / "DJI_0050.MP4", "");
  EXPECT_EQ(in.config.telemetry, (dir / "DJI_0050.SRT").string());
  EXPECT_TRUE(in.telemetry_beside);
  EXPECT_FALSE(in.telemetry_in_video);
  EXPECT_TRUE(warnings.empty());
  fs::remove_all(dir);
}

TEST(RunSteps, MissingTruthIsAnInputErrorNamingIt) {
  RunConfig given;
  given.input = "0";  // a live camera: no sim.json looked for
  given.truth = "/nonexistent/aerovo_truth.tum";
  std::vector<std::string> warnings;
  try {
    ResolveInputs(given, &warnings);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("aerovo_truth.tum"), std::string::npos) << e.what();
  }
}

TEST(RunSteps, TelemetryByFrameIndexOrByTime) {
  const fs::path dir = TempDir("telemetry");
  WriteText(dir / "indexed.csv",
            "frame,time_s,lat_deg,lon_deg,rel_alt\n0,0,45.0,7.0,50\n1,1,45.001,7.0,51\n"
            "2,2,45.002,7.0,52\n");
  WriteText(dir / "timed.csv",
            "time_s,lat_deg,lon_deg,rel_alt\n0,45.0,7.0,50\n1,45.001,7.0,51\n2,45.002,7.0,52\n");
  std::vector<std::string> warnings;
  const std::string indexed_path = (dir / "indexed.csv").string();
  const RunTelemetry indexed = RunTelemetry::Load(indexed_path, false, nullptr, &warnings);
  EXPECT_TRUE(indexed.by_frame_index());
  EXPECT_EQ(indexed.Describe(), "3 fixes from " + indexed_path);
  Frame f;
  f.index = 1;
  f.time_s = 7.0;  // the index decides, not the time
  ASSERT_TRUE(indexed.SampleOf(f).has_value());
  EXPECT_DOUBLE_EQ(*indexed.SampleOf(f)->rel_alt_m, 51.0);
  f.index = 5;
  EXPECT_FALSE(indexed.SampleOf(f).has_value());

  const RunTelemetry timed =
      RunTelemetry::Load((dir / "timed.csv").string(), false, nullptr, &warnings);
  EXPECT_FALSE(timed.by_frame_index());
  f.index = 0;
  f.time_s = 2.0;
  ASSERT_TRUE(timed.SampleOf(f).has_value());
  EXPECT_DOUBLE_EQ(*timed.SampleOf(f)->rel_alt_m, 52.0);
  f.time_s = 3.0;  // outside the span: no invented fix
  EXPECT_FALSE(timed.SampleOf(f).has_value());
  EXPECT_TRUE(warnings.empty());

  const RunTelemetry none = RunTelemetry::Load("", false, nullptr, &warnings);
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(none.Describe(), "none");
  EXPECT_FALSE(none.SampleOf(f).has_value());
  fs::remove_all(dir);
}

TEST(RunSteps, MalformedTelemetryRecordSaysHowToGoOn) {
  const fs::path dir = TempDir("telemetry_bad");
  const std::string path = (dir / "bad.csv").string();
  WriteText(path, "time_s,lat_deg,lon_deg\n0,45.0,7.0\n1,garbage,7.0\n2,45.002,7.0\n");
  std::vector<std::string> warnings;
  try {
    RunTelemetry::Load(path, false, nullptr, &warnings);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad.csv"), std::string::npos) << what;
    EXPECT_NE(what.find("(--lenient-telemetry skips malformed records instead)"), std::string::npos)
        << what;
  }
  const RunTelemetry lenient = RunTelemetry::Load(path, true, nullptr, &warnings);
  EXPECT_EQ(lenient.Describe(), "2 fixes from " + path);
  ASSERT_FALSE(warnings.empty());
  EXPECT_EQ(warnings[0],
            path +
                ": 1 malformed telemetry record(s) skipped (--lenient-telemetry), the first "
                "ones:");
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// 2. Camera

TEST(RunSteps, FocalChainOrderAndSourceNames) {
  const int w = 640, h = 480;
  RunConfig c;
  ImageMetadata photo;
  photo.width_px = w;
  photo.height_px = h;
  photo.calibrated_focal_px = 700.0;
  photo.focal_length_35mm_mm = 24.0;
  TelemetrySample sample = Fix(0.0, 50.0);
  sample.focal_length_35mm_mm = 28.0;
  auto resolve = [&](bool from_sim, const ImageMetadata* p,
                     const std::optional<TelemetrySample>& s) {
    return ResolveRunCamera(c, from_sim, w, h, p, s, "DJI_0001.JPG");
  };

  c.focal_px = 500.0;
  c.hfov_deg = 90.0;
  RunCamera r = resolve(false, &photo, sample);
  EXPECT_EQ(r.focal_px, 500.0);
  EXPECT_EQ(r.focal_source, "flag");
  EXPECT_EQ(resolve(true, &photo, sample).focal_source, "sim.json");

  c.focal_px = 0.0;
  r = resolve(false, &photo, sample);
  EXPECT_EQ(r.focal_px, FocalPxFromHorizontalFov(90.0, w));
  EXPECT_EQ(r.focal_source, "hfov");

  c.hfov_deg = 0.0;
  r = resolve(false, &photo, sample);
  EXPECT_EQ(r.focal_px, 700.0);
  EXPECT_EQ(r.focal_source, "xmp-calibrated");

  // The calibrated focal length is of photos of another size than the frames: not used.
  photo.height_px = h + 16;
  EXPECT_EQ(resolve(false, &photo, sample).focal_source, "exif-35mm");
  photo.height_px = h;
  photo.width_px = 4000;
  r = resolve(false, &photo, sample);
  EXPECT_EQ(r.focal_px, FocalPxFrom35mm(24.0, w, h));
  EXPECT_EQ(r.focal_source, "exif-35mm");

  photo.focal_length_35mm_mm.reset();
  r = resolve(false, &photo, sample);
  EXPECT_EQ(r.focal_px, FocalPxFrom35mm(28.0, w, h));
  EXPECT_EQ(r.focal_source, "telemetry-35mm");
  EXPECT_EQ(resolve(false, nullptr, sample).focal_source, "telemetry-35mm");

  sample.focal_length_35mm_mm.reset();
  for (const ImageMetadata* p : std::vector<const ImageMetadata*>{nullptr, &photo}) {
    try {
      resolve(false, p, sample);
      FAIL() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()),
                "DJI_0001.JPG: the camera focal length is unknown (no EXIF/telemetry 35 mm focal "
                "length): give --focal-px or --hfov-deg");
    }
  }
  EXPECT_THROW(resolve(false, nullptr, std::nullopt), InputError);
}

TEST(RunSteps, UndistorterOnlyWithDistortion) {
  RunConfig c;
  EXPECT_EQ(MakeUndistorter(c, 320, 240, 300.0), nullptr);
  c.p2 = 1e-4;
  std::unique_ptr<FrameUndistorter> u = MakeUndistorter(c, 320, 240, 300.0);
  ASSERT_NE(u, nullptr);
  GrayImage image(320, 240, 100);
  const GrayImageView out = u->Apply(image.view());
  EXPECT_EQ(out.width, 320);
  EXPECT_EQ(out.height, 240);
}

// The photos' own metadata: telemetry by photo rank, focal length from XMP or EXIF.
TEST(RunSteps, PhotoTelemetryAndFocalFromTheirMetadata) {
  AEROVO_REQUIRE_SHARED(turin, "data/flights/turin-p4m/DJI_0010.JPG");
  AEROVO_REQUIRE_SHARED(tampa, "data/flights/tampa-phantom3/DJI_0054.JPG");
  std::vector<std::string> warnings;
  const ImageFolderSource turin_photos(turin.parent_path());
  const RunTelemetry t = RunTelemetry::Load("", false, &turin_photos, &warnings);
  EXPECT_TRUE(t.by_frame_index());
  EXPECT_EQ(t.Describe(), "32 fixes from photo EXIF/XMP");
  Frame f;
  f.index = 0;
  const std::optional<TelemetrySample> first = t.SampleOf(f);
  ASSERT_TRUE(first.has_value());
  HeightProvider height(0.0);
  EXPECT_NEAR(height.HeightOf("DJI_0010.JPG", first, &warnings), 44.5, 0.5);  // README
  const RunConfig c;
  RunCamera cam = ResolveRunCamera(c, false, 1600, 1300, &turin_photos.metadata().front(), first,
                                   "DJI_0010.JPG");
  EXPECT_EQ(cam.focal_source, "xmp-calibrated");
  EXPECT_NEAR(cam.focal_px, 1913.3, 0.1);

  const ImageFolderSource tampa_photos(tampa.parent_path());
  cam = ResolveRunCamera(c, false, 800, 600, &tampa_photos.metadata().front(), std::nullopt,
                         "DJI_0054.JPG");
  EXPECT_EQ(cam.focal_source, "exif-35mm");
  EXPECT_NEAR(cam.focal_px, 462.2, 0.1);  // 20 mm on 800x600: 20 * 1000 / 43.27
}

// Photos without a position of their own (a camera the autopilot triggers) and the autopilot's
// log of the photos it took: photo k takes the k-th CAM message's fix (its byte or line named).
TEST(RunSteps, PhotosArePairedWithTheCameraTriggersOfTheLog) {
  const fs::path dir = TempDir("camera_triggers");
  const fs::path photos_dir = dir / "photos";
  fs::create_directories(photos_dir);
  for (int i = 0; i < 4; ++i) {
    io_test::WriteJpegWithTags(
        photos_dir / fmt::format("IMG_{:04d}.JPG", i), io_test::TextureImage(64, 48, 3 + i),
        {{"Exif.Photo.DateTimeOriginal", fmt::format("2024:06:01 10:00:{:02d}", 2 * i)}});
  }
  const ImageFolderSource photos(photos_dir);
  // ArduPilot's text log (Mission Planner's .log): GPS at 1 Hz from 100 s since boot, and a CAM
  // message per photo at `cam_s` (s since boot): latitude 45.0 + 1e-4 k, RelAlt 80 + k m.
  const auto write_log = [&](const std::string& name, const std::vector<double>& cam_s) {
    std::string t =
        "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n"
        "FMT, 130, 51, GPS, QBBIHBcLLeffffB, "
        "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U\n"
        "FMT, 133, 46, CAM, QBHIHLLeeeccC, "
        "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y\n";
    for (int k = 0; k <= 20; ++k) {
      t += fmt::format("GPS, {}, 0, 3, 0, 0, 14, 0.8, {:.7f}, 7.0, 400, 5, 0, 0, 0, 1\n",
                       (100 + k) * 1000000LL, 44.9 + 1e-3 * k);
    }
    for (std::size_t k = 0; k < cam_s.size(); ++k) {
      t += fmt::format("CAM, {}, 0, {}, 0, 0, {:.7f}, 7.0, 480, {}, 480, 0.5, -1, 90\n",
                       static_cast<long long>(cam_s[k] * 1e6), k + 1, 45.0 + 1e-4 * k, 80 + k);
    }
    std::ofstream(dir / name) << t;
    return (dir / name).string();
  };
  Frame f;
  f.index = 2;
  f.time_s = 4.0;
  std::vector<std::string> warnings;
  const std::string paired = write_log("paired.log", {105.3, 107.3, 109.4, 111.3});
  RunTelemetry t = RunTelemetry::Load(paired, false, &photos, &warnings);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  EXPECT_TRUE(t.by_frame_index());
  EXPECT_TRUE(t.from_camera_triggers());
  EXPECT_EQ(t.Describe(), "4 fixes from " + paired + " (its camera triggers, one per photo)");
  std::optional<TelemetrySample> s = t.SampleOf(f);
  ASSERT_TRUE(s.has_value());
  EXPECT_NEAR(s->lat_deg, 45.0002, 1e-9);
  EXPECT_NEAR(*s->rel_alt_m, 82.0, 1e-9);
  EXPECT_NEAR(*s->yaw_deg, 90.0, 1e-9);
  EXPECT_NEAR(s->time_s, 4.1, 1e-9);  // since the first trigger
  EXPECT_EQ(s->origin, paired + ":27: CAM 3");

  // An offset given: the frames are matched by time against the GPS fixes, as before.
  t = RunTelemetry::Load(paired, false, &photos, &warnings, true);
  EXPECT_FALSE(t.by_frame_index());
  EXPECT_FALSE(t.from_camera_triggers());
  EXPECT_EQ(t.Describe(), "21 fixes from " + paired);

  // One trigger more than photos: not paired, and the warning says why and what to give.
  const std::string more = write_log("more.log", {105.3, 107.3, 109.4, 111.3, 113.3});
  t = RunTelemetry::Load(more, false, &photos, &warnings);
  EXPECT_FALSE(t.by_frame_index());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], ::testing::HasSubstr(more + ": the log's camera logged 5 photo(s), the "
                                                       "folder holds 4"));
  EXPECT_THAT(warnings[0], ::testing::HasSubstr("--telemetry-offset-s"));
  EXPECT_THAT(warnings[0], ::testing::HasSubstr("105.300 s"));

  // As many, but the third photo missed by the camera and one more at the end: the times part
  // at the third photo (4 s after the first against 6 s).
  warnings.clear();
  const std::string shifted = write_log("shifted.log", {105.3, 107.3, 111.4, 113.3});
  t = RunTelemetry::Load(shifted, false, &photos, &warnings);
  EXPECT_FALSE(t.by_frame_index());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0],
              ::testing::HasSubstr("photo '" + (photos_dir / "IMG_0002.JPG").string() +
                                   "' was taken 4.000 s after the first photo, its camera "
                                   "trigger (" +
                                   shifted + ":27: CAM 3) 6.100 s after the first trigger"));
  // Within the capture times' resolution (whole seconds) plus 0.5 s: paired.
  warnings.clear();
  t = RunTelemetry::Load(write_log("late.log", {105.3, 107.3, 110.7, 111.3}), false, &photos,
                         &warnings);
  EXPECT_TRUE(t.by_frame_index());
  EXPECT_TRUE(warnings.empty());
}

// ---------------------------------------------------------------------------------------------
// 3. Height

TEST(RunSteps, HeightFlagWinsOverTelemetry) {
  HeightProvider height(57.0);
  EXPECT_EQ(height.source(), HeightSource::kFlag);
  std::vector<std::string> warnings;
  EXPECT_EQ(height.HeightOf("f0", Fix(0, 100.0), &warnings), 57.0);
  EXPECT_EQ(height.HeightOf("f1", std::nullopt, &warnings), 57.0);
  EXPECT_TRUE(warnings.empty());
}

TEST(RunSteps, HeightFallsBackOnTheLastKnownWithOneWarning) {
  HeightProvider height(0.0);
  EXPECT_EQ(height.source(), HeightSource::kTelemetry);
  std::vector<std::string> warnings;
  EXPECT_EQ(height.HeightOf("f0", Fix(0, 80.0), &warnings), 80.0);
  EXPECT_EQ(height.HeightOf("f1", Fix(1, std::nullopt), &warnings), 80.0);
  EXPECT_EQ(height.HeightOf("f2", Fix(2, 0.0), &warnings), 80.0);  // not a height above ground
  EXPECT_EQ(height.HeightOf("f3", std::nullopt, &warnings), 80.0);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "f1: no relative altitude, using the last known (80.0 m)");
  EXPECT_EQ(height.HeightOf("f4", Fix(4, 81.5), &warnings), 81.5);
  EXPECT_EQ(height.HeightOf("f5", std::nullopt, &warnings), 81.5);
  EXPECT_EQ(warnings.size(), 1u);
}

// A frame shortly before the telemetry's first record (a first caption skipped as damaged, a
// log started after the camera) takes the height of the first record ahead that has one; a frame
// far before it (the telemetry of another clip) or after the start has none.
TEST(RunSteps, FirstRecordAheadOnlyShortlyBeforeTheTelemetry) {
  const auto record = [](int frame_index, double time_s, std::optional<double> rel_alt_m) {
    TelemetrySample s = Fix(time_s, rel_alt_m);
    s.frame_index = frame_index;
    s.origin = "x.srt:" + std::to_string(5 * frame_index + 1);
    return s;
  };
  Frame f;
  f.index = 0;
  f.time_s = 0.0;
  // By frame index: records from frame 2, the first without a relative altitude.
  const RunTelemetry indexed(
      Telemetry({record(2, 0.07, std::nullopt), record(3, 0.10, 61.0), record(4, 0.13, 62.0)}),
      true, "x.srt");
  ASSERT_FALSE(indexed.SampleOf(f).has_value());
  std::optional<TelemetrySample> ahead = indexed.FirstRecordAhead(f);
  ASSERT_TRUE(ahead.has_value());
  EXPECT_EQ(ahead->frame_index, 3);
  EXPECT_DOUBLE_EQ(*ahead->rel_alt_m, 61.0);
  f.index = 3;  // has its own record
  EXPECT_FALSE(indexed.FirstRecordAhead(f).has_value());
  f.index = 9;  // after the last record
  EXPECT_FALSE(indexed.FirstRecordAhead(f).has_value());
  // The second clip of a split recording: its records start at frame 1000.
  const RunTelemetry second_clip(Telemetry({record(1000, 0.0, 60.0), record(1001, 0.03, 60.0)}),
                                 true, "y.srt");
  f.index = 0;
  EXPECT_FALSE(second_clip.FirstRecordAhead(f).has_value());
  const int lead = RunTelemetry::kMaxLeadFrames;
  const RunTelemetry at_limit(Telemetry({record(lead, 1.0, 60.0)}), true, "z.srt");
  EXPECT_TRUE(at_limit.FirstRecordAhead(f).has_value());
  const RunTelemetry beyond(Telemetry({record(lead + 1, 1.0, 60.0)}), true, "z.srt");
  EXPECT_FALSE(beyond.FirstRecordAhead(f).has_value());

  // By time: a log that starts 1.5 s after the video (SampleOf's 0.5 s do not reach it).
  const RunTelemetry timed(Telemetry({Fix(1.5, 70.0), Fix(2.5, 71.0)}), false, "log.gpx");
  f.time_s = 0.0;
  ASSERT_FALSE(timed.SampleOf(f).has_value());
  ahead = timed.FirstRecordAhead(f);
  ASSERT_TRUE(ahead.has_value());
  EXPECT_DOUBLE_EQ(*ahead->rel_alt_m, 70.0);
  f.time_s = 3.5;  // after the span
  EXPECT_FALSE(timed.FirstRecordAhead(f).has_value());
  const RunTelemetry late(Telemetry({Fix(2.1, 70.0)}), false, "log.gpx");
  f.time_s = 0.0;
  EXPECT_FALSE(late.FirstRecordAhead(f).has_value());
  RunTelemetry offset(Telemetry({Fix(2.1, 70.0)}), false, "log.gpx");
  offset.set_offset_s(0.5);  // telemetry time 0.5 s at video time 0
  EXPECT_TRUE(offset.FirstRecordAhead(f).has_value());
}

TEST(RunSteps, FramesBeforeTheFirstRecordTakeItsHeightWithOneWarning) {
  HeightProvider height(0.0);
  std::vector<std::string> warnings;
  TelemetrySample ahead = Fix(0.1, 61.0);
  ahead.origin = "x.srt:11";
  height.set_no_fix_reason("frame 0 is before the first record of x.srt (frame counter 3)");
  height.set_first_record_ahead(ahead);
  EXPECT_EQ(height.HeightOf("f0", std::nullopt, &warnings), 61.0);
  EXPECT_EQ(height.last_source(), "first_record");
  EXPECT_EQ(height.HeightOf("f1", std::nullopt, &warnings), 61.0);
  EXPECT_EQ(height.last_source(), "first_record");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "f0: no telemetry record (frame 0 is before the first record of x.srt (frame counter "
            "3)); its height is that of the first record ahead, 61.0 m (x.srt:11), until a frame "
            "has its own (give --altitude to set it)");
  EXPECT_EQ(height.HeightOf("f2", Fix(0.1, 61.5), &warnings), 61.5);
  EXPECT_EQ(height.last_source(), "telemetry");
  // A later frame without a record: the last known, as before.
  EXPECT_EQ(height.HeightOf("f3", std::nullopt, &warnings), 61.5);
  EXPECT_EQ(height.last_source(), "last_known");
  EXPECT_EQ(warnings.size(), 2u);
  // A record ahead at or below the take-off point says nothing: the error stays.
  HeightProvider grounded(0.0);
  grounded.set_first_record_ahead(Fix(0.1, 0.0));
  EXPECT_THROW(grounded.HeightOf("g0", std::nullopt, &warnings), InputError);
  // Nor does it replace a frame's own sample that lacks a height.
  HeightProvider own(0.0);
  own.set_first_record_ahead(ahead);
  EXPECT_THROW(own.HeightOf("h0", Fix(0.0, std::nullopt), &warnings), InputError);
}

TEST(RunSteps, NoHeightIsAnErrorNamingTheFrameAndTheCause) {
  HeightProvider height(0.0);
  std::vector<std::string> warnings;
  TelemetrySample no_rel_alt = Fix(0, 1.0);
  no_rel_alt.rel_alt_m.reset();
  const std::vector<std::pair<std::optional<TelemetrySample>, std::string>> cases = {
      {std::nullopt, "(the frame has no telemetry fix)"},
      {no_rel_alt, "(the telemetry has no relative altitude)"},
      {Fix(0, -3.0), "(the telemetry's relative altitude is -3.0 m, not above the take-off point"},
  };
  for (const auto& [sample, cause] : cases) {
    try {
      height.HeightOf("DJI_0054.JPG", sample, &warnings);
      FAIL() << "no error";
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind("DJI_0054.JPG: no height above ground ", 0), 0u) << m;
      EXPECT_NE(m.find(cause), std::string::npos) << m;
      EXPECT_NE(m.find("give --altitude"), std::string::npos) << m;
    }
  }
  // The frame loop's reason when there is no fix.
  height.set_no_fix_reason("frame 0 is before the first record of x.srt (frame counter 1001)");
  try {
    height.HeightOf("f0", std::nullopt, &warnings);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frame counter 1001"), std::string::npos) << e.what();
  }
}

// A flight controller on a loopback UDP socket and an AutopilotLink listening for it (udpin on
// a free port).
struct FakeFlightController {
  FakeFlightController() {
    fc = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(bind(fc, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    // A free port for the link: bind one, read it, close it.
    const int probe = socket(AF_INET, SOCK_DGRAM, 0);
    to = a;
    EXPECT_EQ(bind(probe, reinterpret_cast<sockaddr*>(&to), sizeof(to)), 0);
    socklen_t len = sizeof(to);
    getsockname(probe, reinterpret_cast<sockaddr*>(&to), &len);
    close(probe);
    link = std::make_unique<mavlink::AutopilotLink>(
        mavlink::OpenTransport(
            mavlink::ParseLinkUrl("udpin:127.0.0.1:" + std::to_string(ntohs(to.sin_port)))),
        mavlink::AutopilotLink::Options{});
  }
  ~FakeFlightController() {
    link.reset();
    close(fc);
  }
  template <class M>
  void Send(const M& m) {
    const std::vector<uint8_t> bytes = mavlink::Encode(m, seq++, 1, 1);
    sendto(fc, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to));
  }
  int fc = -1;
  sockaddr_in to{};
  uint8_t seq = 0;
  std::unique_ptr<mavlink::AutopilotLink> link;
};

// The autopilot's height over a udpin link (a loopback socket plays the flight controller):
// the rangefinder first, the relative altitude when no rangefinder reading is near, the flag
// above all; each frame's source recorded.
TEST(RunSteps, HeightFromTheAutopilotLink) {
  FakeFlightController fc;
  mavlink::AutopilotLink& link = *fc.link;
  mavlink::GlobalPositionInt g;
  g.relative_alt = 61500;  // 61.5 m above home
  fc.Send(g);
  mavlink::DistanceSensor d;
  d.orientation = mavlink::kMavSensorRotationPitch270;
  d.min_distance = 20;
  d.max_distance = 10000;
  d.current_distance = 5875;  // 58.75 m
  fc.Send(d);
  ASSERT_TRUE(link.WaitForHeight(2.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // both in
  std::vector<std::string> warnings;
  HeightProvider height(0.0, &link, 0.25);
  EXPECT_EQ(height.source(), HeightSource::kMavlink);
  const double now = mavlink::MonotonicNowS();
  EXPECT_DOUBLE_EQ(height.HeightOf("live#0", Fix(0, 80.0), &warnings, now), 58.75);
  EXPECT_EQ(height.last_source(), "mavlink_distance_sensor");
  // Long after every sample: the telemetry's, then the last known.
  EXPECT_DOUBLE_EQ(height.HeightOf("live#1", Fix(1, 80.0), &warnings, now + 60.0), 80.0);
  EXPECT_EQ(height.last_source(), "telemetry");
  EXPECT_DOUBLE_EQ(height.HeightOf("live#2", std::nullopt, &warnings, now + 60.0), 80.0);
  EXPECT_EQ(height.last_source(), "last_known");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0],
            "live#2: no height from the autopilot or relative altitude, using the last known "
            "(80.0 m)");
  HeightProvider flag(40.0, &link, 0.25);
  EXPECT_EQ(flag.HeightOf("live#0", std::nullopt, &warnings, now), 40.0);
  EXPECT_EQ(flag.last_source(), "altitude_flag");
}

// The autopilot's attitude of a frame: the sample nearest its capture time; the first frame,
// read before the run waited for the link, gets the sample received since, later frames only a
// sample near their own capture time.
TEST(RunSteps, AttitudeFromTheAutopilotLinkAlsoForAFirstFrameReadBeforeTheLinksFirstSample) {
  FakeFlightController fc;
  mavlink::Attitude at;
  at.roll = 0.05f;
  at.pitch = -0.025f;
  at.yaw = 0.5f;
  const double before_s = mavlink::MonotonicNowS() - 10.0;  // a frame read 10 s before
  fc.Send(at);
  for (int i = 0; i < 200 && !fc.link->AttitudeNear(mavlink::MonotonicNowS(), 1.0); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(fc.link->AttitudeNear(mavlink::MonotonicNowS(), 1.0)) << "no ATTITUDE received";
  AutopilotAttitudeMatcher first(fc.link.get(), 0.25);
  const std::optional<mavlink::AutopilotAttitude> a0 = first.AttitudeOf(before_s);
  ASSERT_TRUE(a0.has_value()) << "the first frame got no attitude";
  EXPECT_NEAR(a0->roll_rad, 0.05, 1e-6);
  EXPECT_NEAR(a0->pitch_rad, -0.025, 1e-6);
  EXPECT_NEAR(a0->yaw_rad, 0.5, 1e-6);
  // Once a sample has matched, a frame far from every sample has none.
  EXPECT_FALSE(first.AttitudeOf(before_s).has_value());
  AutopilotAttitudeMatcher later(fc.link.get(), 0.25);
  ASSERT_TRUE(later.AttitudeOf(mavlink::MonotonicNowS()).has_value());
  EXPECT_FALSE(later.AttitudeOf(before_s).has_value());
}

// ---------------------------------------------------------------------------------------------
// 4. Outputs

FrameResult FakeResult(int i) {
  FrameResult r;
  r.index = i;
  r.status = i == 0 ? FrameStatus::kFirst : FrameStatus::kOk;
  r.n_surf = 100 + i;
  r.n_matched = 50 + i;
  r.n_inliers = 40 + i;
  r.position_m = {2.0 * i, 0.5 * i};
  r.world_from_frame = Eigen::Matrix3d::Identity();
  r.world_from_frame(0, 2) = 2.0 * i;
  r.world_from_frame(1, 2) = 0.5 * i;
  return r;
}

Frame FakeFrame(int i) {
  Frame f;
  f.index = i;
  f.time_s = 0.5 * i;
  f.name = "f" + std::to_string(i);
  return f;
}

TEST(RunSteps, PendingFrameCarriesTheResult) {
  FrameResult r = FakeResult(3);
  r.status = FrameStatus::kBridged;
  r.failure = StepFailure::kTooFewFeatures;
  const PendingFrame p = PendingFrameOf(FakeFrame(3), r, GeoPoint{45.0, 7.0, 10.0});
  EXPECT_EQ(p.record.frame, 3);
  EXPECT_EQ(p.record.time_s, 1.5);
  EXPECT_EQ(p.record.n_surf, 103);
  EXPECT_EQ(p.record.n_inliers, 43);
  EXPECT_EQ(p.record.status, std::string(ToString(FrameStatus::kBridged)) + ":" +
                                 ToString(StepFailure::kTooFewFeatures));
  EXPECT_EQ(p.local_m, Eigen::Vector2d(6.0, 1.5));
  ASSERT_TRUE(p.gps.has_value());
  EXPECT_EQ(p.gps->lat_deg, 45.0);
}

TEST(RunSteps, OutputsWaitForTheHeadingThenWriteEveryFrame) {
  const fs::path dir = TempDir("outputs");
  RunConfig config;
  config.altitude_m = 50.0;
  std::ostringstream poses;
  std::vector<int> called;
  RunCallbacks cb;
  cb.poses = &poses;
  cb.frame = [&](const FrameRecord& r) { called.push_back(r.frame); };
  const RunCamera camera{400.0, "flag", {}, std::nullopt};
  std::optional<RunOutputs> out;
  out.emplace(dir, config, camera, "flag", 320, 240, 0.0, std::nullopt, cb, true);

  const nlohmann::json cfg = nlohmann::json::parse(ReadText(dir / "config.json"));
  EXPECT_EQ(cfg.at("altitude_m"), 50.0);
  const nlohmann::json& resolved = cfg.at("resolved");
  EXPECT_EQ(resolved.at("focal_px"), 400.0);
  EXPECT_EQ(resolved.at("focal_source"), "flag");
  EXPECT_EQ(resolved.at("height_source"), "flag");
  EXPECT_EQ(resolved.at("frame_width_px"), 320);
  EXPECT_EQ(resolved.at("frame_height_px"), 240);

  GeoReferencer georef;  // no GPS: never ready
  for (int i = 0; i < 3; ++i) {
    const FrameResult r = FakeResult(i);
    out->AppendTransform(i, r.world_from_frame);
    out->Add(PendingFrameOf(FakeFrame(i), r, std::nullopt), georef);
  }
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 0);  // waiting for the heading
  EXPECT_TRUE(poses.str().empty());
  EXPECT_EQ(CsvRows(dir / "transforms.csv"), 3);
  out->Finish(georef);
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 3);
  EXPECT_EQ(called, (std::vector<int>{0, 1, 2}));
  const std::vector<std::string> lines = Lines(poses.str());
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], "0 0.000000 0.0000 0.0000 - - first");
  EXPECT_EQ(lines[2], "2 1.000000 4.0000 1.0000 - - ok");
  // transforms.csv: first_px_from_frame, the first frame's world_from_frame inverted.
  const std::vector<std::string> rows = Lines(ReadText(dir / "transforms.csv"));
  EXPECT_EQ(rows[0], "frame,a11,a12,tx,a21,a22,ty");
  EXPECT_EQ(rows[1], "0,1,0,0.000000,0,1,0.000000");
  EXPECT_EQ(rows[3], "2,1,0,4.000000,0,1,1.000000");
  out.reset();
  for (const char* f : {"vo.geojson", "gps.geojson", "config.json"}) {
    EXPECT_TRUE(nlohmann::json::accept(ReadText(dir / f))) << f;
  }
  fs::remove_all(dir);
}

TEST(RunSteps, OutputsWithoutGpsTelemetryWriteAtOnceAndGeoReferenceWhenReady) {
  const fs::path dir = TempDir("outputs_now");
  RunConfig config;
  std::ostringstream poses;
  RunCallbacks cb;
  cb.poses = &poses;
  const TelemetrySample first = Fix(0.0, 50.0);
  RunOutputs out(dir, config, RunCamera{400.0, "hfov", {}, std::nullopt}, "telemetry", 320, 240,
                 0.0, first, cb, false);
  GeoReferencer georef;
  out.Add(PendingFrameOf(FakeFrame(0), FakeResult(0), std::nullopt), georef);
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 1);
  // Geo-referenced from the camera yaw of the first frame: positions in ENU and WGS84.
  GeoReferencer ready;
  ASSERT_TRUE(ready.Observe({0.0, 0.0}, GpsOf(first), 0.0));
  out.Add(PendingFrameOf(FakeFrame(1), FakeResult(1), GpsOf(first)), ready);
  out.Finish(ready);
  const std::vector<std::string> lines = Lines(poses.str());
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "0 0.000000 0.0000 0.0000 - - first");
  EXPECT_EQ(lines[1].rfind("1 0.500000 2.0000 0.5000 45.0000", 0), 0u) << lines[1];
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 2);
  fs::remove_all(dir);
}

// The lens switch's replay (pipeline/lens_switch.h): the files hold their frames, the pose
// stream does not; released, the replayed frames carry the replay's poses (a frame not replayed
// keeps its own, a flag suffix of the status stays) and the summary's track takes them too.
TEST(RunSteps, OutputsHeldForTheLensReplayTakeTheReplayedPoses) {
  const fs::path dir = TempDir("outputs_replay");
  RunConfig config;
  config.poses_jsonl = (dir / "poses.jsonl").string();
  fs::create_directories(dir);
  RunCallbacks cb;
  std::ostringstream printed;
  cb.poses = &printed;
  RunOutputs out(dir, config, RunCamera{400.0, "hfov", {}, std::nullopt}, "flag", 320, 240, 0.0,
                 std::nullopt, cb, false);
  out.HoldForReplay();
  GeoReferencer georef;  // no GPS: the frames do not wait for a heading
  RunTotals totals(true);
  Frame flagged = FakeFrame(2);
  flagged.flags = "repeated";
  for (int i = 0; i < 3; ++i) {
    const FrameResult r = FakeResult(i);
    out.AppendTransform(i, r.world_from_frame);
    out.Add(PendingFrameOf(i == 2 ? flagged : FakeFrame(i), r, std::nullopt), georef);
    totals.Add(i, 0.5 * i, r, std::nullopt);
  }
  EXPECT_EQ(Lines(ReadText(dir / "poses.jsonl")).size(), 3u);  // the pose lines at once
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 0);
  EXPECT_EQ(CsvRows(dir / "transforms.csv"), 0);
  EXPECT_TRUE(printed.str().empty());
  // Frames 1 and 2 replayed (3 m and 6 m east, 1 bridged), frame 0 not.
  std::vector<ReplayedPose> replayed(2);
  for (int k = 0; k < 2; ++k) {
    replayed[k].frame = k + 1;
    replayed[k].result = FakeResult(k + 1);
    replayed[k].result.position_m = {3.0 * (k + 1), 0.0};
    replayed[k].world_from_full(0, 2) = 3.0 * (k + 1);
  }
  replayed[0].result.status = FrameStatus::kBridged;
  replayed[0].result.failure = StepFailure::kTooFewFeatures;
  replayed[1].result.n_inliers = 7;
  out.ReleaseHeld(replayed);
  totals.ReplacePoses(replayed);
  const std::vector<std::string> rows = Lines(ReadText(dir / "transforms.csv"));
  ASSERT_EQ(rows.size(), 4u);  // written at the release
  EXPECT_EQ(rows[1], "0,1,0,0.000000,0,1,0.000000");
  EXPECT_EQ(rows[3], "2,1,0,6.000000,0,1,0.000000");
  out.Add(PendingFrameOf(FakeFrame(3), FakeResult(3), std::nullopt), georef);
  EXPECT_EQ(CsvRows(dir / "frames.csv"), 4);  // written with the next frame
  out.Finish(georef);
  const std::vector<std::string> lines = Lines(printed.str());
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "0 0.000000 0.0000 0.0000 - - first");
  EXPECT_EQ(lines[1], std::string("1 0.500000 3.0000 0.0000 - - ") +
                          ToString(FrameStatus::kBridged) + ":" +
                          ToString(StepFailure::kTooFewFeatures));
  EXPECT_EQ(lines[2], "2 1.000000 6.0000 0.0000 - - ok+repeated");
  EXPECT_EQ(lines[3], "3 1.500000 6.0000 1.5000 - - ok");
  // The summary's track: the replayed positions, the path length from them (0 -> 3 -> 6 m).
  ASSERT_EQ(totals.local_track.size(), 3u);
  EXPECT_EQ(totals.local_track[1].x, 3.0);
  EXPECT_EQ(totals.local_track[2].y, 0.0);
  EXPECT_DOUBLE_EQ(totals.path_length_m, 6.0);
  EXPECT_EQ(totals.last_local_m, Eigen::Vector2d(6.0, 0.0));
  fs::remove_all(dir);
}

// The pose stream given as one of the run's inputs (the telemetry, a map) is refused before the
// file is opened: the input is left as it was.
TEST(RunSteps, ThePoseStreamNeverOverwritesAnInput) {
  const fs::path dir = TempDir("outputs_inputs");
  const fs::path srt = dir / "flight.SRT";
  WriteText(srt, "1\n00:00:00,000 --> 00:00:00,033\nGPS(7.0,45.0,12)\n");
  RunConfig config;
  config.telemetry = srt.string();
  config.map = {(dir / "missing.tif").string()};
  config.poses_jsonl = (dir / "." / "flight.SRT").string();
  const RunCamera camera{400.0, "flag", {}, std::nullopt};
  const RunCallbacks cb;  // outlives the outputs
  try {
    RunOutputs out(dir / "run", config, camera, "flag", 320, 240, 0.0, std::nullopt, cb, true);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is the run's telemetry"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadText(srt), "1\n00:00:00,000 --> 00:00:00,033\nGPS(7.0,45.0,12)\n");
  config.poses_jsonl = (dir / "poses.jsonl").string();  // any other file is written
  { RunOutputs out(dir / "run2", config, camera, "flag", 320, 240, 0.0, std::nullopt, cb, true); }
  EXPECT_TRUE(fs::exists(dir / "poses.jsonl"));
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// 6. Totals and summary

TEST(RunSteps, SummaryComparesWithGpsAndSaysWhatIsMissing) {
  GeoReferencer georef;
  RunTotals totals(false);
  std::vector<TelemetrySample> fixes;
  for (int i = 0; i < 5; ++i) {
    FrameResult r = FakeResult(i);
    r.position_m = {0.0, 10.0 * i};  // north, as the yaw 0 says
    r.detect_ms = 2.0 * i;
    GeoPoint gps{45.0 + 10.0 * i / 111132.0, 7.0, 0.0};
    georef.Observe(r.position_m, gps, 0.0);
    totals.Add(i, 0.5 * i, r, gps);
  }
  FrameResult last = FakeResult(5);
  last.position_m = {0.0, 50.0};
  georef.Observe(last.position_m, std::nullopt, std::nullopt);
  totals.Add(5, 2.5, last, std::nullopt);
  EXPECT_EQ(totals.frames, 6);
  EXPECT_EQ(totals.frames_with_gps, 5);
  EXPECT_EQ(totals.measured_steps, 5);
  EXPECT_DOUBLE_EQ(totals.path_length_m, 50.0);

  RunSummary s;
  s.frames_processed = 6;
  LoopEnd end;
  end.frames_without_fix = 1;
  OdometryStats stats;
  stats.frames = 6;
  stats.ok = 6;
  Summarize({"source warning"}, true, end, &stats, georef, totals, nullptr, 2.0, &s);
  ASSERT_EQ(s.warnings.size(), 2u);
  EXPECT_EQ(s.warnings[0], "source warning");
  EXPECT_EQ(s.warnings[1].rfind("1 of 6 frames have no telemetry fix", 0), 0u) << s.warnings[1];
  EXPECT_EQ(s.frames_with_gps, 5);
  EXPECT_DOUBLE_EQ(s.vo_path_length_m, 50.0);
  EXPECT_EQ(s.frames_ok, 6);
  EXPECT_DOUBLE_EQ(s.mean.detect_ms, 20.0 / 6);
  EXPECT_DOUBLE_EQ(s.fps, 3.0);
  EXPECT_FALSE(s.interrupted);
  ASSERT_TRUE(s.evaluation.has_value());
  EXPECT_LT(s.evaluation->se2.ate_m.rmse, 0.05);
  EXPECT_FALSE(s.truth_evaluation.has_value());
  EXPECT_TRUE(s.error.empty());

  // Nothing measured after the first frame, fewer than 3 fixes, interrupted.
  RunTotals unmeasured(false);
  GeoReferencer none;
  FrameResult first = FakeResult(0);
  unmeasured.Add(0, 0.0, first, std::nullopt);
  FrameResult bridged = FakeResult(1);
  bridged.status = FrameStatus::kBridged;
  unmeasured.Add(1, 0.5, bridged, std::nullopt);
  RunSummary u;
  u.frames_processed = 2;
  end = LoopEnd();
  end.stopped = true;
  stats = OdometryStats();
  stats.frames = 2;
  stats.ok = 1;
  stats.bridged = 1;
  Summarize({}, false, end, &stats, none, unmeasured, nullptr, 1.0, &u);
  ASSERT_EQ(u.warnings.size(), 1u);
  EXPECT_EQ(u.warnings[0].rfind("no frame could be matched to another", 0), 0u);
  EXPECT_TRUE(u.interrupted);
  EXPECT_FALSE(u.evaluation.has_value());
  EXPECT_EQ(u.frames_bridged, 1);
}

TEST(RunSteps, SummaryComparesWithTheTruth) {
  GeoReferencer georef;
  RunTotals totals(true);
  ReferenceTrack truth;
  truth.format = "tum";
  for (int i = 0; i < 5; ++i) {
    FrameResult r = FakeResult(i);
    r.position_m = {1.0 * i, 0.0};
    totals.Add(i, 0.5 * i, r, std::nullopt);
    ReferencePoint p;
    p.time_s = 0.5 * i;
    p.x_m = 1.0 * i;
    p.frame_index = i;
    truth.points.push_back(p);
  }
  ASSERT_EQ(totals.track_frames, (std::vector<int>{0, 1, 2, 3, 4}));
  RunSummary s;
  s.frames_processed = 5;
  Summarize({}, false, LoopEnd(), nullptr, georef, totals, &truth, 1.0, &s);
  EXPECT_EQ(s.frames_with_truth, 5);
  ASSERT_TRUE(s.truth_evaluation.has_value());
  EXPECT_LT(s.truth_evaluation->se2.ate_m.rmse, 1e-9);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0],
            "the track is not geo-referenced: compare it with the truth after alignment only");
}

TEST(RunSteps, WriteSummaryThenThrowTheFailure) {
  const fs::path dir = TempDir("summary");
  RunSummary s;
  s.input = "in";
  s.frames_processed = 4;
  WriteSummary(dir, s);
  EXPECT_EQ(nlohmann::json::parse(ReadText(dir / "summary.json")).at("frames_processed"), 4);
  s.error = "f4.jpg: cannot decode";
  try {
    WriteSummary(dir, s);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "f4.jpg: cannot decode (the run stopped there: the 4 frames processed before are "
              "in '" +
                  dir.string() + "', each file valid, summary.json included)");
  }
  EXPECT_EQ(nlohmann::json::parse(ReadText(dir / "summary.json")).at("error"),
            "f4.jpg: cannot decode");
  fs::remove_all(dir);
}


// --calibration: the file is the camera (over focal_px and sim.json), scaled to the frames,
// refused for another aspect ratio with both sizes named; the undistorter follows its lens.
TEST(RunSteps, CalibrationFileIsTheCamera) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("aerovo_runsteps_calib_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  CameraIntrinsics k = IntrinsicsFromFocalPx(1800.0, 1920, 1440);
  k.model = LensModel::kFisheye;
  k.distortion = {-0.05, 0.01, 0.0, 0.0};
  const std::string file = (dir / "cam.yaml").string();
  WriteCalibration(file, k, CalibrationFormat::kOpenCv);
  RunConfig c;
  c.focal_px = 500.0;  // e.g. from sim.json: the calibration wins
  c.calibration = file;
  const RunCamera cam = ResolveRunCamera(c, true, 960, 720, nullptr, std::nullopt, "f.png");
  EXPECT_EQ(cam.focal_source, "calibration");
  EXPECT_DOUBLE_EQ(cam.focal_px, 900.0);
  ASSERT_TRUE(cam.calibrated.has_value());
  EXPECT_EQ(cam.calibrated->model, LensModel::kFisheye);
  EXPECT_NE(MakeUndistorter(*cam.calibrated, 960, 720), nullptr);
  // Without distortion and centred, nothing to undistort.
  EXPECT_EQ(MakeUndistorter(IntrinsicsFromFocalPx(900.0, 960, 720), 960, 720), nullptr);
  try {
    ResolveRunCamera(c, false, 1280, 720, nullptr, std::nullopt, "f.png");
    ADD_FAILURE() << "a 16:9 frame with a 4:3 calibration must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("1920x1440"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("1280x720"), std::string::npos) << e.what();
  }
  c.calibration = (dir / "missing.yaml").string();
  EXPECT_THROW(ResolveRunCamera(c, false, 960, 720, nullptr, std::nullopt, "f.png"), InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::run_steps::run_steps_test
