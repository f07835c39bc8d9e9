// `aerovo map build` and `aerovo map info` (docs/map.md) through the CLI, on a short simulated
// flight with exact truth: 60 m east at 100 m over flat ground (`aerovo simulate --pattern line`,
// 640x480, focal 427 px: a footprint of 150 m across and 112 m along the track, the image's top
// towards the east), GPS with 0.5 m of noise. The map built from the flight given as a source
// (run first) must cover what the camera saw: the truth's track widened by the footprint, in
// WGS84 and at the frames' ground sampling, as a tiled, compressed GeoTIFF with an overview; and
// it must do so when the odometry drifts (a height 10 % wrong) as long as the frames are placed
// by the track optimised with the GPS fixes (the default), where the VO track's placement fails.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include <GeographicLib/UTMUPS.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/geo/local_enu.h"
#include "e2e_testing.h"

namespace aerovo::map_test {
namespace {

namespace fs = std::filesystem;

struct MapFlight {
  fs::path dir;
  int simulate_rc = -1, build_rc = -1;
  MapFlight() : dir(e2e::FreshTempDir("aerovo_map", "flight")) {
    simulate_rc = e2e::RunCli(
        fmt::format("simulate --pattern line --length-m 60 --speed-mps 10 --fps 5 --width 640 "
                    "--height 480 --gps-noise-m 0.5 -q -o {}",
                    (dir / "sim").string()));
    build_rc = e2e::RunCli(fmt::format("map build {} -q -o {}", (dir / "sim" / "video.mp4").string(),
                                       (dir / "map.tif").string()),
                           dir / "build.log");
  }
  ~MapFlight() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const MapFlight& Flight() {
  static const MapFlight f;
  return f;
}

nlohmann::json Info(const fs::path& map) {
  const testing::CommandOutput c =
      testing::RunCommand(std::string(AEROVO_CLI_PATH) + " map info --json " + map.string());
  EXPECT_EQ(c.ExitCode(), 0) << c.out;
  return nlohmann::json::parse(c.out, nullptr, false);
}

// The camera's footprint over the truth's track (east from -56.2 m to 60 + 56.2 m: the image's
// 480 rows along the track; north +-74.9 m: its 640 columns, at 100 m / 427 px), in the
// simulation's ENU frame. A map is north-up in UTM zone 35, whose grid is turned 2.3 degrees from
// true north there: its extent is the UTM bounds of the footprint, and those bounds' WGS84 bounds
// (edges sampled). Returns {min lon, max lon, min lat, max lat}, degrees.
std::array<double, 4> TruthExtent(const MapFlight& f) {
  const double gsd = 100.0 / 426.9755;
  const nlohmann::json sim = e2e::ReadJson(f.dir / "sim" / "sim.json");
  const LocalEnu enu(sim.at("origin").at("lat_deg").get<double>(),
                     sim.at("origin").at("lon_deg").get<double>(), 0.0);
  const double along = 240.0 * gsd, across = 320.0 * gsd;
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const double e : {-along, 60.0 + along}) {
    for (const double n : {-across, across}) {
      const GeoPoint p = enu.Reverse(e, n, 0.0);
      double x = 0.0, y = 0.0, gamma = 0.0, k = 0.0;
      int zone = 0;
      bool north = true;
      GeographicLib::UTMUPS::Forward(p.lat_deg, p.lon_deg, zone, north, x, y, gamma, k, 35);
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  }
  double lon0 = 1e300, lon1 = -1e300, lat0 = 1e300, lat1 = -1e300;
  for (int i = 0; i <= 32; ++i) {
    const double f_i = i / 32.0;
    for (const auto& [x, y] : {std::pair{x0 + f_i * (x1 - x0), y0}, {x0 + f_i * (x1 - x0), y1},
                               {x0, y0 + f_i * (y1 - y0)}, {x1, y0 + f_i * (y1 - y0)}}) {
      double lat = 0.0, lon = 0.0;
      GeographicLib::UTMUPS::Reverse(35, true, x, y, lat, lon);
      lon0 = std::min(lon0, lon), lon1 = std::max(lon1, lon);
      lat0 = std::min(lat0, lat), lat1 = std::max(lat1, lat);
    }
  }
  return {lon0, lon1, lat0, lat1};
}

// The largest of the four edges' distances (metres) between a map's WGS84 extent (`map info
// --json`) and `truth` (TruthExtent).
double EdgeErrorM(const nlohmann::json& info, const std::array<double, 4>& truth) {
  const nlohmann::json& g = info.at("extent_lonlat");
  const double m_lat = 111200.0, m_lon = m_lat * std::cos(49.84 * kDegToRad);
  return std::max({std::abs(g.at("min_x").get<double>() - truth[0]) * m_lon,
                   std::abs(g.at("max_x").get<double>() - truth[1]) * m_lon,
                   std::abs(g.at("min_y").get<double>() - truth[2]) * m_lat,
                   std::abs(g.at("max_y").get<double>() - truth[3]) * m_lat});
}

TEST(MapBuild, FromASimulatedFlightCoversWhatTheCameraSaw) {
  const MapFlight& f = Flight();
  ASSERT_EQ(f.simulate_rc, 0);
  ASSERT_EQ(f.build_rc, 0) << e2e::ReadText(f.dir / "build.log");
  // The source was run first, beside the map.
  EXPECT_TRUE(fs::exists(f.dir / "map_run" / "frames.csv"));
  const nlohmann::json m = Info(f.dir / "map.tif");
  ASSERT_TRUE(m.is_object());
  EXPECT_EQ(m.at("epsg"), 32635);  // UTM 35N: longitude 24.03 E
  EXPECT_EQ(m.at("bands"), 4);
  EXPECT_EQ(m.at("compression"), "DEFLATE");
  EXPECT_EQ(m.at("block_x_px"), 512);
  EXPECT_GE(m.at("overviews").size(), 1u);
  // The frames' own ground sampling: 100 m / 427 px (the map is smaller than 4000 px).
  const double gsd = 100.0 / 426.9755;
  EXPECT_NEAR(m.at("m_per_px_x").get<double>(), gsd, 0.02 * gsd);
  // 1 m: GPS noise (0.5 m) in the fixes that place the frames and the mosaic's rounding to whole
  // pixels (0.23 m).
  EXPECT_LT(EdgeErrorM(m, TruthExtent(f)), 1.0);
  const std::string log = e2e::ReadText(f.dir / "build.log");
  EXPECT_NE(log.find("overviews"), std::string::npos) << log;
}

// The same flight run with a height 10 % low (--altitude 90 for 100 m): the odometry's track and
// footprints are 10 % short, so the map placed by that track (--place-by track) is off by metres
// at its edges (5.6 m at the west, where the geo-reference starts, 11.6 m at the east), whereas
// the map placed by the track optimised with the GPS fixes (the default) takes the scale from
// the fixes (the graph's common log-scale; odometry/flight_graph.h BackendOptions::gps_sigma_m).
// A run folder that was not optimised with its GPS cannot be placed by it: an error naming it.
TEST(MapBuild, PlacedByGpsWhereTheOdometryDrifts) {
  const MapFlight& f = Flight();
  ASSERT_EQ(f.simulate_rc, 0);
  const auto build = [&](const std::string& name, const std::string& flags) {
    return e2e::RunCli(fmt::format("map build {} --altitude 90 {} -q -o {}",
                                   (f.dir / "sim" / "video.mp4").string(), flags,
                                   (f.dir / (name + ".tif")).string()),
                       f.dir / (name + ".log")) >> 8;
  };
  ASSERT_EQ(build("low_gps", ""), 0) << e2e::ReadText(f.dir / "low_gps.log");
  ASSERT_EQ(build("low_track", "--place-by track"), 0) << e2e::ReadText(f.dir / "low_track.log");
  const std::array<double, 4> truth = TruthExtent(f);
  const double by_gps = EdgeErrorM(Info(f.dir / "low_gps.tif"), truth);
  const double by_track = EdgeErrorM(Info(f.dir / "low_track.tif"), truth);
  RecordProperty("edge_error_by_gps_m", fmt::format("{:.2f}", by_gps));
  RecordProperty("edge_error_by_track_m", fmt::format("{:.2f}", by_track));
  EXPECT_LT(by_gps, 1.0) << "by the track: " << by_track;
  EXPECT_GT(by_track, 5.0) << "by the GPS: " << by_gps;
  const fs::path log = f.dir / "low_again.log";
  EXPECT_EQ(e2e::RunCli(fmt::format("map build {} -o {}", (f.dir / "low_track_run").string(),
                                    (f.dir / "again.tif").string()),
                        log) >> 8,
            1);
  EXPECT_NE(e2e::ReadText(log).find("'" + (f.dir / "low_track_run").string() +
                                    "': cannot build a map from this run by its GPS"),
            std::string::npos)
      << e2e::ReadText(log);
}

TEST(MapBuild, ARunWithoutGeoReferenceIsAnErrorNamingIt) {
  const MapFlight& f = Flight();
  ASSERT_EQ(f.simulate_rc, 0);
  const fs::path run = f.dir / "denied";
  ASSERT_EQ(e2e::RunCli(fmt::format("run {} --gps-denied-after-s 0 --no-report -q -o {}",
                                    (f.dir / "sim" / "video.mp4").string(), run.string())),
            0);
  const fs::path log = f.dir / "denied.log";
  EXPECT_EQ(e2e::RunCli(fmt::format("map build {} -o {}", run.string(),
                                    (f.dir / "denied.tif").string()),
                        log) >> 8,
            1);
  const std::string text = e2e::ReadText(log);
  EXPECT_NE(text.find("'" + run.string() + "': cannot build a map from this run"),
            std::string::npos)
      << text;
  EXPECT_FALSE(fs::exists(f.dir / "denied.tif"));
  // `map info` on a file that is not a map: exit 1, the file named.
  const testing::CommandOutput c = testing::RunCommand(
      std::string(AEROVO_CLI_PATH) + " map info " + (run / "frames.csv").string() + " 2>&1");
  EXPECT_EQ(c.ExitCode(), 1);
  EXPECT_NE(c.out.find((run / "frames.csv").string() + "': not a raster"), std::string::npos)
      << c.out;
}

// `aerovo run --map`: the map is checked before the frames (an error naming a map that is
// corrupt or covers none of the flight) and its cover of the geo-referenced track is reported
// (summary.json "map", a warning when partial). The partial and the distant maps are the built
// map cut to its western half and moved 10 km east (gdal_translate, gdal-bin).
TEST(MapRun, TheMapIsCheckedAgainstTheFlightAndItsCoverReported) {
  const MapFlight& f = Flight();
  ASSERT_EQ(f.build_rc, 0);
  const std::string video = (f.dir / "sim" / "video.mp4").string();
  const auto run = [&](const std::string& map, const std::string& name) {
    const int rc = e2e::RunCli(fmt::format("run {} --map {} --no-report -q -o {}", video, map,
                                           (f.dir / name).string()),
                               f.dir / (name + ".log"));
    return rc >> 8;
  };
  ASSERT_EQ(run((f.dir / "map.tif").string(), "full"), 0);
  const nlohmann::json full = e2e::ReadJson(f.dir / "full" / "summary.json").at("map");
  EXPECT_GT(full.at("track_points").get<int>(), 20);
  EXPECT_EQ(full.at("covered"), full.at("track_points"));

  if (std::system("command -v gdal_translate > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "gdal_translate (gdal-bin) not installed: the partial and distant maps";
  }
  const nlohmann::json m = Info(f.dir / "map.tif");
  const int w = m.at("width_px"), h = m.at("height_px");
  const fs::path west = f.dir / "west.tif", far = f.dir / "far.tif";
  ASSERT_EQ(std::system(fmt::format("gdal_translate -q -srcwin 0 0 {} {} {} {}", w / 2, h,
                                    (f.dir / "map.tif").string(), west.string())
                            .c_str()),
            0);
  const nlohmann::json& e = m.at("extent_crs");
  ASSERT_EQ(std::system(fmt::format("gdal_translate -q -a_ullr {} {} {} {} {} {}",
                                    e.at("min_x").get<double>() + 10000.0,
                                    e.at("max_y").get<double>(),
                                    e.at("max_x").get<double>() + 10000.0,
                                    e.at("min_y").get<double>(), (f.dir / "map.tif").string(),
                                    far.string())
                            .c_str()),
            0);
  // The western half: the track's first half on it (0 to 60 m east; the half ends near 30 m).
  ASSERT_EQ(run(west.string(), "west"), 0) << e2e::ReadText(f.dir / "west.log");
  const nlohmann::json part = e2e::ReadJson(f.dir / "west" / "summary.json");
  const int covered = part.at("map").at("covered"), points = part.at("map").at("track_points");
  EXPECT_GT(covered, points / 4);
  EXPECT_LT(covered, 3 * points / 4);
  EXPECT_NE(e2e::ReadText(f.dir / "west.log").find("'" + west.string() + "': the map covers"),
            std::string::npos);
  // 10 km away: an error naming it, before any frame.
  EXPECT_EQ(run(far.string(), "far"), 1);
  EXPECT_NE(e2e::ReadText(f.dir / "far.log").find("'" + far.string() + "': the map covers none"),
            std::string::npos)
      << e2e::ReadText(f.dir / "far.log");
  // Not a map: an error naming it.
  const fs::path bad = f.dir / "bad.tif";
  std::ofstream(bad) << "not a GeoTIFF";
  EXPECT_EQ(run(bad.string(), "bad"), 1);
  EXPECT_NE(e2e::ReadText(f.dir / "bad.log").find("'" + bad.string() + "': not a raster"),
            std::string::npos)
      << e2e::ReadText(f.dir / "bad.log");
}

}  // namespace
}  // namespace aerovo::map_test
