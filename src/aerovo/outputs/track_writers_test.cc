#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pugixml.hpp>

#include "aerovo/core/error.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/outputs/track_writers.h"

namespace aerovo::track_writers_test {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// A fresh folder under the system temp dir, removed at the end of the test.
class TrackWritersTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           (std::string("aerovo_track_writers_") + info->name() + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  EXPECT_TRUE(in.good()) << p;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> Lines(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string line; std::getline(ss, line);) out.push_back(line);
  return out;
}

// Minimal XML 1.0 well-formedness check: one root element, every start tag closed in order,
// attributes quoted, no stray '<' or unknown entity in text, nothing but whitespace outside
// the root. Each step reads one item at i_ and returns "" when it is well-formed, else the
// problem; the first root element's name goes to *root when root is given.
class XmlScanner {
 public:
  XmlScanner(const std::string& s, std::string* root) : s_(s), root_(root) {}

  // The whole document: "" when well-formed, else the first problem.
  std::string Run() {
    while (i_ < s_.size()) {
      std::string problem;
      if (s_[i_] != '<') {
        problem = Text();
      } else if (s_.compare(i_, 2, "<?") == 0) {
        problem = ProcessingInstruction();
      } else if (s_.compare(i_, 4, "<!--") == 0) {
        problem = Comment();
      } else if (s_.compare(i_, 2, "</") == 0) {
        problem = EndTag();
      } else {
        problem = StartTag();
      }
      if (!problem.empty()) return problem;
    }
    if (!stack_.empty()) return "unclosed <" + stack_.back() + ">";
    if (!root_done_) return "no root element";
    return "";
  }

 private:
  // Whether c may be part of a tag or attribute name.
  static bool NameChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' ||
           c == '.';
  }

  // "" when every '&' in text starts one of XML's five entities or a character reference.
  static std::string CheckEntities(const std::string& text) {
    static const std::regex entity("&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
    for (size_t k = text.find('&'); k != std::string::npos; k = text.find('&', k + 1)) {
      std::smatch m;
      const std::string rest = text.substr(k);
      if (!std::regex_search(rest, m, entity, std::regex_constants::match_continuous)) {
        return "bad entity at " + rest.substr(0, 10);
      }
    }
    return "";
  }

  // Character data up to the next '<' (or the end).
  std::string Text() {
    const size_t next = s_.find('<', i_);
    const std::string text =
        s_.substr(i_, next == std::string::npos ? std::string::npos : next - i_);
    if (stack_.empty() && text.find_first_not_of(" \t\r\n") != std::string::npos) {
      return "text outside the root element: " + text.substr(0, 20);
    }
    if (std::string e = CheckEntities(text); !e.empty()) return e;
    if (text.find('>') != std::string::npos && stack_.empty()) return "stray '>'";
    i_ = next == std::string::npos ? s_.size() : next;
    return "";
  }

  // "<?...?>"; the XML declaration only at the very start.
  std::string ProcessingInstruction() {
    const size_t e = s_.find("?>", i_);
    if (e == std::string::npos) return "unterminated processing instruction";
    if (i_ != 0 && s_.compare(i_, 5, "<?xml") == 0) return "XML declaration not at the start";
    i_ = e + 2;
    return "";
  }

  // "<!--...-->".
  std::string Comment() {
    const size_t e = s_.find("-->", i_);
    if (e == std::string::npos) return "unterminated comment";
    i_ = e + 3;
    return "";
  }

  // "</name>", which must close the innermost open element.
  std::string EndTag() {
    size_t k = i_ + 2;
    while (k < s_.size() && NameChar(s_[k])) ++k;
    const std::string name = s_.substr(i_ + 2, k - i_ - 2);
    while (k < s_.size() && std::isspace(static_cast<unsigned char>(s_[k]))) ++k;
    if (k >= s_.size() || s_[k] != '>') return "bad end tag " + name;
    if (stack_.empty() || stack_.back() != name) {
      return "end tag </" + name + "> does not match <" + (stack_.empty() ? "" : stack_.back()) +
             ">";
    }
    stack_.pop_back();
    if (stack_.empty()) root_done_ = true;
    i_ = k + 1;
    return "";
  }

  // "<name attributes>" (opens an element) or "<name attributes/>" (an empty element).
  std::string StartTag() {
    size_t k = i_ + 1;
    while (k < s_.size() && NameChar(s_[k])) ++k;
    const std::string name = s_.substr(i_ + 1, k - i_ - 1);
    if (name.empty()) return "empty tag name";
    if (root_done_ || (stack_.empty() && root_ && !root_->empty())) {
      return "second root <" + name + ">";
    }
    if (stack_.empty() && root_) *root_ = name;
    if (std::string e = Attributes(name, &k); !e.empty()) return e;
    if (s_[k] == '/') {
      i_ = k + 2;
      if (stack_.empty()) root_done_ = true;
    } else {
      stack_.push_back(name);
      i_ = k + 1;
    }
    return "";
  }

  // The attributes of start tag <name from *k on; leaves *k at its '>' or "/>".
  std::string Attributes(const std::string& name, size_t* k_io) {
    size_t& k = *k_io;
    for (;;) {
      while (k < s_.size() && std::isspace(static_cast<unsigned char>(s_[k]))) ++k;
      if (k >= s_.size()) return "unterminated tag <" + name;
      if (s_[k] == '>' || s_.compare(k, 2, "/>") == 0) return "";
      const size_t a = k;
      while (k < s_.size() && NameChar(s_[k])) ++k;
      if (k == a || k >= s_.size() || s_[k] != '=') return "bad attribute in <" + name + ">";
      ++k;
      if (k >= s_.size() || (s_[k] != '"' && s_[k] != '\''))
        return "unquoted attribute in <" + name;
      const char q = s_[k];
      const size_t e = s_.find(q, k + 1);
      if (e == std::string::npos) return "unterminated attribute in <" + name;
      const std::string value = s_.substr(k + 1, e - k - 1);
      if (value.find('<') != std::string::npos) return "'<' in attribute of <" + name;
      if (std::string err = CheckEntities(value); !err.empty()) return err;
      k = e + 1;
    }
  }

  const std::string& s_;
  std::string* root_;
  std::vector<std::string> stack_;  // names of the open elements, innermost last
  bool root_done_ = false;          // the root element has been closed
  size_t i_ = 0;                    // read position in s_
};

// "" when s is a well-formed XML document (XmlScanner), else the first problem; the root
// element's name goes to *root when given.
std::string XmlProblem(const std::string& s, std::string* root = nullptr) {
  return XmlScanner(s, root).Run();
}

TEST(XmlChecker, DetectsMalformedDocuments) {
  std::string root;
  EXPECT_EQ(XmlProblem("<?xml version=\"1.0\"?>\n<a x=\"1\"><b/>t &amp; u<c></c></a>\n", &root),
            "");
  EXPECT_EQ(root, "a");
  EXPECT_NE(XmlProblem("<a><b></a></b>"), "");
  EXPECT_NE(XmlProblem("<a><b></b>"), "");
  EXPECT_NE(XmlProblem("<a></a><a></a>"), "");
  EXPECT_NE(XmlProblem("<a x=1></a>"), "");
  EXPECT_NE(XmlProblem("<a>fish & chips</a>"), "");
  EXPECT_NE(XmlProblem("<a></a>trailing"), "");
  EXPECT_NE(XmlProblem(""), "");
}

// Everything parsed back from a run folder.
struct Parsed {
  std::vector<std::vector<std::string>> csv_rows;  // without the header
  std::vector<std::vector<double>> vo_tum, gps_tum;
  json vo_geojson, gps_geojson, frames_geojson;
  std::vector<GeoPoint> vo_kml, gps_kml;
  std::vector<GeoPoint> vo_gpx, gps_gpx;
  std::vector<std::string> gps_gpx_times;
};

std::vector<std::vector<double>> ParseTum(const fs::path& p) {
  std::vector<std::vector<double>> rows;
  for (const std::string& line : Lines(Slurp(p))) {
    std::stringstream ss(line);
    std::vector<double> v;
    for (double x; ss >> x;) v.push_back(x);
    EXPECT_TRUE(ss.eof()) << "non-numeric token in " << p << ": " << line;
    EXPECT_EQ(v.size(), 8u) << line;
    rows.push_back(v);
  }
  return rows;
}

std::vector<GeoPoint> ParseKml(const fs::path& p) {
  const std::string s = Slurp(p);
  std::string root;
  EXPECT_EQ(XmlProblem(s, &root), "") << p << "\n" << s;
  EXPECT_EQ(root, "kml");
  std::vector<GeoPoint> out;
  const size_t a = s.find("<coordinates>");
  if (a == std::string::npos) return out;
  const size_t b = s.find("</coordinates>", a);
  std::stringstream ss(s.substr(a + 13, b - a - 13));
  for (std::string tuple; ss >> tuple;) {
    GeoPoint g;
    char c1 = 0, c2 = 0;
    std::stringstream ts(tuple);
    ts >> g.lon_deg >> c1 >> g.lat_deg;
    EXPECT_TRUE(c1 == ',' && !ts.fail()) << tuple;
    g.alt_m = std::nan("");  // lon,lat: no altitude
    if (ts >> c2) {
      ts >> g.alt_m;
      EXPECT_TRUE(c2 == ',' && !ts.fail()) << tuple;
    }
    out.push_back(g);
  }
  return out;
}

std::vector<GeoPoint> ParseGpx(const fs::path& p, std::vector<std::string>* times = nullptr) {
  const std::string s = Slurp(p);
  std::string root;
  EXPECT_EQ(XmlProblem(s, &root), "") << p << "\n" << s;
  EXPECT_EQ(root, "gpx");
  std::vector<GeoPoint> out;
  static const std::regex pt(
      "<trkpt lat=\"([-0-9.]+)\" lon=\"([-0-9.]+)\">(<ele>([-0-9.]+)</ele>)?(<time>([^<]+)</time>)?"
      "</trkpt>");
  for (auto it = std::sregex_iterator(s.begin(), s.end(), pt); it != std::sregex_iterator(); ++it) {
    out.push_back({std::stod((*it)[1]), std::stod((*it)[2]),
                   (*it)[4].matched ? std::stod((*it)[4]) : std::nan("")});
    if (times) times->push_back((*it)[6]);
  }
  size_t n_trkpt = 0;
  for (size_t k = s.find("<trkpt"); k != std::string::npos; k = s.find("<trkpt", k + 1)) ++n_trkpt;
  EXPECT_EQ(out.size(), n_trkpt);
  return out;
}

Parsed ParseRun(const fs::path& dir) {
  Parsed r;
  const auto csv_lines = Lines(Slurp(dir / "frames.csv"));
  EXPECT_GE(csv_lines.size(), 1u);
  if (!csv_lines.empty()) {
    EXPECT_EQ(csv_lines[0], CsvFrameFormat::Header());
  }
  for (size_t i = 1; i < csv_lines.size(); ++i) {
    std::vector<std::string> cells;
    std::stringstream ss(csv_lines[i]);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (!csv_lines[i].empty() && csv_lines[i].back() == ',') cells.emplace_back();
    r.csv_rows.push_back(cells);
  }
  r.vo_tum = ParseTum(dir / "vo.tum");
  r.gps_tum = ParseTum(dir / "gps.tum");
  r.vo_geojson = json::parse(Slurp(dir / "vo.geojson"));  // throws (test error) if invalid
  r.gps_geojson = json::parse(Slurp(dir / "gps.geojson"));
  r.frames_geojson = json::parse(Slurp(dir / "vo_frames.geojson"));
  r.vo_kml = ParseKml(dir / "vo.kml");
  r.gps_kml = ParseKml(dir / "gps.kml");
  r.vo_gpx = ParseGpx(dir / "vo.gpx");
  r.gps_gpx = ParseGpx(dir / "gps.gpx", &r.gps_gpx_times);
  std::string root;
  EXPECT_EQ(XmlProblem(Slurp(dir / "run.kml"), &root), "");
  return r;
}

// Coordinates of the single track feature of a GeoJSON file (RFC 7946 order: lon, lat, alt).
std::vector<GeoPoint> GeoJsonTrack(const json& fc) {
  EXPECT_EQ(fc.at("type"), "FeatureCollection");
  std::vector<GeoPoint> out;
  const json& features = fc.at("features");
  if (features.empty()) return out;
  EXPECT_EQ(features.size(), 1u);
  const json& g = features[0].at("geometry");
  if (g.at("type") == "Point") {
    const json& c = g.at("coordinates");
    out.push_back({c[1].get<double>(), c[0].get<double>(), c[2].get<double>()});
  } else {
    EXPECT_EQ(g.at("type"), "LineString");
    EXPECT_GE(g.at("coordinates").size(), 2u);
    for (const json& c : g.at("coordinates")) {
      out.push_back({c[1].get<double>(), c[0].get<double>(), c[2].get<double>()});
    }
  }
  return out;
}

// A synthetic flight near Kyiv: 0.7 m/s east-north-east; lat/lon carry digits down to 1e-9 deg
// so that the files must keep at least that precision.
FrameRecord MakeRecord(int i) {
  FrameRecord r;
  r.frame = 3 * i;
  r.time_s = 0.1 * r.frame;
  r.x_m = 0.7 * i;
  r.y_m = 0.3 * i - 2.0;
  r.z_m = 50.0;
  r.yaw_rad = 0.05 * i;
  if (i % 5 != 3) r.geo = GeoPoint{50.4500000001 + 2.7e-6 * i, 30.5200000009 + 6.1e-6 * i, 180.25};
  r.n_surf = 1000 + i;
  r.n_matched = 400 + i;
  r.n_inliers = 300 + i;
  r.cluster = i % 3 - 1;
  r.detect_ms = 12.5;
  r.describe_ms = 8.25;
  r.correspond_ms = 30.0;
  r.estimate_ms = 2.125;
  r.total_ms = 52.875;
  r.status = i == 4 ? "bridged, dark" : "ok";
  if (i % 3 != 1) r.latency_ms = 20.0 + 0.125 * i;  // else NaN: not measured (empty cell)
  if (i % 2 == 0) {  // else no camera attitude applied (empty cells)
    r.camera_roll_deg = -1.5 + 0.25 * i;
    r.camera_pitch_deg = 15.0 - 0.5 * i;
  }
  return r;
}
std::optional<GeoPoint> MakeGps(int i) {
  if (i % 4 == 2) return std::nullopt;
  return GeoPoint{50.4500000007 + 2.69e-6 * i, 30.5199999993 + 6.11e-6 * i, 181.5 + 0.01 * i};
}

// What a test has appended to a TrackWriterSet so far: the records, their geo positions (VO
// track) and the GPS fixes with their record times in seconds.
struct Appended {
  std::vector<FrameRecord> records;
  std::vector<GeoPoint> vo_geo, gps_geo;
  std::vector<double> gps_t;
};

// Appends MakeRecord(i) with MakeGps(i) to `set` and to `a`.
void AppendRecord(int i, TrackWriterSet& set, Appended& a) {
  a.records.push_back(MakeRecord(i));
  const std::optional<GeoPoint> gps = MakeGps(i);
  set.Append(a.records.back(), gps);
  if (a.records.back().geo) a.vo_geo.push_back(*a.records.back().geo);
  if (gps) a.gps_geo.push_back(*gps), a.gps_t.push_back(a.records.back().time_s);
}

// Fatal failure unless the CSV and TUM files hold one row per appended record / GPS fix.
void AssertTableRowCounts(const Parsed& p, const Appended& a) {
  ASSERT_EQ(p.csv_rows.size(), a.records.size());
  ASSERT_EQ(p.vo_tum.size(), a.records.size());
  ASSERT_EQ(p.gps_tum.size(), a.gps_geo.size());
}

// Fatal failure unless every track file (GeoJSON points vo_json, gps_json; KML, GPX) holds one
// point per appended geo position / GPS fix.
void AssertTrackPointCounts(const Parsed& p, const std::vector<GeoPoint>& vo_json,
                            const std::vector<GeoPoint>& gps_json, const Appended& a) {
  ASSERT_EQ(vo_json.size(), a.vo_geo.size());
  ASSERT_EQ(gps_json.size(), a.gps_geo.size());
  ASSERT_EQ(p.frames_geojson.at("features").size(), a.vo_geo.size());
  ASSERT_EQ(p.vo_kml.size(), a.vo_geo.size());
  ASSERT_EQ(p.gps_kml.size(), a.gps_geo.size());
  ASSERT_EQ(p.vo_gpx.size(), a.vo_geo.size());
  ASSERT_EQ(p.gps_gpx.size(), a.gps_geo.size());
}

// The VO track in GeoJSON (vo_json, 1e-9 deg), KML and GPX (1e-7 deg, 1 mm) and the per-frame
// GeoJSON points match the appended geo positions vo_geo (degrees, metres).
void ExpectVoTrack(const Parsed& p, const std::vector<GeoPoint>& vo_json,
                   const std::vector<GeoPoint>& vo_geo) {
  for (size_t k = 0; k < vo_geo.size(); ++k) {
    // GeoJSON with 9 decimals, KML and GPX with 7 (1 cm) and heights in mm.
    EXPECT_NEAR(vo_json[k].lat_deg, vo_geo[k].lat_deg, 1e-9);
    EXPECT_NEAR(vo_json[k].lon_deg, vo_geo[k].lon_deg, 1e-9);
    EXPECT_NEAR(vo_json[k].alt_m, vo_geo[k].alt_m, 1e-4);
    for (const GeoPoint& got : {p.vo_kml[k], p.vo_gpx[k]}) {
      EXPECT_NEAR(got.lat_deg, vo_geo[k].lat_deg, 0.51e-7);
      EXPECT_NEAR(got.lon_deg, vo_geo[k].lon_deg, 0.51e-7);
      EXPECT_NEAR(got.alt_m, vo_geo[k].alt_m, 0.51e-3);
    }
    const json& f = p.frames_geojson["features"][k];
    EXPECT_EQ(f["geometry"]["type"], "Point");
    EXPECT_NEAR(f["geometry"]["coordinates"][0].get<double>(), vo_geo[k].lon_deg, 1e-9);
  }
}

// The GPS track in GeoJSON (gps_json), KML and GPX matches the appended fixes as ExpectVoTrack,
// the GPX times are time_origin_unix_s + the record times (ISO 8601 UTC), and gps.tum holds the
// record times (s) and the fixes in `enu` (m, 1e-6).
void ExpectGpsTrack(const Parsed& p, const std::vector<GeoPoint>& gps_json, const Appended& a,
                    const LocalEnu& enu, double time_origin_unix_s) {
  const std::vector<GeoPoint>& gps_geo = a.gps_geo;
  const std::vector<double>& gps_t = a.gps_t;
  for (size_t k = 0; k < gps_geo.size(); ++k) {
    // GeoJSON with 9 decimals, KML and GPX with 7 (1 cm) and heights in mm.
    EXPECT_NEAR(gps_json[k].lat_deg, gps_geo[k].lat_deg, 1e-9);
    EXPECT_NEAR(gps_json[k].lon_deg, gps_geo[k].lon_deg, 1e-9);
    EXPECT_NEAR(gps_json[k].alt_m, gps_geo[k].alt_m, 1e-4);
    for (const GeoPoint& got : {p.gps_kml[k], p.gps_gpx[k]}) {
      EXPECT_NEAR(got.lat_deg, gps_geo[k].lat_deg, 0.51e-7);
      EXPECT_NEAR(got.lon_deg, gps_geo[k].lon_deg, 0.51e-7);
      EXPECT_NEAR(got.alt_m, gps_geo[k].alt_m, 0.51e-3);
    }
    EXPECT_EQ(p.gps_gpx_times[k], FormatUtcIso8601(time_origin_unix_s + gps_t[k]));
    const Eigen::Vector3d e = enu.Forward(gps_geo[k]);
    EXPECT_NEAR(p.gps_tum[k][0], gps_t[k], 1e-6);
    EXPECT_NEAR(p.gps_tum[k][1], e.x(), 1e-6);
    EXPECT_NEAR(p.gps_tum[k][2], e.y(), 1e-6);
    EXPECT_NEAR(p.gps_tum[k][3], e.z(), 1e-6);
  }
}

// vo.tum row `t` holds record r's time (s), position (m) and yaw (rad) as a unit quaternion
// about z.
void ExpectVoTumRow(const std::vector<double>& t, const FrameRecord& r) {
  EXPECT_NEAR(t[0], r.time_s, 1e-6);
  EXPECT_NEAR(t[1], r.x_m, 1e-6);
  EXPECT_NEAR(t[2], r.y_m, 1e-6);
  EXPECT_NEAR(t[3], r.z_m, 1e-6);
  EXPECT_EQ(t[4], 0.0);
  EXPECT_EQ(t[5], 0.0);
  EXPECT_NEAR(2.0 * std::atan2(t[6], t[7]), r.yaw_rad, 1e-8);
  EXPECT_NEAR(t[6] * t[6] + t[7] * t[7], 1.0, 1e-8);
}

// frames.csv row `c` (cells split at commas) holds record r's fields; fatal failure when it has
// the wrong number of cells (one more when the status holds a comma).
void AssertCsvRow(const std::vector<std::string>& c, const FrameRecord& r) {
  ASSERT_EQ(c.size(), r.status.find(',') != std::string::npos ? 29u : 28u);
  const std::size_t latency = c.size() - 3;
  if (std::isnan(r.latency_ms)) {
    EXPECT_EQ(c[latency], "") << "latency_ms";
  } else {
    EXPECT_NEAR(std::stod(c[latency]), r.latency_ms, 1e-3);
  }
  if (r.camera_roll_deg && r.camera_pitch_deg) {
    EXPECT_NEAR(std::stod(c[c.size() - 2]), *r.camera_roll_deg, 1e-4);
    EXPECT_NEAR(std::stod(c[c.size() - 1]), *r.camera_pitch_deg, 1e-4);
  } else {
    EXPECT_EQ(c[c.size() - 2], "") << "camera_roll_deg";
    EXPECT_EQ(c[c.size() - 1], "") << "camera_pitch_deg";
  }
  EXPECT_EQ(std::stoi(c[0]), r.frame);
  EXPECT_NEAR(std::stod(c[1]), r.time_s, 1e-6);
  EXPECT_NEAR(std::stod(c[2]), r.x_m, 1e-4);
  EXPECT_NEAR(std::stod(c[3]), r.y_m, 1e-4);
  if (r.geo) {
    EXPECT_NEAR(std::stod(c[4]), r.geo->lat_deg, 1e-9);
    EXPECT_NEAR(std::stod(c[5]), r.geo->lon_deg, 1e-9);
  } else {
    EXPECT_EQ(c[4], "");
    EXPECT_EQ(c[6], "");
  }
  EXPECT_EQ(std::stoi(c[9]), r.n_inliers);
  EXPECT_EQ(std::stoi(c[10]), r.cluster);
  EXPECT_NEAR(std::stod(c[15]), r.total_ms, 1e-3);
  if (r.status == "ok") {
    EXPECT_EQ(c[16], "ok");
  }
}

// Every appended record is in vo.tum and frames.csv (fatal failure at the first CSV row of the
// wrong length).
void AssertRecordRows(const Parsed& p, const std::vector<FrameRecord>& records) {
  for (size_t k = 0; k < records.size(); ++k) {
    ExpectVoTumRow(p.vo_tum[k], records[k]);
    ASSERT_NO_FATAL_FAILURE(AssertCsvRow(p.csv_rows[k], records[k]));
  }
}

// Every file of the run folder `dir` parses and holds exactly what `a` says was appended, with
// times from time_origin_unix_s and local positions in `enu`; fatal failure on a count mismatch.
void AssertRunFolderHolds(const fs::path& dir, const Appended& a, const LocalEnu& enu,
                          double time_origin_unix_s) {
  const Parsed p = ParseRun(dir);
  ASSERT_NO_FATAL_FAILURE(AssertTableRowCounts(p, a));
  const std::vector<GeoPoint> vo_json = GeoJsonTrack(p.vo_geojson);
  const std::vector<GeoPoint> gps_json = GeoJsonTrack(p.gps_geojson);
  ASSERT_NO_FATAL_FAILURE(AssertTrackPointCounts(p, vo_json, gps_json, a));
  ExpectVoTrack(p, vo_json, a.vo_geo);
  ExpectGpsTrack(p, gps_json, a, enu, time_origin_unix_s);
  ASSERT_NO_FATAL_FAILURE(AssertRecordRows(p, a.records));
}

// xmllint, when installed, agrees that the XML files of run folder `dir` are well-formed.
void ExpectXmllintAccepts(const fs::path& dir) {
  if (std::system("command -v xmllint >/dev/null 2>&1") == 0) {
    for (const char* f : {"vo.kml", "gps.kml", "run.kml", "vo.gpx", "gps.gpx"}) {
      const std::string cmd = "xmllint --noout '" + (dir / f).string() + "' 2>&1";
      EXPECT_EQ(std::system(cmd.c_str()), 0) << f;
    }
  }
}

TEST_F(TrackWritersTest, EveryFileValidAfterEveryAppend) {
  TrackWriterOptions o;
  o.enu_origin = GeoPoint{50.45, 30.52, 180.0};
  o.time_origin_unix_s = 1600000000.25;  // 2020-09-13T12:26:40.250Z
  o.run_name = "test <run> & co";
  TrackWriterSet set(dir_, o);
  EXPECT_EQ(set.Files().size(), 12u);
  for (const fs::path& f : set.Files()) EXPECT_TRUE(fs::exists(f)) << f;
  const LocalEnu enu(*o.enu_origin);

  Appended appended;
  for (int i = 0; i <= 24; ++i) {
    // Read everything *before* this append too: the state an interrupted run leaves.
    ASSERT_NO_FATAL_FAILURE(AssertRunFolderHolds(dir_, appended, enu, 1600000000.25));
    if (i == 24) break;
    AppendRecord(i, set, appended);
  }
  EXPECT_EQ(set.num_records(), 24);
  // The quoted status survives as one CSV field.
  const std::string csv = Slurp(dir_ / "frames.csv");
  EXPECT_NE(csv.find(",\"bridged, dark\","), std::string::npos);
  // Names are XML-escaped.
  EXPECT_NE(Slurp(dir_ / "vo.kml").find("test &lt;run&gt; &amp; co VO"), std::string::npos);
  set.Close();
  set.Close();  // idempotent
  EXPECT_THROW(set.Append(MakeRecord(30)), InvalidArgument);
  const Parsed after = ParseRun(dir_);  // still valid after Close
  EXPECT_EQ(after.csv_rows.size(), 24u);

  ExpectXmllintAccepts(dir_);
}

// A rejected fix (gps_flag set) is kept, flagged, in frames.csv and left out of every GPS track.
TEST_F(TrackWritersTest, RejectedFixStaysInTheCsvAndOutOfTheGpsTracks) {
  TrackWriterOptions o;
  o.enu_origin = GeoPoint{50.45, 30.52, 180.0};
  o.time_origin_unix_s = 1600000000.0;
  {
    TrackWriterSet set(dir_, o);
    for (int i = 0; i < 4; ++i) {
      FrameRecord r = MakeRecord(i);
      r.geo = GeoPoint{50.45 + 1e-5 * i, 30.52, 180.0};
      std::optional<GeoPoint> gps = GeoPoint{50.45 + 1e-5 * i, 30.52, 181.0};
      if (i == 2) {
        gps = GeoPoint{50.46, 30.52, 181.0};  // 1.1 km off
        r.gps_flag = "rejected_jump";
      }
      set.Append(r, gps);
    }
  }
  const Parsed p = ParseRun(dir_);
  ASSERT_EQ(p.csv_rows.size(), 4u);
  EXPECT_EQ(p.gps_tum.size(), 3u);
  const std::vector<GeoPoint> gps_json = GeoJsonTrack(p.gps_geojson);
  ASSERT_EQ(gps_json.size(), 3u);
  for (const GeoPoint& g : gps_json) EXPECT_LT(g.lat_deg, 50.455);
  ASSERT_EQ(p.gps_kml.size(), 3u);
  ASSERT_EQ(p.gps_gpx.size(), 3u);
  for (const GeoPoint& g : p.gps_kml) EXPECT_LT(g.lat_deg, 50.455);
  for (const GeoPoint& g : p.gps_gpx) EXPECT_LT(g.lat_deg, 50.455);
  const std::string csv = Slurp(dir_ / RunFileNames::kFramesCsv);
  EXPECT_NE(csv.find("rejected_jump"), std::string::npos);
  EXPECT_NE(csv.find("50.46"), std::string::npos);
}

// The ENU origin set after the writers were opened (the run's first accepted fix, known frames
// later): gps.tum is in that frame, starting at (0, 0) at the origin fix; a rejected fix written
// before it does not prevent it; a second origin, or one after a GPS row, is refused.
TEST_F(TrackWritersTest, EnuOriginSetLaterIsTheFrameOfGpsTum) {
  const GeoPoint origin{50.45, 30.52, 181.0};
  {
    TrackWriterSet set(dir_);
    EXPECT_FALSE(set.has_enu_origin());
    FrameRecord bad = MakeRecord(0);
    bad.gps_flag = "rejected:superseded";
    set.Append(bad, GeoPoint{50.46, 30.52, 181.0});  // 1.1 km off, rejected: not in gps.tum
    set.SetEnuOrigin(origin);
    EXPECT_TRUE(set.has_enu_origin());
    EXPECT_THROW(set.SetEnuOrigin(origin), InvalidArgument);
    for (int i = 1; i < 4; ++i) {
      set.Append(MakeRecord(i), GeoPoint{50.45 + 1e-5 * (i - 1), 30.52, 181.0});
    }
    EXPECT_EQ(set.csv_rows(), 4);
  }
  const Parsed p = ParseRun(dir_);
  ASSERT_EQ(p.gps_tum.size(), 3u);
  EXPECT_NEAR(p.gps_tum[0][1], 0.0, 1e-6);
  EXPECT_NEAR(p.gps_tum[0][2], 0.0, 1e-6);
  EXPECT_NEAR(p.gps_tum[2][2], 2.22, 0.01);  // 2e-5 deg of latitude north
  // Too late: a fix already went into the GPS tracks without a frame.
  fs::remove_all(dir_);
  TrackWriterSet late(dir_);
  late.Append(MakeRecord(0), origin);
  EXPECT_THROW(late.SetEnuOrigin(origin), InvalidArgument);
}

// run.kml: both tracks as time-stamped points, valid after every append; the Style children in
// the OGC KML 2.2 order (every Style aerovo writes); the flight's name; 7 decimals.
TEST_F(TrackWritersTest, RunKmlHasTimeStampedPointsOfBothTracks) {
  TrackWriterOptions o;
  o.time_origin_unix_s = 1600000000.25;
  o.run_name = "DJI_0042";
  TrackWriterSet set(dir_, o);
  for (int i = 0; i < 6; ++i) {
    FrameRecord r;
    r.frame = i;
    r.time_s = 0.5 * i;
    r.geo = GeoPoint{50.45 + 1e-5 * i, 30.52, 180.0};
    set.Append(r, i % 2 == 0 ? std::optional<GeoPoint>(GeoPoint{50.45, 30.52 + 1e-5 * i, 181.0})
                             : std::nullopt);
    pugi::xml_document doc;
    ASSERT_TRUE(doc.load_file((dir_ / "run.kml").c_str())) << i;
    EXPECT_EQ(doc.select_nodes("//Placemark").size(), static_cast<size_t>(i + 1 + i / 2 + 1));
  }
  set.Close();
  pugi::xml_document doc;
  ASSERT_TRUE(doc.load_file((dir_ / "run.kml").c_str()));
  EXPECT_STREQ(doc.child("kml").child("Document").child("name").text().get(), "DJI_0042");
  std::map<std::string, std::vector<std::string>> when;  // per track
  for (const pugi::xpath_node& n : doc.select_nodes("//Placemark")) {
    const std::string name = n.node().child("name").text().get();
    ASSERT_EQ(name.rfind("DJI_0042 ", 0), 0u) << name;
    const std::string track = name.find(" GPS ") != std::string::npos ? "gps" : "vo";
    EXPECT_EQ(n.node().child("styleUrl").text().get(), "#" + track);
    when[track].push_back(n.node().child("TimeStamp").child("when").text().get());
    const std::string coords = n.node().child("Point").child("coordinates").text().get();
    // lon,lat,alt: 7 decimals each angle, 3 for the height.
    EXPECT_TRUE(std::regex_match(coords, std::regex(R"(-?\d+\.\d{7},-?\d+\.\d{7},-?\d+\.\d{3})")))
        << coords;
  }
  ASSERT_EQ(when["vo"].size(), 6u);
  ASSERT_EQ(when["gps"].size(), 3u);
  EXPECT_EQ(when["vo"][0], "2020-09-13T12:26:40.250Z");
  EXPECT_EQ(when["gps"][2], FormatUtcIso8601(1600000000.25 + 2.0));
  for (const auto& [track, w] : when) {
    for (size_t i = 1; i < w.size(); ++i) EXPECT_LT(w[i - 1], w[i]) << track;  // ISO: sortable
  }
  // Every Style of every KML file: IconStyle, LabelStyle, LineStyle, PolyStyle in that order.
  const std::vector<std::string> order = {"IconStyle", "LabelStyle", "LineStyle", "PolyStyle"};
  int styles = 0;
  for (const char* f : {"run.kml", "vo.kml", "gps.kml", "run_live.kml"}) {
    pugi::xml_document d;
    ASSERT_TRUE(d.load_file((dir_ / f).c_str())) << f;
    for (const pugi::xpath_node& st : d.select_nodes("//Style")) {
      ++styles;
      int last = -1;
      for (const pugi::xml_node& c : st.node().children()) {
        const auto it = std::find(order.begin(), order.end(), std::string(c.name()));
        ASSERT_NE(it, order.end()) << f << ": " << c.name();
        EXPECT_GT(it - order.begin(), last) << f << ": " << c.name() << " out of order";
        last = static_cast<int>(it - order.begin());
      }
    }
  }
  EXPECT_EQ(styles, 4);  // run.kml: vo, gps; vo.kml, gps.kml: track
  // The track names carry the flight's name; GPX has <time> on every point.
  EXPECT_NE(Slurp(dir_ / "vo.kml").find("<name>DJI_0042 VO</name>"), std::string::npos);
  EXPECT_NE(Slurp(dir_ / "gps.gpx").find("<name>DJI_0042 GPS</name>"), std::string::npos);
  EXPECT_NE(Slurp(dir_ / "run_live.kml").find("<href>vo.kml</href>"), std::string::npos);
}

// Without the telemetry's clock, the run's GPX and KML count time_s from 1970-01-01T00:00:00Z.
TEST_F(TrackWritersTest, TimesWithoutAClockStartAt1970) {
  TrackWriterSet set(dir_, TrackWriterOptions{});
  FrameRecord r;
  r.frame = 0;
  r.time_s = 2.5;
  r.geo = GeoPoint{50.45, 30.52, 180.0};
  set.Append(r, GeoPoint{50.45, 30.52, 180.0});
  set.Close();
  EXPECT_NE(Slurp(dir_ / "vo.gpx").find("<time>1970-01-01T00:00:02.500Z</time>"),
            std::string::npos);
  EXPECT_NE(Slurp(dir_ / "run.kml").find("<when>1970-01-01T00:00:02.500Z</when>"),
            std::string::npos);
}

TEST_F(TrackWritersTest, GpxWithoutTimeOriginOmitsTime) {
  GpxTrackWriter w(dir_.string() + "_x.gpx", "t");
  w.Append(GeoTrackPoint{1.0, {10.0, 20.0, 5.0}});
  const std::string s = Slurp(w.path());
  EXPECT_EQ(XmlProblem(s), "");
  EXPECT_EQ(s.find("<time>"), std::string::npos);
  fs::remove(w.path());
}

TEST_F(TrackWritersTest, LongitudesWrappedForGisFormats) {
  fs::create_directories(dir_);
  GeoJsonTrackWriter j(dir_ / "w.geojson", "w");
  KmlTrackWriter k(dir_ / "w.kml", "w");
  GpxTrackWriter g(dir_ / "w.gpx", "w");
  for (double lon : {179.9999, 180.0001, 190.5}) {
    j.Append(GeoTrackPoint{0.0, {-16.5, lon, 0.0}});
    k.Append(GeoTrackPoint{0.0, {-16.5, lon, 0.0}});
    g.Append(GeoTrackPoint{0.0, {-16.5, lon, 0.0}});
  }
  const std::vector<GeoPoint> from_json = GeoJsonTrack(json::parse(Slurp(dir_ / "w.geojson")));
  const std::vector<GeoPoint> from_kml = ParseKml(dir_ / "w.kml");
  const std::vector<GeoPoint> from_gpx = ParseGpx(dir_ / "w.gpx");
  ASSERT_EQ(from_json.size(), 3u);
  ASSERT_EQ(from_kml.size(), 3u);
  ASSERT_EQ(from_gpx.size(), 3u);
  const double want[] = {179.9999, -179.9999, -169.5};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(from_json[i].lon_deg, want[i], 1e-9);
    EXPECT_NEAR(from_kml[i].lon_deg, want[i], 0.51e-7);
    EXPECT_NEAR(from_gpx[i].lon_deg, want[i], 0.51e-7);
  }
}

// A track whose altitude is not known (alt_m NaN: placed by a map, odometry/georef.h
// altitude_known) is written without one in every format: an empty alt_m cell, GeoJSON
// positions [lon, lat], KML tuples lon,lat, GPX trkpt without <ele>; its latitudes and
// longitudes as with one. The GPS track beside it keeps its altitude; an infinite altitude is
// still an error.
TEST_F(TrackWritersTest, AnUnknownAltitudeIsLeftOut) {
  TrackWriterOptions o;
  o.enu_origin = GeoPoint{50.45, 30.52, 180.0};
  TrackWriterSet set(dir_, o);
  for (int i = 0; i < 3; ++i) {
    FrameRecord r = MakeRecord(i);
    r.geo = GeoPoint{50.45 + 1e-5 * i, 30.52 + 2e-5 * i, std::nan("")};
    set.Append(r, MakeGps(i));
  }
  FrameRecord inf = MakeRecord(3);
  inf.geo = GeoPoint{50.45, 30.52, HUGE_VAL};
  EXPECT_THROW(set.Append(inf), InvalidArgument);
  set.Close();
  const Parsed p = ParseRun(dir_);
  ASSERT_EQ(p.csv_rows.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& row = p.csv_rows[i];
    EXPECT_NEAR(std::stod(row[4]), 50.45 + 1e-5 * i, 1e-9);  // lat_deg
    EXPECT_FALSE(row[5].empty());                            // lon_deg
    EXPECT_TRUE(row[6].empty()) << row[6];                   // alt_m
    EXPECT_EQ(row[19].empty(), i == 2) << row[19];           // gps_alt_m (MakeGps(2): none)
  }
  const json vo = json::parse(Slurp(dir_ / "vo.geojson"));
  const json& line = vo["features"][0]["geometry"]["coordinates"];
  ASSERT_EQ(line.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(line[i].size(), 2u) << line.dump();
    EXPECT_NEAR(line[i][0].get<double>(), 30.52 + 2e-5 * i, 1e-9);
    EXPECT_NEAR(line[i][1].get<double>(), 50.45 + 1e-5 * i, 1e-9);
  }
  const json frames = json::parse(Slurp(dir_ / "vo_frames.geojson"));
  for (const json& f : frames["features"]) EXPECT_EQ(f["geometry"]["coordinates"].size(), 2u);
  const json gps = json::parse(Slurp(dir_ / "gps.geojson"));
  EXPECT_EQ(gps["features"][0]["geometry"]["coordinates"][0].size(), 3u);
  const std::string kml = Slurp(dir_ / "vo.kml");
  const std::vector<GeoPoint> from_kml = ParseKml(dir_ / "vo.kml");
  ASSERT_EQ(from_kml.size(), 3u);
  EXPECT_NEAR(from_kml[1].lat_deg, 50.45001, 0.51e-7);
  for (const GeoPoint& g : from_kml) EXPECT_TRUE(std::isnan(g.alt_m)) << kml;
  EXPECT_NE(kml.find("<altitudeMode>clampToGround</altitudeMode>"), std::string::npos);
  EXPECT_NE(Slurp(dir_ / "run.kml").find("<coordinates>30.5200000,50.4500000</coordinates>"),
            std::string::npos);
  const std::string gpx = Slurp(dir_ / "vo.gpx");
  EXPECT_EQ(gpx.find("<ele>"), std::string::npos) << gpx;
  EXPECT_EQ(ParseGpx(dir_ / "vo.gpx").size(), 3u);
  EXPECT_NE(Slurp(dir_ / "gps.gpx").find("<ele>"), std::string::npos);
  ExpectXmllintAccepts(dir_);
}

void WriteSevenFramesThenDie(const fs::path& dir) {
  TrackWriterOptions o;
  o.enu_origin = GeoPoint{50.45, 30.52, 180.0};
  TrackWriterSet set(dir, o);
  for (int i = 0; i < 7; ++i) set.Append(MakeRecord(i), MakeGps(i));
  std::raise(SIGKILL);
}

TEST_F(TrackWritersTest, KilledRunLeavesValidFiles) {
  // The child writes 7 frames and is killed by SIGKILL: no destructor, no Close.
  ASSERT_EXIT(WriteSevenFramesThenDie(dir_), ::testing::KilledBySignal(SIGKILL), "");
  const Parsed p = ParseRun(dir_);
  EXPECT_EQ(p.csv_rows.size(), 7u);
  EXPECT_EQ(p.vo_tum.size(), 7u);
  int with_geo = 0, with_gps = 0;
  for (int i = 0; i < 7; ++i) with_geo += MakeRecord(i).geo ? 1 : 0, with_gps += MakeGps(i) ? 1 : 0;
  EXPECT_EQ(GeoJsonTrack(p.vo_geojson).size(), static_cast<size_t>(with_geo));
  EXPECT_EQ(p.vo_kml.size(), static_cast<size_t>(with_geo));
  EXPECT_EQ(p.gps_gpx.size(), static_cast<size_t>(with_gps));
  EXPECT_EQ(p.gps_tum.size(), static_cast<size_t>(with_gps));
}

TEST_F(TrackWritersTest, InvalidRecordWritesNothing) {
  TrackWriterSet set(dir_);
  set.Append(MakeRecord(0), MakeGps(0));
  FrameRecord bad = MakeRecord(1);
  bad.x_m = std::nan("");
  try {
    set.Append(bad, MakeGps(1));
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("frame 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("x_m"), std::string::npos) << e.what();
  }
  EXPECT_THROW(set.Append(MakeRecord(1), GeoPoint{95.0, 0.0, 0.0}), InvalidArgument);
  FrameRecord bad_geo = MakeRecord(2);
  bad_geo.geo = GeoPoint{0.0, std::nan(""), 0.0};
  EXPECT_THROW(set.Append(bad_geo), InvalidArgument);
  const Parsed p = ParseRun(dir_);
  EXPECT_EQ(p.csv_rows.size(), 1u);
  EXPECT_EQ(p.vo_tum.size(), 1u);
  EXPECT_EQ(p.gps_kml.size(), 1u);
  EXPECT_EQ(set.num_records(), 1);
}

TEST_F(TrackWritersTest, UnwritablePathsNameThePath) {
  fs::create_directories(dir_);
  const fs::path blocker = dir_ / "not_a_dir";
  std::ofstream(blocker) << "x";
  try {
    TrackWriterSet set(blocker / "run1");
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find((blocker / "run1").string()), std::string::npos)
        << e.what();
  }
  try {
    CsvFrameWriter w(dir_ / "missing" / "frames.csv");
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing/frames.csv"), std::string::npos) << e.what();
  }
  EXPECT_THROW(WriteJsonFileAtomic(dir_ / "missing" / "summary.json", json::object()), OutputError);
  EXPECT_THROW(KmlTrackWriter(dir_ / "a.kml", "a", "red"), InvalidArgument);
}

TEST_F(TrackWritersTest, SummaryJsonAtomic) {
  fs::create_directories(dir_);
  const fs::path p = dir_ / RunFileNames::kSummaryJson;
  json v = {{"ate_rmse_m", 1.25}, {"frames", 172}, {"bad", std::nan("")}, {"name", "tampa"}};
  WriteJsonFileAtomic(p, v);
  json back = json::parse(Slurp(p));
  EXPECT_EQ(back["ate_rmse_m"].get<double>(), 1.25);
  EXPECT_EQ(back["frames"].get<int>(), 172);
  EXPECT_TRUE(back["bad"].is_null());
  v["frames"] = 173;
  WriteJsonFileAtomic(p, v);  // replaces
  EXPECT_EQ(json::parse(Slurp(p))["frames"].get<int>(), 173);
  EXPECT_FALSE(fs::exists(p.string() + ".tmp"));
}

TEST(FormatUtcIso8601, KnownInstants) {
  EXPECT_EQ(FormatUtcIso8601(0.0), "1970-01-01T00:00:00.000Z");
  EXPECT_EQ(FormatUtcIso8601(1600000000.25), "2020-09-13T12:26:40.250Z");
  EXPECT_EQ(FormatUtcIso8601(951782400.0), "2000-02-29T00:00:00.000Z");      // leap day
  EXPECT_EQ(FormatUtcIso8601(1700000039.9996), "2023-11-14T22:14:00.000Z");  // carries
  EXPECT_EQ(FormatUtcIso8601(-0.5), "1969-12-31T23:59:59.500Z");
  EXPECT_THROW(FormatUtcIso8601(std::nan("")), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::track_writers_test
