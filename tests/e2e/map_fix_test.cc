// `aerovo run --map`: absolute fixes against a reference map (docs/map.md), end to end over a
// simulated flight with exact truth. The flight is rendered from the Callas orthophoto
// (`aerovo simulate --ortho`, GPS without noise: the telemetry's positions are the truth); the
// map is the same ground as another survey would give it: 4 x coarser (0.433 m/px), other tones
// (a gamma, less contrast, a veil of haze, a gradient of light), JPEG at quality 40, written as
// a GeoTIFF in a transverse Mercator CRS centred on the orthophoto's north-west corner (the
// simulator's ENU plane there; gdal_translate, gdal-bin). GPS is denied after 5 s: the fixes
// are compared with the withheld positions.
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/report/run_reader.h"
#include "callas_map.h"
#include "e2e_testing.h"

namespace aerovo::map_fix_test {
namespace {

namespace fs = std::filesystem;

constexpr double kOrthoMpp = 0.1082;  // the Callas orthophoto (tests/e2e/run_flight_test.cc)
constexpr double kNwLat = 43.539340, kNwLon = 6.551628;

using e2e::ReadCsvRows;

// The map (callas_map.h): the orthophoto at a quarter of its size (0.433 m/px), other tones,
// JPEG; `band`: two tiles swapped (CallasMapOptions::band).
bool WriteMap(const fs::path& ortho, const fs::path& dir, const std::string& name = "map",
              const std::array<double, 3>& band = {0, 0, 0}) {
  e2e::CallasMapOptions o;
  o.band = band;
  return e2e::WriteCallasMap(ortho, dir, name, o);
}

// The flight and the map, made once for the tests below (a lawnmower of 2 legs of 250 m, 60 m
// apart, at 100 m over the quarry, 640 x 360 at 2 fps, GPS without noise).
struct MapFixFlight {
  fs::path dir;
  std::string skip;  // why the tests cannot run ("" when they can)
  bool made = false;
  MapFixFlight() {
    const fs::path ortho = ::aerovo::testing::SharedDir() / "data/ortho/callas-quarry.jpg";
    if (::aerovo::testing::SharedDir().empty() || !fs::exists(ortho)) {
      skip =
          "shared data not found: data/ortho/callas-quarry.jpg (set AEROVO_SHARED or place "
          "../shared beside the source tree)";
      return;
    }
    if (std::system("command -v gdal_translate > /dev/null 2>&1") != 0) {
      skip = "gdal_translate (gdal-bin) not installed: the map's GeoTIFF";
      return;
    }
    dir = e2e::FreshTempDir("aerovo_map_fix", "flight");
    made = e2e::RunCli(fmt::format(
               "simulate --ortho {} --mpp {} --nw-lat {} --nw-lon {} --ground-alt-m 300 "
               "--pattern lawnmower --length-m 250 --legs 2 --spacing-m 60 --height-m 100 "
               "--width 640 --height 360 --fps 2 --gps-noise-m 0 --centre-north-m 80 -q -o {}",
               ortho.string(), kOrthoMpp, kNwLat, kNwLon, (dir / "sim").string())) == 0 &&
           WriteMap(ortho, dir);
  }
  ~MapFixFlight() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);
  }
  // `aerovo run` over it with GPS denied after 5 s, every 5th frame matched within 40 m.
  int Run(const std::string& name, const std::string& extra) const {
    return e2e::RunCli(fmt::format("run {} --map {} --gps-denied-after-s 5 "
                                   "--map-fix-every-n-frames 5 --map-fix-search-radius-m 40 "
                                   "--no-report -q -o {} {}",
                                   (dir / "sim" / "video.mp4").string(), (dir / "map.tif").string(),
                                   (dir / name).string(), extra),
                       dir / (name + ".log"));
  }
};

const MapFixFlight& Flight() {
  static const MapFixFlight f;
  return f;
}

// Over that flight, GPS denied after 5 s, every 5th frame matched against the map within 40 m of
// the track: the attempts before the track is geo-referenced (the first 30 m of GPS fix its
// heading) are counted apart, at least 80 % of the others are fixes, within 1 m of the truth at the
// median and 3 m at most (measured on 2 legs of 300 m: all 44 of every 3rd frame fixes, median 0.07
// m, max 0.13 m; BENCHMARKS.md); two runs give the same attempts and fixes (a file source waits for
// each fix before the next: the thread does not make the result depend on timing).
TEST(MapFix, SimulatedFlightFixesAgainstAnotherSeasonMap) {
  const MapFixFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  const fs::path& dir = f.dir;
  const auto run = [&](const std::string& name, const std::string& extra) {
    return f.Run(name, extra);
  };
  ASSERT_EQ(run("run", ""), 0) << e2e::ReadText(dir / "run.log");
  const nlohmann::json s = e2e::ReadJson(dir / "run" / "summary.json");
  const nlohmann::json& m = s.at("map_fixes");
  ASSERT_TRUE(m.is_object()) << s.dump(1);
  const int attempted = m.at("attempted"), fixes = m.at("fixes");
  EXPECT_GE(attempted, 18);
  EXPECT_GE(fixes, 0.8 * attempted) << m.dump(1);
  EXPECT_LE(m.at("no_prediction").get<int>(), 2);
  const nlohmann::json& gps = m.at("against_gps");
  ASSERT_TRUE(gps.is_object()) << m.dump(1);
  EXPECT_EQ(gps.at("fixes"), fixes);
  EXPECT_LT(gps.at("median_m").get<double>(), 1.0) << m.dump(1);
  EXPECT_LT(gps.at("max_m").get<double>(), 3.0) << m.dump(1);
  const auto rows = ReadCsvRows(dir / "run" / "map_fixes.csv");
  ASSERT_EQ(static_cast<int>(rows.size()), attempted);
  int fix_rows = 0;
  for (const auto& r : rows) {
    if (r.at("status") != "fix") continue;
    ++fix_rows;
    EXPECT_FALSE(r.at("lat_deg").empty());
    EXPECT_LT(std::stod(r.at("gps_error_m")), 3.0) << "frame " << r.at("frame");
  }
  EXPECT_EQ(fix_rows, fixes);

  // Same input, same attempts (the first 50 frames).
  ASSERT_EQ(run("again", "--max-frames 50"), 0) << e2e::ReadText(dir / "again.log");
  const auto again = ReadCsvRows(dir / "again" / "map_fixes.csv");
  ASSERT_GE(again.size(), 8u);
  ASSERT_LE(again.size(), rows.size());
  for (std::size_t i = 0; i < again.size(); ++i) {
    for (const char* key : {"frame", "status", "lat_deg", "lon_deg", "inliers", "residual_m"}) {
      EXPECT_EQ(again[i].at(key), rows[i].at(key)) << "row " << i << " " << key;
    }
  }
}

// The fixes applied (--map-fix-apply) on a run given a height 10 % low (--altitude 90): the
// odometry's metres are 10 % short, so the track without GPS drifts from the truth, and each
// fix is fused into the pose graph (FlightGraph::AddFix: the "fixes only" window, as
// backend.online is off), which takes it back by its covariance weight, heading included.
// Against the withheld GPS (the truth): without the fixes 16.8 m RMSE, 26.5 m max; with them
// taken whole as a shift of the track (what --map-fix-apply did before they were fused; each
// fix taken at the next due frame, as now) 3.57 m RMSE, 5.27 m max; fused: at most that, with
// 5 % of tolerance (measured 3.64, 5.27 m; BENCHMARKS.md, "Fixes against the map": on this
// flight the error left is the 10 % scale error over the 5 frames between a fix's frame and
// the frame it is taken at, which neither removes). With --backend-enable the offline track
// (vo_optimized.*) uses every fused fix as an absolute factor too (measured 0.06 m RMSE). The
// same input gives the same fused track (the first 32 frames run again: 4 fixes fused).
TEST(MapFix, AppliedFixesBoundTheErrorOfADriftingTrack) {
  const MapFixFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  ASSERT_EQ(f.Run("low", "--altitude 90"), 0) << e2e::ReadText(f.dir / "low.log");
  ASSERT_EQ(f.Run("low_fixed", "--altitude 90 --map-fix-apply --backend-enable"), 0)
      << e2e::ReadText(f.dir / "low_fixed.log");
  const nlohmann::json low = e2e::ReadJson(f.dir / "low" / "summary.json");
  const nlohmann::json fixed = e2e::ReadJson(f.dir / "low_fixed" / "summary.json");
  const nlohmann::json& e0 = low.at("gps_denied").at("error");
  const nlohmann::json& e1 = fixed.at("gps_denied").at("error");
  ASSERT_TRUE(e0.is_object() && e1.is_object()) << low.dump(1);
  EXPECT_GT(e0.at("rmse_m").get<double>(), 10.0) << e0.dump(1);
  EXPECT_GT(e0.at("max_error_m").get<double>(), 20.0) << e0.dump(1);
  EXPECT_LT(e1.at("rmse_m").get<double>(), 1.05 * 3.57) << e1.dump(1);
  EXPECT_LT(e1.at("max_error_m").get<double>(), 1.05 * 5.27) << e1.dump(1);
  RecordProperty("fused_rmse_max_m", e1.at("rmse_m").dump() + " " + e1.at("max_error_m").dump());
  const nlohmann::json& m = fixed.at("map_fixes");
  EXPECT_GE(m.at("fused").get<int>(), 0.8 * m.at("attempted").get<int>()) << m.dump(1);
  EXPECT_EQ(m.at("applied"), m.at("fused"));
  EXPECT_EQ(m.at("gated_by_graph"), 0) << m.dump(1);  // every fix agrees with the track
  EXPECT_EQ(low.at("map_fixes").at("applied"), 0);
  EXPECT_EQ(low.at("map_fixes").at("fused"), 0);
  EXPECT_TRUE(fixed.at("online").is_null());  // "fixes only": no keyframe matching
  // frames.csv: the frames a fused fix moved.
  const auto frames = ReadCsvRows(f.dir / "low_fixed" / "frames.csv");
  int moved = 0;
  for (const auto& r : frames) moved += r.at("status").find("+map_fix") != std::string::npos;
  EXPECT_EQ(moved, m.at("fused").get<int>());
  // The offline track with the fixes as absolute factors (and the overlaps between the legs):
  // within the fixes' own error of the truth.
  const nlohmann::json& opt = fixed.at("optimized");
  ASSERT_TRUE(opt.is_object()) << fixed.dump(1);
  const nlohmann::json& e2 = opt.at("gps_denied_error");
  ASSERT_TRUE(e2.is_object()) << opt.dump(1);
  EXPECT_LT(e2.at("rmse_m").get<double>(), 1.0) << e2.dump(1);  // measured 0.06 m
  // Same input, same fused track.
  ASSERT_EQ(f.Run("low_fixed_again", "--altitude 90 --map-fix-apply --max-frames 32"), 0)
      << e2e::ReadText(f.dir / "low_fixed_again.log");
  const auto again = ReadCsvRows(f.dir / "low_fixed_again" / "frames.csv");
  ASSERT_GE(again.size(), 30u);  // 4 fixes fused (frames 15, 20, 25, 30)
  for (std::size_t i = 0; i < again.size(); ++i) {
    for (const char* key : {"frame", "x_m", "y_m", "lat_deg", "lon_deg", "status"}) {
      ASSERT_EQ(again[i].at(key), frames[i].at(key)) << "row " << i << " " << key;
    }
  }
}

// The telemetry of the flight with every latitude moved `north_m` north (`[latitude: ...]` of the
// simulator's SRT; metres to degrees by the WGS84 meridian radius of curvature at the latitude).
bool WriteShiftedSrt(const fs::path& srt, double north_m, const fs::path& out) {
  const double a = 6378137.0, e2 = 6.69437999014e-3, lat = kNwLat * kDegToRad;
  const double m = a * (1 - e2) / std::pow(1 - e2 * std::sin(lat) * std::sin(lat), 1.5);
  const double dlat_deg = north_m / m * kRadToDeg;
  std::ifstream in(srt);
  std::ofstream o(out);
  const std::string key = "[latitude: ";
  int shifted = 0;
  for (std::string line; std::getline(in, line);) {
    const std::size_t at = line.find(key);
    if (at != std::string::npos) {
      const std::size_t from = at + key.size(), to = line.find(']', from);
      line = line.substr(0, from) +
             fmt::format("{:.6f}", std::stod(line.substr(from, to - from)) + dlat_deg) +
             line.substr(to);
      ++shifted;
    }
    o << line << '\n';
  }
  return shifted > 0 && static_cast<bool>(o);
}

// Lost and found: the telemetry 300 m south of the truth, so that the track, geo-referenced by
// it before GPS is denied at 5 s, predicts every frame 300 m off the map. The run's first
// attempt is a wide search (400 m around the prediction, coarse to fine) that finds the frame
// 300 m from its GPS (the truth, within 1.5 m) and, applied, takes the track there; the local
// attempts after it are fixes again. Measured (BENCHMARKS.md, "Lost and found"): the first
// attempt is the first fix.
TEST(MapFix, AStart300MOffIsFound) {
  const MapFixFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  ASSERT_TRUE(WriteShiftedSrt(f.dir / "sim" / "telemetry.srt", -300.0, f.dir / "off300.srt"));
  ASSERT_EQ(f.Run("off300", fmt::format("--telemetry {} --map-fix-apply --max-frames 60",
                                        (f.dir / "off300.srt").string())),
            0)
      << e2e::ReadText(f.dir / "off300.log");
  const nlohmann::json m = e2e::ReadJson(f.dir / "off300" / "summary.json").at("map_fixes");
  ASSERT_TRUE(m.is_object());
  EXPECT_GE(m.at("searches").get<int>(), 1) << m.dump(1);
  EXPECT_GE(m.at("found").get<int>(), 1) << m.dump(1);
  ASSERT_FALSE(m.at("time_to_first_fix_s").is_null()) << m.dump(1);
  EXPECT_LE(m.at("time_to_first_fix_s").get<double>(), 10.0) << m.dump(1);
  const auto rows = ReadCsvRows(f.dir / "off300" / "map_fixes.csv");
  std::size_t first = 0;
  while (first < rows.size() && rows[first].at("status") != "fix") ++first;
  ASSERT_LT(first, rows.size());
  const auto& r = rows[first];
  EXPECT_EQ(r.at("search"), "wide");
  EXPECT_NEAR(std::stod(r.at("track_distance_m")), 300.0, 5.0);
  EXPECT_NEAR(std::stod(r.at("gps_error_m")), 300.0, 1.5) << "frame " << r.at("frame");
  // After it, the track is where the map puts it: the local attempts are fixes near it.
  int after = 0, fixes_after = 0;
  for (std::size_t i = first + 1; i < rows.size(); ++i) {
    ++after;
    if (rows[i].at("status") != "fix") continue;
    ++fixes_after;
    EXPECT_NEAR(std::stod(rows[i].at("gps_error_m")), 300.0, 3.0)
        << "frame " << rows[i].at("frame");
    EXPECT_LT(std::stod(rows[i].at("track_distance_m")), 20.0) << "frame " << rows[i].at("frame");
  }
  EXPECT_GE(after, 4);
  EXPECT_GE(fixes_after, 0.8 * after) << m.dump(1);

  // Without the search at the start: the local attempts fail (few inliers, the map window
  // does not hold the frame's ground) until search_after_failures (3) of them in a row start a
  // wide search, which finds it: the 4th attempt, 3 x 5 frames at 2 fps = 7.5 s after the first.
  ASSERT_EQ(f.Run("lost", fmt::format("--telemetry {} --map-fix-apply --max-frames 60 "
                                      "--no-map-fix-search-at-start",
                                      (f.dir / "off300.srt").string())),
            0)
      << e2e::ReadText(f.dir / "lost.log");
  const nlohmann::json lost = e2e::ReadJson(f.dir / "lost" / "summary.json").at("map_fixes");
  ASSERT_FALSE(lost.at("time_to_first_fix_s").is_null()) << lost.dump(1);
  EXPECT_NEAR(lost.at("time_to_first_fix_s").get<double>(), 7.5, 2.6) << lost.dump(1);
  EXPECT_EQ(lost.at("found").get<int>(), 1) << lost.dump(1);
  const auto lost_rows = ReadCsvRows(f.dir / "lost" / "map_fixes.csv");
  ASSERT_GE(lost_rows.size(), 4u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(lost_rows[i].at("search"), "local");
    EXPECT_NE(lost_rows[i].at("status"), "fix") << "row " << i;
  }
}

// A false map region: the map's tile of the ground east 440-600 m placed 200 m farther east (and
// the tile there in its place), under the east end of both legs (east 318-582 m; the frames'
// ground is 84 m along the track). The track has fixes before it, so over the tile its local
// attempts fail and the wide search that follows (gate: 40 m + 10 % of the distance since the
// last fix) finds the frame 200 m off and rejects it (gate): no fix off the truth, the applied
// fixes keep the track within 3 m of the withheld GPS (the truth).
TEST(MapFix, AFalseMapRegionIsRejectedByTheGate) {
  const MapFixFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  const fs::path ortho = ::aerovo::testing::SharedDir() / "data/ortho/callas-quarry.jpg";
  ASSERT_TRUE(WriteMap(ortho, f.dir, "false_region", {440.0, 600.0, 200.0}));
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --map {} --gps-denied-after-s 5 "
                                    "--map-fix-every-n-frames 5 --map-fix-search-radius-m 40 "
                                    "--map-fix-apply --no-report -q -o {}",
                                    (f.dir / "sim" / "video.mp4").string(),
                                    (f.dir / "false_region.tif").string(),
                                    (f.dir / "false_region").string()),
                        f.dir / "false_region.log"),
            0)
      << e2e::ReadText(f.dir / "false_region.log");
  const nlohmann::json s = e2e::ReadJson(f.dir / "false_region" / "summary.json");
  const nlohmann::json& m = s.at("map_fixes");
  const auto rows = ReadCsvRows(f.dir / "false_region" / "map_fixes.csv");
  int wide_gate = 0, fixes = 0;
  for (const auto& r : rows) {
    if (r.at("status") == "gate" && r.at("search") == "wide") {
      ++wide_gate;
      EXPECT_NEAR(std::stod(r.at("track_distance_m")), 200.0, 10.0) << "frame " << r.at("frame");
    }
    if (r.at("status") != "fix") continue;
    ++fixes;
    EXPECT_LT(std::stod(r.at("gps_error_m")), 3.0) << "frame " << r.at("frame");
  }
  EXPECT_GE(wide_gate, 1) << m.dump(1);
  EXPECT_GE(fixes, 8) << m.dump(1);
  const nlohmann::json& e = s.at("gps_denied").at("error");
  ASSERT_TRUE(e.is_object()) << s.dump(1);
  EXPECT_LT(e.at("max_error_m").get<double>(), 3.0) << e.dump(1);
}

// GPS denied from the start (`--gps-denied-after-s 0`): no GPS geo-references the track, so the
// map does. The first due frame (frame 0) is searched over the whole map (no prior, no heading:
// rotation-invariant, coarse to fine) and found, a candidate; the next attempt (frame 5), predicted
// through the candidate, confirms it and seeds the geo-reference (heading and position from its
// fit); the later fixes are fused. Every frame is written geo-referenced (they wait for the seed),
// and the track against the withheld GPS (the truth, unaligned) from the first frame on is within
// the tolerances below (measured 0.07 m RMSE, 0.17 m max; the whole-map search 1.0-1.4 s under a
// load of 10; BENCHMARKS.md, "A start without GPS").
TEST(MapFix, GpsDeniedFromTheStartTheMapSeedsTheGeoReference) {
  const MapFixFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --map {} --gps-denied-after-s 0 "
                                    "--map-fix-every-n-frames 5 --map-fix-search-radius-m 40 "
                                    "--map-fix-apply --no-report -q -o {}",
                                    (f.dir / "sim" / "video.mp4").string(),
                                    (f.dir / "map.tif").string(), (f.dir / "seed").string()),
                        f.dir / "seed.log"),
            0)
      << e2e::ReadText(f.dir / "seed.log");
  const nlohmann::json s = e2e::ReadJson(f.dir / "seed" / "summary.json");
  EXPECT_EQ(s.at("heading_source"), "map") << s.dump(1);
  const nlohmann::json& m = s.at("map_fixes");
  const nlohmann::json& g = m.at("georef");
  ASSERT_TRUE(g.is_object()) << m.dump(1);
  EXPECT_TRUE(g.at("seeded").get<bool>()) << g.dump(1);
  EXPECT_EQ(g.at("candidate_frame"), 0) << g.dump(1);
  EXPECT_EQ(g.at("frame"), 5) << g.dump(1);
  EXPECT_EQ(g.at("whole_map_searches"), 1) << g.dump(1);
  EXPECT_NEAR(m.at("time_to_first_fix_s").get<double>(), 0.0, 1e-6) << m.dump(1);
  RecordProperty("whole_map_search_ms", m.at("search_ms").dump());
  const auto rows = ReadCsvRows(f.dir / "seed" / "map_fixes.csv");
  ASSERT_GE(rows.size(), 10u);
  EXPECT_EQ(rows[0].at("search"), "whole_map");
  EXPECT_EQ(rows[0].at("seed"), "candidate");
  EXPECT_LT(std::stod(rows[0].at("gps_error_m")), 1.5);
  EXPECT_EQ(rows[1].at("seed"), "confirmed");
  EXPECT_EQ(rows[1].at("status"), "fix");
  EXPECT_LT(std::stod(rows[1].at("gps_error_m")), 1.0);
  int fixes = 0;
  for (std::size_t i = 2; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].at("search"), "local") << "row " << i;
    fixes += rows[i].at("status") == "fix";
  }
  EXPECT_GE(fixes, 0.8 * static_cast<double>(rows.size() - 2)) << m.dump(1);
  EXPECT_EQ(m.at("gated_by_graph"), 0) << m.dump(1);
  // The track against the withheld GPS (the truth), unaligned, from frame 0 on.
  const nlohmann::json& e = s.at("gps_denied").at("error");
  ASSERT_TRUE(e.is_object()) << s.at("gps_denied").dump(1);
  EXPECT_LT(e.at("rmse_m").get<double>(), 1.0) << e.dump(1);
  EXPECT_LT(e.at("max_error_m").get<double>(), 2.0) << e.dump(1);
  RecordProperty("seeded_rmse_max_m", e.at("rmse_m").dump() + " " + e.at("max_error_m").dump());
  // Every frame written geo-referenced, the first ones too (held for the seed), without an
  // altitude: the map gives none and no GPS ever did (the ENU origin's null, frames.csv's alt_m
  // empty, the GeoJSON positions [lon, lat], no <ele> in the GPX).
  const auto frames = ReadCsvRows(f.dir / "seed" / "frames.csv");
  ASSERT_GE(frames.size(), 100u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    ASSERT_FALSE(frames[i].at("lat_deg").empty()) << "frames.csv row " << i;
    ASSERT_TRUE(frames[i].at("alt_m").empty()) << "frames.csv row " << i;
  }
  EXPECT_TRUE(s.at("enu_origin").at("alt_m").is_null()) << s.at("enu_origin").dump();
  const nlohmann::json vo = e2e::ReadJson(f.dir / "seed" / "vo.geojson");
  const nlohmann::json& line = vo.at("features").at(0).at("geometry").at("coordinates");
  ASSERT_EQ(line.size(), frames.size());
  for (const nlohmann::json& c : line) ASSERT_EQ(c.size(), 2u) << c.dump();
  EXPECT_EQ(e2e::ReadText(f.dir / "seed" / "vo.gpx").find("<ele>"), std::string::npos);
  // Read back (report/run_reader.h, the Python module's read_run): no altitude known.
  const RunData data = ReadRunDir(f.dir / "seed");
  ASSERT_EQ(data.frames.size(), frames.size());
  for (const RunFrameRow& r : data.frames) {
    ASSERT_TRUE(r.geo.has_value()) << r.frame;
    ASSERT_FALSE(r.geo_alt_known) << r.frame;
  }
}

// The same start over a map of nothing the flight sees (the orthophoto mirrored east-west: the
// same kind of texture, nowhere in its place): the whole-map searches find nothing (one per 4
// due frames: search_after_failures 3), the run completes in the local frame and says why
// (summary.json map_fixes.georef.note, a warning, the text summary); with map_fix.seed_wait_s
// the frames stop waiting for a seed and the run stays local from there, a later seed refused.
TEST(MapFix, GpsDeniedFromTheStartOverAMapWithoutTheFlightSaysSo) {
  const MapFixFlight& f = Flight();
  if (!f.skip.empty()) GTEST_SKIP() << f.skip;
  ASSERT_TRUE(f.made);
  const fs::path ortho = ::aerovo::testing::SharedDir() / "data/ortho/callas-quarry.jpg";
  e2e::CallasMapOptions o;
  o.mirror = true;
  ASSERT_TRUE(e2e::WriteCallasMap(ortho, f.dir, "mirrored", o));
  ASSERT_EQ(
      e2e::RunCli(fmt::format("run {} --map {} --gps-denied-after-s 0 "
                              "--map-fix-every-n-frames 5 --map-fix-search-radius-m 40 "
                              "--max-frames 40 --no-report -o {}",
                              (f.dir / "sim" / "video.mp4").string(),
                              (f.dir / "mirrored.tif").string(), (f.dir / "nomatch").string()),
                  f.dir / "nomatch.log"),
      0)
      << e2e::ReadText(f.dir / "nomatch.log");
  const nlohmann::json s = e2e::ReadJson(f.dir / "nomatch" / "summary.json");
  EXPECT_EQ(s.at("heading_source"), "") << s.dump(1);
  const nlohmann::json& m = s.at("map_fixes");
  const nlohmann::json& g = m.at("georef");
  ASSERT_TRUE(g.is_object()) << m.dump(1);
  EXPECT_FALSE(g.at("seeded").get<bool>()) << g.dump(1);
  EXPECT_EQ(g.at("whole_map_searches"), 2) << g.dump(1);  // due frames 0 and 20 of 0..35
  EXPECT_EQ(m.at("fixes"), 0) << m.dump(1);
  EXPECT_EQ(m.at("no_prediction"), 6) << m.dump(1);
  const std::string note = g.at("note");
  EXPECT_NE(note.find("no whole-map search found the frame"), std::string::npos) << note;
  bool warned = false;
  for (const auto& w : s.at("warnings")) {
    warned = warned || w.get<std::string>().find("no geo-reference from the map") == 0;
  }
  EXPECT_TRUE(warned) << s.at("warnings").dump(1);
  EXPECT_TRUE(s.at("gps_denied").at("error").is_null());
  EXPECT_NE(e2e::ReadText(f.dir / "nomatch.log").find("none from the map: " + note),
            std::string::npos)
      << e2e::ReadText(f.dir / "nomatch.log");
  const auto frames = ReadCsvRows(f.dir / "nomatch" / "frames.csv");
  ASSERT_EQ(frames.size(), 40u);
  EXPECT_TRUE(frames.back().at("lat_deg").empty());

  // The frames wait for a seed at most map_fix.seed_wait_s: 8 s, frame 16 at 2 fps. There the
  // held frames are written in the local frame and the run stays local: the due frame 20 makes
  // no whole-map search (the run above made one there), so 1 search and 4 due frames without a
  // prediction (5, 10, 15 after the failed search, 20 after giving up), and the note says when.
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --map {} --gps-denied-after-s 0 "
                                    "--map-fix-every-n-frames 5 --map-fix-search-radius-m 40 "
                                    "--map-fix-seed-wait-s 8 --max-frames 24 --no-report -o {}",
                                    (f.dir / "sim" / "video.mp4").string(),
                                    (f.dir / "mirrored.tif").string(), (f.dir / "waited").string()),
                        f.dir / "waited.log"),
            0)
      << e2e::ReadText(f.dir / "waited.log");
  const nlohmann::json w = e2e::ReadJson(f.dir / "waited" / "summary.json");
  const nlohmann::json& wm = w.at("map_fixes");
  EXPECT_FALSE(wm.at("georef").at("seeded").get<bool>()) << wm.dump(1);
  EXPECT_EQ(wm.at("georef").at("whole_map_searches"), 1) << wm.dump(1);
  EXPECT_EQ(wm.at("no_prediction"), 4) << wm.dump(1);
  const std::string wnote = wm.at("georef").at("note");
  EXPECT_EQ(wnote.find("no seed within map_fix.seed_wait_s (8 s): the frames were written in the "
                       "local frame from frame 16 (8.000 s) on and the run stayed local; no "
                       "whole-map search found the frame"),
            0u)
      << wnote;
  const std::string wlog = e2e::ReadText(f.dir / "waited.log");
  EXPECT_NE(wlog.find("frame 16: no geo-reference from the map after 8.0 s"), std::string::npos)
      << wlog;
  EXPECT_NE(wlog.find("none from the map: " + wnote), std::string::npos) << wlog;
  const auto wframes = ReadCsvRows(f.dir / "waited" / "frames.csv");
  ASSERT_EQ(wframes.size(), 24u);
  for (const auto& r : wframes) EXPECT_TRUE(r.at("lat_deg").empty());

  // Once local, the run stays local: over the map of the flight, the whole-map search of frame 0
  // finds a candidate, but the wait (1 s: frame 2) ends before the attempt that would confirm
  // it (frame 5), which is not made: no seed, every frame in the local frame.
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --map {} --gps-denied-after-s 0 "
                                    "--map-fix-every-n-frames 5 --map-fix-search-radius-m 40 "
                                    "--map-fix-apply --map-fix-seed-wait-s 1 --max-frames 12 -q "
                                    "--no-report -o {}",
                                    (f.dir / "sim" / "video.mp4").string(),
                                    (f.dir / "map.tif").string(), (f.dir / "late").string()),
                        f.dir / "late.log"),
            0)
      << e2e::ReadText(f.dir / "late.log");
  const nlohmann::json l = e2e::ReadJson(f.dir / "late" / "summary.json");
  EXPECT_EQ(l.at("heading_source"), "") << l.dump(1);
  const nlohmann::json& lg = l.at("map_fixes").at("georef");
  EXPECT_FALSE(lg.at("seeded").get<bool>()) << lg.dump(1);
  EXPECT_EQ(lg.at("candidates"), 1) << lg.dump(1);
  EXPECT_EQ(l.at("map_fixes").at("no_prediction"), 2) << l.at("map_fixes").dump(1);  // 5, 10
  EXPECT_NE(lg.at("note").get<std::string>().find("from frame 2 (1.000 s) on"), std::string::npos)
      << lg.dump(1);
  const auto lframes = ReadCsvRows(f.dir / "late" / "frames.csv");
  ASSERT_EQ(lframes.size(), 12u);
  for (const auto& r : lframes) EXPECT_TRUE(r.at("lat_deg").empty());
}

}  // namespace
}  // namespace aerovo::map_fix_test
