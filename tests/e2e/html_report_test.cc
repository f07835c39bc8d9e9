// `aerovo report`: the HTML report of a short simulated flight (run folder) and of hand-written
// experiment folders, and (when Debian's chromium is installed) the rendering checked in a headless
// browser. The flight is simulated and run once per test process (~2 s on 2 cores); the
// reports take ~1 s each, the browser ~3 s per page.
#include "aerovo/report/html_report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <pugixml.hpp>

#include "aerovo/core/error.h"
#include "aerovo/io/track_writers.h"
#include "aerovo/report/run_reader.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo {
namespace {

namespace fs = std::filesystem;

std::string ReadText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

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

// Self-contained: no http(s) reference anywhere, every src= is a data: URI.
void CheckSelfContained(const std::string& html) {
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  static const std::regex src(R"(\bsrc\s*=\s*["']([^"']{0,10}))");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), src); it != std::sregex_iterator();
       ++it) {
    EXPECT_EQ((*it)[1].str().substr(0, 5), "data:");
  }
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
  const int plots = truth ? 5 : 4;
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

TEST_F(HtmlReport, RendersInHeadlessChromium) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "chromium not installed (Debian package chromium; scripts/install-deps.sh "
                    "installs it): browser rendering not checked";
  }
  const fs::path run = CopyRun("run_browser");
  ReportOptions o;
  o.plot.png = false;  // the page inlines the SVGs; PNG files play no part in it
  const ReportResult r = WriteReport(run, o);
  const std::string url = "file://" + fs::absolute(r.html).string();
  const fs::path profile = root_ / "chromium-profile";
  const std::string flags =
      "--headless --no-sandbox --disable-gpu --disable-dev-shm-usage --hide-scrollbars "
      "--no-first-run --user-data-dir=" +
      profile.string();
  // 1. The DOM after load: the report's own script counts the figures that rendered.
  const fs::path dom = root_ / "dom.html";
  std::string cmd = "timeout 90 " + chromium + " " + flags +
                    " --virtual-time-budget=5000 --dump-dom '" + url + "' > " + dom.string() +
                    " 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::string body = ReadText(dom);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(body, m, std::regex(R"re(data-figures-expected="(\d+)")re")));
  const int expected = std::stoi(m[1]);
  EXPECT_GE(expected, 5);  // 4 or 5 plots (with a ground truth) and the mosaic
  ASSERT_TRUE(std::regex_search(body, m, std::regex(R"re(data-figures-ok="(\d+)")re")))
      << "the report's check script did not run";
  EXPECT_EQ(std::stoi(m[1]), expected);
  ASSERT_TRUE(std::regex_search(body, m, std::regex(R"re(data-figures-failed="([^"]*)")re")));
  EXPECT_EQ(m[1].str(), "");

  // 2. A screenshot: not blank, and the plots' colours are on it.
  const fs::path shot = root_ / "shot.png";
  cmd = "timeout 90 " + chromium + " " + flags +
        " --window-size=1400,5000 --screenshot=" + shot.string() + " '" + url +
        "' > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const cv::Mat img = cv::imread(shot.string());
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1400);
  cv::Mat gray;
  cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray < 200), 0.02 * gray.total()) << "blank page";
  // Palette colours of the figures (aerovo/report/plot.cc): blue #0072B2, vermillion #D55E00,
  // green #009E73 — curves drawn in the SVGs.
  EXPECT_GT(CountColour(img, 0x00, 0x72, 0xB2), 300);
  EXPECT_GT(CountColour(img, 0xD5, 0x5E, 0x00), 300);
  EXPECT_GT(CountColour(img, 0x00, 0x9E, 0x73), 100);
}

}  // namespace
}  // namespace aerovo
