// report/style.h: the track colours are the ones documented, the other series never take one,
// and the gnuplot figures draw a series without a colour in the palette's.
#include "aerovo/report/style.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "aerovo/report/plot.h"

namespace aerovo::style_test {
namespace {

TEST(ReportStyle, HexSpellsTheColour) {
  EXPECT_EQ(style::Hex(style::kGps), "#0072B2");
  EXPECT_EQ(style::Hex(style::kVo), "#D55E00");
  EXPECT_EQ(style::Hex(style::kTruth), "#009E73");
  EXPECT_EQ(style::Hex(style::kVoSim2), "#CC79A7");
  EXPECT_EQ(style::Hex(style::kBridged), "#E69F00");
  EXPECT_EQ(style::Hex(0x000000), "#000000");
  EXPECT_EQ(style::Hex(0xFFFFFF), "#FFFFFF");
  EXPECT_EQ(style::Hex(0x123456), "#123456");
}

TEST(ReportStyle, SeriesPaletteHoldsNoTrackColour) {
  const std::set<std::string> tracks = {style::Hex(style::kGps), style::Hex(style::kVo),
                                        style::Hex(style::kTruth), style::Hex(style::kVoSim2),
                                        style::Hex(style::kBridged),
                                        style::Hex(style::kVoOptimized),
                                        style::Hex(style::kMapFixFused),
                                        style::Hex(style::kMapFixRecorded),
                                        style::Hex(style::kMapFixGated)};
  std::set<std::string> seen;
  for (const char* c : style::kSeriesPalette) {
    EXPECT_EQ(tracks.count(c), 0u) << c;
    EXPECT_TRUE(seen.insert(c).second) << "twice: " << c;
  }
  // A figure of four stages and their black total: black is not among the first four.
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NE(std::string(style::kSeriesPalette[i]), "#000000");
}

TEST(ReportStyle, UncolouredSeriesTakeThePalette) {
  Figure f;
  f.name = "palette";
  for (int i = 0; i < 3; ++i) {
    PlotSeries s;
    s.x = {0, 1};
    s.y = {0, 1};
    f.series.push_back(s);
  }
  f.series[1].color = style::Hex(style::kVo);
  const std::string script = GnuplotScript(f, "d.dat", "f.svg", "");
  EXPECT_NE(script.find(std::string("lc rgb '") + style::kSeriesPalette[0] + "'"),
            std::string::npos);
  EXPECT_NE(script.find("lc rgb '#D55E00'"), std::string::npos);
  EXPECT_NE(script.find(std::string("lc rgb '") + style::kSeriesPalette[2] + "'"),
            std::string::npos);
}

}  // namespace
}  // namespace aerovo::style_test
