// CsvLines and SplitCsv: the CSV tokenizer shared by the named-column readers.
#include "aerovo/telemetry/csv_lines.h"

#include <gtest/gtest.h>

#include <sstream>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::csv_lines_test {
namespace {

using io_test::ExpectInputError;
using Cells = std::vector<std::string>;

TEST(CsvLines, SplitHonoursQuotes) {
  Cells cells;
  EXPECT_TRUE(SplitCsv("a,\"b,c\",\"say \"\"hi\"\"\",", ',', cells));
  EXPECT_EQ(cells, (Cells{"a", "b,c", "say \"hi\"", ""}));
  EXPECT_TRUE(SplitCsv(" x ; y", ';', cells));
  EXPECT_EQ(cells, (Cells{" x ", " y"}));  // not trimmed
  EXPECT_FALSE(SplitCsv("a,\"b", ',', cells));
  EXPECT_EQ(cells, (Cells{"a", "b"}));
}

TEST(CsvLines, HeaderAfterBomBlankAndCommentLinesThenRecordsWithLineNumbers) {
  std::istringstream in(
      "\xEF\xBB\xBF\r\n# made by hand\r\nt;lat;\"lon\"\r\n1;2,5;3\r\n\r\n  # note\n4;\"5\n6\n");
  CsvLines csv(in, "f.csv");
  EXPECT_EQ(csv.header_line(), 3);
  EXPECT_EQ(csv.separator(), ';');
  EXPECT_EQ(csv.header(), (Cells{"t", "lat", "lon"}));
  Cells cells;
  ASSERT_TRUE(csv.Next(cells));
  EXPECT_EQ(csv.line(), 4);
  EXPECT_FALSE(csv.unterminated_quote());
  EXPECT_EQ(cells, (Cells{"1", "2,5", "3"}));
  ASSERT_TRUE(csv.Next(cells));
  EXPECT_EQ(csv.line(), 7);
  EXPECT_TRUE(csv.unterminated_quote());
  ASSERT_TRUE(csv.Next(cells));
  EXPECT_EQ(csv.line(), 8);
  EXPECT_FALSE(csv.unterminated_quote());
  EXPECT_EQ(cells, (Cells{"6"}));
  EXPECT_FALSE(csv.Next(cells));
}

TEST(CsvLines, SeparatorHintLineIsNotTheHeader) {
  std::istringstream in("sep=;\r\nOSD.latitude;OSD.height [ft]\r\n1,5;2\r\n");
  CsvLines csv(in, "f.csv");
  EXPECT_EQ(csv.header_line(), 2);
  EXPECT_EQ(csv.separator(), ';');
  EXPECT_EQ(csv.header(), (Cells{"OSD.latitude", "OSD.height [ft]"}));
  Cells cells;
  ASSERT_TRUE(csv.Next(cells));
  EXPECT_EQ(csv.line(), 3);
  EXPECT_EQ(cells, (Cells{"1,5", "2"}));
  std::istringstream only_hint("sep=,\n\n");
  ExpectInputError([&] { CsvLines csv2(only_hint, "h.csv"); }, {"h.csv: empty CSV file"});
}

TEST(CsvLines, NoHeaderOrBrokenHeaderNamesTheSource) {
  std::istringstream empty("\n  \n# only a comment\n");
  ExpectInputError([&] { CsvLines csv(empty, "e.csv"); }, {"e.csv: empty CSV file (no header)"});
  std::istringstream quote("\na,\"b\n1,2\n");
  ExpectInputError([&] { CsvLines csv(quote, "q.csv"); }, {"q.csv:2: unterminated quote"});
}

}  // namespace
}  // namespace aerovo::csv_lines_test
