// The gnuplot layer: script and data generation, SVG/PNG outputs, and clear errors when gnuplot is
// missing or fails.
#include "aerovo/report/plot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <pugixml.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::plot_test {
namespace {

namespace fs = std::filesystem;

Figure TwoSeries() {
  Figure f;
  f.name = "test_fig";
  f.title = "Fig. 9: a \"quoted\" title";
  f.x_label = "frame";
  f.y_label = "time (ms)";
  PlotSeries a;
  a.title = "a";
  a.x = {0, 1, 2, 3};
  a.y = {1, 4, std::numeric_limits<double>::quiet_NaN(), 9};
  PlotSeries b;
  b.title = "b";
  b.x = {0, 3};
  b.y = {2, 2};
  b.style = SeriesStyle::kLinesPoints;
  b.color = "#112233";
  f.series = {a, b};
  return f;
}

fs::path TempDir(const std::string& name) {
  return ::aerovo::testing::FreshTempDir("aerovo_plot_test", name);
}

TEST(Plot, DataHasOneBlockPerSeriesAndMissingValues) {
  const std::string data = GnuplotData(TwoSeries());
  EXPECT_NE(data.find("0 1\n1 4\n2 ?\n3 9\n"), std::string::npos) << data;
  EXPECT_NE(data.find("\n\n\n# series 1: b\n0 2\n3 2\n"), std::string::npos) << data;
}

TEST(Plot, ScriptQuotesTextAndWritesBothTerminals) {
  const std::string s = GnuplotScript(TwoSeries(), "d.dat", "o.svg", "o.png");
  EXPECT_NE(s.find("set title 'Fig. 9: a \"quoted\" title'"), std::string::npos) << s;
  EXPECT_NE(s.find("set xlabel 'frame'"), std::string::npos);
  EXPECT_NE(s.find("set ylabel 'time (ms)'"), std::string::npos);
  EXPECT_NE(s.find("set terminal svg size 900,540"), std::string::npos);
  EXPECT_NE(s.find("set terminal pngcairo size 1800,1080"), std::string::npos);
  EXPECT_NE(s.find("'d.dat' index 1 using 1:2 with linespoints"), std::string::npos);
  EXPECT_NE(s.find("lc rgb '#112233'"), std::string::npos);
  const std::string svg_only = GnuplotScript(TwoSeries(), "d.dat", "o.svg", "");
  EXPECT_EQ(svg_only.find("pngcairo"), std::string::npos);
}

TEST(Plot, ValidateRejectsBadFigures) {
  Figure f = TwoSeries();
  f.series[0].y.pop_back();
  EXPECT_THROW(Validate(f), InvalidArgument);
  f = TwoSeries();
  f.series[1].color = "red";
  EXPECT_THROW(Validate(f), InvalidArgument);
  f = TwoSeries();
  f.name = "../escape";
  EXPECT_THROW(Validate(f), InvalidArgument);
  f = TwoSeries();
  f.series.clear();
  EXPECT_THROW(Validate(f), InvalidArgument);
}

TEST(Plot, RendersValidSvgAndPng) {
  PlotOptions o;
  if (FindGnuplot(o).empty()) GTEST_SKIP() << "gnuplot not installed (Debian gnuplot-nox)";
  const fs::path dir = TempDir("render");
  const FigureFiles files = RenderFigure(TwoSeries(), dir, o);
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_file(files.svg.c_str());
  ASSERT_TRUE(parsed) << parsed.description();
  const pugi::xml_node svg = doc.child("svg");
  ASSERT_TRUE(svg);
  EXPECT_STREQ(svg.attribute("width").value(), "900");
  // Two curves and the axes are paths; the title and labels are text.
  EXPECT_GT(doc.select_nodes("//path").size(), 5u);
  bool title_found = false;
  for (const pugi::xpath_node& t : doc.select_nodes("//text")) {
    if (std::string(t.node().child_value()).find("Fig. 9") != std::string::npos ||
        std::string(t.node().text().get()).find("Fig. 9") != std::string::npos) {
      title_found = true;
    }
  }
  EXPECT_TRUE(title_found);
  const cv::Mat png = cv::imread(files.png.string());
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 1800);
  EXPECT_EQ(png.rows, 1080);
  EXPECT_TRUE(fs::exists(dir / "test_fig.gp"));
  EXPECT_TRUE(fs::exists(dir / "test_fig.dat"));
  fs::remove_all(dir);
}

// gnuplot substitutes `command` in backquotes outside single-quoted strings: hostile text in a
// title, a series name or the folder's path must not run anything.
TEST(Plot, HostileTextAndFolderNamesRunNothing) {
  PlotOptions o;
  if (FindGnuplot(o).empty()) GTEST_SKIP() << "gnuplot not installed (Debian gnuplot-nox)";
  const fs::path dir = TempDir("hostile") / "x';`touch PWNED`;$(touch PWNED)'";
  fs::create_directories(dir);
  Figure f = TwoSeries();
  f.title = "`touch PWNED` it's";
  f.series[0].title = "$(touch PWNED) `touch PWNED`";
  o.png = false;
  const FigureFiles files = RenderFigure(f, dir, o);
  EXPECT_TRUE(fs::exists(files.svg));
  EXPECT_FALSE(fs::exists(dir / "PWNED"));
  EXPECT_FALSE(fs::exists(dir.parent_path() / "PWNED"));
  EXPECT_FALSE(fs::exists("PWNED"));
  const std::string script = GnuplotScript(f, "d.dat", "o.svg", "");
  EXPECT_NE(script.find("set title '`touch PWNED` it''s'"), std::string::npos) << script;
  fs::remove_all(dir.parent_path());
}

TEST(Plot, MissingGnuplotIsAnInputErrorNamingTheFigure) {
  PlotOptions o;
  o.gnuplot = "/nonexistent/gnuplot";
  try {
    RenderFigure(TwoSeries(), TempDir("missing"), o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("figure 'test_fig'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("gnuplot-nox"), std::string::npos) << e.what();
  }
}

TEST(Plot, FailingGnuplotIsAnInputErrorWithItsMessage) {
  PlotOptions o;
  if (FindGnuplot(o).empty()) GTEST_SKIP() << "gnuplot not installed (Debian gnuplot-nox)";
  Figure f = TwoSeries();
  f.key = "no_such_key_option";  // gnuplot rejects it
  const fs::path dir = TempDir("fail");
  try {
    RenderFigure(f, dir, o);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("figure 'test_fig'"), std::string::npos) << m;
    EXPECT_NE(m.find("failed"), std::string::npos) << m;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::plot_test
