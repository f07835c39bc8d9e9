// HtmlBuilder (report/html_builder.h): text and attribute values escaped, tags and Raw() as given.
#include "aerovo/report/html_builder.h"

#include <gtest/gtest.h>

namespace aerovo::html_builder_test {
namespace {

TEST(HtmlBuilder, EscapesTextAndAttributeValues) {
  HtmlBuilder h;
  h.Open("a", {{"href", "run \"1\"/report.html?a=1&b=<2>"}, {"title", "it's"}})
      .Text("k<1 & k>0 \"quoted\" 'single'")
      .Close("a");
  EXPECT_EQ(h.str(),
            "<a href=\"run &quot;1&quot;/report.html?a=1&amp;b=&lt;2&gt;\" title=\"it&apos;s\">"
            "k&lt;1 &amp; k&gt;0 &quot;quoted&quot; &apos;single&apos;</a>");
}

TEST(HtmlBuilder, ElementNewlineAndAttributeOrder) {
  HtmlBuilder h;
  h.Element("h2", {{"id", "runs"}}, "Runs & tables").Newline();
  h.Element("p", {{"class", "note"}, {"id", "n1"}}, "").Newline();
  h.Element("code", {}, "</code><script>");
  EXPECT_EQ(h.str(),
            "<h2 id=\"runs\">Runs &amp; tables</h2>\n<p class=\"note\" id=\"n1\"></p>\n"
            "<code>&lt;/code&gt;&lt;script&gt;</code>");
}

TEST(HtmlBuilder, RawIsNotEscapedAndInsertPlacesASection) {
  HtmlBuilder page;
  page.Raw("<nav><a href=\"#map\">Map</a></nav>\n");
  const std::size_t at = page.size();
  page.Element("p", {}, "after").Newline();
  HtmlBuilder map;
  map.Open("div", {{"id", "aerovo-map"}}).Close("div").Newline();
  page.Insert(at, map);
  EXPECT_EQ(page.str(),
            "<nav><a href=\"#map\">Map</a></nav>\n<div id=\"aerovo-map\"></div>\n<p>after</p>\n");
  EXPECT_EQ(page.size(), page.str().size());
}

TEST(HtmlBuilder, NonAsciiTextIsKept) {
  HtmlBuilder h;
  h.Text("ATE — 2 m · k=0.50");
  EXPECT_EQ(h.str(), "ATE — 2 m · k=0.50");
}

}  // namespace
}  // namespace aerovo::html_builder_test
