// Telemetry that lies (docs/reliability.md, "Telemetry that lies"): implausible GPS fixes,
// telemetry clocks that do not match the video, and the messages that say why a run has no height
// or no comparison with GPS. Every case generates its own input in a temporary folder (photos
// rendered from the simulator's procedural terrain, as in bad_input_test.cc; telemetry written
// here) and runs it through RunFlight. docs/reliability.md lists the cases.
//
// Frames: 320x240 nadir views of a 0.25 m/px terrain (focal 400 px at 100 m), one per second
// (a photo folder without EXIF: time = rank). The flight goes east.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <system_error>
#include <utility>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/frames/exif_test_writer.h"
#include "aerovo/geo/geodesic.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/run_reader.h"
#include "aerovo/sim/terrain.h"
#include "e2e_testing.h"

namespace aerovo::telemetry_trust_test {
namespace {

namespace fs = std::filesystem;

constexpr int kW = 320, kH = 240;
constexpr double kFocalPx = 400.0, kHeightM = 100.0, kGsd = kHeightM / kFocalPx;

fs::path TempDir(const std::string& name) { return e2e::FreshTempDir("aerovo_tel", name); }

const cv::Mat& Ground() {
  static const cv::Mat ground = e2e::GreyTerrain(kGsd, 11);
  return ground;
}

// The nadir frame centred at local (x east, y north) metres of the ground's centre.
cv::Mat Render(const Eigen::Vector2d& p) {
  return e2e::RenderNadir(Ground(), kGsd, p.x(), p.y(), 0.0, kW, kH);
}

// Positions (m) of frame i = time i s: east from x0 with the given steps (m per frame).
std::vector<Eigen::Vector2d> Path(const std::vector<double>& steps_m, double x0 = -140.0) {
  std::vector<Eigen::Vector2d> p{{x0, 20.0}};
  for (const double s : steps_m) p.push_back(p.back() + Eigen::Vector2d(s, 0.0));
  return p;
}

std::vector<double> Steady(int n, double step_m = 2.0) { return std::vector<double>(n, step_m); }

// Speeds that change (for the offset estimate): 1 to 4 m per frame, a fixed pattern.
std::vector<double> Varying(int n) {
  const double pattern[] = {1.0, 1.0, 3.0, 4.0, 4.0, 1.5, 0.5, 2.0, 3.5, 1.0, 2.5, 4.0, 0.5};
  std::vector<double> s;
  for (int i = 0; i < n; ++i) s.push_back(pattern[i % 13]);
  return s;
}

const LocalEnu& Origin() {
  static const LocalEnu enu(49.84, 24.03, 300.0);
  return enu;
}
GeoPoint GeoOf(const Eigen::Vector2d& p) { return Origin().Reverse(p.x(), p.y(), kHeightM); }

void WritePhotos(const fs::path& dir, const std::vector<Eigen::Vector2d>& path) {
  fs::create_directories(dir);
  for (std::size_t i = 0; i < path.size(); ++i) {
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("frame_{:04d}.png", i)).string(), Render(path[i])));
  }
}

// One SRT record per frame (FrameCnt = frame + first_count), 1 s apart.
struct Fix {
  GeoPoint geo;
  double rel_alt_m = kHeightM;
};
std::string MakeSrt(const std::vector<Fix>& fixes, int first_count = 1) {
  std::string out;
  for (int i = 0; i < static_cast<int>(fixes.size()); ++i) {
    out += fmt::format(
        "{}\n00:{:02d}:{:02d},000 --> 00:{:02d}:{:02d},999\n<font size=\"28\">FrameCnt: {}, "
        "DiffTime: 1000ms\n[latitude: {:.7f}] [longitude: {:.7f}] [rel_alt: {:.3f} abs_alt: "
        "{:.3f}]\n</font>\n\n",
        i + 1, i / 60, i % 60, i / 60, i % 60, i + first_count, fixes[i].geo.lat_deg,
        fixes[i].geo.lon_deg, fixes[i].rel_alt_m, 300.0 + fixes[i].rel_alt_m);
  }
  return out;
}

std::vector<Fix> FixesOf(const std::vector<Eigen::Vector2d>& path) {
  std::vector<Fix> f;
  // 1 m of deterministic GPS noise.
  for (std::size_t i = 0; i < path.size(); ++i) {
    const double k = static_cast<double>(i);
    f.push_back({GeoOf(path[i] + Eigen::Vector2d(std::sin(7.1 * k), std::cos(5.3 * k)))});
  }
  return f;
}

RunConfig Config(const fs::path& photos, const fs::path& out, const fs::path& telemetry) {
  RunConfig c;
  c.input = photos.string();
  c.out = out.string();
  c.focal_px = kFocalPx;
  c.telemetry = telemetry.string();
  c.quiet = true;
  return c;
}

using e2e::ReadFramesCsv;

// Geodesic distance (m) between the geo-referenced VO position of the last frame and the truth.
double EndErrorM(const fs::path& run_dir, const std::vector<Eigen::Vector2d>& path) {
  const auto rows = ReadFramesCsv(run_dir);
  EXPECT_EQ(rows.size(), path.size());
  if (rows.empty() || rows.back().at("lat_deg").empty()) return 1e9;
  GeoPoint p;
  p.lat_deg = std::stod(rows.back().at("lat_deg"));
  p.lon_deg = std::stod(rows.back().at("lon_deg"));
  return GeodesicDistance(p, GeoOf(path.back()));
}

std::string Joined(const std::vector<std::string>& v) { return fmt::format("{}", fmt::join(v, "\n")); }

bool HasWarning(const RunSummary& s, const std::string& part) {
  return std::any_of(s.warnings.begin(), s.warnings.end(),
                     [&](const std::string& w) { return w.find(part) != std::string::npos; });
}

// ------------------------------------------------------------------------- impossible fixes

struct Glitch {
  const char* name;
  std::function<void(int, Fix&)> edit;
  std::vector<int> rejected;  // frames whose fix must be flagged
};

// +0.01 degree of latitude = 1112 m.
void North(Fix& f, double deg) { f.geo.lat_deg += deg; }

// 32 frames, 2 m apart (62 m): the heading is fixed from the first 30 m of GPS. Each glitch
// shape (in the first 30 m, at the very first fix, late) is rejected and reported with its
// frame; the geo-referenced track ends where the clean run ends (within 1 m; the clean run's end
// error is ~1 m of GPS noise and VO drift) instead of tens of metres away, and the ATE against
// GPS stays at the clean run's level.
constexpr int kGlitchSteps = 31;

struct CleanRun {
  fs::path dir;
  std::vector<Eigen::Vector2d> path;
  RunSummary summary;
  double end_error_m = 0.0;
  ~CleanRun() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);  // at exit
  }
};

// The photos and the clean run, made once for the glitch tests.
const CleanRun& Clean() {
  static const CleanRun clean = [] {
    CleanRun c;
    c.dir = TempDir("glitch");
    c.path = Path(Steady(kGlitchSteps));
    WritePhotos(c.dir / "photos", c.path);
    std::ofstream(c.dir / "clean.srt") << MakeSrt(FixesOf(c.path));
    c.summary = RunFlight(Config(c.dir / "photos", c.dir / "clean", c.dir / "clean.srt"));
    c.end_error_m = EndErrorM(c.dir / "clean", c.path);
    return c;
  }();
  return clean;
}

void ExpectGlitchHandled(const Glitch& g) {
  SCOPED_TRACE(g.name);
  const CleanRun& clean = Clean();
  ASSERT_EQ(clean.summary.gps_rejected, 0) << Joined(clean.summary.warnings);
  ASSERT_LT(clean.end_error_m, 3.0);
  ASSERT_TRUE(clean.summary.evaluation.has_value());
  const fs::path& dir = clean.dir;
  const std::vector<Eigen::Vector2d>& path = clean.path;
  std::vector<Fix> fixes = FixesOf(path);
  for (int i = 0; i < static_cast<int>(fixes.size()); ++i) g.edit(i, fixes[i]);
  const std::string file = std::string(g.name) + ".srt";
  std::ofstream(dir / file) << MakeSrt(fixes);
  const fs::path out = dir / g.name;
  const RunSummary s = RunFlight(Config(dir / "photos", out, dir / file));
  EXPECT_EQ(s.gps_rejected, static_cast<int>(g.rejected.size())) << Joined(s.warnings);
  ASSERT_EQ(s.gps_rejected_fixes.size(), g.rejected.size());
  for (std::size_t k = 0; k < g.rejected.size(); ++k) {
    EXPECT_EQ(s.gps_rejected_fixes[k].frame, g.rejected[k]);
    // The message names the telemetry file and the frame.
    EXPECT_NE(s.gps_rejected_fixes[k].message.find(file), std::string::npos);
    EXPECT_NE(s.gps_rejected_fixes[k].message.find(fmt::format("frame {} ", g.rejected[k])),
              std::string::npos)
        << s.gps_rejected_fixes[k].message;
    // ... and the record the fix was read from: MakeSrt's subtitle of frame f starts at line
    // 6 f + 1.
    EXPECT_NE(
        s.gps_rejected_fixes[k].message.find(fmt::format("{}:{})", file, 6 * g.rejected[k] + 1)),
        std::string::npos)
        << s.gps_rejected_fixes[k].message;
  }
  EXPECT_TRUE(HasWarning(s, "rejected")) << Joined(s.warnings);
  // frames.csv flags exactly those frames.
  const auto rows = ReadFramesCsv(out);
  ASSERT_EQ(rows.size(), path.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const bool want = std::count(g.rejected.begin(), g.rejected.end(), static_cast<int>(i)) > 0;
    // The last cell: absent from the row when empty.
    const auto flag = rows[i].find("gps_flag");
    const std::string cell = flag == rows[i].end() ? "" : flag->second;
    EXPECT_EQ(cell.rfind("rejected:", 0) == 0, want) << i << ": '" << cell << "'";
  }
  const double end_error_m = EndErrorM(out, path);
  std::cout << fmt::format("{}: end error {:.2f} m (clean {:.2f} m), ATE {:.3f} m (clean {:.3f} m)\n",
                           g.name, end_error_m, clean.end_error_m,
                           s.evaluation ? s.evaluation->se2.ate_m.rmse : -1.0,
                           clean.summary.evaluation->se2.ate_m.rmse);
  EXPECT_NEAR(end_error_m, clean.end_error_m, 1.0);
  // The comparison with GPS leaves the rejected fixes out: ATE at the clean run's level.
  ASSERT_TRUE(s.evaluation.has_value());
  EXPECT_NEAR(s.evaluation->se2.ate_m.rmse, clean.summary.evaluation->se2.ate_m.rmse, 0.3);
}

TEST(TelemetryTrust, ImplausibleSpikeOrFirstFixDoesNotSteerTheGeoReference) {
  ExpectGlitchHandled({"spike", [](int i, Fix& f) { if (i == 5) North(f, 0.01); }, {5}});
  ExpectGlitchHandled({"first_fix", [](int i, Fix& f) { if (i == 0) North(f, 0.01); }, {0}});
}

TEST(TelemetryTrust, ImplausibleRunOrSmallJumpDoesNotSteerTheGeoReference) {
  ExpectGlitchHandled(
      {"run", [](int i, Fix& f) { if (i >= 4 && i < 8) North(f, 0.01); }, {4, 5, 6, 7}});
  // 40 m in 1 s: a plausible speed, but the camera moved 2 m.
  ExpectGlitchHandled(
      {"small_spike", [](int i, Fix& f) { if (i == 6) f.geo.lat_deg += 40.0 / 111200.0; }, {6}});
}

TEST(TelemetryTrust, ImplausibleAltitudeOrLateStepDoesNotSteerTheTrack) {
  ExpectGlitchHandled({"altitude_spike", [](int i, Fix& f) { if (i == 5) f.rel_alt_m += 400.0; }, {5}});
  std::vector<int> late;
  for (int i = 24; i <= kGlitchSteps; ++i) late.push_back(i);
  ExpectGlitchHandled({"late_step", [](int i, Fix& f) { if (i >= 24) North(f, 0.01); }, late});
}

// A fix read from a photo's EXIF and rejected as implausible is named by its photo (before, the
// warning said "frame 5" only). The photos carry EXIF GPS as a camera writes it (IFD0 with the
// GPS IFD pointer); the fifth is 1.1 km north.
TEST(TelemetryTrust, RejectedPhotoFixNamesThePhoto) {
  const fs::path dir = TempDir("photo_fix");
  const std::vector<Eigen::Vector2d> path = Path(Steady(kGlitchSteps));
  std::vector<Fix> fixes = FixesOf(path);
  North(fixes[5], 0.01);
  // Degrees, minutes and seconds (1/10000 s) as EXIF RATIONALs.
  const auto dms = [](double deg) {
    const unsigned d = static_cast<unsigned>(deg);
    const double min = (deg - d) * 60.0;
    const unsigned m = static_cast<unsigned>(min);
    const unsigned s = static_cast<unsigned>(std::lround((min - m) * 60.0 * 10000.0));
    return io_test::Rationals({{d, 1}, {m, 1}, {s, 10000}});
  };
  fs::create_directories(dir / "photos");
  for (std::size_t i = 0; i < path.size(); ++i) {
    const GeoPoint& g = fixes[i].geo;
    const std::vector<io_test::TiffEntry> gps = {
        {0x0001, 2, 2, std::string("N\0", 2), {}},  // GPSLatitudeRef
        {0x0002, 5, 3, dms(g.lat_deg), {}},         // GPSLatitude
        {0x0003, 2, 2, std::string("E\0", 2), {}},  // GPSLongitudeRef
        {0x0004, 5, 3, dms(g.lon_deg), {}}};        // GPSLongitude
    io_test::WriteJpegWithExif(dir / "photos" / fmt::format("DJI_{:04d}.JPG", i), Render(path[i]),
                               {io_test::Ascii(0x010f, "DJI"), {0x8825, 4, 1, "", gps}});
  }
  RunConfig c = Config(dir / "photos", dir / "out", "");
  c.altitude_m = kHeightM;
  const RunSummary s = RunFlight(c);
  ASSERT_EQ(s.gps_rejected, 1) << Joined(s.warnings);
  ASSERT_EQ(s.gps_rejected_fixes.size(), 1u);
  EXPECT_EQ(s.gps_rejected_fixes[0].frame, 5);
  const std::string& message = s.gps_rejected_fixes[0].message;
  EXPECT_NE(message.find("frame 5 (time 5.000 s, "), std::string::npos) << message;
  EXPECT_NE(message.find("DJI_0005.JPG) rejected"), std::string::npos) << message;
  EXPECT_TRUE(HasWarning(s, "DJI_0005.JPG")) << Joined(s.warnings);
}

// The run's ENU frame (x_m/y_m, vo.tum, gps.tum, the comparisons with GPS and the truth, the
// report) has its origin at the first fix the check accepted and kept, never at a rejected one:
// a bad first fix 1.1 km off, a first fix with latitude and longitude swapped (24.03 N 49.84 E:
// 3000 km away, where the horizontal plane is tilted 30 degrees against the flight's), and two
// bad first fixes in a row. Every
// output in that frame agrees: gps.tum starts at (0, 0) at the first good fix, vo.tum and
// frames.csv hold the same positions and follow gps.tum within GPS noise, summary.json and the
// report name the same origin, and the truth (noise-free SRT) is met as in the clean run.
std::vector<std::vector<double>> ReadTum(const fs::path& file) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::vector<double> v;
    double x = 0.0;
    while (ss >> x) v.push_back(x);
    rows.push_back(v);
  }
  return rows;
}

TEST(TelemetryTrust, EnuOriginIsTheFirstAcceptedFix) {
  const CleanRun& clean = Clean();
  const fs::path& dir = clean.dir;
  const std::vector<Eigen::Vector2d>& path = clean.path;
  std::vector<Fix> truth;
  for (const Eigen::Vector2d& p : path) truth.push_back({GeoOf(p)});
  std::ofstream(dir / "truth.srt") << MakeSrt(truth);
  RunConfig cc = Config(dir / "photos", dir / "clean_truth", dir / "clean.srt");
  cc.truth = (dir / "truth.srt").string();
  const RunSummary clean_truth = RunFlight(cc);
  ASSERT_TRUE(clean_truth.truth_evaluation.has_value());
  ASSERT_TRUE(clean_truth.enu_origin.has_value());
  // The SRT has 7 decimals (1e-7 deg, 1 cm).
  EXPECT_NEAR(clean_truth.enu_origin->lat_deg, FixesOf(path)[0].geo.lat_deg, 1e-7);
  const double clean_truth_end_m = clean_truth.truth_evaluation->se2.end_point_error_unaligned_m;

  struct Case {
    const char* name;
    std::function<void(int, Fix&)> edit;
    int first_good;
  };
  const Case cases[] = {
      {"origin_glitch", [](int i, Fix& f) { if (i == 0) North(f, 0.01); }, 1},
      {"origin_swapped", [](int i, Fix& f) { if (i == 0) std::swap(f.geo.lat_deg, f.geo.lon_deg); }, 1},
      {"origin_two_bad", [](int i, Fix& f) { if (i < 2) North(f, 0.01); }, 2},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    std::vector<Fix> fixes = FixesOf(path);
    for (int i = 0; i < static_cast<int>(fixes.size()); ++i) c.edit(i, fixes[i]);
    const GeoPoint good = fixes[static_cast<std::size_t>(c.first_good)].geo;
    const fs::path srt = dir / (std::string(c.name) + ".srt"), out = dir / c.name;
    std::ofstream(srt) << MakeSrt(fixes);
    RunConfig config = Config(dir / "photos", out, srt);
    config.truth = (dir / "truth.srt").string();
    const RunSummary s = RunFlight(config);
    EXPECT_EQ(s.gps_rejected, c.first_good) << Joined(s.warnings);
    // summary: the origin is the first good fix.
    ASSERT_TRUE(s.enu_origin.has_value());
    EXPECT_NEAR(s.enu_origin->lat_deg, good.lat_deg, 1e-7);
    EXPECT_NEAR(s.enu_origin->lon_deg, good.lon_deg, 1e-7);
    const RunData run = ReadRunDir(out);
    ASSERT_TRUE(run.summary.contains("enu_origin"));
    EXPECT_DOUBLE_EQ(run.summary["enu_origin"]["lat_deg"].get<double>(), s.enu_origin->lat_deg);
    // gps.tum: the rejected fixes left out, the first row the origin itself.
    const auto gps = ReadTum(out / "gps.tum");
    ASSERT_EQ(gps.size(), path.size() - static_cast<std::size_t>(c.first_good));
    EXPECT_DOUBLE_EQ(gps[0][0], static_cast<double>(c.first_good));
    EXPECT_NEAR(gps[0][1], 0.0, 1e-6);
    EXPECT_NEAR(gps[0][2], 0.0, 1e-6);
    // vo.tum = frames.csv x/y, within GPS noise (1.4 m) + VO drift of gps.tum at the same time.
    const auto vo = ReadTum(out / "vo.tum");
    ASSERT_EQ(vo.size(), path.size());
    ASSERT_EQ(run.frames.size(), path.size());
    double worst_m = 0.0;
    for (std::size_t i = 0; i < vo.size(); ++i) {
      EXPECT_NEAR(vo[i][1], run.frames[i].x_m, 1e-3) << i;
      EXPECT_NEAR(vo[i][2], run.frames[i].y_m, 1e-3) << i;
      if (i >= static_cast<std::size_t>(c.first_good)) {
        const auto& g = gps[i - static_cast<std::size_t>(c.first_good)];
        EXPECT_DOUBLE_EQ(g[0], vo[i][0]);
        worst_m = std::max(worst_m, std::hypot(vo[i][1] - g[1], vo[i][2] - g[2]));
      }
    }
    EXPECT_LT(worst_m, 3.0);
    // The report: same frame, same comparison as summary.json.
    const std::optional<LocalEnu> enu = RunEnuFrame(run);
    ASSERT_TRUE(enu.has_value());
    EXPECT_DOUBLE_EQ(enu->origin().lat_deg, s.enu_origin->lat_deg);
    const RunComparison cmp = CompareWithGps(run);
    ASSERT_TRUE(cmp.comparison.has_value());
    ASSERT_TRUE(s.evaluation.has_value());
    EXPECT_NEAR(cmp.reference.front().x, 0.0, 1e-6);
    EXPECT_NEAR(cmp.comparison->se2.ate_m.rmse, s.evaluation->se2.ate_m.rmse, 0.01);
    EXPECT_NEAR(s.evaluation->se2.ate_m.rmse, clean.summary.evaluation->se2.ate_m.rmse, 0.3);
    // The truth, in the same frame: met as in the clean run; and the track on Earth.
    ASSERT_TRUE(s.truth_evaluation.has_value());
    const double end_m = s.truth_evaluation->se2.end_point_error_unaligned_m;
    EXPECT_NEAR(end_m, clean_truth_end_m, 1.0);
    const double geo_end_m = EndErrorM(out, path);
    EXPECT_NEAR(geo_end_m, clean.end_error_m, 1.0);
    std::cout << fmt::format(
        "{}: origin = fix {}; gps.tum {} rows from (0, 0); |vo - gps| <= {:.2f} m; truth end "
        "error {:.2f} m (clean {:.2f} m); geo end error {:.2f} m (clean {:.2f} m)\n",
        c.name, c.first_good, gps.size(), worst_m, end_m, clean_truth_end_m, geo_end_m,
        clean.end_error_m);
  }
}

// With the check disabled (gps_check.enabled = false, the behaviour before the checks) the same
// spike rotates the track: the test above would fail without the check.
TEST(TelemetryTrust, WithoutTheCheckASpikeSteersTheTrack) {
  const fs::path dir = TempDir("nocheck");
  const std::vector<Eigen::Vector2d> path = Path(Steady(kGlitchSteps));
  WritePhotos(dir / "photos", path);
  std::vector<Fix> fixes = FixesOf(path);
  North(fixes[5], 0.01);
  std::ofstream(dir / "spike.srt") << MakeSrt(fixes);
  RunConfig c = Config(dir / "photos", dir / "run", dir / "spike.srt");
  c.gps_check.enabled = false;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.gps_rejected, 0);
  EXPECT_GT(EndErrorM(dir / "run", path), 20.0);
  fs::remove_all(dir);
}

// ------------------------------------------------------------------------ telemetry clocks

// CSV telemetry "time,lat,lon,rel_alt", one row per 0.5 s, telemetry time = frame time +
// shift_s (scaled by `time_scale`: 1000 writes milliseconds).
std::string MakeCsv(const std::vector<Eigen::Vector2d>& path, double shift_s, double time_scale) {
  std::string out = "time,lat,lon,rel_alt\n";
  const double t_end = static_cast<double>(path.size() - 1);
  for (double tel = 0.0; tel <= t_end + 2.0 * std::abs(shift_s); tel += 0.5) {
    const double t = std::clamp(tel - shift_s, 0.0, t_end);  // the frame time it shows
    const std::size_t i = std::min(static_cast<std::size_t>(t), path.size() - 2);
    const double w = t - static_cast<double>(i);
    const GeoPoint g = GeoOf(path[i] + w * (path[i + 1] - path[i]));
    out += fmt::format("{:.3f},{:.8f},{:.8f},{:.1f}\n", tel * time_scale, g.lat_deg, g.lon_deg,
                       kHeightM);
  }
  return out;
}

TEST(TelemetryTrust, CsvTimesInMillisecondsAreWarnedAbout) {
  const fs::path dir = TempDir("ms");
  const std::vector<Eigen::Vector2d> path = Path(Steady(24));
  WritePhotos(dir / "photos", path);
  std::ofstream(dir / "flight_ms.csv") << MakeCsv(path, 0.0, 1000.0);
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run", dir / "flight_ms.csv"));
  EXPECT_TRUE(HasWarning(s, "flight_ms.csv")) << Joined(s.warnings);
  EXPECT_TRUE(HasWarning(s, "milliseconds")) << Joined(s.warnings);
  fs::remove_all(dir);
}

// A flight log export as Airdata writes it (docs/inputs.md "CSV exports of flight logs": heights
// in feet, the elapsed time in milliseconds with a UTC date beside it, speeds in mph, rows at 0, 0
// where the GPS had no fix) is the same flight as the plain CSV of the same fixes in metres and
// seconds: every frame's position and height above ground, and the comparison with GPS.
TEST(TelemetryTrust, AnAirdataExportInFeetAndMillisecondsIsTheSameFlight) {
  const fs::path dir = TempDir("airdata");
  const std::vector<Eigen::Vector2d> path = Path(Steady(16, 3.0));
  WritePhotos(dir / "photos", path);
  std::string plain = "time,lat,lon,rel_alt,alt\n";
  std::string airdata =
      "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(feet),"
      "altitude_above_seaLevel(feet),speed(mph),satellites,isPhoto\n";
  const double ft = 0.3048;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const GeoPoint g = GeoOf(path[i]);
    const double t = static_cast<double>(i);
    plain += fmt::format("{:.3f},{:.8f},{:.8f},{:.3f},{:.3f}\n", t, g.lat_deg, g.lon_deg, kHeightM,
                         300.0 + kHeightM);
    airdata += fmt::format("{:.0f},2024-05-11 14:03:{:02d},{:.8f},{:.8f},{:.9f},{:.9f},6.7,14,1\n",
                           1000.0 * t, 20 + static_cast<int>(i), g.lat_deg, g.lon_deg,
                           kHeightM / ft, (300.0 + kHeightM) / ft);
    // A row the GPS had no fix for, half a second later.
    airdata += fmt::format("{:.0f},2024-05-11 14:03:{:02d},0,0,{:.9f},0,6.7,0,0\n",
                           1000.0 * t + 500.0, 20 + static_cast<int>(i), kHeightM / ft);
  }
  std::ofstream(dir / "plain.csv") << plain;
  std::ofstream(dir / "airdata.csv") << airdata;
  const RunSummary a = RunFlight(Config(dir / "photos", dir / "plain", dir / "plain.csv"));
  const RunSummary b = RunFlight(Config(dir / "photos", dir / "airdata", dir / "airdata.csv"));
  EXPECT_EQ(b.frames_with_gps, static_cast<int>(path.size()));
  EXPECT_EQ(b.frames_with_gps, a.frames_with_gps);
  const auto rows_a = ReadFramesCsv(dir / "plain"), rows_b = ReadFramesCsv(dir / "airdata");
  ASSERT_EQ(rows_a.size(), path.size());
  ASSERT_EQ(rows_b.size(), path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_NEAR(std::stod(rows_b[i].at("height_m")), kHeightM, 1e-6);
    for (const char* column : {"x_m", "y_m", "lat_deg", "lon_deg", "gps_lat_deg", "gps_lon_deg"}) {
      EXPECT_NEAR(std::stod(rows_b[i].at(column)), std::stod(rows_a[i].at(column)), 1e-7) << column;
    }
  }
  ASSERT_TRUE(a.evaluation.has_value());
  ASSERT_TRUE(b.evaluation.has_value());
  EXPECT_NEAR(b.evaluation->sim2.ate_m.rmse, a.evaluation->sim2.ate_m.rmse, 1e-6);
  EXPECT_NEAR(b.evaluation->se2.end_point_error_unaligned_m,
              a.evaluation->se2.end_point_error_unaligned_m, 1e-6);
  EXPECT_LT(b.evaluation->sim2.ate_m.rmse, 1.0);
  fs::remove_all(dir);
}

// A telemetry 3 s late: the offset is estimated within 0.5 s; with --telemetry-offset-s (or
// telemetry_auto_offset) the comparison with GPS is back at the unshifted run's level.
TEST(TelemetryTrust, ShiftedTelemetryOffsetIsEstimatedAndApplied) {
  const fs::path dir = TempDir("shift");
  const std::vector<Eigen::Vector2d> path = Path(Varying(36));
  WritePhotos(dir / "photos", path);
  std::ofstream(dir / "ok.csv") << MakeCsv(path, 0.0, 1.0);
  std::ofstream(dir / "late.csv") << MakeCsv(path, 3.0, 1.0);
  const RunSummary ok = RunFlight(Config(dir / "photos", dir / "ok", dir / "ok.csv"));
  ASSERT_TRUE(ok.evaluation.has_value());
  const RunSummary late = RunFlight(Config(dir / "photos", dir / "late", dir / "late.csv"));
  ASSERT_TRUE(late.telemetry_offset_estimate_valid);
  EXPECT_NEAR(late.telemetry_offset_estimate_s, 3.0, 0.5);
  EXPECT_TRUE(late.telemetry_offset_clear);
  EXPECT_TRUE(HasWarning(late, "--telemetry-offset-s")) << Joined(late.warnings);
  ASSERT_TRUE(late.evaluation.has_value());
  EXPECT_GT(late.evaluation->se2.ate_m.rmse, ok.evaluation->se2.ate_m.rmse + 1.0);

  RunConfig fixed = Config(dir / "photos", dir / "fixed", dir / "late.csv");
  fixed.telemetry_offset_s = 3.0;
  const RunSummary f = RunFlight(fixed);
  ASSERT_TRUE(f.evaluation.has_value());
  EXPECT_NEAR(f.evaluation->se2.ate_m.rmse, ok.evaluation->se2.ate_m.rmse, 0.3);
  EXPECT_DOUBLE_EQ(f.telemetry_offset_s, 3.0);

  std::cout << fmt::format(
      "offset estimate {:.2f} s (correlation {:.2f}); ATE unshifted {:.3f} m, 3 s late {:.3f} m, "
      "offset applied {:.3f} m\n",
      late.telemetry_offset_estimate_s, late.telemetry_offset_correlation,
      ok.evaluation->se2.ate_m.rmse, late.evaluation->se2.ate_m.rmse, f.evaluation->se2.ate_m.rmse);
  RunConfig automatic = Config(dir / "photos", dir / "auto", dir / "late.csv");
  automatic.telemetry_auto_offset = true;
  const RunSummary a = RunFlight(automatic);
  EXPECT_NEAR(a.telemetry_offset_s, 3.0, 0.5);
  ASSERT_TRUE(a.evaluation.has_value());
  EXPECT_NEAR(a.evaluation->se2.ate_m.rmse, ok.evaluation->se2.ate_m.rmse, 0.5);
  EXPECT_TRUE(HasWarning(a, "telemetry_auto_offset")) << Joined(a.warnings);
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------- clear messages

void ExpectInputError(const RunConfig& config, const std::vector<std::string>& parts) {
  try {
    RunFlight(config);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    for (const std::string& p : parts) EXPECT_NE(m.find(p), std::string::npos) << m;
  }
}

// "no height above ground" says its actual cause.
TEST(TelemetryTrust, NoHeightSaysWhy) {
  const fs::path dir = TempDir("height");
  const std::vector<Eigen::Vector2d> path = Path(Steady(5));
  WritePhotos(dir / "photos", path);
  std::vector<Fix> fixes = FixesOf(path);
  // A split recording's second clip: FrameCnt starts at 1001.
  std::ofstream(dir / "clip2.srt") << MakeSrt(fixes, 1001);
  ExpectInputError(Config(dir / "photos", dir / "a", dir / "clip2.srt"),
                   {"no height above ground", "frame counter 1001", "split recording"});
  // A negative relative altitude.
  for (Fix& f : fixes) f.rel_alt_m = -3.0;
  std::ofstream(dir / "below.srt") << MakeSrt(fixes);
  ExpectInputError(Config(dir / "photos", dir / "b", dir / "below.srt"),
                   {"no height above ground", "-3.0 m", "take-off"});
  // No time overlap: a CSV whose times start 1000 s later.
  std::string csv = "time,lat,lon,rel_alt\n";
  for (int i = 0; i < 6; ++i) {
    csv += fmt::format("{},{:.8f},{:.8f},100\n", 1000 + i, fixes[i].geo.lat_deg,
                       fixes[i].geo.lon_deg);
  }
  std::ofstream(dir / "later.csv") << csv;
  ExpectInputError(Config(dir / "photos", dir / "c", dir / "later.csv"),
                   {"no height above ground", "time span", "later.csv", "no time overlap"});
  fs::remove_all(dir);
}

// Every frame has a fix but no step was measured (blank frames): the summary says so.
TEST(TelemetryTrust, NoComparisonWithGpsSaysWhy) {
  const fs::path dir = TempDir("nocmp");
  const std::vector<Eigen::Vector2d> path = Path(Steady(5));
  fs::create_directories(dir / "photos");
  for (std::size_t i = 0; i < path.size(); ++i) {
    cv::imwrite((dir / "photos" / fmt::format("frame_{:04d}.png", i)).string(),
                cv::Mat(kH, kW, CV_8UC1, cv::Scalar(128)));
  }
  std::ofstream(dir / "ok.srt") << MakeSrt(FixesOf(path));
  const RunSummary s = RunFlight(Config(dir / "photos", dir / "run", dir / "ok.srt"));
  EXPECT_EQ(s.frames_with_gps, 6);
  // Every frame bridged at the same place: the alignment is undefined.
  ASSERT_FALSE(s.evaluation.has_value());
  EXPECT_NE(s.gps_comparison_note.find("no step between frames was measured"), std::string::npos)
      << s.gps_comparison_note;
  EXPECT_NE(FormatRunSummary(s).find("no step between frames was measured"), std::string::npos);
  EXPECT_EQ(FormatRunSummary(s).find("fewer than 3 frames with a fix"), std::string::npos);
  EXPECT_TRUE(HasWarning(s, "no comparison with GPS")) << Joined(s.warnings);
  fs::remove_all(dir);
}

// Heights and focal lengths that would make non-finite geometry: a clear error up front, naming
// the option.
TEST(TelemetryTrust, AbsurdHeightOrFocalIsAClearError) {
  const fs::path dir = TempDir("absurd");
  WritePhotos(dir / "photos", Path(Steady(3)));
  RunConfig c = Config(dir / "photos", dir / "run", "");
  c.telemetry.clear();
  c.altitude_m = 1e308;
  try {
    RunFlight(c);
    ADD_FAILURE() << "expected an error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("altitude_m"), std::string::npos) << e.what();
  }
  c.altitude_m = 100.0;
  c.focal_px = 1e-300;
  try {
    RunFlight(c);
    ADD_FAILURE() << "expected an error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("focal_px"), std::string::npos) << e.what();
  }
  // The largest accepted height still gives a completed run with finite positions.
  c.focal_px = kFocalPx;
  c.altitude_m = 1e5;
  const RunSummary s = RunFlight(c);
  EXPECT_EQ(s.frames_processed, 4);
  for (const auto& row : ReadFramesCsv(dir / "run")) {
    EXPECT_TRUE(std::isfinite(std::stod(row.at("x_m"))));
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::telemetry_trust_test
