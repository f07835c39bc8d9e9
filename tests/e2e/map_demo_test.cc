// Navigating without GPS over a known map, all of it in one flight (docs/map.md, "The 3 km
// demonstration"): 3.3 km over the Callas orthophoto at 110 m, GPS off 5 s after take-off, the map
// the same ground as another survey would give it (callas_map.h: 0.4 m/px, other tones, haze,
// JPEG) with a gap in its coverage and a tile placed 200 m wrong, and the GPS before the denial
// 300 m off. Everything is compared with the simulator's exact truth (ground_truth.csv).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "callas_map.h"
#include "e2e_testing.h"

namespace aerovo {
namespace {

namespace fs = std::filesystem;
using Rows = std::vector<std::map<std::string, std::string>>;

constexpr double kNwLat = 43.539340, kNwLon = 6.551628;
constexpr double kPi = 3.14159265358979323846;
// The map's layout, metres east of the orthophoto's west edge: no data in [600, 900); the tile
// [1000, 1100) and the one 200 m east of it swapped. The flight's frames reach 95 m east or
// west of their centre (a 165 x 93 m footprint at a heading of 72 or 252 degrees).
constexpr double kGap0 = 600.0, kGap1 = 900.0, kBand0 = 1000.0, kBand1 = 1100.0, kShift = 200.0;
constexpr double kReach = 95.0;

// East and north of the orthophoto's north-west corner, m (equirectangular at its latitude:
// within centimetres over the 2 km of the flight).
struct EastNorth {
  double e = 0.0, n = 0.0;
};
EastNorth FromLatLon(double lat_deg, double lon_deg) {
  const double r = 6378137.0;
  return {(lon_deg - kNwLon) * kPi / 180.0 * r * std::cos(kNwLat * kPi / 180.0),
          (lat_deg - kNwLat) * kPi / 180.0 * r};
}
double Distance(const EastNorth& a, const EastNorth& b) { return std::hypot(a.e - b.e, a.n - b.n); }

// The telemetry with the latitude of its first `blocks` SRT blocks (frames, at 1 fps) moved
// `north_m` north: the GPS before the denial wrong by that much.
bool ShiftFirstFixes(const fs::path& srt, int blocks, double north_m, const fs::path& out) {
  std::ifstream in(srt);
  std::ofstream o(out);
  const std::string key = "[latitude: ";
  int block = 0, shifted = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.find("-->") != std::string::npos) ++block;
    const std::size_t at = line.find(key);
    if (at != std::string::npos && block <= blocks) {
      const std::size_t from = at + key.size(), to = line.find(']', from);
      const double lat = std::stod(line.substr(from, to - from)) + north_m / 6378137.0 * 180.0 / kPi;
      line = line.substr(0, from) + fmt::format("{:.6f}", lat) + line.substr(to);
      ++shifted;
    }
    o << line << '\n';
  }
  return shifted == blocks && static_cast<bool>(o);
}

// Unaligned errors of a run's frames.csv positions against the truth, frames from `first` on, m.
std::vector<double> TrackErrors(const Rows& frames, const std::map<int, EastNorth>& truth,
                                int first) {
  std::vector<double> e;
  for (const auto& r : frames) {
    const int frame = std::stoi(r.at("frame"));
    if (frame < first || r.at("lat_deg").empty()) continue;
    e.push_back(Distance(FromLatLon(std::stod(r.at("lat_deg")), std::stod(r.at("lon_deg"))),
                         truth.at(frame)));
  }
  return e;
}

double Rmse(const std::vector<double>& v) {
  double s = 0.0;
  for (const double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

bool In(double e, double a, double b) { return e >= a && e < b; }

// The flight (3 legs of 1 km, 100 m apart, along the quarry), its map and its telemetry with the
// GPS before the denial 300 m off, in `dir`; the truth's position of every frame.
void MakeFlight(const fs::path& ortho, const fs::path& dir, std::map<int, EastNorth>* truth) {
  // 3 legs of 1 km, 100 m apart, along the quarry (heading 72 deg), at 110 m and 15 m/s, 480 x 270
  // at 1 fps, the orthophoto at 0.2 m/px; a consumer GPS (2 m per axis).
  ASSERT_EQ(e2e::RunCli(fmt::format(
                "simulate --ortho {} --mpp 0.2 --nw-lat {} --nw-lon {} --ground-alt-m 300 "
                "--pattern lawnmower --legs 3 --length-m 1000 --spacing-m 100 --heading-deg 72 "
                "--centre-east-m -20 --centre-north-m 180 --height-m 110 --speed-mps 15 "
                "--width 480 --height 270 --fps 1 --gps-noise-m 2 -q -o {}",
                ortho.string(), kNwLat, kNwLon, (dir / "sim").string())),
            0);
  const nlohmann::json sim = e2e::ReadJson(dir / "sim" / "sim.json");
  EXPECT_GE(sim.at("distance_m").get<double>(), 3000.0);
  e2e::CallasMapOptions mo;
  mo.ortho_mpp = 0.2;
  mo.reduction = 2;  // 0.4 m/px
  mo.nodata = true;
  mo.gap = {kGap0, kGap1};
  mo.band = {kBand0, kBand1, kShift};
  ASSERT_TRUE(e2e::WriteCallasMap(ortho, dir, "map", mo));
  ASSERT_TRUE(ShiftFirstFixes(dir / "sim" / "telemetry.srt", 5, -300.0, dir / "off300.srt"));
  for (const auto& r : e2e::ReadCsvRows(dir / "sim" / "ground_truth.csv")) {
    (*truth)[std::stoi(r.at("frame"))] = FromLatLon(std::stod(r.at("lat_deg")), std::stod(r.at("lon_deg")));
  }
}

// The fused run's attempts (map_fixes.csv rows) by where the frame truly is: the start 300 m off
// found, every fix within 3 m of the truth, at least 90 % of fixes where the map is right (no
// frame reaching into the gap or a swapped tile), none inside the gap and fixes again within 3
// attempts after each crossing, the swapped tile found 200 m off by a wide search and gated.
void CheckAttempts(const Rows& rows, const std::map<int, EastNorth>& truth) {
  ASSERT_GE(rows.size(), 70u);
  // A start 300 m off: the first attempt (frame 0) is a wide search that finds the frame there.
  EXPECT_EQ(rows[0].at("search"), "wide");
  EXPECT_EQ(rows[0].at("status"), "fix");
  EXPECT_NEAR(std::stod(rows[0].at("track_distance_m")), 300.0, 10.0);
  int textured = 0, textured_fixes = 0, gap = 0, gate = 0;
  bool in_gap_before = false;
  int resumed = 0, crossings = 0, since_gap = -1;
  for (const auto& r : rows) {
    const int frame = std::stoi(r.at("frame"));
    const double e = truth.at(frame).e;
    const std::string& status = r.at("status");
    if (status == "fix") {  // every fix where the truth is, whatever the map's tile
      const EastNorth at = FromLatLon(std::stod(r.at("lat_deg")), std::stod(r.at("lon_deg")));
      EXPECT_LT(Distance(at, truth.at(frame)), 3.0) << "frame " << frame;
    }
    const bool near_gap = In(e, kGap0 - kReach, kGap1 + kReach);
    const bool near_band = In(e, kBand0 - kReach, kBand1 + kReach) ||
                           In(e, kBand0 + kShift - kReach, kBand1 + kShift + kReach);
    if (!near_gap && !near_band) {
      ++textured;
      textured_fixes += status == "fix";
    }
    // The gap: a frame wholly inside it has no fix (its ground is not on the map: no_map, or
    // few inliers against the map's data beside it); after it the fixes resume within 3 attempts.
    const bool inside_gap = In(e, kGap0 + kReach, kGap1 - kReach);
    if (inside_gap) {
      ++gap;
      EXPECT_NE(status, "fix") << "frame " << frame;
    }
    if (in_gap_before && !inside_gap) {
      ++crossings;
      since_gap = 0;
    }
    if (since_gap >= 0 && !inside_gap) {
      if (status == "fix") {
        ++resumed;
        since_gap = -1;
      } else if (++since_gap > 3) {
        since_gap = -1;
      }
    }
    in_gap_before = inside_gap;
    // The false tile: a wide search finds the frame 200 m off and the gate rejects it.
    if (status == "gate" && r.at("search") == "wide") {
      ++gate;
      EXPECT_NEAR(std::stod(r.at("track_distance_m")), kShift, 15.0) << "frame " << frame;
    }
  }
  EXPECT_GE(textured, 40);
  EXPECT_GE(textured_fixes, 0.9 * textured) << textured_fixes << " of " << textured;
  EXPECT_GE(gap, 3);
  EXPECT_EQ(crossings, 3);  // the 3 legs
  EXPECT_EQ(resumed, crossings);
  EXPECT_GE(gate, 1);
  std::printf("attempts %zu, where the map is right %d (fixes %d), in the gap %d, gate %d\n",
              rows.size(), textured, textured_fixes, gap, gate);
}

TEST(MapDemo, ThreeKilometresWithoutGpsOverAnotherSurveysMap) {
  const fs::path ortho = ::aerovo::testing::SharedDir() / "data/ortho/callas-quarry.jpg";
  if (::aerovo::testing::SharedDir().empty() || !fs::exists(ortho)) {
    GTEST_SKIP() << "shared data not found: data/ortho/callas-quarry.jpg (set AEROVO_SHARED or "
                    "place ../shared beside the source tree)";
  }
  if (std::system("command -v gdal_translate > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "gdal_translate (gdal-bin) not installed: the map's GeoTIFF";
  }
  const fs::path dir = e2e::FreshTempDir("aerovo_map_demo", "flight");
  std::map<int, EastNorth> truth;
  ASSERT_NO_FATAL_FAILURE(MakeFlight(ortho, dir, &truth));
  const std::string video = (dir / "sim" / "video.mp4").string();
  // The odometry alone (its GPS right before the denial), and with the map (its GPS 300 m off).
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --gps-denied-after-s 5 --no-report -q -o {}", video,
                                    (dir / "vo").string()),
                        dir / "vo.log"),
            0)
      << e2e::ReadText(dir / "vo.log");
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --telemetry {} --map {} --gps-denied-after-s 5 "
                                    "--map-fix-every-n-frames 3 --map-fix-apply --no-report -q -o {}",
                                    video, (dir / "off300.srt").string(),
                                    (dir / "map.tif").string(), (dir / "fused").string()),
                        dir / "fused.log"),
            0)
      << e2e::ReadText(dir / "fused.log");

  // The track without GPS (frames from the denial at 5 s on), unaligned against the truth.
  const std::vector<double> vo = TrackErrors(e2e::ReadCsvRows(dir / "vo" / "frames.csv"), truth, 5);
  const std::vector<double> fused =
      TrackErrors(e2e::ReadCsvRows(dir / "fused" / "frames.csv"), truth, 5);
  ASSERT_GE(fused.size(), 200u);
  ASSERT_EQ(vo.size(), fused.size());
  const double fused_max = *std::max_element(fused.begin(), fused.end());
  const double vo_max = *std::max_element(vo.begin(), vo.end());
  EXPECT_LT(Rmse(fused), 3.0);
  EXPECT_LT(fused_max, 8.0);
  EXPECT_GT(Rmse(vo), 3.0);
  EXPECT_GT(vo_max, 8.0);
  RecordProperty("fused_rmse_max_m", fmt::format("{:.2f} {:.2f}", Rmse(fused), fused_max));
  RecordProperty("odometry_rmse_max_m", fmt::format("{:.2f} {:.2f}", Rmse(vo), vo_max));
  std::printf("fused track: RMSE %.2f m, max %.2f m; odometry alone: RMSE %.2f m, max %.2f m\n",
              Rmse(fused), fused_max, Rmse(vo), vo_max);

  // The attempts, by where the frame truly is.
  const Rows rows = e2e::ReadCsvRows(dir / "fused" / "map_fixes.csv");
  CheckAttempts(rows, truth);
  const nlohmann::json m = e2e::ReadJson(dir / "fused" / "summary.json").at("map_fixes");
  EXPECT_EQ(m.at("gated_by_graph"), 0) << m.dump(1);
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace aerovo
