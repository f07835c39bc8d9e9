// The geo products of `aerovo report` (report/geo_mosaic.h) on a short simulated flight: the
// GeoTIFF read back by GDAL's own gdalinfo (gdal-bin), the KMZ by unzip, mosaic_geo.png/.json
// (the report map's overlay); and the KML/GPX tracks of the run folder by ogrinfo. The flight is
// simulated, run and reported once per test process (~4 s); each test then reads files (< 1 s).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <pugixml.hpp>

#include "aerovo/geo/local_enu.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/report/geo_mosaic.h"
#include "aerovo/report/run_reader.h"

#include "e2e_testing.h"

namespace aerovo::geo_products_test {
namespace {

namespace fs = std::filesystem;

// stdout of `cmd`; *rc its exit status.
std::string Output(const std::string& cmd, int* rc = nullptr) {
  const testing::CommandOutput c = testing::RunCommand(cmd);
  if (rc) *rc = c.ExitCode();
  return c.out;
}

bool Have(const char* tool) {
  return std::system((std::string("command -v ") + tool + " > /dev/null 2>&1").c_str()) == 0;
}

using e2e::ReadText;

// Band values (R, G, B, A per point) of the GeoTIFF at "lon lat" lines (gdallocationinfo).
std::vector<int> TifValues(const fs::path& tif, const std::string& lon_lat_lines) {
  const fs::path in = tif.parent_path() / "points.txt";
  std::ofstream(in) << lon_lat_lines;
  std::stringstream out(Output("gdallocationinfo -wgs84 -valonly " + tif.string() + " < " +
                               in.string()));
  fs::remove(in);
  std::vector<int> v;
  for (int x = 0; out >> x;) v.push_back(x);
  return v;
}

class GeoProducts : public ::testing::Test {
 protected:
  // The lawnmower flight of html_report_test (2 legs of 120 m, 40 m apart, 100 m high, 400x300
  // frames at 1 fps: 31 frames), run and reported through the CLI.
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("aerovo_geo_products_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    const fs::path sim = root_ / "flight_42";
    const std::string cli = AEROVO_CLI_PATH;
    std::string cmd = cli +
                      " simulate --pattern lawnmower --legs 2 --length-m 120 --spacing-m 40 "
                      "--fps 1 --width 400 --height 300 --frames-only -q --out " +
                      sim.string() + " > /dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    run_ = root_ / "run";
    cmd = cli + " run " + (sim / "frames").string() + " --telemetry " +
          (sim / "telemetry.srt").string() + " --hfov-deg 73.7 -q --out " + run_.string() +
          " > /dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    cmd = cli + " report " + run_.string() + " 2>&1";
    int rc = 0;
    report_log_ = Output(cmd, &rc);
    ASSERT_EQ(rc, 0) << report_log_;
    data_ = ReadRunDir(run_);
    // The flight's mean GPS fix.
    int n = 0;
    for (const RunFrameRow& f : data_.frames) {
      if (!f.gps) continue;
      mean_gps_.lat_deg += f.gps->lat_deg;
      mean_gps_.lon_deg += f.gps->lon_deg;
      ++n;
    }
    ASSERT_GT(n, 20);
    mean_gps_.lat_deg /= n;
    mean_gps_.lon_deg /= n;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // Metres between (lat, lon) and the mean GPS fix (ENU at the mean fix).
  static double MetresFromMeanGps(double lat_deg, double lon_deg) {
    const LocalEnu enu(mean_gps_.lat_deg, mean_gps_.lon_deg, 0.0);
    return enu.Forward(lat_deg, lon_deg, 0.0).head<2>().norm();
  }

  static fs::path root_, run_;
  static std::string report_log_;
  static RunData data_;
  static GeoPoint mean_gps_;
};
fs::path GeoProducts::root_, GeoProducts::run_;
std::string GeoProducts::report_log_;
RunData GeoProducts::data_;
GeoPoint GeoProducts::mean_gps_{0.0, 0.0, 0.0};

// The criterion: the mosaic's centre within 100 m of the flight's mean GPS fix. The centre
// of the frames' bounding box is not the mean of the positions (13 m apart for this lawnmower),
// so the tight check is GeoTiffShowsEachFrameWhereGpsSaysItWas: pixels at the GPS fixes.
constexpr double kCentreToleranceM = 100.0;
constexpr double kCentreBboxToleranceM = 20.0;  // the mosaic's centre, this flight: 13 m

TEST_F(GeoProducts, ReportWritesEveryGeoFile) {
  for (const std::string& name : GeoMosaicFileNames::All()) {
    EXPECT_TRUE(fs::exists(run_ / name)) << name << "\n" << report_log_;
  }
  EXPECT_NE(report_log_.find("geo mosaic: mosaic.tif (UTM zone"), std::string::npos)
      << report_log_;
  // No temporary file left behind.
  for (const auto& e : fs::directory_iterator(run_)) {
    EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
  }
}

TEST_F(GeoProducts, GeoTiffIsNorthUpUtmCentredOnTheFlight) {
  if (!Have("gdalinfo")) GTEST_SKIP() << "gdalinfo (Debian gdal-bin) is not installed";
  int rc = 0;
  const std::string text = Output("gdalinfo -json " + (run_ / "mosaic.tif").string(), &rc);
  ASSERT_EQ(rc, 0) << text;
  const nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["driverShortName"], "GTiff");
  // The UTM zone of the flight's centre (the simulator flies at 24.03 E, 49.84 N: zone 35N).
  const std::string wkt = j["coordinateSystem"]["wkt"].get<std::string>();
  EXPECT_NE(wkt.find("UTM zone 35N"), std::string::npos) << wkt;
  EXPECT_NE(wkt.find("WGS 84"), std::string::npos) << wkt;
  EXPECT_EQ(j["stac"]["proj:epsg"].get<int>(), 32635);
  // North-up: no rotation terms, square pixels, y decreasing.
  const std::vector<double> gt = j["geoTransform"].get<std::vector<double>>();
  ASSERT_EQ(gt.size(), 6u);
  EXPECT_EQ(gt[2], 0.0);
  EXPECT_EQ(gt[4], 0.0);
  EXPECT_GT(gt[1], 0.1);
  EXPECT_LT(gt[1], 1.0);  // about the frames' own 0.37 m ground pixel at 100 m
  EXPECT_DOUBLE_EQ(gt[5], -gt[1]);
  // RGB + alpha.
  ASSERT_EQ(j["bands"].size(), 4u);
  EXPECT_EQ(j["bands"][3]["colorInterpretation"], "Alpha");
  // The centre (mean of the WGS84 corners) near the flight's mean GPS fix, and every fix inside.
  const nlohmann::json& ring = j["wgs84Extent"]["coordinates"][0];
  ASSERT_GE(ring.size(), 4u);
  double lat = 0, lon = 0, lat0 = 1e9, lat1 = -1e9, lon0 = 1e9, lon1 = -1e9;
  for (int i = 0; i < 4; ++i) {
    lon += ring[i][0].get<double>() / 4;
    lat += ring[i][1].get<double>() / 4;
    lon0 = std::min(lon0, ring[i][0].get<double>());
    lon1 = std::max(lon1, ring[i][0].get<double>());
    lat0 = std::min(lat0, ring[i][1].get<double>());
    lat1 = std::max(lat1, ring[i][1].get<double>());
  }
  EXPECT_LT(MetresFromMeanGps(lat, lon), kCentreToleranceM);
  EXPECT_LT(MetresFromMeanGps(lat, lon), kCentreBboxToleranceM);
  for (const RunFrameRow& f : data_.frames) {
    if (!f.gps) continue;
    EXPECT_GT(f.gps->lat_deg, lat0);
    EXPECT_LT(f.gps->lat_deg, lat1);
    EXPECT_GT(f.gps->lon_deg, lon0);
    EXPECT_LT(f.gps->lon_deg, lon1);
  }
  // Most pixels are covered (alpha), the corners of a lawnmower's bounding box are not all.
  cv::Mat tif = cv::imread((run_ / "mosaic.tif").string(), cv::IMREAD_UNCHANGED);
  if (!tif.empty() && tif.channels() == 4) {
    std::vector<cv::Mat> ch;
    cv::split(tif, ch);
    EXPECT_GT(cv::countNonZero(ch[3]), 0.6 * tif.total());
  }
}

// The geo-reference end to end: the simulator's GPS is its truth (no noise on this flight), so
// the GeoTIFF at each frame's GPS fix must show that frame's centre pixels (or a later frame's,
// drawn on top, of the same ground); 20 m east of the fixes it must not.
TEST_F(GeoProducts, GeoTiffShowsEachFrameWhereGpsSaysItWas) {
  if (!Have("gdallocationinfo")) GTEST_SKIP() << "gdallocationinfo (gdal-bin) is not installed";
  std::string at_fix, shifted;
  std::vector<cv::Vec3d> centre;  // R, G, B of each frame's 4 centre pixels
  for (const RunFrameRow& f : data_.frames) {
    if (!f.gps) continue;
    const cv::Mat img = cv::imread(
        (root_ / "flight_42" / "frames" / fmt::format("frame_{:06d}.jpg", f.frame)).string());
    ASSERT_FALSE(img.empty()) << f.frame;
    const cv::Scalar c = cv::mean(img(cv::Rect(img.cols / 2 - 1, img.rows / 2 - 1, 2, 2)));
    centre.emplace_back(c[2], c[1], c[0]);
    const LocalEnu enu(f.gps->lat_deg, f.gps->lon_deg, 0.0);
    const GeoPoint east = enu.Reverse(20.0, 0.0, 0.0);
    at_fix += fmt::format("{:.9f} {:.9f}\n", f.gps->lon_deg, f.gps->lat_deg);
    shifted += fmt::format("{:.9f} {:.9f}\n", east.lon_deg, east.lat_deg);
  }
  ASSERT_GT(centre.size(), 20u);
  auto median_diff = [&](const std::string& coords) {
    const std::vector<int> v = TifValues(run_ / "mosaic.tif", coords);
    EXPECT_EQ(v.size(), 4 * centre.size());
    std::vector<double> d;
    for (std::size_t i = 0; i < centre.size() && 4 * i + 3 < v.size(); ++i) {
      if (v[4 * i + 3] != 255) continue;
      d.push_back((std::abs(centre[i][0] - v[4 * i]) + std::abs(centre[i][1] - v[4 * i + 1]) +
                   std::abs(centre[i][2] - v[4 * i + 2])) / 3.0);
    }
    EXPECT_GT(d.size(), centre.size() / 2);
    std::sort(d.begin(), d.end());
    return d.empty() ? 1e9 : d[d.size() / 2];
  };
  const double at = median_diff(at_fix), off = median_diff(shifted);
  EXPECT_LT(at, 8.0);  // 2.4 measured: JPEG and resampling
  EXPECT_GT(off, 4.0 * at);  // 34 measured
  std::cout << "median |tif - frame centre| at the GPS fixes " << at << ", 20 m east " << off
            << " (grey levels)\n";
}

// run.kml as GDAL (and so QGIS) reads it: every frame of both tracks, named after the flight,
// time-stamped in order (the simulator's SRT gives absolute times).
TEST_F(GeoProducts, RunKmlListsTheVoAndGpsFeaturesInOgrinfo) {
  if (!Have("ogrinfo")) GTEST_SKIP() << "ogrinfo (Debian gdal-bin) is not installed";
  int rc = 0;
  const std::string out = Output("ogrinfo -ro -al " + (run_ / "run.kml").string() + " 2>&1", &rc);
  ASSERT_EQ(rc, 0) << out;
  int vo = 0, gps = 0, points = 0;
  std::vector<std::string> stamps;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    if (line.find("Name (String) = frames VO ") != std::string::npos) ++vo;
    if (line.find("Name (String) = frames GPS ") != std::string::npos) ++gps;
    if (line.find("POINT") != std::string::npos) ++points;
    if (const auto at = line.find("timestamp (DateTime) = "); at != std::string::npos) {
      stamps.push_back(line.substr(at + 23));
    }
  }
  const int frames = static_cast<int>(data_.frames.size());
  EXPECT_EQ(vo, frames) << out.substr(0, 2000);
  EXPECT_EQ(gps, frames);
  EXPECT_EQ(points, 2 * frames);
  ASSERT_EQ(static_cast<int>(stamps.size()), 2 * frames);
  // VO and GPS of one frame share its time; frames in order (1 fps).
  for (int i = 2; i < 2 * frames; i += 2) EXPECT_LT(stamps[i - 2], stamps[i]) << i;
  // The GPX tracks carry the same name and a <time> per point.
  const std::string gpx = ReadText(run_ / "vo.gpx");
  EXPECT_NE(gpx.find("<name>frames VO</name>"), std::string::npos);
  int times = 0;
  for (std::size_t p = gpx.find("<time>"); p != std::string::npos; p = gpx.find("<time>", p + 1)) {
    ++times;
  }
  EXPECT_EQ(times, frames);
  // The GPX 1.1 schema's structure (topografix.com/GPX/1/1/gpx.xsd): gpx@version="1.1" with its
  // namespace and a creator; trk = name, trkseg; trkpt@lat in [-90, 90], @lon in [-180, 180),
  // children ele then time (xsd:dateTime, UTC).
  for (const char* f : {"vo.gpx", "gps.gpx"}) {
    pugi::xml_document doc;
    ASSERT_TRUE(doc.load_file((run_ / f).c_str())) << f;
    const pugi::xml_node gpx_node = doc.child("gpx");
    EXPECT_STREQ(gpx_node.attribute("version").value(), "1.1");
    EXPECT_STREQ(gpx_node.attribute("xmlns").value(), "http://www.topografix.com/GPX/1/1");
    EXPECT_STRNE(gpx_node.attribute("creator").value(), "");
    const pugi::xml_node trk = gpx_node.child("trk");
    ASSERT_TRUE(trk) << f;
    EXPECT_STREQ(trk.first_child().name(), "name");
    EXPECT_STREQ(trk.first_child().next_sibling().name(), "trkseg");
    static const std::regex date_time(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z)");
    std::string last_time;
    int n = 0;
    for (const pugi::xml_node& pt : trk.child("trkseg").children()) {
      ASSERT_STREQ(pt.name(), "trkpt");
      const double lat = pt.attribute("lat").as_double(1e9), lon = pt.attribute("lon").as_double(1e9);
      EXPECT_TRUE(lat >= -90 && lat <= 90 && lon >= -180 && lon < 180) << lat << " " << lon;
      const pugi::xml_node ele = pt.first_child();
      EXPECT_STREQ(ele.name(), "ele");
      EXPECT_STREQ(ele.next_sibling().name(), "time");
      EXPECT_FALSE(ele.next_sibling().next_sibling());
      const std::string t = pt.child("time").text().get();
      EXPECT_TRUE(std::regex_match(t, date_time)) << t;
      EXPECT_LT(last_time, t);  // monotonic (ISO 8601 UTC sorts as text)
      last_time = t;
      ++n;
    }
    EXPECT_EQ(n, frames) << f;
  }
}

// <tag>value</tag> of `box`.
double Child(const pugi::xml_node& box, const char* tag) {
  return std::stod(box.child(tag).text().get());
}

TEST_F(GeoProducts, KmzUnzipsToAGroundOverlayAroundTheFlight) {
  if (!Have("unzip")) GTEST_SKIP() << "unzip is not installed";
  const std::string kmz = (run_ / "mosaic.kmz").string();
  int rc = 0;
  const std::string test_log = Output("unzip -t " + kmz, &rc);
  ASSERT_EQ(rc, 0) << test_log;
  const std::string listing = Output("unzip -Z1 " + kmz, &rc);
  EXPECT_EQ(listing, "doc.kml\nmosaic_geo.png\n");  // doc.kml first: what Google Earth opens
  const std::string kml = Output("unzip -p " + kmz + " doc.kml", &rc);
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_string(kml.c_str())) << kml;
  const pugi::xml_node overlay = doc.child("kml").child("Document").child("GroundOverlay");
  ASSERT_TRUE(overlay) << kml;
  EXPECT_STREQ(overlay.child("name").text().get(), "frames");  // the input's stem
  EXPECT_STREQ(overlay.child("Icon").child("href").text().get(), "mosaic_geo.png");
  const pugi::xml_node box = overlay.child("LatLonBox");
  const double n = Child(box, "north"), s = Child(box, "south"), e = Child(box, "east"),
               w = Child(box, "west");
  EXPECT_EQ(Child(box, "rotation"), 0.0);
  EXPECT_GT(n, s);
  EXPECT_GT(e, w);
  EXPECT_LT(MetresFromMeanGps(0.5 * (n + s), 0.5 * (e + w)), kCentreToleranceM);
  // The image inside decodes, RGBA.
  const std::string png = Output("unzip -p " + kmz + " mosaic_geo.png", &rc);
  const cv::Mat img = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.channels(), 4);
  // Same bounds as mosaic_geo.json (the map's overlay).
  const nlohmann::json j = nlohmann::json::parse(ReadText(run_ / "mosaic_geo.json"));
  EXPECT_NEAR(j["north"].get<double>(), n, 1e-8);
  EXPECT_NEAR(j["south"].get<double>(), s, 1e-8);
  EXPECT_NEAR(j["east"].get<double>(), e, 1e-8);
  EXPECT_NEAR(j["west"].get<double>(), w, 1e-8);
}

TEST_F(GeoProducts, GeoPngAndJsonAgreeWithTheGeoTiff) {
  const nlohmann::json j = nlohmann::json::parse(ReadText(run_ / "mosaic_geo.json"));
  EXPECT_EQ(j["image"], "mosaic_geo.png");
  const cv::Mat png = cv::imread((run_ / "mosaic_geo.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(png.empty());
  ASSERT_EQ(png.channels(), 4);
  EXPECT_EQ(png.cols, j["width_px"].get<int>());
  EXPECT_EQ(png.rows, j["height_px"].get<int>());
  EXPECT_LE(std::max(png.cols, png.rows), 2000);
  // Transparent outside the frames, opaque over most of the image.
  std::vector<cv::Mat> ch;
  cv::split(png, ch);
  const int covered = cv::countNonZero(ch[3]);
  EXPECT_GT(covered, 0.6 * png.total());
  EXPECT_LT(covered, png.total());
  EXPECT_EQ(ch[3].at<uchar>(0, 0) == 0 || ch[3].at<uchar>(0, png.cols - 1) == 0 ||
                ch[3].at<uchar>(png.rows - 1, 0) == 0 ||
                ch[3].at<uchar>(png.rows - 1, png.cols - 1) == 0,
            true);
  // The image's size in metres is its bounds' size.
  const double s = j["south"], w = j["west"], n = j["north"], e = j["east"];
  const double m = j["m_per_px"];
  const LocalEnu enu(0.5 * (s + n), 0.5 * (w + e), 0.0);
  EXPECT_NEAR(enu.Forward(n, 0.5 * (w + e), 0).y() - enu.Forward(s, 0.5 * (w + e), 0).y(),
              png.rows * m, 0.05);
  EXPECT_NEAR(enu.Forward(0.5 * (s + n), e, 0).x() - enu.Forward(0.5 * (s + n), w, 0).x(),
              png.cols * m, 0.05);
  EXPECT_LT(j["overlay_max_error_m"].get<double>(), 0.05);
  EXPECT_LT(MetresFromMeanGps(0.5 * (n + s), 0.5 * (e + w)), kCentreToleranceM);
  // Same pixels as the GeoTIFF at the same places (GDAL reads the tif at WGS84 positions; the
  // overlay is placed linearly between its bounds, as Leaflet and Google Earth do).
  if (!Have("gdallocationinfo")) GTEST_SKIP() << "gdallocationinfo (gdal-bin) is not installed";
  std::string coords;
  std::vector<cv::Point> at;
  for (int y = png.rows / 10; y < png.rows; y += png.rows / 10) {
    for (int x = png.cols / 10; x < png.cols; x += png.cols / 10) {
      if (ch[3].at<uchar>(y, x) != 255) continue;
      const double lon = w + (x + 0.5) / png.cols * (e - w);
      const double lat = n - (y + 0.5) / png.rows * (n - s);
      coords += fmt::format("{:.9f} {:.9f}\n", lon, lat);
      at.emplace_back(x, y);
    }
  }
  ASSERT_GT(at.size(), 40u);
  const std::vector<int> tif = TifValues(run_ / "mosaic.tif", coords);
  ASSERT_EQ(tif.size(), 4 * at.size());
  std::vector<double> diffs;
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (tif[4 * i + 3] != 255) continue;
    const cv::Vec4b p = png.at<cv::Vec4b>(at[i]);  // B, G, R, A
    diffs.push_back((std::abs(p[2] - tif[4 * i]) + std::abs(p[1] - tif[4 * i + 1]) +
                     std::abs(p[0] - tif[4 * i + 2])) / 3.0);
  }
  ASSERT_GT(diffs.size(), 40u);
  std::sort(diffs.begin(), diffs.end());
  EXPECT_LT(diffs[diffs.size() / 2], 8.0);  // median: interpolation of two resamplings
}

TEST_F(GeoProducts, RunWithoutGeoReferenceGetsANoteAndNoFiles) {
  RunData local = data_;
  for (RunFrameRow& f : local.frames) f.geo.reset();
  const fs::path out = root_ / "not_geo";
  fs::create_directories(out);
  const GeoMosaicResult r = WriteGeoMosaic(local, out, "x");
  EXPECT_FALSE(r.written);
  EXPECT_NE(r.note.find("not geo-referenced"), std::string::npos) << r.note;
  EXPECT_EQ(r.note.find('\n'), std::string::npos);
  EXPECT_TRUE(fs::is_empty(out));
}

}  // namespace
}  // namespace aerovo::geo_products_test
