// The bytes of telemetry text files as other programs write them (io_detail::TextLines,
// Printable, Utf16ToUtf8 in parse_util.h) through the CSV, DJI SRT and GPX readers: UTF-16
// with a byte-order mark (Windows "Unicode" text), classic Mac line ends, binary data, huge
// lines and control characters. Each input is written byte for byte.
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::text_input_test {
namespace {

using io_test::ExpectInputError;

// `utf8` (ASCII only) as UTF-16 code units, little- or big-endian, after the byte-order mark.
std::string Utf16WithBom(const std::string& utf8, bool big_endian) {
  std::string r = big_endian ? std::string("\xFE\xFF") : std::string("\xFF\xFE");
  for (char c : utf8) {
    if (big_endian) r.push_back('\0');
    r.push_back(c);
    if (!big_endian) r.push_back('\0');
  }
  return r;
}

std::string MessageOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

// A CSV saved as "Unicode text" (UTF-16 LE with its mark, CRLF), a DJI SRT in UTF-16 BE: read
// as their UTF-8 originals. Before: "header has no latitude column" and
// "expected a subtitle number, found '\xFF\xFE1'" (raw bytes on the terminal).
TEST(TextInput, Utf16WithAByteOrderMarkIsRead) {
  io_test::TempDir dir("aerovo_text_input");
  {
    std::ofstream out(dir / "u16.csv", std::ios::binary);
    out << Utf16WithBom("time,lat,lon,rel_alt\r\n0,47.1,8.1,30\r\n1.5,47.1001,8.1002,31.5\r\n",
                        false);
  }
  const TelemetryReadResult csv = ReadTelemetryFile(dir / "u16.csv");
  ASSERT_EQ(csv.records, 2);
  EXPECT_DOUBLE_EQ(csv.telemetry[1].time_s, 1.5);
  EXPECT_DOUBLE_EQ(csv.telemetry[1].lat_deg, 47.1001);
  EXPECT_DOUBLE_EQ(csv.telemetry[1].lon_deg, 8.1002);
  EXPECT_DOUBLE_EQ(*csv.telemetry[1].rel_alt_m, 31.5);
  EXPECT_EQ(csv.telemetry[1].origin, (dir / "u16.csv").string() + ":3");

  std::istringstream srt(Utf16WithBom(
      "1\r\n00:00:00,000 --> 00:00:00,033\r\n"
      "[latitude: -37.996099] [longitude: 177.035704] [rel_alt: 75.645 abs_alt: 227.888]\r\n\r\n"
      "2\r\n00:00:00,033 --> 00:00:00,066\r\n"
      "[latitude: -37.996100] [longitude: 177.035705] [rel_alt: 75.700 abs_alt: 227.900]\r\n",
      true));
  const TelemetryReadResult s = ParseDjiSrt(srt, "u16.srt");
  ASSERT_EQ(s.records, 2);
  EXPECT_DOUBLE_EQ(s.telemetry[1].time_s, 0.033);
  EXPECT_DOUBLE_EQ(s.telemetry[1].lat_deg, -37.9961);
  EXPECT_DOUBLE_EQ(*s.telemetry[1].rel_alt_m, 75.7);
  EXPECT_EQ(s.telemetry[1].origin, "u16.srt:5");
}

// A GPX file in UTF-16 is parsed as before (pugixml reads it), and its errors now name the line
// of the text: pugixml's offsets are those of its UTF-8 copy, which put this error at line 2.
TEST(TextInput, Utf16GpxErrorsNameTheirLine) {
  const std::string gpx =
      "<?xml version=\"1.0\" encoding=\"UTF-16\"?>\n"
      "<gpx version=\"1.1\" xmlns=\"http://www.topografix.com/GPX/1/1\">\n"
      "<trk><trkseg>\n"
      "<trkpt lat=\"47.1\" lon=\"8.1\"><ele>500</ele><time>2020-01-01T00:00:00Z</time></trkpt>\n"
      "<trkpt lat=\"47.2\" lon=\"8.1\"><ele>x</ele><time>2020-01-01T00:00:01Z</time></trkpt>\n"
      "</trkseg></trk></gpx>\n";
  for (bool big_endian : {false, true}) {
    for (bool bom : {true, false}) {  // without the mark: XML 1.0 Appendix F.1 ("<?" in UTF-16)
      std::string bytes = Utf16WithBom(gpx, big_endian);
      if (!bom) bytes.erase(0, 2);
      std::istringstream in(bytes);
      EXPECT_EQ(MessageOf([&] { ParseGpx(in, "u16.gpx"); }), "u16.gpx:5: <ele> 'x' is not a number")
          << big_endian << bom;
    }
  }
  std::string fine = gpx;
  fine.replace(fine.find("<ele>x"), 6, "<ele>501.5");
  std::istringstream in(Utf16WithBom(fine, false));
  const TelemetryReadResult r = ParseGpx(in, "u16.gpx");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].abs_alt_m, 501.5);
  EXPECT_EQ(r.telemetry[1].origin, "u16.gpx:5");
}

// Lines ended by a lone CR (classic Mac OS spreadsheet exports) are lines: before, the whole
// file was one header line ("header has no time column").
TEST(TextInput, LoneCarriageReturnsEndLines) {
  std::istringstream csv("time,lat,lon,rel_alt\r0,47.1,8.1,30\r2,47.2,8.2,32\r");
  const TelemetryReadResult r = ParseTelemetryCsv(csv, "mac.csv");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].time_s, 2.0);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lon_deg, 8.2);
  EXPECT_EQ(r.telemetry[1].origin, "mac.csv:3");
}

// Binary data, UTF-16 without a mark, UTF-32, and a line of 2 MB are refused naming the file
// and the line, in strict and lenient mode alike; none is read into a misleading message (the
// 200 MB line took 570 MB of memory to be read whole before).
TEST(TextInput, BinaryDataAndHugeLinesAreRefusedNamingTheLine) {
  for (bool lenient : {false, true}) {
    TelemetryReadOptions options;
    options.lenient = lenient;
    std::istringstream nul(std::string("time,lat,lon\n0,47.1,8.1\n1,\0\x01\x02", 29));
    ExpectInputError([&] { ParseTelemetryCsv(nul, "log.DAT.csv", options); },
                     {"log.DAT.csv:3: a NUL byte at column 3: not a text file (binary data, or "
                      "UTF-16/UTF-32 text without a byte-order mark"});
    const std::string no_bom = Utf16WithBom("1\n00:00:00,000 --> 00:00:01,000\n", false).substr(2);
    std::istringstream srt(no_bom);
    ExpectInputError([&] { ParseDjiSrt(srt, "u16.srt", options); },
                     {"u16.srt:1: a NUL byte at column 2: not a text file"});
    std::istringstream utf32(std::string("\xFF\xFE\0\0t\0\0\0", 8));
    ExpectInputError([&] { ParseTelemetryCsv(utf32, "u32.csv", options); },
                     {"u32.csv: the file is UTF-32 text"});
    std::istringstream huge("time,lat,lon\n0,47.1," + std::string(2'000'000, '8') + "\n");
    ExpectInputError([&] { ParseTelemetryCsv(huge, "huge.csv", options); },
                     {"huge.csv:2: a line longer than 1048576 bytes: not a telemetry text file"});
    std::istringstream huge_srt("1\n00:00:00,000 --> 00:00:01,000\n" + std::string(1 << 21, 'x'));
    ExpectInputError([&] { ParseDjiSrt(huge_srt, "huge.srt", options); },
                     {"huge.srt:3: a line longer than 1048576 bytes"});
  }
  // A line of exactly the limit is still read (a record, whatever its content).
  std::istringstream at_limit("time,lat,lon,note\n0,47.1,8.1," +
                              std::string(io_detail::kMaxTextLineBytes - 11, 'n') + "\n");
  EXPECT_EQ(ParseTelemetryCsv(at_limit, "wide.csv").records, 1);
}

// Text quoted from a file in a message never carries its control characters (an ESC sequence
// would retitle or clear the terminal) nor bytes that are not UTF-8; it is cut at 40-60 bytes.
TEST(TextInput, MessagesQuoteInputTextEscaped) {
  std::istringstream csv("time,lat,lon\n0,\x1B]0;owned\x07,8.1\n");
  const std::string c = MessageOf([&] { ParseTelemetryCsv(csv, "esc.csv"); });
  EXPECT_EQ(c, "esc.csv:2: latitude '\\x1B]0;owned\\x07' is not a number");
  std::istringstream srt("\x1B[2J1\n00:00:00,000 --> 00:00:01,000\n");
  EXPECT_EQ(MessageOf([&] { ParseDjiSrt(srt, "esc.srt"); }),
            "esc.srt:1: expected a subtitle number, found '\\x1B[2J1'");
  std::istringstream gpx(
      "<gpx><trk><trkseg><trkpt lat=\"4\x9B"
      "7\" lon=\"8\"/></trkseg></trk></gpx>");
  EXPECT_EQ(MessageOf([&] { ParseGpx(gpx, "c1.gpx"); }), "c1.gpx:1: lat '4\\x9B7' is not a number");
}

// Printable itself: core/text_test.cc.
TEST(TextInput, Utf16Conversion) {
  // U+1F600 as a surrogate pair, U+00E9, an unpaired high surrogate (U+FFFD), little-endian.
  const std::string le("\x3D\xD8\x00\xDE\xE9\x00\x3D\xD8\x41\x00", 10);
  EXPECT_EQ(io_detail::Utf16ToUtf8(le, false, "x"),
            "\xF0\x9F\x98\x80\xC3\xA9\xEF\xBF\xBD"
            "A");
  ExpectInputError([] { io_detail::Utf16ToUtf8(std::string("\x41\x00\x42", 3), false, "odd.csv"); },
                   {"odd.csv: UTF-16 text with an odd number of bytes (3)"});
}

}  // namespace
}  // namespace aerovo::text_input_test
