// `aerovo run --map A --map B`: several reference maps in the order of preference (docs/map.md,
// "Several maps"), end to end over a simulated flight with exact truth, rendered from the Callas
// orthophoto (`aerovo simulate --ortho`, GPS without noise: the telemetry's positions are the
// truth). The maps are the same ground as two surveys would give it:
// - "recent": the orthophoto at half its size (0.216 m/px, its own tones, JPEG at quality 70),
//   only its part west of east = 450 m (the flight's legs run east 318-582 m: the map covers
//   half of each), warped by gdalwarp into UTM zone 32N (EPSG:32632, a grid turned 1.7 deg from
//   the orthophoto's) with an alpha band;
// - "older": the whole orthophoto 4 x coarser (0.433 m/px) in another season's tones, JPEG at
//   quality 40, warped into geographic WGS84 (EPSG:4326) with an alpha band.
// Both start as GeoTIFFs in a transverse Mercator CRS centred on the orthophoto's north-west
// corner (the simulator's ENU plane there; gdal_translate, gdal-bin).
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "aerovo/geo/local_enu.h"
#include "e2e_testing.h"

namespace aerovo::map_several_test {
namespace {

namespace fs = std::filesystem;

constexpr double kOrthoMpp = 0.1082;  // the Callas orthophoto (tests/e2e/run_flight_test.cc)
constexpr double kNwLat = 43.539340, kNwLon = 6.551628;
constexpr double kRecentEastM = 450.0;  // the recent map covers east < this (m from the NW corner)

using e2e::ReadCsvRows;

// The orthophoto read at 1 / `reduce` (2 or 4) of its size, its columns east of `east_m`
// dropped, tones `tone(v)` (v in [0, 1]), JPEG at `quality`, as a GeoTIFF in the transverse
// Mercator CRS at the NW corner, then warped into `srs` with an alpha band: `dir`/`name`.tif.
template <class Tone>
bool WriteMap(const fs::path& ortho, const fs::path& dir, const std::string& name, int reduce,
              double east_m, Tone tone, int quality, const std::string& srs) {
  cv::Mat g = cv::imread(ortho.string(), reduce == 2 ? cv::IMREAD_REDUCED_GRAYSCALE_2
                                                     : cv::IMREAD_REDUCED_GRAYSCALE_4);
  if (g.empty()) return false;
  const double mpp = reduce * kOrthoMpp;
  const int cols = east_m / mpp >= g.cols ? g.cols : static_cast<int>(east_m / mpp);
  cv::Mat map(g.rows, cols, CV_8U);
  for (int y = 0; y < g.rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const double v = tone(g.at<std::uint8_t>(y, x) / 255.0, static_cast<double>(x) / g.cols);
      map.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(255.0 * v);
    }
  }
  const fs::path jpg = dir / (name + ".jpg"), tm = dir / (name + "_tm.tif");
  if (!cv::imwrite(jpg.string(), map, {cv::IMWRITE_JPEG_QUALITY, quality})) return false;
  const std::string cmd = fmt::format(
      "gdal_translate -q -a_srs '+proj=tmerc +lat_0={} +lon_0={} +k=1 +x_0=0 +y_0=0 "
      "+ellps=WGS84 +units=m +no_defs' -a_ullr 0 0 {} {} {} {} && "
      "gdalwarp -q -overwrite -t_srs {} -r bilinear -dstalpha {} {}",
      kNwLat, kNwLon, map.cols * mpp, -map.rows * mpp, jpg.string(), tm.string(), srs,
      tm.string(), (dir / (name + ".tif")).string());
  return std::system(cmd.c_str()) == 0;
}

// The flight (a lawnmower of 2 legs of 250 m, 60 m apart, at 100 m over the quarry, 640 x 360 at
// 2 fps, GPS without noise; as tests/e2e/map_fix_test.cc) and the two maps, made once.
struct SeveralMapsFlight {
  fs::path dir;
  std::string skip;  // why the tests cannot run ("" when they can)
  bool made = false;
  SeveralMapsFlight() {
    const fs::path ortho = ::aerovo::testing::SharedDir() / "data/ortho/callas-quarry.jpg";
    if (::aerovo::testing::SharedDir().empty() || !fs::exists(ortho)) {
      skip =
          "shared data not found: data/ortho/callas-quarry.jpg (set AEROVO_SHARED or place "
          "../shared beside the source tree)";
      return;
    }
    if (std::system("command -v gdal_translate gdalwarp > /dev/null 2>&1") != 0) {
      skip = "gdal_translate or gdalwarp (gdal-bin) not installed: the maps' GeoTIFFs";
      return;
    }
    dir = e2e::FreshTempDir("aerovo_map_several", "flight");
    const auto recent = [](double v, double) { return 0.05 + 0.9 * v; };
    const auto older = [](double v, double x) { return std::pow(v, 0.7) * 0.65 + 0.22 + 0.06 * x; };
    made = e2e::RunCli(fmt::format(
               "simulate --ortho {} --mpp {} --nw-lat {} --nw-lon {} --ground-alt-m 300 "
               "--pattern lawnmower --length-m 250 --legs 2 --spacing-m 60 --height-m 100 "
               "--width 640 --height 360 --fps 2 --gps-noise-m 0 --centre-north-m 80 -q -o {}",
               ortho.string(), kOrthoMpp, kNwLat, kNwLon, (dir / "sim").string())) == 0 &&
           WriteMap(ortho, dir, "recent", 2, kRecentEastM, recent, 70, "EPSG:32632") &&
           WriteMap(ortho, dir, "older", 4, 1e9, older, 40, "EPSG:4326");
  }
  ~SeveralMapsFlight() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);
  }
  // `aerovo run` over it with `maps` (each a --map), GPS denied after 5 s, every 5th frame
  // matched within 40 m, the fixes fused.
  int Run(const std::string& name, const std::vector<std::string>& maps,
          const std::string& extra = "") const {
    std::string flags;
    for (const std::string& m : maps) flags += " --map " + (dir / m).string();
    return e2e::RunCli(fmt::format("run {}{} --gps-denied-after-s 5 --map-fix-every-n-frames 5 "
                                   "--map-fix-search-radius-m 40 --map-fix-apply --no-report -q "
                                   "-o {} {}",
                                   (dir / "sim" / "video.mp4").string(), flags,
                                   (dir / name).string(), extra),
                       dir / (name + ".log"));
  }
};

const SeveralMapsFlight& Flight() {
  static const SeveralMapsFlight f;
  return f;
}

// The truth's east (m from the orthophoto's NW corner) at each frame (ground_truth.csv).
std::map<int, double> TruthEast(const fs::path& csv) {
  const LocalEnu nw(GeoPoint{kNwLat, kNwLon, 0.0});
  std::map<int, double> east;
  for (const auto& r : ReadCsvRows(csv)) {
    east[std::stoi(r.at("frame"))] =
        nw.Forward(GeoPoint{std::stod(r.at("lat_deg")), std::stod(r.at("lon_deg")), 0.0}).x();
  }
  return east;
}

// The recent partial map first, the older full one second: together they cover the flight (no
// cover warning); every attempt's frame west of the recent map's edge is fixed on it (map 0),
// east of it on the older map (map 1), both areas with fixes, each within 3 m of the truth and
// 1 m at the median; summary.json counts the fixes per map and they add up.
TEST(MapSeveral, RecentPartialMapFirstOlderFullMapAfterIt) {
  const SeveralMapsFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  ASSERT_EQ(f.Run("both", {"recent.tif", "older.tif"}), 0) << e2e::ReadText(f.dir / "both.log");
  const nlohmann::json s = e2e::ReadJson(f.dir / "both" / "summary.json");
  for (const auto& w : s.at("warnings")) {
    EXPECT_EQ(w.get<std::string>().find("cover"), std::string::npos) << w;
  }
  ASSERT_EQ(s.at("map").at("paths").size(), 2u);
  EXPECT_EQ(s.at("map").at("covered"), s.at("map").at("track_points")) << s.at("map").dump(1);
  const nlohmann::json& m = s.at("map_fixes");
  const nlohmann::json& by_map = m.at("by_map");
  ASSERT_EQ(by_map.size(), 2u) << m.dump(1);
  EXPECT_NE(by_map[0].at("path").get<std::string>().find("recent.tif"), std::string::npos);
  EXPECT_NE(by_map[1].at("path").get<std::string>().find("older.tif"), std::string::npos);
  EXPECT_EQ(by_map[0].at("fixes").get<int>() + by_map[1].at("fixes").get<int>(),
            m.at("fixes").get<int>());
  EXPECT_EQ(by_map[0].at("fused").get<int>() + by_map[1].at("fused").get<int>(),
            m.at("fused").get<int>());
  const std::map<int, double> east = TruthEast(f.dir / "sim" / "ground_truth.csv");
  int fixes[2] = {0, 0}, attempts[2] = {0, 0};
  std::vector<double> errors;
  for (const auto& r : ReadCsvRows(f.dir / "both" / "map_fixes.csv")) {
    const int frame = std::stoi(r.at("frame"));
    if (r.at("status") == "no_prediction" || east.count(frame) == 0) continue;
    const double e = east.at(frame);
    if (std::abs(e - kRecentEastM) < 5.0) continue;  // at the edge: either map
    const int expected = e < kRecentEastM ? 0 : 1;
    ++attempts[expected];
    if (r.at("status") != "fix") continue;
    ++fixes[expected];
    EXPECT_EQ(r.at("map"), std::to_string(expected)) << "frame " << frame << " east " << e;
    errors.push_back(std::stod(r.at("gps_error_m")));
    EXPECT_LT(errors.back(), 3.0) << "frame " << frame << " map " << r.at("map");
  }
  for (int k = 0; k < 2; ++k) {
    EXPECT_GE(attempts[k], 6) << "map " << k;
    EXPECT_GE(fixes[k], 0.8 * attempts[k]) << "map " << k << ": " << m.dump(1);
    EXPECT_EQ(by_map[k].at("fixes").get<int>() >= fixes[k], true) << m.dump(1);
  }
  ASSERT_FALSE(errors.empty());
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 1.0);
  // The fused track against the withheld GPS (the truth).
  const nlohmann::json& e = s.at("gps_denied").at("error");
  ASSERT_TRUE(e.is_object()) << s.dump(1);
  EXPECT_LT(e.at("max_error_m").get<double>(), 3.0) << e.dump(1);
  RecordProperty("fixes_recent_older", fmt::format("{} of {}, {} of {}", fixes[0], attempts[0],
                                                   fixes[1], attempts[1]));
  RecordProperty("fix_error_median_max_m",
                 fmt::format("{:.3f} {:.3f}", errors[errors.size() / 2],
                             *std::max_element(errors.begin(), errors.end())));
  RecordProperty("fused_track_rmse_max_m",
                 fmt::format("{:.3f} {:.3f}", e.at("rmse_m").get<double>(),
                             e.at("max_error_m").get<double>()));

  // The report draws every fix: one marker on its map per map_fixes.csv row with status fix
  // (fused, or recorded) or gate, and the figure of the fixes over the track.
  ASSERT_EQ(e2e::RunCli(fmt::format("report {} --no-mosaic -q", (f.dir / "both").string()),
                        f.dir / "report.log"),
            0)
      << e2e::ReadText(f.dir / "report.log");
  const std::string html = e2e::ReadText(f.dir / "both" / "report.html");
  const std::string open = "<script type=\"application/json\" id=\"aerovo-map-data\">";
  const std::size_t a = html.find(open);
  ASSERT_NE(a, std::string::npos);
  const nlohmann::json data =
      nlohmann::json::parse(html.substr(a + open.size(), html.find("</script>", a) - a - open.size()));
  std::map<std::string, int> markers, expected;
  for (const auto& mk : data.at("map_fixes")) ++markers[mk.at(2).get<std::string>()];
  for (const auto& r : ReadCsvRows(f.dir / "both" / "map_fixes.csv")) {
    if (r.at("status") == "gate" || r.at("gated_by_graph") == "1") {
      ++expected["gated"];
    } else if (r.at("status") == "fix") {
      ++expected[r.at("applied") == "1" ? "fused" : "recorded"];
    }
  }
  EXPECT_EQ(markers, expected);
  EXPECT_EQ(markers["fused"], m.at("fused").get<int>());
  EXPECT_TRUE(fs::exists(f.dir / "both" / "figures" / "map_fixes.png"));
}

// The recent map alone covers part of the flight (the first 64 frames: the first leg, east
// 302-582 m, and the turn): a warning naming it (the track's cover), fixes only where it covers
// (the attempts whose window lies wholly east of its edge are no_map, without a map index). A corrupt second map is an error naming
// that file, before any frame.
TEST(MapSeveral, PartialCoverWarnsAndACorruptSecondMapIsNamed) {
  const SeveralMapsFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  ASSERT_EQ(f.Run("recent_only", {"recent.tif"}, "--max-frames 64"), 0)
      << e2e::ReadText(f.dir / "recent_only.log");
  const nlohmann::json s = e2e::ReadJson(f.dir / "recent_only" / "summary.json");
  bool warned = false;
  for (const auto& w : s.at("warnings")) {
    const std::string t = w.get<std::string>();
    warned = warned || (t.find("recent.tif") != std::string::npos &&
                        t.find("the map covers") != std::string::npos);
  }
  EXPECT_TRUE(warned) << s.at("warnings").dump(1);
  const std::map<int, double> east = TruthEast(f.dir / "sim" / "ground_truth.csv");
  int east_of_edge = 0;
  for (const auto& r : ReadCsvRows(f.dir / "recent_only" / "map_fixes.csv")) {
    const double e = east.at(std::stoi(r.at("frame")));
    // The window around the prediction reaches the search radius (40 m) and half the frame's
    // diagonal (73 m) past the frame's centre.
    if (e < kRecentEastM + 115.0) continue;
    ++east_of_edge;
    EXPECT_EQ(r.at("status"), "no_map") << "frame " << r.at("frame");
    EXPECT_EQ(r.at("map"), "");
  }
  EXPECT_GE(east_of_edge, 1);

  {
    std::ofstream(f.dir / "corrupt.tif") << "II*\0 this is not a TIFF";
  }
  ASSERT_EQ(WEXITSTATUS(f.Run("corrupt", {"recent.tif", "corrupt.tif"})), 1);
  const std::string log = e2e::ReadText(f.dir / "corrupt.log");
  EXPECT_NE(log.find("corrupt.tif"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(f.dir / "corrupt" / "frames.csv"));
}

}  // namespace
}  // namespace aerovo::map_several_test
