// `aerovo report`: the HTML report of a short simulated flight (run folder) and of hand-written
// experiment folders, and (when Debian's chromium is installed) the rendering checked in a headless
// browser. The flight is simulated and run once per test process (~2 s on 2 cores); the
// reports take ~1 s each, the browser ~3 s per page.
#include "aerovo/report/html_report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <pugixml.hpp>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/leaflet_assets.h"
#include "aerovo/report/run_reader.h"

#include "e2e_testing.h"

namespace aerovo::html_report_test {
namespace {

namespace fs = std::filesystem;

using e2e::ReadText;

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t pos = text.find(what); pos != std::string::npos;
       pos = text.find(what, pos + what.size())) {
    ++n;
  }
  return n;
}

// Every figure file is a valid SVG (pugixml) or a decodable image.
void CheckFigureFiles(const ReportResult& r) {
  ASSERT_FALSE(r.figures.empty());
  for (const fs::path& f : r.figures) {
    ASSERT_TRUE(fs::exists(f)) << f;
    if (f.extension() == ".svg") {
      pugi::xml_document doc;
      ASSERT_TRUE(doc.load_file(f.c_str())) << f;
      EXPECT_TRUE(doc.child("svg")) << f;
      EXPECT_GT(doc.select_nodes("//path").size(), 3u) << f;
    } else {
      EXPECT_FALSE(cv::imread(f.string()).empty()) << f;
    }
  }
}

// Self-contained: every src= is a data: URI, no href= or CSS url() to the network, and the
// Content-Security-Policy that refuses whatever the page does not hold. (The inlined Leaflet
// names two URLs as text, the SVG namespace and its home page in an attribution prefix the
// report replaces: text, not requests; the browser test checks that nothing is requested.)
void CheckSelfContained(std::string html) {
  // Leaflet's own text (its attribution prefix names its home page) is not the page's markup.
  if (const std::size_t at = html.find(leaflet::Js()); at != std::string::npos) {
    html.erase(at, leaflet::Js().size());
  }
  static const std::regex src(R"(\bsrc\s*=\s*["']([^"']{0,10}))");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), src); it != std::sregex_iterator();
       ++it) {
    EXPECT_EQ((*it)[1].str().substr(0, 5), "data:");
  }
  static const std::regex net(R"re((href\s*=\s*["']|url\(\s*["']?)(https?:)?//)re");
  std::smatch m;
  EXPECT_FALSE(std::regex_search(html, m, net)) << m.str();
  EXPECT_NE(html.find("<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'"),
            std::string::npos);
}

// The JSON of the report's map (<script id="aerovo-map-data">), null when the page has no map.
nlohmann::json MapJson(const std::string& html) {
  const std::string open = "<script type=\"application/json\" id=\"aerovo-map-data\">";
  const std::size_t a = html.find(open);
  if (a == std::string::npos) return nullptr;
  const std::size_t b = html.find("</script>", a);
  return nlohmann::json::parse(html.substr(a + open.size(), b - a - open.size()));
}

// A small north-up RGBA fixture in place of the geo-referenced mosaic (mosaic_geo.png/.json of
// `aerovo report`): a light grey square, 20 m larger than the run's GPS fixes on every side.
void WriteGeoMosaicFixture(const fs::path& run_dir, const RunData& run) {
  double s = 90, n = -90, w = 180, e = -180;
  for (const RunFrameRow& f : run.frames) {
    if (!f.gps) continue;
    s = std::min(s, f.gps->lat_deg);
    n = std::max(n, f.gps->lat_deg);
    w = std::min(w, f.gps->lon_deg);
    e = std::max(e, f.gps->lon_deg);
  }
  const double dlat = 20.0 / 111320.0, dlon = dlat / std::cos(s * kDegToRad);
  cv::Mat rgba(120, 160, CV_8UC4, cv::Scalar(200, 200, 200, 255));
  cv::rectangle(rgba, {10, 10}, {150, 110}, cv::Scalar(170, 170, 170, 255), 3);
  ASSERT_TRUE(cv::imwrite((run_dir / "mosaic_geo.png").string(), rgba));
  const nlohmann::json j = {{"image", "mosaic_geo.png"}, {"south", s - dlat}, {"west", w - dlon},
                            {"north", n + dlat},         {"east", e + dlon},  {"width_px", 160},
                            {"height_px", 120},          {"m_per_px", 1.0}};
  std::ofstream(run_dir / "mosaic_geo.json") << j.dump(2);
}

class HtmlReport : public ::testing::Test {
 protected:
  // A lawnmower flight (2 legs of 120 m, 40 m apart, 100 m high, 10 m/s) as 400x300 JPEG frames
  // + DJI SRT at 1 fps: 31 frames; simulated and run once per test process (ctest runs each test
  // alone), ~2 s.
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("aerovo_html_report_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    sim_ = root_ / "sim";
    const std::string cmd = std::string(AEROVO_CLI_PATH) +
                            " simulate --pattern lawnmower --legs 2 --length-m 120 --spacing-m 40 "
                            "--fps 1 --width 400 --height 300 --frames-only -q --out " +
                            sim_.string() + " > /dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    RunConfig c;
    c.input = (sim_ / "frames").string();
    c.telemetry = (sim_ / "telemetry.srt").string();
    c.hfov_deg = 73.7;  // the simulator's camera
    c.out = (root_ / "run").string();
    c.quiet = true;
    const RunSummary s = RunFlight(c);
    frames_ = s.frames_processed;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // A copy of the run folder (tests that modify it).
  static fs::path CopyRun(const std::string& name) {
    const fs::path d = root_ / name;
    fs::remove_all(d);
    fs::copy(root_ / "run", d, fs::copy_options::recursive);
    fs::remove_all(d / "figures");
    fs::remove(d / "report.html");
    return d;
  }

  static fs::path root_, sim_;
  static int frames_;
};
fs::path HtmlReport::root_, HtmlReport::sim_;
int HtmlReport::frames_ = 0;

TEST_F(HtmlReport, RunFolderReport) {
  const fs::path run = CopyRun("run_report");
  ASSERT_EQ(frames_, 31);
  // transforms.csv: one row per frame, identity first.
  const RunData data = ReadRunDir(run);
  ASSERT_EQ(static_cast<int>(data.transforms.size()), frames_);
  EXPECT_EQ(data.transforms[0].a[0], 1.0);
  EXPECT_EQ(data.transforms[0].a[2], 0.0);
  // The report's comparison is the summary's (same pairs, same ENU frame, same alignment).
  const RunComparison cmp = CompareWithGps(data);
  ASSERT_TRUE(cmp.comparison.has_value());
  EXPECT_EQ(static_cast<int>(cmp.vo.size()), data.summary["frames_with_gps"].get<int>());
  EXPECT_NEAR(cmp.comparison->se2.ate_m.rmse,
              data.summary["evaluation"]["se2"]["ate_m"]["rmse"].get<double>(), 1e-3);
  EXPECT_NEAR(cmp.comparison->sim2.ate_m.rmse,
              data.summary["evaluation"]["sim2"]["ate_m"]["rmse"].get<double>(), 1e-3);

  const ReportResult r = WriteReport(run);
  EXPECT_EQ(r.kind, "run");
  EXPECT_EQ(r.html, run / "report.html");
  CheckFigureFiles(r);
  for (const char* name : {"fig2_trajectory", "fig3_points", "stage_times", "ate_per_frame"}) {
    EXPECT_TRUE(fs::exists(run / "figures" / (std::string(name) + ".svg"))) << name;
    EXPECT_TRUE(fs::exists(run / "figures" / (std::string(name) + ".png"))) << name;
  }
  ASSERT_FALSE(r.mosaic.empty()) << (r.notes.empty() ? "" : r.notes[0]);
  const cv::Mat mosaic = cv::imread(r.mosaic.string());
  ASSERT_FALSE(mosaic.empty());
  EXPECT_LE(std::max(mosaic.cols, mosaic.rows), 2000);
  // The frames cover most of the mosaic (a 2-leg lawnmower: few white gaps).
  cv::Mat gray;
  cv::cvtColor(mosaic, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray < 245), 0.5 * gray.total());

  const std::string html = ReadText(r.html);
  CheckSelfContained(html);
  // The runner compares a simulated flight with its ground truth on its own (sim.json found):
  // then Fig. 2 is drawn against the ground truth too.
  const bool truth = !data.summary.value("truth", std::string()).empty();
  // Fig. 2 (and against the truth), Fig. 3, stage times, the error by distance, time, frame.
  const int plots = truth ? 7 : 6;
  EXPECT_EQ(fs::exists(run / "figures" / "fig2_trajectory_truth.svg"), truth);
  EXPECT_EQ(Count(html, "<figure class=\"plot\""), plots);
  EXPECT_EQ(Count(html, "<svg"), plots);
  EXPECT_EQ(Count(html, "<img"), 1);
  EXPECT_NE(html.find("src=\"data:image/jpeg;base64,"), std::string::npos);
  EXPECT_NE(html.find("data-figures-expected=\"" + std::to_string(plots + 1) + "\""),
            std::string::npos);
  EXPECT_NE(html.find("Fig. 2: VO trajectory against GPS"), std::string::npos);
  EXPECT_NE(html.find("Fig. 3"), std::string::npos);
  EXPECT_NE(html.find("ATE RMSE (m)"), std::string::npos);
  EXPECT_NE(html.find("Effective configuration"), std::string::npos);
  // Ids are unique per figure (prefixed), so the inlined SVGs do not share ids.
  EXPECT_NE(html.find("id=\"fig2_trajectory-gnuplot_canvas\""), std::string::npos);
  EXPECT_EQ(html.find("id=\"gnuplot_canvas\""), std::string::npos);
  for (const char* name : {"error_vs_distance", "error_vs_time"}) {
    EXPECT_TRUE(fs::exists(run / "figures" / (std::string(name) + ".svg"))) << name;
  }

  // The accuracy answer first (before the map, the figures and the timings), with the
  // summary's numbers; the explanation beside the comparison.
  const std::size_t answer = html.find("id=\"answer\"");
  ASSERT_NE(answer, std::string::npos);
  EXPECT_LT(answer, html.find("id=\"map\""));
  EXPECT_LT(html.find("id=\"map\""), html.find("id=\"comparison\""));
  EXPECT_LT(html.find("id=\"comparison\""), html.find("id=\"figures\""));
  EXPECT_LT(html.find("id=\"figures\""), html.find("id=\"timings\""));
  const nlohmann::json& se2 = data.summary["evaluation"]["se2"];
  EXPECT_NE(html.find(fmt::format("<strong>End error against GPS: {:.2f} m ({:.2f} % of the "
                                  "distance)</strong>",
                                  se2["end_point_error_m"].get<double>(),
                                  se2["end_point_error_percent"].get<double>())),
            std::string::npos);
  EXPECT_NE(html.find(fmt::format(
                "<strong>Tracked {} of {} frames</strong>",
                data.summary["frames_ok"].get<int>() + data.summary["frames_reacquired"].get<int>(),
                frames_)),
            std::string::npos);
  EXPECT_NE(html.find("a lower Sim(2) ATE with a higher Sim(2) end error is expected"),
            std::string::npos);
  EXPECT_NE(html.find("Relative error over L m</strong> (drift)"), std::string::npos);

  // One colour per track: Fig. 2 draws GPS blue, VO vermillion, VO Sim(2) reddish purple, as
  // the map and the mosaic do (report/style.h).
  const std::string gp = ReadText(run / "figures" / "fig2_trajectory.gp");
  static const std::regex fig2_colour(R"re(lc rgb '(#[0-9A-Fa-f]{6})'.*title '([^']*)')re");
  std::map<std::string, std::string> colour_of;
  for (auto it = std::sregex_iterator(gp.begin(), gp.end(), fig2_colour);
       it != std::sregex_iterator(); ++it) {
    colour_of[(*it)[2].str()] = (*it)[1].str();
  }
  EXPECT_EQ(colour_of["GPS"], "#0072B2");
  EXPECT_EQ(colour_of["VO, SE(2)-aligned"], "#D55E00");
  EXPECT_EQ(colour_of["VO, Sim(2)-aligned"], "#CC79A7");

  // The map: Leaflet inlined with its licence, the run's tracks in lat/lon, per-frame hover data.
  EXPECT_NE(html.find("Redistribution and use in source and binary forms"), std::string::npos);
  EXPECT_NE(html.find("Vladimir Agafonkin"), std::string::npos);
  EXPECT_NE(html.find("<div id=\"aerovo-map\"></div>"), std::string::npos);
  const nlohmann::json map = MapJson(html);
  ASSERT_TRUE(map.is_object());
  int geo = 0, gps = 0;
  for (const RunFrameRow& f : data.frames) {
    geo += f.geo.has_value();
    gps += f.gps.has_value();
  }
  ASSERT_GT(geo, 20);
  EXPECT_EQ(static_cast<int>(map["vo"].size()), geo);
  EXPECT_EQ(static_cast<int>(map["info"].size()), geo);
  EXPECT_EQ(static_cast<int>(map["gps"].size()), gps);
  // The report's own geo mosaic (mosaic_geo.json/.png) is on the map, around the GPS fixes.
  ASSERT_TRUE(map["mosaic"].is_object());
  EXPECT_EQ(map["mosaic"]["uri"].get<std::string>().rfind("data:image/png;base64,", 0), 0u);
  for (const nlohmann::json& g : map["gps"]) {
    EXPECT_GT(g[0].get<double>(), map["mosaic"]["south"].get<double>());
    EXPECT_LT(g[0].get<double>(), map["mosaic"]["north"].get<double>());
    EXPECT_GT(g[1].get<double>(), map["mosaic"]["west"].get<double>());
    EXPECT_LT(g[1].get<double>(), map["mosaic"]["east"].get<double>());
  }
  EXPECT_EQ(map["colours"]["vo"], "#D55E00");
  EXPECT_EQ(map["colours"]["gps"], "#0072B2");
  // A frame's entry: [frame, time, status, distance to its fix as drawn, SE(2) error]; the
  // SE(2) error is the figure's (ate_per_point_m of the same frame).
  const RunFrameRow& last = data.frames.back();
  ASSERT_TRUE(last.geo && last.gps);
  const nlohmann::json& e = map["info"].back();
  EXPECT_EQ(e[0].get<int>(), last.frame);
  EXPECT_EQ(e[2].get<std::string>(), last.status);
  EXPECT_NEAR(map["vo"].back()[0].get<double>(), last.geo->lat_deg, 1e-7);
  EXPECT_NEAR(map["gps"].back()[1].get<double>(), last.gps->lon_deg, 1e-7);
  const LocalEnu enu(*data.frames.front().gps);
  const Eigen::Vector3d a = enu.Forward(*last.geo), b = enu.Forward(*last.gps);
  EXPECT_NEAR(e[3].get<double>(), std::hypot(a.x() - b.x(), a.y() - b.y()), 2e-3);
  EXPECT_NEAR(e[3].get<double>(), se2["end_point_error_unaligned_m"].get<double>(), 0.05);
  EXPECT_NEAR(e[4].get<double>(), cmp.comparison->se2.ate_per_point_m.back(), 2e-3);
  // The SE(2)-aligned VO layer: one point per frame, its last point the SE(2) end error away
  // from the last GPS fix.
  ASSERT_EQ(map["vo_se2"].size(), data.frames.size());
  const Eigen::Vector3d aligned_end =
      enu.Forward(map["vo_se2"].back()[0].get<double>(), map["vo_se2"].back()[1].get<double>(), 0);
  EXPECT_NEAR(std::hypot(aligned_end.x() - b.x(), aligned_end.y() - b.y()),
              se2["end_point_error_m"].get<double>(), 0.02);
}

// The geo-referenced north-up mosaic (mosaic_geo.json + .png, the contract with `aerovo
// report`'s geo mosaic) goes under the map's tracks as an image overlay with its bounds; a
// malformed one is a note naming the file, and the map is drawn without it.
TEST_F(HtmlReport, GeoMosaicOnTheMap) {
  const fs::path run = CopyRun("run_geo_mosaic");
  const RunData data = ReadRunDir(run);
  WriteGeoMosaicFixture(run, data);
  ReportOptions o;
  o.mosaic = false;
  o.plot.png = false;
  const ReportResult r = WriteReport(run, o);
  EXPECT_TRUE(r.notes.empty()) << r.notes[0];
  const nlohmann::json spec = nlohmann::json::parse(ReadText(run / "mosaic_geo.json"));
  nlohmann::json map = MapJson(ReadText(r.html));
  ASSERT_TRUE(map["mosaic"].is_object());
  for (const char* k : {"south", "west", "north", "east"}) {
    EXPECT_EQ(map["mosaic"][k].get<double>(), spec[k].get<double>()) << k;
  }
  const std::string uri = map["mosaic"]["uri"].get<std::string>();
  EXPECT_EQ(uri.rfind("data:image/png;base64,", 0), 0u);

  for (const auto& [bad, problem] : std::vector<std::pair<nlohmann::json, std::string>>{
           {{{"image", "mosaic_geo.png"},
             {"south", 1.0},
             {"west", 2.0},
             {"north", 0.5},
             {"east", 3.0}},
            "south < north"},
           {{{"image", "mosaic_geo.png"}, {"south", 1.0}, {"north", 2.0}, {"east", 3.0}},
            "\"west\" is missing"},
           {{{"image", "../x.png"}, {"south", 1.0}, {"west", 2.0}, {"north", 1.5}, {"east", 3.0}},
            "beside it"}}) {
    std::ofstream(run / "mosaic_geo.json") << bad.dump();
    const ReportResult b = WriteReport(run, o);
    ASSERT_EQ(b.notes.size(), 1u) << bad.dump();
    EXPECT_NE(b.notes[0].find("mosaic_geo.json"), std::string::npos) << b.notes[0];
    EXPECT_NE(b.notes[0].find(problem), std::string::npos) << b.notes[0];
    map = MapJson(ReadText(b.html));
    EXPECT_TRUE(map["mosaic"].is_null());
    EXPECT_GT(map["vo"].size(), 20u);
  }
}

// frames.csv of a run killed mid-write ends with a partial record: dropped. A broken record
// anywhere else is an error naming the file and line.
TEST_F(HtmlReport, RunReaderDropsOnlyABrokenLastRecord) {
  const fs::path run = CopyRun("run_cut");
  const fs::path csv = run / RunFileNames::kFramesCsv;
  const std::string whole = ReadText(csv);
  const int lines = Count(whole, "\n");  // header + one line per frame
  ASSERT_EQ(lines, frames_ + 1);
  for (const std::string cut : {"31,15.5,1", "31,15.5,\"unterminated"}) {
    std::ofstream(csv) << whole << cut;
    EXPECT_EQ(static_cast<int>(ReadRunDir(run).frames.size()), frames_) << cut;
    std::ofstream(csv) << whole << cut << "\n" << whole.substr(whole.find('\n') + 1);
    try {
      ReadRunDir(run);
      ADD_FAILURE() << "no InputError for " << cut;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("frames.csv' line " + std::to_string(lines + 1)),
                std::string::npos)
          << e.what();
    }
  }
  // vo_optimized.tum (the offline optimisation) likewise: a cut last line is dropped, a bad line
  // before the last is an InputError naming the file and line.
  std::ofstream(csv) << whole;
  const fs::path tum = run / RunFileNames::kVoOptimizedTum;
  const std::string rows = "# timestamp tx ty tz qx qy qz qw\n0.0 1.0 2.0 0 0 0 0 1\n";
  std::ofstream(tum) << rows << "0.5 3.0";
  ASSERT_EQ(ReadRunDir(run).optimized.size(), 1u);
  EXPECT_EQ(ReadRunDir(run).optimized[0].y, 2.0);
  std::ofstream(tum) << rows << "0.5 3.0\n" << rows;
  try {
    ReadRunDir(run);
    ADD_FAILURE() << "no InputError for a cut line before the last";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("vo_optimized.tum:3: a TUM line needs at least t x y"),
              std::string::npos)
        << e.what();
  }
}

TEST_F(HtmlReport, InterruptedRunWithoutSummaryAndInputGone) {
  const fs::path run = CopyRun("run_partial");
  fs::remove(run / "summary.json");
  nlohmann::json config = nlohmann::json::parse(ReadText(run / "config.json"));
  config["input"] = (root_ / "no_such_frames").string();
  std::ofstream(run / "config.json") << config.dump(2);
  const ReportResult r = WriteReport(run);
  EXPECT_TRUE(r.mosaic.empty());
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_NE(r.notes[0].find("not readable"), std::string::npos) << r.notes[0];
  const std::string html = ReadText(r.html);
  EXPECT_NE(html.find("summary.json is missing"), std::string::npos);
  EXPECT_NE(html.find("not readable"), std::string::npos);
  EXPECT_EQ(Count(html, "<img"), 0);
  EXPECT_GE(Count(html, "<svg"), 4);  // the comparison is recomputed from frames.csv

  // --no-mosaic, SVG only.
  fs::remove_all(run / "figures");
  ReportOptions o;
  o.mosaic = false;
  o.plot.png = false;
  const ReportResult svg_only = WriteReport(run, o);
  EXPECT_TRUE(svg_only.notes.empty());
  EXPECT_FALSE(fs::exists(run / "figures" / "fig3_points.png"));
  EXPECT_TRUE(fs::exists(run / "figures" / "fig3_points.svg"));
}

TEST_F(HtmlReport, ExperimentFolders) {
  const fs::path exp = root_ / "exp_ransac";
  fs::create_directories(exp);
  fs::copy(root_ / "run", exp / "standard", fs::copy_options::recursive);
  fs::copy(root_ / "run", exp / "clustered", fs::copy_options::recursive);
  const nlohmann::json j = {
      {"kind", "ransac"},
      {"runs",
       {{{"label", "standard"}, {"dir", "standard"}, {"mode", "standard"}},
        {{"label", "clustered"}, {"dir", "clustered"}, {"mode", "clustered"}}}},
      {"ground_truth", nullptr},
      {"tables",
       {{"speedup",
         {{"columns", {"stage", "speed-up"}},
          {"rows", nlohmann::json::array({nlohmann::json::array({"correspondence", 9.5}),
                                          nlohmann::json::array({"total", "1.1x"})})}}}}}};
  std::ofstream(exp / "experiment.json") << j.dump(2);
  ReportOptions o;
  o.mosaic = false;
  o.plot.png = false;  // PNG outputs are checked on the run report; keeps the test short
  const ReportResult r = WriteReport(exp, o);
  EXPECT_EQ(r.kind, "experiment");
  CheckFigureFiles(r);
  ASSERT_EQ(r.sub_reports.size(), 2u);
  for (const fs::path& s : r.sub_reports) EXPECT_TRUE(fs::exists(s)) << s;
  for (const char* name : {"fig7_stage_times_standard", "fig8_stage_times_clustered",
                           "fig8_correspond_per_step", "trajectories"}) {
    EXPECT_TRUE(fs::exists(exp / "figures" / (std::string(name) + ".svg"))) << name;
  }
  const std::string html = ReadText(r.html);
  CheckSelfContained(html);
  EXPECT_NE(html.find("href=\"standard/report.html\""), std::string::npos);
  EXPECT_NE(html.find("href=\"clustered/report.html\""), std::string::npos);
  EXPECT_NE(html.find("Table: speedup"), std::string::npos);
  EXPECT_NE(html.find("<td>9.5</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>1.1x</td>"), std::string::npos);
  EXPECT_NE(html.find("Fig. 7: time of each stage per step, standard RANSAC"), std::string::npos);
  EXPECT_NE(html.find("Fig. 8: time of each stage per step, clustered RANSAC"), std::string::npos);

  // Illumination, against the simulator's ground truth, one listed run missing.
  const fs::path exp2 = root_ / "exp_illum";
  fs::create_directories(exp2);
  fs::copy(root_ / "run", exp2 / "k1.00", fs::copy_options::recursive);
  fs::copy(root_ / "run", exp2 / "k0.50", fs::copy_options::recursive);
  const nlohmann::json j2 = {
      {"kind", "illumination"},
      {"runs",
       {{{"label", "k=1.00"}, {"dir", "k1.00"}, {"k", 1.0}},
        {{"label", "k=0.50"}, {"dir", "k0.50"}, {"k", 0.5}},
        {{"label", "k=0.10"}, {"dir", "k0.10"}, {"k", 0.1}}}},  // not run: left out with a note
      {"ground_truth", (sim_ / "ground_truth.csv").string()},
      {"tables", nlohmann::json::object()}};
  std::ofstream(exp2 / "experiment.json") << j2.dump(2);
  ReportOptions o2;
  o2.mosaic = false;
  o2.sub_reports = false;
  o2.plot.png = false;
  const ReportResult r2 = WriteReport(exp2, o2);
  CheckFigureFiles(r2);
  for (const char* name : {"fig4_nsurf_per_frame", "fig5_mean_nsurf_vs_k", "fig6_trajectories"}) {
    EXPECT_TRUE(fs::exists(exp2 / "figures" / (std::string(name) + ".svg"))) << name;
  }
  ASSERT_EQ(r2.notes.size(), 1u);
  EXPECT_NE(r2.notes[0].find("k=0.10"), std::string::npos);
  const std::string html2 = ReadText(r2.html);
  EXPECT_NE(html2.find("Fig. 6: trajectories at different illumination k against ground truth"),
            std::string::npos);
  // The simulator's camera is exact: the VO lies within a metre of the ground truth.
  const RunComparison c = CompareWithReference(ReadRunDir(exp2 / "k1.00"),
                                               ReadGroundTruthCsv(sim_ / "ground_truth.csv"));
  ASSERT_TRUE(c.comparison.has_value());
  EXPECT_EQ(static_cast<int>(c.vo.size()), frames_);
  EXPECT_LT(c.comparison->se2.ate_m.rmse, 1.0);
}

// A run with no geographic position at all (not geo-referenced, no GPS): no map and no
// Leaflet in the page, a note on it; the rest of the report is written.
TEST_F(HtmlReport, NoMapWithoutPositions) {
  const fs::path run = CopyRun("run_no_geo");
  std::istringstream in(ReadText(run / RunFileNames::kFramesCsv));
  std::string line, out;
  std::getline(in, line);
  out = line + "\n";
  while (std::getline(in, line)) {  // empty lat_deg, lon_deg, alt_m and gps_lat/lon/alt_deg
    std::vector<std::string> cells(1);  // every cell, the trailing empty ones too
    for (const char c : line) {
      if (c == ',') {
        cells.emplace_back();
      } else {
        cells.back() += c;
      }
    }
    for (int i : {4, 5, 6, 17, 18, 19}) cells[static_cast<std::size_t>(i)].clear();
    for (std::size_t i = 0; i < cells.size(); ++i) out += (i ? "," : "") + cells[i];
    out += "\n";
  }
  std::ofstream(run / RunFileNames::kFramesCsv) << out;
  fs::remove(run / "summary.json");
  ReportOptions o;
  o.mosaic = false;
  o.plot.png = false;
  const ReportResult r = WriteReport(run, o);
  const std::string html = ReadText(r.html);
  EXPECT_TRUE(MapJson(html).is_null());
  EXPECT_EQ(html.find("<div id=\"aerovo-map\">"), std::string::npos);
  EXPECT_EQ(html.find(leaflet::Js()), std::string::npos);
  EXPECT_NE(html.find("No map: the run has neither a geo-referenced VO position nor a GPS fix."),
            std::string::npos);
  EXPECT_NE(html.find("No comparison with GPS"), std::string::npos);
  EXPECT_GE(Count(html, "<svg"), 3);  // Fig. 2, Fig. 3, stage times
}

TEST(HtmlReportInput, NeitherRunNorExperimentIsAnInputError) {
  const fs::path empty =
      fs::temp_directory_path() / ("aerovo_html_report_empty_" + std::to_string(::getpid()));
  fs::remove_all(empty);
  fs::create_directories(empty);
  try {
    WriteReport(empty);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("neither a run folder"), std::string::npos) << e.what();
  }
  std::ofstream(empty / "experiment.json") << "{\"kind\": \"ransac\"";  // truncated JSON
  EXPECT_THROW(WriteReport(empty), InputError);
  fs::remove_all(empty);
}

// --- Headless browser ---------------------------------------------------------------------------

std::string FindChromium() {
  if (const char* env = std::getenv("AEROVO_CHROMIUM"); env != nullptr && *env != '\0') return env;
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    for (const char* dir : {"/usr/bin/", "/usr/local/bin/", "/bin/"}) {
      const std::string p = std::string(dir) + name;
      if (::access(p.c_str(), X_OK) == 0) return p;
    }
  }
  return "";
}

// Pixels within `tol` of an RGB colour.
int CountColour(const cv::Mat& bgr, int r, int g, int b, int tol = 12) {
  cv::Mat mask;
  cv::inRange(bgr, cv::Scalar(b - tol, g - tol, r - tol), cv::Scalar(b + tol, g + tol, r + tol),
              mask);
  return cv::countNonZero(mask);
}

// The http(s) URLs that a page asked for, from Chromium's network log (--log-net-log): the
// URL_REQUEST_START_JOB events whose initiator is an origin (a file:// page's is "null"); the
// browser's own requests (updates, time, accounts) have the initiator "not an origin".
std::vector<std::string> PageRequests(const fs::path& net_log) {
  const nlohmann::json log = nlohmann::json::parse(ReadText(net_log));
  const int start_job = log.at("constants").at("logEventTypes").at("URL_REQUEST_START_JOB");
  std::vector<std::string> urls;
  for (const nlohmann::json& e : log.at("events")) {
    if (e.value("type", -1) != start_job || !e.contains("params")) continue;
    const nlohmann::json& p = e["params"];
    const std::string url = p.value("url", ""), initiator = p.value("initiator", "");
    if (initiator != "not an origin" &&
        (url.rfind("http:", 0) == 0 || url.rfind("https:", 0) == 0)) {
      urls.push_back(url);
    }
  }
  return urls;
}

// The report in headless Chromium with the network off (a proxy to nowhere, and the page's
// Content-Security-Policy whose refusals the page counts): every figure renders, the page asks
// for nothing (Chromium's network log, checked on a page that does ask first), and the map draws
// the VO and GPS tracks (SVG paths, their colours on a screenshot of the map's area), the
// geo-referenced mosaic under them, a metric scale bar, and the hover text of a frame. Three
// browser starts, ~3 s each.
TEST_F(HtmlReport, RendersInHeadlessChromium) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "chromium not installed (Debian package chromium; scripts/install-deps.sh "
                    "installs it): browser rendering not checked";
  }
  const fs::path run = CopyRun("run_browser");
  const RunData data = ReadRunDir(run);
  WriteGeoMosaicFixture(run, data);
  ReportOptions o;
  o.mosaic = false;    // the fixture's plain grey is the overlay the screenshot looks for
  o.plot.png = false;  // the page inlines the SVGs; PNG files play no part in it
  const ReportResult r = WriteReport(run, o);
  const std::string url = "file://" + fs::absolute(r.html).string();
  const fs::path profile = root_ / "chromium-profile";
  // The same window for both starts: the map lies where the DOM dump says on the screenshot.
  const std::string flags =
      "--headless --no-sandbox --disable-gpu --disable-dev-shm-usage --hide-scrollbars "
      "--no-first-run --disable-extensions --disable-background-networking "
      "--disable-component-update --proxy-server=127.0.0.1:9 --proxy-bypass-list='<-loopback>' "
      "--window-size=1400,5000 --virtual-time-budget=5000 --user-data-dir=" +
      profile.string();
  // 0. The network-log check can fail: a page that asks for a tile and a fetch is caught.
  const fs::path leak = root_ / "leak.html", leak_log = root_ / "leak_net.json";
  std::ofstream(leak) << "<!DOCTYPE html><html><body><img src=\"https://tiles.invalid/1/0/0.png\">"
                         "<script>fetch('http://api.invalid/x').catch(function(){});</script>"
                         "</body></html>\n";
  std::string cmd = "timeout 90 " + chromium + " " + flags + " --log-net-log=" + leak_log.string() +
                    " --dump-dom 'file://" + fs::absolute(leak).string() + "' > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::vector<std::string> leaked = PageRequests(leak_log);
  EXPECT_EQ(leaked.size(), 2u);
  EXPECT_NE(std::find(leaked.begin(), leaked.end(), "https://tiles.invalid/1/0/0.png"),
            leaked.end());

  // 1. The DOM after load: the report's own script counts what rendered; the network log
  // records what the page asked for.
  const fs::path dom = root_ / "dom.html", net_log = root_ / "net.json";
  cmd = "timeout 90 " + chromium + " " + flags + " --log-net-log=" + net_log.string() +
        " --dump-dom '" + url + "' > " + dom.string() + " 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::vector<std::string> requested = PageRequests(net_log);
  EXPECT_TRUE(requested.empty()) << requested.size() << " requests, the first " << requested[0];
  const std::string body = ReadText(dom);
  auto attribute = [&](const std::string& name) -> std::string {
    std::smatch m;
    if (!std::regex_search(body, m, std::regex(name + R"re(="([^"]*)")re"))) return "<absent>";
    return m[1].str();
  };
  ASSERT_NE(attribute("data-figures-ok"), "<absent>") << "the report's check script did not run";
  const int expected = std::stoi(attribute("data-figures-expected"));
  EXPECT_GE(expected, 7);  // 6 or 7 plots (with a ground truth) and the mosaic
  EXPECT_EQ(std::stoi(attribute("data-figures-ok")), expected);
  EXPECT_EQ(attribute("data-figures-failed"), "");
  // Nothing requested from outside the page (the policy refuses and counts every attempt).
  EXPECT_EQ(attribute("data-blocked-requests"), "0") << attribute("data-blocked-urls");
  // The map: Leaflet ran, both tracks are SVG paths, the overlay decoded, a metric scale bar.
  EXPECT_EQ(attribute("data-map-ready"), "1");
  EXPECT_GE(std::stoi(attribute("data-map-vo-vertices")), 4);  // 2 legs: at least 4 corners
  EXPECT_GE(std::stoi(attribute("data-map-gps-vertices")), 4);
  EXPECT_EQ(attribute("data-map-overlay"), "1");
  EXPECT_TRUE(std::regex_match(attribute("data-map-scale"), std::regex(R"(\d+ k?m)")))
      << attribute("data-map-scale");
  // Hover text of the middle VO frame: index, time, status, distance to its GPS fix.
  const nlohmann::json map = MapJson(ReadText(r.html));
  const nlohmann::json& mid = map["info"][map["vo"].size() / 2];
  EXPECT_EQ(attribute("data-map-hover")
                .rfind(fmt::format("frame {} · {:.1f} s · {} · to GPS ", mid[0].get<int>(),
                                   mid[1].get<double>(), mid[2].get<std::string>()),
                       0),
            0u)
      << attribute("data-map-hover");
  int rect[4];
  ASSERT_EQ(std::sscanf(attribute("data-map-rect").c_str(), "%d,%d,%d,%d", &rect[0], &rect[1],
                        &rect[2], &rect[3]),
            4)
      << attribute("data-map-rect");
  EXPECT_GT(rect[2], 600);
  EXPECT_GE(rect[3], 500);

  // 2. A screenshot: not blank; on the map's area, the VO and GPS colours (style.h) and the
  // fixture mosaic's grey; the figures carry the track colours too.
  const fs::path shot = root_ / "shot.png";
  cmd = "timeout 90 " + chromium + " " + flags + " --screenshot=" + shot.string() + " '" + url +
        "' > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const cv::Mat img = cv::imread(shot.string());
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1400);
  cv::Mat gray;
  cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray < 200), 0.02 * gray.total()) << "blank page";
  const cv::Rect map_area =
      cv::Rect(rect[0], rect[1], rect[2], rect[3]) & cv::Rect(0, 0, img.cols, img.rows);
  ASSERT_EQ(map_area.area(), rect[2] * rect[3]) << "the map is off the screenshot";
  const cv::Mat on_map = img(map_area);
  const int vo_px = CountColour(on_map, 0xD5, 0x5E, 0x00);
  const int gps_px = CountColour(on_map, 0x00, 0x72, 0xB2, 20);
  if (const char* keep = std::getenv("AEROVO_KEEP_MAP_SHOT"); keep != nullptr && *keep != '\0') {
    cv::imwrite(keep, on_map);  // to look at it
  }                             // drawn at 85 % opacity
  EXPECT_GT(vo_px, 300) << "VO track not drawn on the map";
  EXPECT_GT(gps_px, 300) << "GPS track not drawn on the map";
  EXPECT_GT(CountColour(on_map, 200, 200, 200, 3), 0.05 * map_area.area())
      << "mosaic overlay not drawn";
  // Track colours in the figures below the map.
  EXPECT_GT(CountColour(img, 0xCC, 0x79, 0xA7), 100);  // VO, Sim(2)-aligned
}

}  // namespace
}  // namespace aerovo::html_report_test
