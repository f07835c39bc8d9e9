// GPS denial on any flight (RunConfig::gps_denied_after_s; docs/map.md): from the denial on the
// telemetry's positions reach nothing but the comparison with GPS. Every case renders its own
// photo flight (nadir 320x240 views of a 0.25 m/px procedural terrain, focal 400 px at 100 m,
// one photo per second, a photo folder without EXIF: time = rank) with an SRT whose fixes are
// the exact path plus 0.3 m of deterministic noise, and runs it through RunFlight.
//
// The path: 40 steps of 2 m east, then 50 of 2 m north (90 photos, 180 m, 90 s). Without a yaw
// in the SRT the heading comes from the first 30 m of GPS (odometry/georef.h), i.e. frame 15.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <algorithm>
#include <fstream>
#include <map>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/geo/geodesic.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/html_report.h"
#include "e2e_testing.h"

namespace aerovo::gps_denied_test {
namespace {

namespace fs = std::filesystem;

constexpr int kW = 320, kH = 240;
constexpr double kFocalPx = 400.0, kHeightM = 100.0, kGsd = kHeightM / kFocalPx;
constexpr int kEastSteps = 40, kNorthSteps = 50;
constexpr int kFrames = kEastSteps + kNorthSteps + 1;
// The runs that need no minute after the denial take the first 30 photos (CPU time).
constexpr int kShort = 30;

const cv::Mat& Ground() {
  static const cv::Mat ground = e2e::GreyTerrain(kGsd, 23);
  return ground;
}

// The nadir frame centred at (x east, y north) metres from the ground's centre.
cv::Mat Render(const Eigen::Vector2d& p) {
  return e2e::RenderNadir(Ground(), kGsd, p.x(), p.y(), 0.0, kW, kH);
}

std::vector<Eigen::Vector2d> Path() {
  std::vector<Eigen::Vector2d> p{{-150.0, -60.0}};
  for (int i = 0; i < kEastSteps; ++i) p.push_back(p.back() + Eigen::Vector2d(2.0, 0.0));
  for (int i = 0; i < kNorthSteps; ++i) p.push_back(p.back() + Eigen::Vector2d(0.0, 2.0));
  return p;
}

const LocalEnu& Origin() {
  static const LocalEnu enu(27.95, -82.46, 10.0);
  return enu;
}

// One SRT record per photo (FrameCnt = photo + 1), 1 s apart; `wild_from` >= 0: the positions
// of the photos from that one on moved by up to a few km (a telemetry no run may use).
std::string MakeSrt(const std::vector<Eigen::Vector2d>& path, int wild_from) {
  std::string out;
  for (int i = 0; i < static_cast<int>(path.size()); ++i) {
    const double k = i;
    const Eigen::Vector2d noise(0.3 * std::sin(7.1 * k), 0.3 * std::cos(5.3 * k));
    GeoPoint g = Origin().Reverse(path[i].x() + noise.x(), path[i].y() + noise.y(), kHeightM);
    if (wild_from >= 0 && i >= wild_from) {
      g.lat_deg += 0.02 * std::sin(1.3 * k);
      g.lon_deg += 0.03 * std::cos(1.7 * k);
    }
    out += fmt::format(
        "{}\n00:{:02d}:{:02d},000 --> 00:{:02d}:{:02d},999\n<font size=\"28\">FrameCnt: {}, "
        "DiffTime: 1000ms\n[latitude: {:.8f}] [longitude: {:.8f}] [rel_alt: {:.3f} abs_alt: "
        "{:.3f}]\n</font>\n\n",
        i + 1, i / 60, i % 60, i / 60, i % 60, i + 1, g.lat_deg, g.lon_deg, kHeightM,
        10.0 + kHeightM);
  }
  return out;
}

// The photos and the two telemetries, made once.
struct Flight {
  fs::path dir;
  std::vector<Eigen::Vector2d> path;
  Flight() : dir(e2e::FreshTempDir("aerovo_denied", "flight")), path(Path()) {
    fs::create_directories(dir / "photos");
    for (std::size_t i = 0; i < path.size(); ++i) {
      cv::imwrite((dir / "photos" / fmt::format("p_{:04d}.png", i)).string(), Render(path[i]));
    }
    std::ofstream(dir / "clean.srt") << MakeSrt(path, -1);
  }
  ~Flight() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  fs::path Wild(int from) const {
    const fs::path p = dir / fmt::format("wild_{}.srt", from);
    if (!fs::exists(p)) std::ofstream(p) << MakeSrt(path, from);
    return p;
  }
};

const Flight& TheFlight() {
  static const Flight flight;
  return flight;
}

// The first `frames` photos (0: all) run with `srt`, GPS denied after `denied_after_s`.
RunSummary RunDenied(const std::string& name, const fs::path& srt, double denied_after_s,
                     int frames, bool gps_check = true) {
  RunConfig c;
  c.input = (TheFlight().dir / "photos").string();
  c.out = (TheFlight().dir / name).string();
  c.telemetry = srt.string();
  c.focal_px = kFocalPx;
  c.gps_denied_after_s = denied_after_s;
  c.gps_check.enabled = gps_check;
  c.max_frames = frames;
  c.quiet = true;
  return RunFlight(c);
}

using Rows = std::vector<std::map<std::string, std::string>>;
Rows FramesOf(const std::string& name) { return e2e::ReadFramesCsv(TheFlight().dir / name); }

// The largest distance between two runs' positions (frames.csv x_m, y_m), m.
double LargestDifferenceM(const Rows& a, const Rows& b) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    worst = std::max(worst, std::hypot(std::stod(a[i].at("x_m")) - std::stod(b[i].at("x_m")),
                                       std::stod(a[i].at("y_m")) - std::stod(b[i].at("y_m"))));
  }
  return worst;
}

// Denied at 8 s (frame 8, before the heading is known from 30 m of GPS): the telemetry's
// positions from there on replaced by values kilometres off change nothing of the track, the
// GPS check never sees them, the telemetry clock's estimate neither; without the denial the same
// telemetry moves the track (GPS check off) or is rejected by the check (on): the positions
// would reach the run if a path still read them. The first 30 photos.
TEST(GpsDenied, WithheldPositionsDoNotChangeTheTrack) {
  const Flight& f = TheFlight();
  const RunSummary clean = RunDenied("denied_clean", f.dir / "clean.srt", 8.0, kShort);
  const RunSummary wild = RunDenied("denied_wild", f.Wild(8), 8.0, kShort);
  const Rows a = FramesOf("denied_clean"), b = FramesOf("denied_wild");
  ASSERT_EQ(a.size(), static_cast<std::size_t>(kShort));
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE(i);
    for (const char* col : {"x_m", "y_m", "lat_deg", "lon_deg", "status"}) {
      EXPECT_EQ(a[i].at(col), b[i].at(col)) << col;
    }
    EXPECT_EQ(b[i].at("gps_flag"), i >= 8 ? "withheld" : "");
    EXPECT_FALSE(b[i].at("lat_deg").empty());  // geo-referenced from the 8 fixes before
  }
  EXPECT_EQ(wild.gps_rejected, 0);
  EXPECT_EQ(clean.heading_source, "gps-segment");
  EXPECT_EQ(wild.telemetry_offset_estimate_valid, clean.telemetry_offset_estimate_valid);
  EXPECT_EQ(wild.telemetry_offset_estimate_s, clean.telemetry_offset_estimate_s);
  ASSERT_TRUE(wild.gps_denied && wild.gps_denied->error);
  EXPECT_EQ(wild.gps_denied->from_frame, 8);
  EXPECT_EQ(wild.gps_denied->fixes_withheld, kShort - 8);
  // The wild telemetry is what the track is compared with: kilometres.
  EXPECT_GT(wild.gps_denied->error->max_error_m, 500.0);

  // The controls: the same wild positions, not withheld.
  RunDenied("open_wild", f.Wild(8), -1.0, kShort, false);
  EXPECT_GT(LargestDifferenceM(a, FramesOf("open_wild")), 50.0);
  const RunSummary checked = RunDenied("open_wild_checked", f.Wild(8), -1.0, kShort, true);
  EXPECT_GT(checked.gps_rejected, 10);
}

// Denied at 20 s, after the heading is known (frame 15): the summary's figures are the distances
// between frames.csv's geo-referenced positions and its withheld fixes, the flight's length
// without GPS is the path's, and the error stays within what 0.3 m GPS noise and the odometry's
// drift allow over 140 m.
TEST(GpsDenied, ErrorOverTimeIsTheTracksAgainstTheWithheldFixes) {
  const RunSummary s = RunDenied("denied_20", TheFlight().dir / "clean.srt", 20.0, 0);
  ASSERT_TRUE(s.gps_denied.has_value());
  const RunSummary::GpsDenied& d = *s.gps_denied;
  EXPECT_EQ(d.after_s, 20.0);
  EXPECT_EQ(d.from_frame, 20);
  EXPECT_EQ(d.from_time_s, 20.0);
  ASSERT_TRUE(d.error.has_value()) << d.note;
  const DeniedError& e = *d.error;
  EXPECT_EQ(e.pairs, kFrames - 20);
  EXPECT_EQ(e.duration_s, kFrames - 1 - 20);
  EXPECT_NEAR(e.distance_m, 2.0 * (kFrames - 1 - 20), 0.1 * (kFrames - 1 - 20));
  ASSERT_EQ(e.at.size(), 1u);  // 60 s after the denial; the flight ends before 5 minutes
  EXPECT_EQ(e.at[0].time_s, 80.0);
  const Rows rows = FramesOf("denied_20");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kFrames));
  const auto error_at = [&](int frame) {
    const auto& r = rows[static_cast<std::size_t>(frame)];
    EXPECT_EQ(r.at("gps_flag"), frame >= 20 ? "withheld" : "");
    return GeodesicDistance({std::stod(r.at("lat_deg")), std::stod(r.at("lon_deg")), 0.0},
                            {std::stod(r.at("gps_lat_deg")), std::stod(r.at("gps_lon_deg")), 0.0});
  };
  EXPECT_NEAR(e.first_error_m, error_at(20), 0.01);
  EXPECT_NEAR(e.at[0].error_m, error_at(80), 0.01);
  EXPECT_NEAR(e.end_error_m, error_at(kFrames - 1), 0.01);
  ASSERT_TRUE(e.end_error_per_km_m.has_value());
  EXPECT_NEAR(*e.end_error_per_km_m, e.end_error_m / (e.distance_m / 1000.0), 1e-9);
  EXPECT_LT(e.max_error_m, 3.0);
  EXPECT_LT(e.rmse_m, 2.0);
  // Every frame has its fix (withheld ones too): no "without a telemetry fix" warning; the text.
  EXPECT_EQ(s.frames_with_gps, kFrames);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("no telemetry fix"), std::string::npos) << w;
  const std::string text = FormatRunSummary(s);
  EXPECT_NE(text.find("GPS denied from frame 20 (20.0 s), 71 fixes withheld"), std::string::npos)
      << text;
  EXPECT_NE(text.find("after 1 min"), std::string::npos) << text;
  // The report's section (no mosaic: the figures from summary.json and frames.csv).
  ReportOptions ro;
  ro.mosaic = false;
  const ReportResult report = WriteReport(TheFlight().dir / "denied_20", ro);
  const std::string html = e2e::ReadText(report.html);
  EXPECT_NE(html.find("Without GPS"), std::string::npos);
  EXPECT_NE(html.find("GPS withheld from frame 20 (20.0 s)"), std::string::npos);
  EXPECT_NE(html.find("end error per km without GPS"), std::string::npos);
}

// Denied from the start (the first 30 photos): no position ever reaches the run, so the track is not geo-referenced;
// the frames are written as they come (not held for a heading that cannot come), the summary
// says why there is no error figure.
TEST(GpsDenied, FromTheStartTheTrackStaysLocal) {
  const RunSummary s = RunDenied("denied_0", TheFlight().dir / "clean.srt", 0.0, kShort);
  ASSERT_TRUE(s.gps_denied.has_value());
  EXPECT_EQ(s.gps_denied->from_frame, 0);
  EXPECT_EQ(s.gps_denied->fixes_withheld, kShort);
  EXPECT_FALSE(s.gps_denied->error.has_value());
  EXPECT_NE(s.gps_denied->note.find("not geo-referenced"), std::string::npos);
  EXPECT_FALSE(s.enu_origin.has_value());
  EXPECT_TRUE(s.heading_source.empty());
  const Rows rows = FramesOf("denied_0");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kShort));
  for (const auto& r : rows) EXPECT_TRUE(r.at("lat_deg").empty());
  bool said = false;
  for (const std::string& w : s.warnings) said = said || w.find("GPS denied from frame 0") == 0;
  EXPECT_TRUE(said);
  // The aligned comparison with GPS still uses the withheld fixes (a comparison).
  ASSERT_TRUE(s.evaluation.has_value());
  EXPECT_LT(s.evaluation->se2.ate_m.rmse, 2.0);
}

}  // namespace
}  // namespace aerovo::gps_denied_test
