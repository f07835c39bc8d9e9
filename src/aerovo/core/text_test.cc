// TrimSpace, ParseDecimal and Printable (core/text.h): the grammar of a number in outside text,
// and outside text quoted in a message.
#include "aerovo/core/text.h"

#include <cmath>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace aerovo {
namespace {

TEST(ReadAtMost, TheWholeStreamOrNothingPastTheLimit) {
  const std::string text(200000, 'x');  // over three 64 KiB blocks
  std::istringstream exact(text);
  const auto all = ReadAtMost(exact, text.size());
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(*all, text);
  std::istringstream over(text);
  EXPECT_FALSE(ReadAtMost(over, text.size() - 1).has_value());
  // At most max_bytes + 1 are taken from the stream.
  std::istringstream long_stream(text);
  EXPECT_FALSE(ReadAtMost(long_stream, 1000).has_value());
  EXPECT_EQ(long_stream.tellg(), std::streampos(1001));
  std::istringstream small("abc");
  EXPECT_EQ(ReadAtMost(small, 1 << 20).value(), "abc");
  std::istringstream empty("");
  EXPECT_EQ(ReadAtMost(empty, 0).value(), "");
  std::istringstream one("a");
  EXPECT_FALSE(ReadAtMost(one, 0).has_value());
}

TEST(TrimSpace, AsciiWhiteSpaceOnBothEndsOnly) {
  EXPECT_EQ(TrimSpace(" \t\r\n\v\fa b\t \r\n"), "a b");
  EXPECT_EQ(TrimSpace(""), "");
  EXPECT_EQ(TrimSpace(" \t "), "");
  EXPECT_EQ(TrimSpace("\xC2\xA0x"), "\xC2\xA0x");  // U+00A0 is not ASCII space
}

TEST(ParseDecimal, PlainDecimalNumbers) {
  EXPECT_EQ(*ParseDecimal("0"), 0.0);
  EXPECT_EQ(*ParseDecimal(" +44.47 "), 44.47);
  EXPECT_EQ(*ParseDecimal("-1e3"), -1000.0);
  EXPECT_EQ(*ParseDecimal("1E+3"), 1000.0);
  EXPECT_EQ(*ParseDecimal("2.5e-3"), 0.0025);
  EXPECT_EQ(*ParseDecimal(".5"), 0.5);
  EXPECT_EQ(*ParseDecimal("5."), 5.0);
  EXPECT_EQ(*ParseDecimal("-0"), 0.0);
  EXPECT_TRUE(std::signbit(*ParseDecimal("-0")));
  EXPECT_EQ(*ParseDecimal("\t-122.4194155\r\n"), -122.4194155);
  EXPECT_EQ(*ParseDecimal("1.7976931348623157e308"), 1.7976931348623157e308);
  EXPECT_EQ(*ParseDecimal("0e999"), 0.0);
  EXPECT_EQ(*ParseDecimal("1e-310"), 1e-310);  // subnormal, not zero
  EXPECT_EQ(*ParseDecimal(std::string(64, '1')), 1.1111111111111111e63);
}

TEST(ParseDecimal, EverythingElseIsNotANumber) {
  for (const char* bad :
       {"",      " ",      "nan",    "NaN",  "-nan", "inf",   "-inf", "infinity", "0x10", "0x1p3",
        "1e400", "-1e400", "1e-400", "1.5m", "1,5",  "1.2.3", "--1",  "+-1",      "-+1",  "+",
        "-",     ".",      "-.",     "e5",   ".e5",  "1e",    "1e+",  "1e5.5",    "1 2",  "12 m"}) {
    EXPECT_FALSE(ParseDecimal(bad)) << "'" << bad << "'";
  }
  // U+2212 MINUS SIGN is not '-'.
  EXPECT_FALSE(ParseDecimal(std::string("\xE2\x88\x92") + "1"));
  EXPECT_FALSE(ParseDecimal(std::string_view("1\0", 2)));  // an embedded NUL
  EXPECT_FALSE(ParseDecimal(std::string(65, '1')));        // longer than any number of a file
}

// Outside text quoted in a message: printable ASCII and valid UTF-8 kept, control characters and
// invalid bytes escaped, cut at a character boundary.
TEST(Printable, ControlAndInvalidBytesEscapedCutAtACharacter) {
  EXPECT_EQ(Printable("GPS(47.1, 8.1) 12\xC2\xB0"), "GPS(47.1, 8.1) 12\xC2\xB0");  // ° kept
  EXPECT_EQ(Printable("a\tb\x7F\xC2\x9B[2J"), "a\\x09b\\x7F\\xC2\\x9B[2J");   // C0, DEL, C1 CSI
  EXPECT_EQ(Printable("\xC0\xAF\xED\xA0\x80"), "\\xC0\\xAF\\xED\\xA0\\x80");  // overlong, surrogate
  EXPECT_EQ(Printable(std::string(100, 'a'), 5), "aaaaa...");
  EXPECT_EQ(Printable("ab\xE2\x82\xAC", 4), "ab...");  // "€" not cut in half
  EXPECT_EQ(Printable(std::string("\x1b[2J\0x", 6)), "\\x1B[2J\\x00x");
}

}  // namespace
}  // namespace aerovo
