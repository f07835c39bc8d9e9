#include "aerovo/telemetry/telemetry_readers.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/binary_log_util.h"
#include "aerovo/telemetry/csv_lines.h"
#include "aerovo/telemetry/io_test_util.h"
#include "aerovo/telemetry/parse_util.h"

namespace aerovo::telemetry_readers_test {
namespace {

using io_test::ExpectInputError;

using ::testing::HasSubstr;

// ---------------------------------------------------------------- dates and numbers

TEST(ParseUtil, DateTimes) {
  using io_detail::ParseDateTime;
  EXPECT_DOUBLE_EQ(*ParseDateTime("1970-01-01T00:00:00Z"), 0.0);
  EXPECT_DOUBLE_EQ(*ParseDateTime("2000-03-01T00:00:00Z"), 951868800.0);
  EXPECT_DOUBLE_EQ(*ParseDateTime("2023-05-01T12:00:00Z"), 1682942400.0);
  EXPECT_NEAR(*ParseDateTime("2023-05-01T12:00:00.250Z"), 1682942400.25, 1e-6);
  EXPECT_DOUBLE_EQ(*ParseDateTime("2023-05-01T14:00:00+02:00"), 1682942400.0);
  EXPECT_DOUBLE_EQ(*ParseDateTime("2023-05-01T07:30:00-0430"), 1682942400.0);
  EXPECT_DOUBLE_EQ(*ParseDateTime("2023:05:01 12:00:00"), 1682942400.0);  // EXIF
  EXPECT_DOUBLE_EQ(*ParseDateTime("2023.05.01 12:00:00"), 1682942400.0);  // old DJI HOME line
  EXPECT_NEAR(*ParseDateTime("2023-05-01 12:00:00,123,456"), 1682942400.123456, 1e-6);  // SRT
  EXPECT_FALSE(ParseDateTime("2023-02-29T00:00:00Z"));  // not a leap year
  EXPECT_TRUE(ParseDateTime("2024-02-29T00:00:00Z"));
  EXPECT_FALSE(ParseDateTime("2023-13-01T00:00:00Z"));
  EXPECT_FALSE(ParseDateTime("2023-05-01T25:00:00Z"));
  EXPECT_FALSE(ParseDateTime("2023-05-01"));
  EXPECT_FALSE(ParseDateTime("yesterday"));
  EXPECT_FALSE(ParseDateTime("2023-05-01T12:00:00Zjunk"));
}

// The binary logs' attitude series: yaw in [0, 360) whether t falls between two points or on one
// (a log's yaw of -40 degrees is 320), along the shorter arc, never across a gap or outside.
TEST(ParseUtil, InterpolateSeriesNormalisesYawAtAndBetweenPoints) {
  using io_detail::InterpolateSeries;
  using io_detail::SeriesPoint;
  const std::vector<SeriesPoint> s = {{1.0, {1.0, 2.0, -40.0}},
                                      {2.0, {3.0, 4.0, 20.0}},
                                      {3.0, {5.0, 6.0, 170.0}},
                                      {4.0, {7.0, 8.0, -170.0}},
                                      {9.0, {0.0, 0.0, 0.0}}};
  const auto at = [&](double t, bool angles) { return InterpolateSeries(s, t, angles, 1.0); };
  ASSERT_TRUE(at(1.0, true));
  EXPECT_DOUBLE_EQ(at(1.0, true)->v[2], 320.0);
  EXPECT_DOUBLE_EQ(at(1.0, true)->v[0], 1.0);
  EXPECT_DOUBLE_EQ(at(1.0, false)->v[2], -40.0);  // not angles: as logged
  EXPECT_DOUBLE_EQ(at(1.5, true)->v[2], 350.0);   // -40 .. 20 through 0
  EXPECT_DOUBLE_EQ(at(1.5, true)->v[0], 2.0);
  EXPECT_DOUBLE_EQ(at(3.5, true)->v[2], 180.0);  // 170 .. -170 through 180, not 0
  EXPECT_DOUBLE_EQ(at(4.0, true)->v[2], 190.0);
  EXPECT_FALSE(at(5.0, true));  // 4 .. 9: a gap longer than 1 s
  EXPECT_FALSE(at(0.5, true));  // before the series
  EXPECT_FALSE(at(9.5, true));  // after it
}

// Numbers themselves: ParseDecimal (core/text_test.cc).
TEST(ParseUtil, SrtClock) {
  EXPECT_DOUBLE_EQ(*io_detail::ParseSrtClock("01:02:03,456"), 3723.456);
  EXPECT_FALSE(io_detail::ParseSrtClock("01:02:03"));
}

// ---------------------------------------------------------------- DJI SRT

// Mavic Air 2 / Mavic 3 style: one subtitle per frame, bracketed fields.
const char kSrtBracketed[] =
    "1\n"
    "00:00:00,000 --> 00:00:00,033\n"
    "<font size=\"28\">FrameCnt: 1, DiffTime: 33ms\n"
    "2023-05-01 12:00:00,123,456\n"
    "[iso : 100] [shutter : 1/500.0] [fnum : 280] [ev : 0] [ct : 5500] [color_md : default] "
    "[focal_len : 240] [latitude: 43.536700] [longitude: 6.556700] [rel_alt: 100.000 abs_alt: "
    "350.123] </font>\n"
    "\n"
    "2\n"
    "00:00:00,033 --> 00:00:00,066\n"
    "<font size=\"28\">FrameCnt: 2, DiffTime: 33ms\n"
    "2023-05-01 12:00:00,156,789\n"
    "[iso : 100] [shutter : 1/500.0] [fnum : 280] [ev : 0] [ct : 5500] [color_md : default] "
    "[focal_len : 240] [latitude: 43.536800] [longitude: 6.556900] [rel_alt: 100.500 abs_alt: "
    "350.623] </font>\n"
    "\n"
    "3\n"
    "00:00:00,066 --> 00:00:00,100\n"
    "<font size=\"28\">FrameCnt: 3, DiffTime: 34ms\n"
    "2023-05-01 12:00:00,190,000\n"
    "[iso : 100] [shutter : 1/500.0] [fnum : 280] [ev : 0] [ct : 5500] [color_md : default] "
    "[focal_len : 166.00] [latitude: 43.536900] [longitude: 6.557100] [rel_alt: 101.000 abs_alt: "
    "351.123] [gb_yaw: -12.5 gb_pitch: -90.0 gb_roll: 0.0] </font>\n";

TEST(DjiSrt, BracketedFormat) {
  std::istringstream in(kSrtBracketed);
  const TelemetryReadResult r = ParseDjiSrt(in, "flight.srt");
  ASSERT_EQ(r.records, 3);
  EXPECT_EQ(r.skipped_records, 0);
  const Telemetry& t = r.telemetry;
  EXPECT_DOUBLE_EQ(t[0].time_s, 0.0);
  EXPECT_DOUBLE_EQ(t[1].time_s, 0.033);
  EXPECT_DOUBLE_EQ(t[2].time_s, 0.066);
  EXPECT_EQ(t[0].frame_index, 0);
  EXPECT_EQ(t[2].frame_index, 2);
  EXPECT_DOUBLE_EQ(t[0].lat_deg, 43.5367);
  EXPECT_DOUBLE_EQ(t[0].lon_deg, 6.5567);
  EXPECT_DOUBLE_EQ(*t[1].rel_alt_m, 100.5);
  EXPECT_DOUBLE_EQ(*t[1].abs_alt_m, 350.623);
  EXPECT_DOUBLE_EQ(*t[0].focal_length_35mm_mm, 24.0);   // 240 tenths
  EXPECT_DOUBLE_EQ(*t[2].focal_length_35mm_mm, 166.0);  // decimals: millimetres (a tele)
  EXPECT_NEAR(*t[0].unix_time_s, 1682942400.123456, 1e-5);
  EXPECT_FALSE(t[0].gimbal_yaw_deg);
  EXPECT_DOUBLE_EQ(*t[2].gimbal_yaw_deg, -12.5);
  EXPECT_DOUBLE_EQ(*t[2].gimbal_pitch_deg, -90.0);
  auto mid = t.AtFrame(1);
  ASSERT_TRUE(mid);
  EXPECT_DOUBLE_EQ(mid->lon_deg, 6.5569);
}

TEST(DjiSrt, MavicProMisspeltLongitudeAndCrLf) {
  const std::string text =
      "\xEF\xBB\xBF"
      "1\r\n00:00:00,000 --> 00:00:00,033\r\n"
      "<font size=\"36\">SrtCnt : 1, DiffTime : 33ms\r\n"
      "2017-10-08 14:48:18,085,263\r\n"
      "[iso : 100] [shutter : 1/320.0] [fnum : 220] [ev : 0] [ct : 5068] [color_md : default] "
      "[focal_len : 280] [latitude : 48.587612] [longtitude : 7.736712] [altitude: 144.830000] "
      "</font>\r\n\r\n"
      "2\r\n00:00:00,033 --> 00:00:00,067\r\n"
      "<font size=\"36\">SrtCnt : 2, DiffTime : 34ms\r\n"
      "2017-10-08 14:48:18,118,597\r\n"
      "[iso : 100] [shutter : 1/320.0] [fnum : 220] [ev : 0] [ct : 5068] [color_md : default] "
      "[focal_len : 280] [latitude : 48.587620] [longtitude : 7.736720] [altitude: 144.930000] "
      "</font>\r\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseDjiSrt(in, "mavicpro.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lon_deg, 7.73672);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lat_deg, 48.58762);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].abs_alt_m, 144.83);
  EXPECT_FALSE(r.telemetry[0].rel_alt_m);
  EXPECT_EQ(r.telemetry[1].frame_index, 1);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].focal_length_35mm_mm, 28.0);
}

TEST(DjiSrt, OldGpsFormatLongitudeFirst) {
  const char text[] =
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "HOME(6.5500,43.5300) 2017.08.05 14:11:51\n"
      "GPS(6.5567,43.5367,19) BAROMETER:99.8\n"
      "ISO:100 Shutter:60 EV: Fnum:F2.2\n\n"
      "2\n00:00:01,000 --> 00:00:02,000\n"
      "HOME(6.5500,43.5300) 2017.08.05 14:11:52\n"
      "GPS (6.5577, 43.5377, 19) BAROMETER:100.2\n"
      "ISO:100 Shutter:60 EV: Fnum:F2.2\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseDjiSrt(in, "p4.srt");
  ASSERT_EQ(r.records, 2);
  const Telemetry& t = r.telemetry;
  EXPECT_DOUBLE_EQ(t[0].lon_deg, 6.5567);
  EXPECT_DOUBLE_EQ(t[0].lat_deg, 43.5367);
  EXPECT_DOUBLE_EQ(*t[0].rel_alt_m, 99.8);
  EXPECT_DOUBLE_EQ(t[1].lon_deg, 6.5577);
  EXPECT_DOUBLE_EQ(t[1].lat_deg, 43.5377);
  EXPECT_DOUBLE_EQ(*t[1].rel_alt_m, 100.2);
  EXPECT_FALSE(t[0].abs_alt_m);    // the third GPS value is not an altitude
  EXPECT_FALSE(t[0].frame_index);  // one subtitle per second: no frame numbers
  EXPECT_DOUBLE_EQ(t[1].time_s, 1.0);
  EXPECT_DOUBLE_EQ(*t[1].unix_time_s - *t[0].unix_time_s, 1.0);
  auto half = t.Lookup(0.5);
  ASSERT_TRUE(half);
  EXPECT_NEAR(half->lat_deg, 43.5372, 1e-12);
  EXPECT_NEAR(*half->rel_alt_m, 100.0, 1e-12);
}

TEST(DjiSrt, Mavic2HeightToken) {
  const char text[] =
      "1\n00:00:00,000 --> 00:00:00,033\n"
      "F/2.8, SS 320, ISO 100, EV 0, DZOOM 1.000, GPS (7.7367, 48.5876, 19), D 24.38m, H 19.30m, "
      "H.S 0.00m/s, V.S 0.00m/s\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseDjiSrt(in, "m2.srt");
  ASSERT_EQ(r.records, 1);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 48.5876);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lon_deg, 7.7367);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].rel_alt_m, 19.3);
}

// Three valid blocks with a bad one (given as text) in the middle, at lines 7..
std::string SrtWithBadBlock(const std::string& bad_block) {
  return "1\n00:00:00,000 --> 00:00:00,033\n[latitude: 43.1] [longitude: 6.1] [rel_alt: 50.0 "
         "abs_alt: 300.0]\n\n"
         "2\n00:00:00,033 --> 00:00:00,066\n[latitude: 43.2] [longitude: 6.2]\n\n" +
         bad_block + "\n4\n00:00:00,100 --> 00:00:00,133\n[latitude: 43.4] [longitude: 6.4]\n";
}

TEST(DjiSrt, OutOfRangeLatitudeNamesFileAndLine) {
  std::istringstream in(
      SrtWithBadBlock("3\n00:00:00,066 --> 00:00:00,100\n[latitude: 123.4] [longitude: 6.3]\n"));
  // Line 11 holds the value (line 9 is the subtitle's number).
  ExpectInputError([&] { ParseDjiSrt(in, "flight.srt"); },
                   {"flight.srt:11: latitude 123.4 out of range [-90, 90]"});
}

// A DJI subtitle spreads its values over several lines: an out-of-range value is named at the
// line that holds it, not at the subtitle's first line (9 here).
TEST(DjiSrt, AValueOutOfRangeIsNamedAtTheLineHoldingIt) {
  const auto block = [](const std::string& counter, const std::string& position,
                        const std::string& height, const std::string& gimbal) {
    const std::string lines[] = {
        "3",                                                              // line 9
        "00:00:00,066 --> 00:00:00,100",                                  // 10
        "<font size=\"28\">FrameCnt: " + counter + ", DiffTime: 34ms",    // 11
        "2023-05-01 12:00:00,190,000",                                    // 12
        "[latitude: " + position + "]",                                   // 13
        "[rel_alt: " + height + " abs_alt: 350.0] [focal_len : 240]",     // 14
        "[gb_yaw: -12.5 gb_pitch: " + gimbal + " gb_roll: 0.0] </font>",  // 15
    };
    std::string text;
    for (const std::string& l : lines) text += l + "\n";
    return text;
  };
  const struct {
    std::string text, expected;
  } cases[] = {
      {block("3", "43.3] [longitude: 200", "100.0", "-90.0"),
       "c.srt:13: longitude 200 out of range [-180, 180]"},
      {block("3", "43.3] [longitude: 6.3", "1e6", "-90.0"),
       "c.srt:14: relative altitude (m) 1000000 out of range [-100000, 100000]"},
      {block("3", "43.3] [longitude: 6.3", "100.0", "-900"),
       "c.srt:15: gimbal pitch -900 out of range [-360, 360]"},
      {block("0", "43.3] [longitude: 6.3", "100.0", "-90.0"),
       "c.srt:11: frame counter 0 out of range"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.expected);
    std::istringstream in(SrtWithBadBlock(c.text));
    ExpectInputError([&] { ParseDjiSrt(in, "c.srt"); }, {c.expected.c_str()});
  }
  // The same block with valid values reads.
  std::istringstream in(SrtWithBadBlock(block("3", "43.3] [longitude: 6.3", "100.0", "-90.0")));
  EXPECT_EQ(ParseDjiSrt(in, "c.srt").records, 4);
}

TEST(DjiSrt, GarbageStrictThrowsLenientSkipsAndCounts) {
  const std::string text = SrtWithBadBlock("%%% garbage line\nmore garbage\n");
  {
    std::istringstream in(text);
    ExpectInputError([&] { ParseDjiSrt(in, "g.srt"); },
                     {"g.srt:9:", "expected a subtitle number", "garbage"});
  }
  std::istringstream in(text);
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  const TelemetryReadResult r = ParseDjiSrt(in, "g.srt", lenient);
  EXPECT_EQ(r.records, 3);
  EXPECT_EQ(r.skipped_records, 1);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("g.srt:9:"));
  EXPECT_DOUBLE_EQ(r.telemetry[2].lat_deg, 43.4);
}

TEST(DjiSrt, MissingFieldsBadNumbersBadTimingOutOfOrder) {
  {
    std::istringstream in(SrtWithBadBlock("3\n00:00:00,066 --> 00:00:00,100\n[latitude: 43.3]\n"));
    ExpectInputError([&] { ParseDjiSrt(in, "m.srt"); }, {"m.srt:9:", "has no longitude"});
  }
  {
    std::istringstream in(
        SrtWithBadBlock("3\n00:00:00,066 --> 00:00:00,100\n[latitude: 4x.3] [longitude: 6]\n"));
    ExpectInputError([&] { ParseDjiSrt(in, "n.srt"); },
                     {"n.srt:11:", "latitude value '4x.3' is not a number"});
  }
  {
    std::istringstream in(SrtWithBadBlock("3\n00:00:00 -> 00:00:01\n[latitude: 43.3]\n"));
    ExpectInputError([&] { ParseDjiSrt(in, "t.srt"); }, {"t.srt:10:", "bad timing line"});
  }
  {
    std::istringstream in(
        SrtWithBadBlock("3\n00:00:00,010 --> 00:00:00,020\n[latitude: 43.3] [longitude: 6.3]\n"));
    ExpectInputError([&] { ParseDjiSrt(in, "o.srt"); }, {"o.srt:10:", "out of order"});
  }
  {
    std::istringstream in(SrtWithBadBlock("3\n00:00:00,066 --> 00:00:00,100\n[latitude: 43.3"));
    ExpectInputError([&] { ParseDjiSrt(in, "u.srt"); }, {"u.srt:11:", "unclosed '['"});
  }
}

// A recording that stopped while writing its last subtitle (dji_srt_parser's
// samples/broken_incomplete.SRT ends after a subtitle's HOME line): the cut subtitle is dropped
// with a warning naming it, in strict and lenient mode alike; the same problems before the last
// subtitle stay errors (MissingFieldsBadNumbersBadTimingOutOfOrder).
TEST(DjiSrt, ACutLastSubtitleIsDroppedWithAWarning) {
  const std::string good =
      "1\n00:00:01,000 --> 00:00:02,000\nHOME(149.0251,-20.2532) 2017.08.05 14:11:51\n"
      "GPS(149.0251,-20.2533,16) BAROMETER:1.9\n\n"
      "2\n00:00:02,000 --> 00:00:03,000\nHOME(149.0251,-20.2532) 2017.08.05 14:11:52\n"
      "GPS(149.0252,-20.2534,16) BAROMETER:2.0\n\n";
  const struct {
    std::string tail;
    long line;
    const char* problem;
  } cuts[] = {
      // Cut after the HOME line: no position (the real sample's case), with or without a line end.
      {"3\n00:00:03,000 --> 00:00:04,000\nHOME(149.0251,-20.2532) 2017.08.05 14:11:53\n", 11,
       "subtitle 3 has no latitude and longitude"},
      {"3\n00:00:03,000 --> 00:00:04,000\nHOME(149.0251,-20.2532) 2017.08.05 14:11:53", 11,
       "subtitle 3 has no latitude and longitude"},
      // Cut inside the telemetry line, the timing line or after the number.
      {"3\n00:00:03,000 --> 00:00:04,000\n[latitude: -20.25 [longi", 13, "unclosed '['"},
      {"3\n00:00:03,000 --> 00:0", 11, "subtitle 3 has no latitude and longitude"},
      {"3\n00:00:03", 12, "bad timing line"},
      {"3\n", 11, "subtitle 3 has no timing line"},
  };
  for (const auto& c : cuts) {
    SCOPED_TRACE(c.tail);
    for (const bool lenient : {false, true}) {
      std::istringstream in(good + c.tail);
      TelemetryReadOptions options;
      options.lenient = lenient;
      const TelemetryReadResult r = ParseDjiSrt(in, "cut.srt", options);
      ASSERT_EQ(r.records, 2);
      EXPECT_EQ(r.skipped_records, 0);
      EXPECT_DOUBLE_EQ(r.telemetry[1].lat_deg, -20.2534);
      ASSERT_EQ(r.warnings.size(), 1u);
      EXPECT_THAT(r.warnings[0],
                  HasSubstr(fmt::format("cut.srt:{}: the last subtitle (3) is cut short", c.line)));
      EXPECT_THAT(r.warnings[0], HasSubstr(c.problem));
    }
  }
  // Not cuts: a wrong value in the last subtitle, or text that does not parse on a line before
  // the file's last one, is an error as anywhere else.
  {
    std::istringstream in(good + "3\n00:00:03,000 --> 00:00:04,000\nGPS(149.0251,-95.0,16)\n");
    ExpectInputError([&] { ParseDjiSrt(in, "v.srt"); }, {"v.srt:13:", "latitude -95"});
  }
  {
    std::istringstream in(good +
                          "3\n00:00:03,000 --> 00:00:04,000\n[latitude: 4x.3] [longitude: 6]\n"
                          "[rel_alt: 10.0]\n");
    ExpectInputError([&] { ParseDjiSrt(in, "w.srt"); }, {"w.srt:13:", "is not a number"});
  }
}

// A model whose SRT records no position at all (dji_srt_parser's samples/mavic_air.SRT: FrameCnt,
// a date and the camera's settings, no latitude or longitude in any subtitle): its subtitles are
// records without a fix that keep what they have (heights, angles), not malformed ones.
TEST(DjiSrt, AFileThatRecordsNoPositionGivesRecordsWithoutAFix) {
  const std::string text =
      "1\n00:00:00,000 --> 00:00:00,039\n<font size=\"36\">FrameCnt : 1, DiffTime : 39ms\n"
      "2018-02-19 08:04:51,265,847\n[iso : 100] [shutter : 1/240.0] [rel_alt: 12.5] </font>\n\n"
      "2\n00:00:00,039 --> 00:00:00,079\n<font size=\"36\">FrameCnt : 2, DiffTime : 40ms\n"
      "2018-02-19 08:04:51,305,846\n[iso : 100] [shutter : 1/240.0] [rel_alt: 12.7] </font>\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseDjiSrt(in, "air.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_EQ(r.no_fix_records, 2);
  EXPECT_EQ(r.skipped_records, 0);
  EXPECT_FALSE(r.telemetry[0].has_fix);
  EXPECT_EQ(r.telemetry[1].frame_index, 1);
  ASSERT_TRUE(r.telemetry[1].rel_alt_m);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].rel_alt_m, 12.7);
  // In a file whose other subtitles have a position, a subtitle without one is malformed.
  std::istringstream mixed(
      text + "\n3\n00:00:00,079 --> 00:00:00,119\n[iso : 100] [latitude: 43.1] [longitude: 6.1]\n");
  ExpectInputError([&] { ParseDjiSrt(mixed, "mixed.srt"); },
                   {"mixed.srt:1:", "subtitle 1 has no latitude and longitude"});
}

TEST(DjiSrt, MissingBlankSeparatorLine) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:00,033\n[latitude: 43.1] [longitude: 6.1]\n"
      "2\n00:00:00,033 --> 00:00:00,066\n[latitude: 43.2] [longitude: 6.2]\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "nosep.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lat_deg, 43.2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].time_s, 0.033);
}

// A record without a fix (latitude = longitude = 0, "N/A") is a sample without a position that
// keeps its heights and angles; before, it was dropped (and a GPS(N/A,...) record refused the
// file).
TEST(DjiSrt, NoFixRecordsKeepTheirHeightAndAngles) {
  std::istringstream in(SrtWithBadBlock(
      "3\n00:00:00,066 --> 00:00:00,100\n[latitude: 0.000000] [longitude: 0.000000] "
      "[rel_alt: 50.500 abs_alt: 300.500] [gb_yaw: 10.0 gb_pitch: -45.0 gb_roll: 0.0]\n"));
  const TelemetryReadResult r = ParseDjiSrt(in, "nofix.srt");
  ASSERT_EQ(r.records, 4);
  EXPECT_EQ(r.no_fix_records, 1);
  EXPECT_EQ(r.skipped_records, 0);
  const TelemetrySample& s = r.telemetry[2];
  EXPECT_FALSE(s.has_fix);
  EXPECT_DOUBLE_EQ(*s.rel_alt_m, 50.5);
  EXPECT_DOUBLE_EQ(*s.gimbal_pitch_deg, -45.0);
  EXPECT_TRUE(r.telemetry[1].has_fix);
  EXPECT_EQ(r.telemetry[1].origin, "nofix.srt:5");
  // Between a fix and a record without one there is no position.
  const auto mid = r.telemetry.Lookup(0.08);
  ASSERT_TRUE(mid);
  EXPECT_FALSE(mid->has_fix);
  EXPECT_EQ(r.telemetry.Lookup(0.02)->origin, "between nofix.srt:1 and nofix.srt:5");
}

// ---- Every family of DJI SRT records, as the aircraft write them (lines of real files, from
// public samples: JuanIrache/DJI_SRT_Parser samples/, PhilipQuirke/SkyCombAnalystHelp
// FlightLogs.md, OpenDroneMap opendm/video/srtparser.py).

// Phantom 3/4, Inspire 1 (1 Hz): HOME(lon,lat) date, GPS(lon,lat,satellites) BAROMETER:height.
TEST(DjiSrtFamilies, PhantomOneHertzLongitudeFirst) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "HOME(149.0251,-20.2532) 2017.08.05 14:11:51\n"
      "GPS(149.0251,-20.2533,16) BAROMETER:1.9\n"
      "ISO:110 Shutter:120 EV: Fnum:F2.8 \n\n"
      "2\n00:00:01,000 --> 00:00:02,000\n"
      "HOME(149.0251,-20.2532) 2017.08.05 14:11:52\n"
      "GPS(149.0252,-20.2534,16) BAROMETER:3.4\n"
      "ISO:110 Shutter:120 EV: Fnum:F2.8 \n");
  const TelemetryReadResult r = ParseDjiSrt(in, "p3.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lat_deg, -20.2534);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lon_deg, 149.0252);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].rel_alt_m, 3.4);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].unix_time_s - *r.telemetry[0].unix_time_s, 1.0);
}

// The "Hb:" (barometric) and "Hs:" heights of some 1 Hz records: the height when there is no
// BAROMETER (Hb before Hs).
TEST(DjiSrtFamilies, HbAndHsHeights) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "HOME(6.5500,43.5300) 2018.03.01 10:00:00\n"
      "GPS(6.5567,43.5367,18) Hb:35.2m Hs:34.8m\n\n"
      "2\n00:00:01,000 --> 00:00:02,000\n"
      "HOME(6.5500,43.5300) 2018.03.01 10:00:01\n"
      "GPS(6.5568,43.5368,18) Hs:36.1m\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "hb.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 43.5367);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].rel_alt_m, 35.2);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].rel_alt_m, 36.1);
}

// Phantom 4 Pro / P4 RTK (1 Hz, one line): GPS or RTK (lon, lat, satellites), HOME (lon, lat,
// altitude), H (height), F.PRY / G.PRY (pitch, roll, yaw) of the aircraft and the gimbal. An
// oblique camera (G.PRY pitch -24.4) must be read as such.
TEST(DjiSrtFamilies, P4RtkOneLineWithAttitudes) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "F/5.6, SS 400, ISO 100, EV 0, GPS (-58.851745, -34.237922, 15), HOME (-58.847509, "
      "-34.232707, -57.98m), D 698.70m, H 85.80m, H.S 0.00m/s, V.S 0.00m/s, F.PRY (2.7\xC2\xB0, "
      "-7.0\xC2\xB0, 110.1\xC2\xB0), G.PRY (-24.4\xC2\xB0, 0.0\xC2\xB0, 110.4\xC2\xB0)\n\n"
      "36\n00:00:35,000 --> 00:00:36,000\n"
      "F/6.3, SS 60, ISO 100, EV 0, RTK (120.083799, 30.213635, 28), HOME (120.084146, "
      "30.214243, 103.55m), D 75.36m, H 76.19m, H.S 0.30m/s, V.S 0.00m/s, F.PRY (-5.3\xC2\xB0, "
      "2.1\xC2\xB0, 28.3\xC2\xB0), G.PRY (-40.0\xC2\xB0, 0.0\xC2\xB0, 28.2\xC2\xB0)\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "p4rtk.srt");
  ASSERT_EQ(r.records, 2);
  const TelemetrySample& a = r.telemetry[0];
  EXPECT_DOUBLE_EQ(a.lat_deg, -34.237922);
  EXPECT_DOUBLE_EQ(a.lon_deg, -58.851745);
  EXPECT_DOUBLE_EQ(*a.rel_alt_m, 85.8);
  EXPECT_DOUBLE_EQ(*a.pitch_deg, 2.7);
  EXPECT_DOUBLE_EQ(*a.roll_deg, -7.0);
  EXPECT_DOUBLE_EQ(*a.yaw_deg, 110.1);
  EXPECT_DOUBLE_EQ(*a.gimbal_pitch_deg, -24.4);
  EXPECT_DOUBLE_EQ(*a.gimbal_roll_deg, 0.0);
  EXPECT_DOUBLE_EQ(*a.gimbal_yaw_deg, 110.4);
  const TelemetrySample& b = r.telemetry[1];
  EXPECT_DOUBLE_EQ(b.lat_deg, 30.213635);  // RTK (lon, lat, satellites)
  EXPECT_DOUBLE_EQ(b.lon_deg, 120.083799);
  EXPECT_DOUBLE_EQ(*b.rel_alt_m, 76.19);
  EXPECT_DOUBLE_EQ(*b.gimbal_pitch_deg, -40.0);
  EXPECT_EQ(b.origin, "p4rtk.srt:5");
}

// Autel EVO II captions (the text ExifTool's QuickTimeStream.pl Process_tx3g documents): each
// position value carries its hemisphere, GPS(W: longitude, N: latitude, altitude m), HOME likewise
// then the date; F.PRY / G.PRY as DJI's. The letters decide the order and the signs.
TEST(DjiSrtFamilies, AutelHemisphereLetters) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "HOME(W: 111.902410, N: 40.761250) 2024-04-02 09:15:31\n"
      "GPS(W: 111.903317, N: 40.760884, 1452.30m)\n"
      "HDR ISO:100 SHUTTER:800 EV:0 F-NUM:2.8\n"
      "F.PRY (-2.1\xC2\xB0, 0.4\xC2\xB0, 35.5\xC2\xB0), G.PRY (-90.0\xC2\xB0, 0.0\xC2\xB0, "
      "35.2\xC2\xB0)\n\n"
      "2\n00:00:01,000 --> 00:00:02,000\n"
      "HOME(E: 151.210000, S: 33.868000) 2024-04-02 09:15:32\n"
      "GPS(S: 33.867512, E: 151.209907, 60.00m)\n"
      "F.PRY (0.0\xC2\xB0, 0.0\xC2\xB0, -120.0\xC2\xB0), G.PRY (-90.0\xC2\xB0, 0.0\xC2\xB0, "
      "-120.0\xC2\xB0)\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "autel.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 40.760884);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lon_deg, -111.903317);
  EXPECT_FALSE(r.telemetry[0].abs_alt_m);  // which altitude the third value is, no source says
  EXPECT_DOUBLE_EQ(*r.telemetry[0].gimbal_pitch_deg, -90.0);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].yaw_deg, 35.5);
  ASSERT_TRUE(r.telemetry[0].unix_time_s.has_value());
  EXPECT_DOUBLE_EQ(r.telemetry[1].lat_deg, -33.867512);  // latitude first, south
  EXPECT_DOUBLE_EQ(r.telemetry[1].lon_deg, 151.209907);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].gimbal_yaw_deg, -120.0);
  // Two latitudes, a signed magnitude, a letter without a number: errors naming the line.
  for (const char* bad :
       {"GPS(N: 40.1, S: 40.2, 10m)", "GPS(W: -111.9, N: 40.7, 10m)", "GPS(W: 111.9, 40.7, 10m)",
        "GPS(W: x, N: 40.7, 10m)", "GPS(W: 1.0, 5)", "GPS(, N: 2)"}) {
    // (Not the last subtitle: a last one cut short is dropped with a warning.)
    std::istringstream b(std::string("1\n00:00:00,000 --> 00:00:01,000\n") + bad +
                         "\n\n2\n00:00:01,000 --> 00:00:02,000\nGPS(W: 111.9, N: 40.7, 10m)\n");
    try {
      ParseDjiSrt(b, "bad.srt");
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.srt:3: "), std::string::npos) << e.what();
    }
  }
}

// Matrice 200/300 with XT2/Z30 (1 Hz): GPS(latitude, longitude, altitude M) — latitude FIRST,
// the third value an altitude with its unit. Before, it was read in the Phantom order, which
// moved the flight to another continent.
TEST(DjiSrtFamilies, EnterpriseGpsLatitudeFirst) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "2022.06.21 16:06:17\n"
      "GPS(36.6146,-6.1120,0.0M) BAROMETER:0.3M\n\n"
      "2\n00:00:01,000 --> 00:00:02,000\n"
      "2022.06.21 16:06:18\n"
      "GPS(36.6146,-6.1120,0.0M) BAROMETER:0.8M\n\n"
      "405\n00:06:44,000 --> 00:06:45,000\n"
      "2023.08.07 20:10:01\n"
      "GPS(-41.3899,174.0177,0.0M) BAROMETER:97.7M\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "m300.srt");
  ASSERT_EQ(r.records, 3);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 36.6146);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lon_deg, -6.112);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].rel_alt_m, 0.8);
  EXPECT_FALSE(r.telemetry[0].abs_alt_m);  // the third value is not the altitude above sea
  EXPECT_DOUBLE_EQ(r.telemetry[2].lat_deg, -41.3899);
  EXPECT_DOUBLE_EQ(r.telemetry[2].lon_deg, 174.0177);
  EXPECT_DOUBLE_EQ(*r.telemetry[2].rel_alt_m, 97.7);
}

// A GPS(...) whose third value marks neither order, with values that both fit a latitude: an
// error naming file:line and both readings. Two orders in one file: an error naming both lines.
// Values that can only be read one way (a longitude beyond 90) decide by themselves.
TEST(DjiSrtFamilies, AmbiguousGpsOrderIsAnErrorNeverAGuess) {
  {
    std::istringstream in(
        "1\n00:00:00,000 --> 00:00:01,000\nGPS(36.6146,-6.1120,17.5) BAROMETER:0.3\n");
    ExpectInputError([&] { ParseDjiSrt(in, "amb.srt"); },
                     {"amb.srt:3:", "GPS(36.6146, -6.1120, 17.5)",
                      "as (latitude, longitude) it is 36.6146, -6.112",
                      "as (longitude, latitude) it is -6.112, 36.6146"});
  }
  {
    std::istringstream in(
        "1\n00:00:00,000 --> 00:00:01,000\nGPS(36.6146,-6.1120,0.0M) BAROMETER:0.3M\n\n"
        "2\n00:00:01,000 --> 00:00:02,000\nGPS(-6.1120,36.6146,17) BAROMETER:0.3\n");
    ExpectInputError([&] { ParseDjiSrt(in, "mixed.srt"); },
                     {"mixed.srt:7:", "line 3 reads as (latitude, longitude, altitude)",
                      "this line as (longitude, latitude, satellites)"});
  }
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\nGPS(39.906217,116.391305,69.800) BAROMETER(91.2)\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "proof.srt");
  EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 39.906217);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lon_deg, 116.391305);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].rel_alt_m, 91.2);
}

// GPS(N/A,N/A,n) before the fix: a sample without a fix that keeps its height; the file is read.
TEST(DjiSrtFamilies, NotAvailableGpsIsASampleWithoutFix) {
  std::istringstream in(
      "1\n00:00:00,000 --> 00:00:01,000\n"
      "HOME(149.0251,-20.2532) 2017.08.05 14:11:51\n"
      "GPS(N/A,N/A,4) BAROMETER:0.5\n\n"
      "2\n00:00:01,000 --> 00:00:02,000\n"
      "HOME(149.0251,-20.2532) 2017.08.05 14:11:52\n"
      "GPS(149.0251,-20.2533,9) BAROMETER:1.9\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "na.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_EQ(r.no_fix_records, 1);
  EXPECT_FALSE(r.telemetry[0].has_fix);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].rel_alt_m, 0.5);
  EXPECT_TRUE(r.telemetry[1].has_fix);
  EXPECT_DOUBLE_EQ(r.telemetry[1].lat_deg, -20.2533);
}

// Mavic 2 Enterprise: "[longtitude: ...] [altitude: ...] [Drone: Yaw:.., Pitch:.., Roll:..]".
TEST(DjiSrtFamilies, Mavic2EnterpriseDroneAngles) {
  std::istringstream in(
      "4\n00:00:00,341 --> 00:00:00,455\n"
      "<font size=\"36\">FrameCnt : 4, DiffTime : 114ms\n"
      "2022-09-08 06:26:55,549,370\n"
      "[color_md : default] [latitude: -36.885326] [longtitude: 174.697242] [altitude: "
      "28.736000] [Drone: Yaw:-146.0, Pitch:-0.6, Roll:1.3] </font>\n");
  const TelemetryReadResult r = ParseDjiSrt(in, "m2e.srt");
  ASSERT_EQ(r.records, 1);
  const TelemetrySample& s = r.telemetry[0];
  EXPECT_EQ(s.frame_index, 3);
  EXPECT_DOUBLE_EQ(s.lat_deg, -36.885326);
  EXPECT_DOUBLE_EQ(s.lon_deg, 174.697242);
  EXPECT_DOUBLE_EQ(*s.abs_alt_m, 28.736);
  EXPECT_DOUBLE_EQ(*s.yaw_deg, -146.0);
  EXPECT_DOUBLE_EQ(*s.pitch_deg, -0.6);
  EXPECT_DOUBLE_EQ(*s.roll_deg, 1.3);
}

// M300 with H20T / H20N: one subtitle over many lines (counter, date, camera, position, heights,
// speed, aircraft and gimbal angles), a blank line, a lone "0", then the zoom and </font>. Before,
// the "0" was taken for a new subtitle and the file refused ("bad timing line").
TEST(DjiSrtFamilies, EnterpriseMultiLineRecords) {
  const std::string text =
      "1\n"
      "00:00:00,000 --> 00:00:00,033\n"
      "< font size=\"28\" >FrameCnt: 1, DiffTime: 33ms\n"
      "2024-02-27 22:30:45.395\n"
      "[fnum: 1.0] [focal_len: 58.00] [dzoom: 1.00] \n"
      "[latitude: -44.228828] [longitude: 171.193516] [rel_alt: 40.162 abs_alt: 97.829] \n"
      "[drone_speedx: 0.2 drone_speedy: 0.0 drone_speedz: 0.0] \n"
      "[drone_yaw: -20.4 drone_pitch: 2.4 drone_roll: -2.1] \n"
      "[gb_yaw: -30.0 gb_pitch: -29.9 gb_roll: 0.0] \n"
      "\n"
      "0\n"
      "[dzoom_ratio: 10000, delta:0] [color_md : default] \n"
      "< /font >\n"
      "\n"
      "2\n"
      "00:00:00,033 --> 00:00:00,069\n"
      "< font size=\"28\" >SrtCnt : 2, DiffTime : 36ms\n"
      "2024-02-28 00:13:26.240\n"
      "[fnum: 1.0] [focal_len: 52.00] [dzoom: 1.79] \n"
      "[latitude: -44.228930] [longitude: 171.193573] [rel_alt: 40.050 abs_alt: 104.235] \n"
      "[drone_speedx: 0.5 drone_speedy: -0.1 drone_speedz: 0.0] \n"
      "[drone_yaw: -19.8 drone_pitch: -3.3 drone_roll: 0.0] \n"
      "[gb_yaw: -35.4 gb_pitch: -30.3 gb_roll: 0.0] \n"
      "\n"
      "0\n"
      "[dzoom_ratio: 17871, delta:0] < /font >\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseDjiSrt(in, "h20t.srt");
  ASSERT_EQ(r.records, 2);
  EXPECT_EQ(r.skipped_records, 0);
  const TelemetrySample& a = r.telemetry[0];
  EXPECT_EQ(a.frame_index, 0);
  EXPECT_DOUBLE_EQ(a.lat_deg, -44.228828);
  EXPECT_DOUBLE_EQ(a.lon_deg, 171.193516);
  EXPECT_DOUBLE_EQ(*a.rel_alt_m, 40.162);
  EXPECT_DOUBLE_EQ(*a.abs_alt_m, 97.829);
  EXPECT_DOUBLE_EQ(*a.yaw_deg, -20.4);
  EXPECT_DOUBLE_EQ(*a.pitch_deg, 2.4);
  EXPECT_DOUBLE_EQ(*a.roll_deg, -2.1);
  EXPECT_DOUBLE_EQ(*a.gimbal_yaw_deg, -30.0);
  EXPECT_DOUBLE_EQ(*a.gimbal_pitch_deg, -29.9);  // oblique camera
  EXPECT_DOUBLE_EQ(*a.focal_length_35mm_mm, 58.0);
  const TelemetrySample& b = r.telemetry[1];
  EXPECT_EQ(b.frame_index, 1);
  EXPECT_DOUBLE_EQ(b.time_s, 0.033);
  EXPECT_DOUBLE_EQ(*b.gimbal_pitch_deg, -30.3);
  EXPECT_EQ(b.origin, "h20t.srt:15");
}

TEST(DjiSrt, EmptyAndAllGarbageFilesThrow) {
  {
    std::istringstream in("");
    ExpectInputError([&] { ParseDjiSrt(in, "empty.srt"); }, {"empty.srt", "no telemetry"});
  }
  std::istringstream in("hello\nworld\n");
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  ExpectInputError([&] { ParseDjiSrt(in, "junk.srt", lenient); },
                   {"junk.srt", "no telemetry", "1 malformed"});
}

// ---------------------------------------------------------------- GPX

const char kGpx[] = R"(<?xml version="1.0" encoding="UTF-8"?>
<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1">
  <trk><name>flight</name><trkseg>
    <trkpt lat="43.5367" lon="6.5567"><ele>350.5</ele><time>2023-05-01T12:00:00Z</time></trkpt>
    <trkpt lat="43.5368" lon="6.5569"><ele>351.5</ele><time>2023-05-01T12:00:01.500Z</time></trkpt>
    <trkpt lat="43.5369" lon="6.5571">
      <ele>352.5</ele>
      <time>2023-05-01T14:00:03+02:00</time>
    </trkpt>
  </trkseg></trk>
</gpx>
)";

TEST(Gpx, ReadsTrackPoints) {
  std::istringstream in(kGpx);
  const TelemetryReadResult r = ParseGpx(in, "track.gpx");
  ASSERT_EQ(r.records, 3);
  const Telemetry& t = r.telemetry;
  EXPECT_DOUBLE_EQ(t[0].time_s, 0.0);
  EXPECT_DOUBLE_EQ(t[1].time_s, 1.5);
  EXPECT_DOUBLE_EQ(t[2].time_s, 3.0);
  EXPECT_DOUBLE_EQ(*t[0].unix_time_s, 1682942400.0);
  EXPECT_DOUBLE_EQ(t[1].lat_deg, 43.5368);
  EXPECT_DOUBLE_EQ(t[1].lon_deg, 6.5569);
  EXPECT_DOUBLE_EQ(*t[2].abs_alt_m, 352.5);
  auto m = t.Lookup(2.25);
  ASSERT_TRUE(m);
  EXPECT_NEAR(*m->abs_alt_m, 352.0, 1e-9);
}

std::string GpxWith(const std::string& middle) {
  return "<?xml version=\"1.0\"?>\n<gpx><trk><trkseg>\n"                             // lines 1-2
         "<trkpt lat=\"10\" lon=\"20\"><time>2023-05-01T12:00:00Z</time></trkpt>\n"  // 3
         + middle +                                                                  // 4
         "\n<trkpt lat=\"10.2\" lon=\"20.2\"><time>2023-05-01T12:00:05Z</time></trkpt>\n"
         "</trkseg></trk></gpx>\n";
}

TEST(Gpx, BadPointsNameTheLine) {
  const std::pair<const char*, const char*> cases[] = {
      {"<trkpt lat=\"95\" lon=\"20\"><time>2023-05-01T12:00:01Z</time></trkpt>",
       "latitude 95 out of range"},
      {"<trkpt lon=\"20\"><time>2023-05-01T12:00:01Z</time></trkpt>", "without a lat"},
      {"<trkpt lat=\"abc\" lon=\"20\"><time>2023-05-01T12:00:01Z</time></trkpt>",
       "lat 'abc' is not a number"},
      {"<trkpt lat=\"10.1\" lon=\"20\"><ele>high</ele><time>2023-05-01T12:00:01Z</time></trkpt>",
       "<ele> 'high'"},
      {"<trkpt lat=\"10.1\" lon=\"20\"><time>noon</time></trkpt>", "not an ISO 8601 date"},
      {"<trkpt lat=\"10.1\" lon=\"20\"><time>2023-05-01T11:59:00Z</time></trkpt>", "out of order"},
      {"<trkpt lat=\"10.1\" lon=\"20\"></trkpt>", "without <time>"},
  };
  for (const auto& [xml, msg] : cases) {
    SCOPED_TRACE(xml);
    {
      std::istringstream in(GpxWith(xml));
      ExpectInputError([&] { ParseGpx(in, "bad.gpx"); }, {"bad.gpx:4:", msg});
    }
    std::istringstream in(GpxWith(xml));
    TelemetryReadOptions lenient;
    lenient.lenient = true;
    const TelemetryReadResult r = ParseGpx(in, "bad.gpx", lenient);
    EXPECT_EQ(r.records, 2);
    EXPECT_EQ(r.skipped_records, 1);
    EXPECT_DOUBLE_EQ(r.telemetry[1].time_s, 5.0);
  }
}

TEST(Gpx, XmlErrorsAndWrongRoot) {
  {
    std::istringstream in("<gpx>\n<trk>\n<trkpt lat=\"1\" lon=\"2\">\n</gpx>\n");
    ExpectInputError([&] { ParseGpx(in, "broken.gpx"); }, {"broken.gpx:", "XML error"});
  }
  {
    std::istringstream in("<kml></kml>");
    ExpectInputError([&] { ParseGpx(in, "k.gpx"); }, {"k.gpx", "not a GPX file"});
  }
  {
    std::istringstream in("");
    ExpectInputError([&] { ParseGpx(in, "e.gpx"); }, {"e.gpx"});
  }
  {
    std::istringstream in("<gpx><trk></trk></gpx>");
    ExpectInputError([&] { ParseGpx(in, "n.gpx"); }, {"n.gpx", "no telemetry samples"});
  }
}

// A GPX whose writing stopped (a logger's battery, a crash, a partial copy: the real TomTom
// track of gpx-parse's tests/integration/data/route-1.1.gpx cut anywhere) is read up to the cut,
// in both modes, with a warning: cut at every byte after the first point, it gives exactly the
// points whose end tag is in the text.
TEST(Gpx, AFileCutAnywhereIsReadUpToTheCut) {
  const std::string full = kGpx;
  const std::size_t first_end = full.find("</trkpt>") + 8;
  for (std::size_t n = first_end; n < full.size(); ++n) {
    const std::string text = full.substr(0, n);
    SCOPED_TRACE(text.substr(text.size() > 40 ? text.size() - 40 : 0));
    int closed = 0;
    for (std::size_t at = text.find("</trkpt>"); at != std::string::npos;
         at = text.find("</trkpt>", at + 1)) {
      ++closed;
    }
    for (const bool lenient : {false, true}) {
      std::istringstream in(text);
      TelemetryReadOptions options;
      options.lenient = lenient;
      const TelemetryReadResult r = ParseGpx(in, "cut.gpx", options);
      ASSERT_EQ(r.records, closed);
      EXPECT_EQ(r.skipped_records, 0);
      EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 43.5367);
      const bool whole = text.find("</gpx>") != std::string::npos;
      if (!whole) {
        ASSERT_EQ(r.warnings.size(), 1u);
        EXPECT_THAT(r.warnings[0], HasSubstr("the file ends before the end of its GPX document"));
      }
    }
  }
  // An error before the end is not a cut.
  std::istringstream in(full.substr(0, first_end) +
                        "<trkpt lat=\"1\"</trkpt>\n</trkseg></trk></gpx>");
  ExpectInputError([&] { ParseGpx(in, "bad.gpx"); }, {"bad.gpx:4: XML error"});
}

TEST(Gpx, DeepNestingDoesNotOverflowTheStack) {
  std::string deep = "<gpx>";
  for (int i = 0; i < 200000; ++i) deep += "<a>";
  for (int i = 0; i < 200000; ++i) deep += "</a>";
  deep += "<trk><trkseg><trkpt lat=\"1\" lon=\"2\"/></trkseg></trk></gpx>";
  std::istringstream in(deep);
  const TelemetryReadResult r = ParseGpx(in, "deep.gpx");
  EXPECT_EQ(r.records, 1);
  EXPECT_EQ(r.warnings.size(), 1u);  // no <time>: rank used as time
}

// ---------------------------------------------------------------- CSV

TEST(Csv, CommaWithAliases) {
  const char text[] =
      "# exported by test\n"
      "Frame,Time,Latitude,LNG,Altitude,Height,Heading,notes\n"
      "0,0.0,43.5,6.5,350,100,90,\"a, quoted\"\n"
      "1,0.5,43.6,6.6,351,101,100,\n"
      "\n"
      "2,1.0,43.7,6.7,,102,,x\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "t.csv");
  ASSERT_EQ(r.records, 3);
  const Telemetry& t = r.telemetry;
  EXPECT_EQ(t[1].frame_index, 1);
  EXPECT_DOUBLE_EQ(t[1].time_s, 0.5);
  EXPECT_DOUBLE_EQ(t[1].lat_deg, 43.6);
  EXPECT_DOUBLE_EQ(t[1].lon_deg, 6.6);
  EXPECT_DOUBLE_EQ(*t[1].abs_alt_m, 351.0);
  EXPECT_DOUBLE_EQ(*t[1].rel_alt_m, 101.0);
  EXPECT_DOUBLE_EQ(*t[1].yaw_deg, 100.0);
  EXPECT_FALSE(t[2].abs_alt_m);
  EXPECT_FALSE(t[2].yaw_deg);
}

TEST(Csv, SemicolonIsoTimesNoFrame) {
  const char text[] =
      "timestamp;lat;lon;rel_alt;gimbal_yaw\r\n"
      "2023-05-01T12:00:00Z;43,5;6;10;5\r\n";  // "43,5" is not a number with ';' separators
  std::istringstream in(text);
  ExpectInputError([&] { ParseTelemetryCsv(in, "s.csv"); },
                   {"s.csv:2:", "latitude '43,5' is not a number"});
  const char good[] =
      "timestamp;lat;lon;rel_alt;gimbal_yaw\n"
      "2023-05-01T12:00:00Z;43.5;6.0;10;5\n"
      "2023-05-01T12:00:02.5Z;43.6;6.1;11;6\n";
  std::istringstream in2(good);
  const TelemetryReadResult r = ParseTelemetryCsv(in2, "s.csv");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].time_s, 2.5);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].unix_time_s, 1682942400.0);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].gimbal_yaw_deg, 6.0);
  EXPECT_FALSE(r.telemetry[0].frame_index);
}

TEST(Csv, FrameOnlyUsesFrameAsTime) {
  std::istringstream in("frame,lat,lon\n0,1,2\n5,1.5,2.5\n");
  const TelemetryReadResult r = ParseTelemetryCsv(in, "f.csv");
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry[1].time_s, 5.0);
  auto f = r.telemetry.AtFrame(1);
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->lat_deg, 1.1, 1e-12);
}

// A date with whole seconds on a 4 Hz log: four records per time, moving about 11 m/s east along
// the equator (1e-4 degrees of longitude = 11.13 m). Spread over each second, every record keeps
// its own time and lookups interpolate the flight instead of jumping once a second.
TEST(Csv, RecordsSharingATimeAreSpreadOverTheClocksStep) {
  std::string text = "datetime,lat,lon\n";
  for (int k = 0; k < 12; ++k) {
    text += fmt::format("2023-05-01 12:00:0{},0,{:.6f}\n", k / 4, 1.0 + 0.000025 * k);
  }
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "log.csv");
  ASSERT_EQ(r.records, 12);
  for (int k = 0; k < 12; ++k) {
    EXPECT_NEAR(r.telemetry[k].time_s, 0.25 * k, 1e-9) << k;
    EXPECT_NEAR(*r.telemetry[k].unix_time_s, 1682942400.0 + 0.25 * k, 1e-6) << k;
  }
  const auto at = r.telemetry.Lookup(1.625);
  ASSERT_TRUE(at);
  EXPECT_NEAR(at->lon_deg, 1.0 + 0.000025 * 6.5, 1e-12);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("log.csv:2: 4 records share the time 0.000 s but not the "
                                       "position"));
  EXPECT_THAT(r.warnings[0], HasSubstr("spread evenly over 0.000..1.000 s; 2 more such runs (12 "
                                       "records in all)"));

  // A duplicated record (same time, same place) is left as it is, without a warning; a repeated
  // time in a finer clock is spread over that clock's step only (0.1 s here), never past the
  // next record.
  std::istringstream dup(
      "time,lat,lon\n0,1,2\n0.1,1,2.001\n0.1,1,2.001\n0.2,1,2.002\n"
      "0.3,1,2.003\n0.3,1,2.0035\n0.4,1,2.004\n");
  const TelemetryReadResult d = ParseTelemetryCsv(dup, "dup.csv");
  ASSERT_EQ(d.records, 7);
  EXPECT_DOUBLE_EQ(d.telemetry[2].time_s, 0.1);
  EXPECT_NEAR(d.telemetry[5].time_s, 0.35, 1e-9);
  EXPECT_DOUBLE_EQ(d.telemetry[6].time_s, 0.4);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_THAT(d.warnings[0], HasSubstr("dup.csv:6: 2 records share the time 0.300 s"));
}

// What a file as a whole says (its dates not read, its records on a coarse clock spread) is kept
// however many record messages came first, after them, and within max_warnings +
// kMaxReadNotes (fuzz_csv found a file with both notes and more skipped rows than max_warnings).
TEST(Csv, NotesAboutTheWholeFileFollowTheRecordMessagesWhateverTheirNumber) {
  std::string text = "CUSTOM.updateTime [local],OSD.flyTime [s],OSD.latitude,OSD.longitude\n";
  for (int k = 0; k < 5; ++k) text += "x,1,2\n";  // 3 fields: skipped
  text +=
      "2:11:51.20 PM,0.1,28.0,-82.0\n"
      "2:11:51.20 PM,0.1,28.00001,-82.0\n"
      "2:11:51.30 PM,0.2,28.00002,-82.0\n";
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  lenient.max_warnings = 2;
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "notes.csv", lenient);
  EXPECT_EQ(r.records, 3);
  EXPECT_EQ(r.skipped_records, 5);
  ASSERT_EQ(r.warnings.size(), 2u + kMaxReadNotes);
  EXPECT_THAT(r.warnings[0], HasSubstr("notes.csv:2: 3 fields, the header has 4"));
  EXPECT_THAT(r.warnings[1], HasSubstr("notes.csv:3: 3 fields, the header has 4"));
  EXPECT_THAT(r.warnings[2], HasSubstr("notes.csv:7: column 'CUSTOM.updateTime [local]' holds "
                                       "'2:11:51.20 PM', not a date"));
  EXPECT_THAT(r.warnings[3], HasSubstr("notes.csv:7: 2 records share the time 0.100 s but not "
                                       "the position"));
  EXPECT_NEAR(r.telemetry[1].time_s, 0.15, 1e-9);

  // No record message at all (max_warnings 0): the notes stay.
  lenient.max_warnings = 0;
  std::istringstream again(text);
  const TelemetryReadResult quiet = ParseTelemetryCsv(again, "notes.csv", lenient);
  EXPECT_EQ(quiet.skipped_records, 5);
  ASSERT_EQ(quiet.warnings.size(), 2u);
  EXPECT_THAT(quiet.warnings[0], HasSubstr("not a date"));
  EXPECT_THAT(quiet.warnings[1], HasSubstr("share the time"));
}

// One time for every record and different places: nothing says when each was, so the read
// stops (a guess would be a silently wrong track); frame indices place them instead.
TEST(Csv, OneTimeForEveryRecordIsAnErrorUnlessFramesPlaceThem) {
  std::istringstream in("time,lat,lon\n5,1,2\n5,1,2.001\n5,1,2.002\n");
  ExpectInputError([&] { ParseTelemetryCsv(in, "same.csv"); },
                   {"same.csv:2: all 3 records of this CSV file have the time 5.000 s but not the "
                    "same position"});
  std::istringstream framed("time,frame,lat,lon\n5,0,1,2\n5,1,1,2.001\n5,2,1,2.002\n");
  const TelemetryReadResult r = ParseTelemetryCsv(framed, "framed.csv");
  ASSERT_EQ(r.records, 3);
  const auto f = r.telemetry.AtFrame(2);
  ASSERT_TRUE(f);
  EXPECT_DOUBLE_EQ(f->lon_deg, 2.002);
}

TEST(Csv, HeaderProblems) {
  {
    std::istringstream in("time,lat\n0,1\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "h.csv"); }, {"h.csv:1:", "no longitude"});
  }
  {
    std::istringstream in("lat,lon,alt\n1,2,3\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "h.csv"); }, {"h.csv:1:", "neither a time"});
  }
  {
    std::istringstream in("lat,latitude,lon,t\n1,1,2,0\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "h.csv"); }, {"h.csv:1:", "two columns"});
  }
  {
    std::istringstream in("\n# only a comment\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "h.csv"); }, {"h.csv", "empty CSV"});
  }
}

TEST(Csv, BadRowsStrictAndLenient) {
  const char text[] =
      "t,lat,lon\n"
      "0,10,20\n"
      "1,10.1\n"          // line 3: too few fields
      "2,10.2,200\n"      // line 4: longitude out of range
      "-0.5,10.3,20.3\n"  // line 5: out of order
      "\"3,10.4,20.4\n"   // line 6: unterminated quote
      "4,,20.5\n"         // line 7: empty latitude
      "5,10.5,20.5\n";
  {
    std::istringstream in(text);
    ExpectInputError([&] { ParseTelemetryCsv(in, "rows.csv"); },
                     {"rows.csv:3:", "2 fields, the header has 3"});
  }
  std::istringstream in(text);
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  lenient.max_warnings = 3;
  const TelemetryReadResult r = ParseTelemetryCsv(in, "rows.csv", lenient);
  EXPECT_EQ(r.records, 2);
  EXPECT_EQ(r.skipped_records, 5);
  ASSERT_EQ(r.warnings.size(), 3u);
  EXPECT_THAT(r.warnings[1], HasSubstr("rows.csv:4: longitude 200 out of range"));
  EXPECT_THAT(r.warnings[2], HasSubstr("rows.csv:5:"));
  EXPECT_THAT(r.warnings[2], HasSubstr("out of order"));
}

// ---------------------------------------------------------------- CSV exports of flight logs
// Each test writes the header line a tool writes (the column names, copied as a format from the
// tool's documentation or a public export) and a few rows; docs/inputs.md "Flight log exports".

// One CSV record of `header`: the cells named in `cells` (by trimmed column name), "0" elsewhere.
std::string Row(const std::string& header, const std::map<std::string, std::string>& cells) {
  std::vector<std::string> names;
  SplitCsv(header, ',', names);
  std::string row;
  std::size_t used = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto it = cells.find(std::string(TrimSpace(names[i])));
    if (it != cells.end()) ++used;
    row += (i ? "," : "") + (it == cells.end() ? std::string("0") : it->second);
  }
  EXPECT_EQ(used, cells.size()) << "a cell names no column of the header";
  return row + "\n";
}

constexpr double kFoot = 0.3048;

TEST(CsvColumnNames, BaseUnitAndPrefix) {
  using io_detail::SplitColumnName;
  const auto check = [](const char* cell, const char* prefix, const char* base, const char* unit) {
    const io_detail::ColumnName n = SplitColumnName(cell);
    EXPECT_EQ(n.prefix, prefix) << cell;
    EXPECT_EQ(n.base, base) << cell;
    EXPECT_EQ(n.unit, unit) << cell;
  };
  check("time(millisecond)", "", "time", "millisecond");
  check(" height_above_takeoff(feet) ", "", "height_above_takeoff", "feet");
  check("OSD.height [ft]", "osd", "height", "ft");
  check("GIMBAL.yaw [360]", "gimbal", "yaw", "360");
  check("Altitude (M)", "", "altitude", "m");
  check("lat_deg", "", "lat", "deg");
  check("abs_alt_m", "", "abs_alt", "m");
  check("altitude_msl_m", "", "altitude_msl", "m");
  check("time_s", "", "time", "s");
  check("focal_35mm", "", "focal_35mm", "");  // "35mm" is no unit
  check("gimbal_pitch", "", "gimbal_pitch", "");
  check("CUSTOM.updateTime", "custom", "updatetime", "");
  check("time_utc_usec", "", "time_utc", "usec");
  const io_detail::ColumnName cut = SplitColumnName("OSD.height(ft");
  EXPECT_TRUE(cut.malformed);
  EXPECT_EQ(cut.base, "height");
  EXPECT_EQ(cut.unit, "");
  EXPECT_FALSE(SplitColumnName("OSD.height(ft)").malformed);
}

// Airdata UAV "Downloadable Flight Data CSV"
// (app.airdata.com/wiki/Help/Downloadable+Flight+Data+CSV), imperial units: 10 Hz rows from
// power-on, latitude = longitude = 0 before the GPS fix.
const char kAirdataFeetHeader[] =
    "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(feet),"
    "height_above_ground_at_drone_location(feet),ground_elevation_at_drone_location(feet),"
    "altitude_above_seaLevel(feet),height_sonar(feet),speed(mph),distance(feet),mileage(feet),"
    "satellites,gpslevel,voltage(v),max_altitude(feet),max_ascent(feet),max_speed(mph),"
    "max_distance(feet), xSpeed(mph), ySpeed(mph), zSpeed(mph), compass_heading(degrees), "
    "pitch(degrees), roll(degrees),isPhoto,isVideo,rc_elevator,rc_aileron,rc_throttle,rc_rudder,"
    "rc_elevator(percent),rc_aileron(percent),rc_throttle(percent),rc_rudder(percent),"
    "gimbal_heading(degrees),gimbal_pitch(degrees),battery_percent,voltageCell1,voltageCell2,"
    "voltageCell3,voltageCell4,voltageCell5,voltageCell6,current(A),battery_temperature(f),"
    "altitude(feet),ascent(feet),flycStateRaw,flycState,message";

TEST(CsvExports, AirdataFeetMillisecondsAndRowsBeforeTheFix) {
  const std::string h = kAirdataFeetHeader;
  std::string text = h + "\n";
  text += Row(h, {{"time(millisecond)", "0"}, {"datetime(utc)", "2022-02-09 13:56:08"}});
  text += Row(h, {{"time(millisecond)", "100"}, {"datetime(utc)", "2022-02-09 13:56:08"}});
  text += Row(h, {{"time(millisecond)", "200"},
                  {"datetime(utc)", "2022-02-09 13:56:08"},
                  {"latitude", "43.5367001"},
                  {"longitude", "6.5567002"},
                  {"height_above_takeoff(feet)", "1.64042"},
                  {"altitude_above_seaLevel(feet)", "170.7093476543"},
                  {"altitude(feet)", "170.7093476543"},
                  {"compass_heading(degrees)", "187.8"},
                  {"pitch(degrees)", "-2.3"},
                  {"roll(degrees)", "-0.4"},
                  {"gimbal_heading(degrees)", "186.2"},
                  {"gimbal_pitch(degrees)", "-90"}});
  text += Row(h, {{"time(millisecond)", "1300"},
                  {"datetime(utc)", "2022-02-09 13:56:09"},
                  {"latitude", "43.5367101"},
                  {"longitude", "6.5567102"},
                  {"height_above_takeoff(feet)", "328.084"},
                  {"altitude_above_seaLevel(feet)", "497.153"},
                  {"compass_heading(degrees)", "-170"},
                  {"gimbal_heading(degrees)", "190.5"},
                  {"gimbal_pitch(degrees)", "-45.5"}});
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "airdata.csv");
  ASSERT_EQ(r.records, 2);
  EXPECT_EQ(r.no_fix_records, 2);
  EXPECT_EQ(r.skipped_records, 0);
  const Telemetry& t = r.telemetry;
  EXPECT_NEAR(t[0].time_s, 0.2, 1e-12);
  EXPECT_NEAR(t[1].time_s, 1.3, 1e-12);
  EXPECT_DOUBLE_EQ(t[0].lat_deg, 43.5367001);
  EXPECT_DOUBLE_EQ(t[0].lon_deg, 6.5567002);
  EXPECT_NEAR(*t[0].rel_alt_m, 1.64042 * kFoot, 1e-9);  // 0.5 m
  EXPECT_NEAR(*t[1].rel_alt_m, 100.0000032, 1e-9);      // 328.084 ft
  EXPECT_NEAR(*t[0].abs_alt_m, 170.7093476543 * kFoot, 1e-9);
  EXPECT_NEAR(*t[1].abs_alt_m, 497.153 * kFoot, 1e-9);  // not altitude(feet), 0 in this row
  EXPECT_DOUBLE_EQ(*t[0].yaw_deg, 187.8);
  EXPECT_DOUBLE_EQ(*t[1].yaw_deg, -170.0);
  EXPECT_DOUBLE_EQ(*t[0].pitch_deg, -2.3);
  EXPECT_DOUBLE_EQ(*t[0].roll_deg, -0.4);
  EXPECT_DOUBLE_EQ(*t[0].gimbal_yaw_deg, 186.2);
  EXPECT_DOUBLE_EQ(*t[1].gimbal_pitch_deg, -45.5);
  EXPECT_FALSE(t[0].gimbal_roll_deg);  // Airdata writes no gimbal roll
  EXPECT_EQ(t[0].origin, "airdata.csv:4");
  // Absolute time: the elapsed time plus (date - elapsed time) of the first row (time 0).
  ASSERT_TRUE(t[1].unix_time_s);
  EXPECT_NEAR(*t[1].unix_time_s, 1644414968.0 + 1.3, 1e-6);
}

TEST(CsvExports, AirdataMetres) {
  const char text[] =
      "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(meters),"
      "altitude_above_seaLevel(meters),compass_heading(degrees),gimbal_pitch(degrees)\n"
      "0,2023-06-01 10:00:00,0,0,0,0,0,0\n"
      "500,2023-06-01 10:00:00,-37.9960991,177.0357041,80.25,312.5,350.1,-89.9\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "m.csv");
  ASSERT_EQ(r.records, 1);
  EXPECT_DOUBLE_EQ(r.telemetry[0].time_s, 0.5);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].rel_alt_m, 80.25);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].abs_alt_m, 312.5);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].gimbal_pitch_deg, -89.9);
}

// Litchi flight log CSV (as read by CsvView; public export on pastebin.com/qutYx4mE): metric,
// "altitude(m)" is the height above the take-off point; time(millisecond) is read, not the
// "timestamp" column; gimbal angles are only in the "...Raw" columns, not read.
const char kLitchiHeader[] =
    "latitude,longitude,altitude(m),ultrasonicHeight(m),speed(mps),distance(m),max_altitude(m),"
    "max_ascent(m),max_speed(mps),max_distance(m),time(millisecond),datetime(utc),"
    "datetime(local),satellites,pressure(Pa),temperature(F),voltage(v),home_latitude,"
    "home_longitude,velocityX(mps),velocityY(mps),velocityZ(mps),pitch(deg),roll(deg),yaw(deg),"
    "powerlevel,isflying,istakingphoto,remainPowerPercent,remainLifePercent,currentCurrent,"
    "currentElectricity,currentVoltage,batteryTemperature,dischargeCount,flightmode,isMotorsOn,"
    "isTakingVideo,Rc_elevator,Rc_aileron,Rc_throttle,Rc_rudder,Rc_gyro,timestamp,Battery_Cell1,"
    "Battery_Cell2,Battery_Cell3,Battery_Cell4,Battery_Cell5,Battery_Cell6,Dronetype,AppVersion,"
    "Planename,FlyControllerSerialNumber,RemoteSerialNumber,BatterySerialNumber,"
    "CENTER_BATTERY.productDate,CENTER_BATTERY.serialNo,CENTER_BATTERY.fullCapacity,"
    "CENTER_BATTERY.productDateRaw,pitchRaw,rollRaw,yawRaw,gimbalPitchRaw,gimbalRollRaw,"
    "gimbalYawRaw,flyState,altitudeRaw,speedRaw,distanceRaw,velocityXRaw,velocityYRaw,"
    "velocityZRaw";

TEST(CsvExports, LitchiAltitudeIsHeightAboveTakeOff) {
  const std::string h = kLitchiHeader;
  std::string text = h + "\n";
  text += Row(h, {{"time(millisecond)", "0"},
                  {"datetime(utc)", "2017-08-05 14:11:50"},
                  {"timestamp", "1501942310000"}});
  text += Row(h, {{"latitude", "43.951710"},
                  {"longitude", "4.900240"},
                  {"altitude(m)", "1.7"},
                  {"home_latitude", "43.95"},
                  {"time(millisecond)", "2100"},
                  {"datetime(utc)", "2017-08-05 14:11:52"},
                  {"pitch(deg)", "-1.5"},
                  {"roll(deg)", "0.8"},
                  {"yaw(deg)", "-120.3"},
                  {"timestamp", "1501942312100"}});
  text += Row(h, {{"latitude", "43.951810"},
                  {"longitude", "4.900340"},
                  {"altitude(m)", "60.2"},
                  {"time(millisecond)", "2200"},
                  {"datetime(utc)", "2017-08-05 14:11:52"},
                  {"timestamp", "1501942312200"}});
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "litchi.csv");
  ASSERT_EQ(r.records, 2);
  EXPECT_EQ(r.no_fix_records, 1);
  const Telemetry& t = r.telemetry;
  EXPECT_DOUBLE_EQ(t[0].time_s, 2.1);
  EXPECT_DOUBLE_EQ(t[1].time_s, 2.2);
  EXPECT_DOUBLE_EQ(t[0].lat_deg, 43.951710);
  EXPECT_DOUBLE_EQ(*t[0].rel_alt_m, 1.7);
  EXPECT_DOUBLE_EQ(*t[1].rel_alt_m, 60.2);
  EXPECT_FALSE(t[0].abs_alt_m);
  EXPECT_DOUBLE_EQ(*t[0].yaw_deg, -120.3);
  EXPECT_DOUBLE_EQ(*t[0].pitch_deg, -1.5);
  EXPECT_DOUBLE_EQ(*t[0].roll_deg, 0.8);
  EXPECT_FALSE(t[0].gimbal_pitch_deg);
  EXPECT_NEAR(*t[1].unix_time_s, 1501942310.0 + 2.2, 1e-6);
}

// DJI flight record CSV of the log viewers (TXTlogToCSVtool / PhantomHelp / Airdata "original"
// export): a "sep=," line, then "GROUP.name [unit]" columns; OSD = the aircraft, GIMBAL = the
// gimbal; HOME.* and APPGPS.* (the phone) are other positions and are not read.
const char kDjiHeader[] =
    "CUSTOM.date [local],CUSTOM.updateTime [local],OSD.flyTime [s],OSD.latitude,OSD.longitude,"
    "OSD.height [ft],OSD.heightMax [ft],OSD.vpsHeight [ft],OSD.altitude [ft],OSD.hSpeed [MPH],"
    "OSD.xSpeed [MPH],OSD.ySpeed [MPH],OSD.zSpeed [MPH],OSD.pitch,OSD.roll,OSD.yaw,"
    "OSD.yaw [360],OSD.directionOfTravel,GIMBAL.pitch,GIMBAL.roll,GIMBAL.yaw,GIMBAL.yaw [360],"
    "HOME.latitude,HOME.longitude,APPGPS.latitude,APPGPS.longitude,CAMERA.isVideo";

TEST(CsvExports, DjiFlightRecordFeetAndPrefixes) {
  const std::string h = kDjiHeader;
  std::string text = "sep=,\n" + h + "\n";
  const std::map<std::string, std::string> common = {{"HOME.latitude", "-20.2532"},
                                                     {"HOME.longitude", "149.0251"},
                                                     {"APPGPS.latitude", "-20.2533"},
                                                     {"APPGPS.longitude", "149.0252"},
                                                     {"CUSTOM.date [local]", "8/5/2017"}};
  auto row = [&](std::map<std::string, std::string> cells) {
    cells.insert(common.begin(), common.end());
    return Row(h, cells);
  };
  text += row({{"CUSTOM.updateTime [local]", "2:11:51.20 PM"},
               {"OSD.flyTime [s]", "12.3"},
               {"OSD.latitude", "-20.2531"},
               {"OSD.longitude", "149.0250"},
               {"OSD.height [ft]", "100"},
               {"OSD.vpsHeight [ft]", "11.5"},
               {"OSD.altitude [ft]", "1100"},
               {"OSD.pitch", "-3.1"},
               {"OSD.roll", "1.2"},
               {"OSD.yaw", "-45.6"},
               {"OSD.yaw [360]", "314.4"},
               {"GIMBAL.pitch", "-89.9"},
               {"GIMBAL.roll", "0.1"},
               {"GIMBAL.yaw", "-44.0"},
               {"GIMBAL.yaw [360]", "316.0"}});
  text += row({{"CUSTOM.updateTime [local]", "2:11:51.30 PM"},
               {"OSD.flyTime [s]", "12.4"},
               {"OSD.latitude", "-20.2530"},
               {"OSD.longitude", "149.0249"},
               {"OSD.height [ft]", "101"},
               {"OSD.altitude [ft]", "1101"}});
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "dji.csv");
  ASSERT_EQ(r.records, 2);
  const Telemetry& t = r.telemetry;
  EXPECT_DOUBLE_EQ(t[0].time_s, 12.3);
  EXPECT_DOUBLE_EQ(t[0].lat_deg, -20.2531);
  EXPECT_DOUBLE_EQ(t[0].lon_deg, 149.0250);
  EXPECT_NEAR(*t[0].rel_alt_m, 30.48, 1e-9);  // OSD.height, not OSD.vpsHeight
  EXPECT_NEAR(*t[1].rel_alt_m, 101 * kFoot, 1e-9);
  EXPECT_NEAR(*t[0].abs_alt_m, 335.28, 1e-9);
  EXPECT_DOUBLE_EQ(*t[0].pitch_deg, -3.1);
  EXPECT_DOUBLE_EQ(*t[0].roll_deg, 1.2);
  EXPECT_DOUBLE_EQ(*t[0].yaw_deg, -45.6);  // OSD.yaw before OSD.yaw [360]
  EXPECT_DOUBLE_EQ(*t[0].gimbal_pitch_deg, -89.9);
  EXPECT_DOUBLE_EQ(*t[0].gimbal_roll_deg, 0.1);
  EXPECT_DOUBLE_EQ(*t[0].gimbal_yaw_deg, -44.0);
  EXPECT_EQ(t[0].origin, "dji.csv:3");
  // A clock that is not a date: the elapsed time is read, the absolute time is not, and a
  // warning says so.
  EXPECT_FALSE(t[0].unix_time_s);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("dji.csv:3: column 'CUSTOM.updateTime [local]' holds "
                                       "'2:11:51.20 PM', not a date"));
}

TEST(CsvExports, DjiUpdateTimeDateOnly) {
  // The older TXTlogToCSVtool columns, metres, the time a "YYYY/MM/DD hh:mm:ss.fff" date only.
  const char text[] =
      "CUSTOM.updateTime,OSD.latitude,OSD.longitude,OSD.height [m],GIMBAL.yaw,GIMBAL.pitch,"
      "GIMBAL.roll,CUSTOM.isVideo\n"
      "2018/07/04 09:19:32.113,52.1,5.1,30.5,12.5,-90,0,1\n"
      "2018/07/04 09:19:32.213,52.1001,5.1001,30.6,12.6,-90,0,1\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "dvm.csv");
  ASSERT_EQ(r.records, 2);
  EXPECT_NEAR(r.telemetry[1].time_s, 0.1, 1e-6);  // dates near 1.5e9 s: ~2e-7 s apart
  EXPECT_NEAR(*r.telemetry[0].unix_time_s, 1530695972.113, 1e-6);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].rel_alt_m, 30.6);
  EXPECT_DOUBLE_EQ(*r.telemetry[1].gimbal_yaw_deg, 12.6);
}

// PX4 ulog2csv of vehicle_gps_position before v1.14 (PX4-Autopilot msg/VehicleGpsPosition.msg:
// int32 lat, lon in 1e-7 degrees, alt in millimetres; timestamp in microseconds since boot).
const char kPx4GpsHeader[] =
    "timestamp,time_utc_usec,lat,lon,alt,alt_ellipsoid,s_variance_m_s,c_variance_rad,eph,epv,"
    "hdop,vdop,noise_per_ms,jamming_indicator,vel_m_s,vel_n_m_s,vel_e_m_s,vel_d_m_s,cog_rad,"
    "timestamp_time_relative,heading,heading_offset,fix_type,vel_ned_valid,satellites_used";

TEST(CsvExports, Px4VehicleGpsPositionIntegers) {
  const std::string h = kPx4GpsHeader;
  std::string text = h + "\n";
  text += Row(h, {{"timestamp", "5000000"}, {"fix_type", "0"}});  // before the fix
  text += Row(h, {{"timestamp", "96807904"},
                  {"lat", "473566124"},
                  {"lon", "85190391"},
                  {"alt", "488123"},
                  {"alt_ellipsoid", "535456"},
                  {"eph", "0.9"},
                  {"fix_type", "3"}});
  text += Row(h, {{"timestamp", "97007901"},
                  {"lat", "-473566125"},
                  {"lon", "-1785190391"},
                  {"alt", "-12"},
                  {"fix_type", "3"}});
  {
    std::istringstream in(text);
    const TelemetryReadResult r = ParseTelemetryCsv(in, "px4_vehicle_gps_position_0.csv");
    ASSERT_EQ(r.records, 2);
    EXPECT_EQ(r.no_fix_records, 1);
    const Telemetry& t = r.telemetry;
    EXPECT_NEAR(t[0].time_s, 96.807904, 1e-9);
    EXPECT_NEAR(t[0].lat_deg, 47.3566124, 1e-12);
    EXPECT_NEAR(t[0].lon_deg, 8.5190391, 1e-12);
    EXPECT_NEAR(*t[0].abs_alt_m, 488.123, 1e-9);  // alt (MSL) before alt_ellipsoid
    EXPECT_NEAR(t[1].lat_deg, -47.3566125, 1e-12);
    EXPECT_NEAR(t[1].lon_deg, -178.5190391, 1e-12);
    EXPECT_NEAR(*t[1].abs_alt_m, -0.012, 1e-12);
  }
  // The layout says integers: a value with decimals is an error naming the line, not a guess.
  text += Row(h, {{"timestamp", "97207901"}, {"lat", "47.35"}, {"lon", "8.5"}, {"fix_type", "3"}});
  std::istringstream in(text);
  ExpectInputError([&] { ParseTelemetryCsv(in, "gps.csv"); },
                   {"gps.csv:5:", "latitude 47.35 is not an integer", "1e-7 degrees"});
}

TEST(CsvExports, Px4SensorGpsDegreesAndGlobalPosition) {
  // sensor_gps (v1.14 on, msg/SensorGps.msg): latitude_deg, longitude_deg, altitude_msl_m.
  const char gps[] =
      "timestamp,timestamp_sample,device_id,latitude_deg,longitude_deg,altitude_msl_m,"
      "altitude_ellipsoid_m,s_variance_m_s,c_variance_rad,fix_type,eph,epv,hdop,vdop\n"
      "96807904,96807000,11,47.35661242686341,8.519039153652166,423.97,471.31,0.3,0.1,3,0.95,"
      "2.1,0.7,1.1\n";
  std::istringstream in(gps);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "sensor_gps_0.csv");
  ASSERT_EQ(r.records, 1);
  EXPECT_NEAR(r.telemetry[0].time_s, 96.807904, 1e-9);
  EXPECT_DOUBLE_EQ(r.telemetry[0].lat_deg, 47.35661242686341);
  EXPECT_DOUBLE_EQ(*r.telemetry[0].abs_alt_m, 423.97);
  // vehicle_global_position: float degrees and metres under lat, lon, alt (no fix_type).
  const char global[] =
      "timestamp,lat,lon,alt,alt_ellipsoid,delta_alt,vel_n,vel_e,vel_d,yaw,eph,epv\n"
      "96807904,47.35661242686341,8.519039153652166,423.97333,471.31973,-0.0,0.0046,0.039,"
      "0.052,-1.5470879,0.95,2.15\n";
  std::istringstream in2(global);
  const TelemetryReadResult g = ParseTelemetryCsv(in2, "vehicle_global_position_0.csv");
  ASSERT_EQ(g.records, 1);
  EXPECT_NEAR(g.telemetry[0].time_s, 96.807904, 1e-9);
  EXPECT_DOUBLE_EQ(g.telemetry[0].lon_deg, 8.519039153652166);
  EXPECT_DOUBLE_EQ(*g.telemetry[0].abs_alt_m, 423.97333);
  EXPECT_NEAR(*g.telemetry[0].yaw_deg, -1.5470879 * 57.29577951308232, 1e-9);  // radians in PX4
  // vehicle_gps_position's "heading" (dual-antenna receivers only, NaN otherwise) is not read.
  const std::string h = kPx4GpsHeader;
  std::istringstream in3(h + "\n" +
                         Row(h, {{"timestamp", "1000000"},
                                 {"lat", "473566124"},
                                 {"lon", "85190391"},
                                 {"heading", "nan"},
                                 {"fix_type", "3"}}));
  const TelemetryReadResult n = ParseTelemetryCsv(in3, "vehicle_gps_position_0.csv");
  ASSERT_EQ(n.records, 1);
  EXPECT_FALSE(n.telemetry[0].yaw_deg);
}

TEST(CsvExports, IntegerDegE7OutsideAKnownLayoutStopsWithWhatToDo) {
  std::istringstream in("t,lat,lon,alt\n0,473566124,85190391,488123\n");
  ExpectInputError(
      [&] { ParseTelemetryCsv(in, "ints.csv"); },
      {"ints.csv:2:", "latitude 473566124 out of range [-90, 90]", "degE7", "'lat(degE7)'"});
  std::istringstream named("t,lat(degE7),lon(degE7),alt(mm)\n0,473566124,85190391,488123\n");
  const TelemetryReadResult r = ParseTelemetryCsv(named, "ints.csv");
  EXPECT_NEAR(r.telemetry[0].lat_deg, 47.3566124, 1e-12);
  EXPECT_NEAR(*r.telemetry[0].abs_alt_m, 488.123, 1e-9);
}

TEST(CsvUnits, ConvertedToMetresSecondsDegrees) {
  const char text[] =
      "Time (ms);Lat [deg];Lon [deg];Height [ft];Alt_m;Yaw (rad);gimbal_pitch(rad);"
      "focal_length(m);speed(knots)\n"
      "1500;43.5;6.5;10;100;3.141592653589793;-1.5707963267948966;0.0045;12\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "u.csv");
  const TelemetrySample& s = r.telemetry[0];
  EXPECT_DOUBLE_EQ(s.time_s, 1.5);
  EXPECT_NEAR(*s.rel_alt_m, 3.048, 1e-12);
  EXPECT_DOUBLE_EQ(*s.abs_alt_m, 100.0);
  EXPECT_NEAR(*s.yaw_deg, 180.0, 1e-12);
  EXPECT_NEAR(*s.gimbal_pitch_deg, -90.0, 1e-12);
  EXPECT_NEAR(*s.focal_length_mm, 4.5, 1e-12);
  std::istringstream us("timestamp(us),lat,lon\n2500000,1,2\n");
  EXPECT_DOUBLE_EQ(ParseTelemetryCsv(us, "us.csv").telemetry[0].time_s, 2.5);
}

TEST(CsvUnits, AnUnknownUnitOnAReadColumnIsAnErrorNamingFileLineColumnAndUnit) {
  {
    std::istringstream in("# exported\ntime(fortnight),lat,lon\n1,2,3\n");
    ExpectInputError(
        [&] { ParseTelemetryCsv(in, "f.csv"); },
        {"f.csv:2:", "column 'time(fortnight)'", "as the time", "unit 'fortnight'", "known: s,"});
  }
  {
    // A length unit on a time, a time unit on a height: not read as anything else.
    std::istringstream in("t,lat,lon,height_above_takeoff(s)\n1,2,3,4\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "h.csv"); },
                     {"h.csv:1:", "'height_above_takeoff(s)'", "relative altitude", "'s'"});
  }
  {
    std::istringstream in("t,lat,lon,Alt (gps)\n1,2,3,4\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "g.csv"); }, {"g.csv:1:", "unit 'gps'"});
  }
  // Units on columns aerovo does not read are not its business.
  std::istringstream ignored("t,lat,lon,speed(furlongs per fortnight),temp [K]\n1,2,3,4,5\n");
  EXPECT_EQ(ParseTelemetryCsv(ignored, "i.csv").records, 1);
}

// A unit whose bracket does not close (a hand-edited or cut header) on a column aerovo reads: an
// error naming file:line and the column, not "no time column" nor a value read in the wrong unit.
TEST(CsvUnits, AnUnclosedUnitOnAReadColumnIsAnErrorNamingTheColumn) {
  {
    std::istringstream in("time(ms,lat,lon\n1,2,3\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "t.csv"); },
                     {"t.csv:1:", "column 'time(ms'", "as the time", "not written 'name(unit)'"});
  }
  {
    std::istringstream in("t,lat,lon,height_above_takeoff(feet) avg\n1,2,3,4\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "h.csv"); },
                     {"h.csv:1:", "'height_above_takeoff(feet) avg'", "relative altitude"});
  }
  {
    std::istringstream in("t,latitude [deg,lon\n1,2,3\n");
    ExpectInputError([&] { ParseTelemetryCsv(in, "l.csv"); }, {"l.csv:1:", "'latitude [deg'"});
  }
  // On a column aerovo does not read, still not its business.
  std::istringstream ignored("t,lat,lon,speed(mph\n1,2,3,4\n");
  EXPECT_EQ(ParseTelemetryCsv(ignored, "i.csv").records, 1);
}

TEST(CsvUnits, PrecedenceAmongColumnsOfOneFieldAndTrueDuplicates) {
  std::istringstream in(
      "alt,abs_alt,height,rel_alt,time(ms),timestamp,datetime(local),datetime(utc),lat,lon\n"
      "1,2,3,4,1000,99,2020-01-01 00:00:10,2020-01-01 00:00:00,5,6\n");
  const TelemetryReadResult r = ParseTelemetryCsv(in, "p.csv");
  const TelemetrySample& s = r.telemetry[0];
  EXPECT_DOUBLE_EQ(*s.abs_alt_m, 2.0);
  EXPECT_DOUBLE_EQ(*s.rel_alt_m, 4.0);
  EXPECT_DOUBLE_EQ(s.time_s, 1.0);
  EXPECT_DOUBLE_EQ(*s.unix_time_s, 1577836800.0);  // datetime(utc), not (local)
  const char* const duplicates[] = {
      "t,lat,lon,height_above_takeoff(feet),height_above_takeoff(meters)\n0,1,2,3,4\n",
      "t,lat,lon,OSD.height [ft],OSD.height [m]\n0,1,2,3,4\n",
      "time(ms),time(s),lat,lon\n0,0,1,2\n",
      "t,lat,lon,alt,altitude\n0,1,2,3,4\n",
  };
  for (const char* d : duplicates) {
    std::istringstream dup(d);
    ExpectInputError([&] { ParseTelemetryCsv(dup, "d.csv"); }, {"d.csv:1:", "two columns mean"});
  }
}

TEST(Csv, OldAliasesWithUnitSuffixesStillRead) {
  const char text[] =
      "frame_idx,time_s,lat_deg,lon_deg,abs_alt_m,rel_alt_m,yaw_deg,flight_yaw_unused,"
      "gimbal_roll,focal_mm,focal35\n"
      "3,0.25,43.5,6.5,350,100,91,x,0.5,4.5,24\n";
  std::istringstream in(text);
  const TelemetryReadResult r = ParseTelemetryCsv(in, "old.csv");
  const TelemetrySample& s = r.telemetry[0];
  EXPECT_EQ(s.frame_index, 3);
  EXPECT_DOUBLE_EQ(s.time_s, 0.25);
  EXPECT_DOUBLE_EQ(s.lat_deg, 43.5);
  EXPECT_DOUBLE_EQ(s.lon_deg, 6.5);
  EXPECT_DOUBLE_EQ(*s.abs_alt_m, 350.0);
  EXPECT_DOUBLE_EQ(*s.rel_alt_m, 100.0);
  EXPECT_DOUBLE_EQ(*s.yaw_deg, 91.0);
  EXPECT_DOUBLE_EQ(*s.gimbal_roll_deg, 0.5);
  EXPECT_DOUBLE_EQ(*s.focal_length_mm, 4.5);
  EXPECT_DOUBLE_EQ(*s.focal_length_35mm_mm, 24.0);
  std::istringstream h("height_m,elevation,t,lng,latitude\n12,300,1,6,43\n");
  const TelemetryReadResult r2 = ParseTelemetryCsv(h, "old.csv");
  EXPECT_DOUBLE_EQ(*r2.telemetry[0].rel_alt_m, 12.0);
  EXPECT_DOUBLE_EQ(*r2.telemetry[0].abs_alt_m, 300.0);
}

TEST(Csv, EmptyTimeAndFrameIsAMalformedRecordNotACrash) {
  std::istringstream in("t,frame,lat,lon\n,,1,2\n3,3,1,2\n");
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  const TelemetryReadResult r = ParseTelemetryCsv(in, "e.csv", lenient);
  EXPECT_EQ(r.records, 1);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("e.csv:2: no time, date or frame"));
}

// ---------------------------------------------------------------- files

TEST(TelemetryFiles, DispatchByExtensionAndMissingFile) {
  const auto dir = std::filesystem::temp_directory_path() / "aerovo_io_telemetry_test";
  std::filesystem::create_directories(dir);
  {
    std::ofstream(dir / "a.SRT") << kSrtBracketed;
    std::ofstream(dir / "b.gpx") << kGpx;
    std::ofstream(dir / "c.csv") << "t,lat,lon\n0,1,2\n";
    std::ofstream(dir / "d.kml") << "<kml/>";
  }
  EXPECT_EQ(ReadTelemetryFile(dir / "a.SRT").records, 3);
  EXPECT_EQ(ReadTelemetryFile(dir / "b.gpx").records, 3);
  EXPECT_EQ(ReadTelemetryFile(dir / "c.csv").records, 1);
  EXPECT_EQ(ReadTelemetryFile(dir / "a.SRT").telemetry.source(), (dir / "a.SRT").string());
  ExpectInputError([&] { ReadTelemetryFile(dir / "d.kml"); }, {"d.kml", "unknown telemetry"});
  // Without a telemetry extension: a missing file is said as such (not "unknown format ''"),
  // SRT and GPX text is read by its content with a warning saying so; other text is refused.
  ExpectInputError([&] { ReadTelemetryFile(dir / "missing"); },
                   {"cannot open", "missing", "no such file"});
  {
    std::ofstream(dir / "DJI_0042") << kSrtBracketed;
    std::ofstream(dir / "track.xml") << kGpx;
    std::ofstream(dir / "notes") << "1\nnot a timing line\n";
  }
  const TelemetryReadResult srt = ReadTelemetryFile(dir / "DJI_0042");
  EXPECT_EQ(srt.records, 3);
  ASSERT_FALSE(srt.warnings.empty());
  EXPECT_THAT(srt.warnings[0], HasSubstr("DJI_0042: read as .srt by its content (its extension "
                                         "'' names no telemetry format)"));
  EXPECT_EQ(ReadTelemetryFile(dir / "track.xml").records, 3);
  ExpectInputError([&] { ReadTelemetryFile(dir / "notes"); },
                   {"notes", "unknown telemetry format ''", "the content is none"});
  ExpectInputError([&] { ReadDjiSrt(dir / "missing.srt"); },
                   {"cannot open", "missing.srt", "no such file"});
  ExpectInputError([&] { ReadGpx(dir); }, {"is a directory"});
  // The DJI apps' binary flight record (its name and .txt extension as the app writes them; the
  // first bytes of dji-log-parser's examples/DJIFlightRecord_2015-12-05_[10-42-03].txt) is named
  // as such; a CSV export under that name is read.
  {
    std::ofstream(dir / "DJIFlightRecord_2015-12-05_[10-42-03].txt")
        << std::string("\xCC\x06\x0C\x00\x00\x00\x00\x00\x90\x01\x04\x00\x0F\x72", 14);
    std::ofstream(dir / "DJIFlightRecord_2015-12-06_[11-00-00].txt") << "t,lat,lon\n0,1,2\n";
  }
  ExpectInputError(
      [&] { ReadTelemetryFile(dir / "DJIFlightRecord_2015-12-05_[10-42-03].txt"); },
      {"DJIFlightRecord_2015-12-05_[10-42-03].txt: a DJI flight record", "reads its CSV export"});
  EXPECT_EQ(ReadTelemetryFile(dir / "DJIFlightRecord_2015-12-06_[11-00-00].txt").records, 1);
  TelemetryReadOptions bad;
  bad.max_warnings = -1;
  EXPECT_THROW(ReadTelemetryFile(dir / "c.csv", bad), InvalidArgument);
  std::filesystem::remove_all(dir);
}

// ---------------------------------------------------------------- regressions (fuzzing, fuzz/)
// Inputs that once made a parser misbehave, inlined; the sanitizer stage of scripts/test.sh
// runs them under ASan/UBSan (-fsanitize=float-cast-overflow included).

TEST(CsvRegression, HugeFrameNumberIsAnErrorNotAnOverflowingCast) {
  // Was: the integer check cast 1e300 to long long before the range check (undefined).
  const char text[] = "frame,lat,lon\n1e300,1,2\n-1e300,1,2\n3,1,2\n";
  {
    std::istringstream in(text);
    ExpectInputError([&] { ParseTelemetryCsv(in, "f.csv"); },
                     {"f.csv:2:", "is not a non-negative integer"});
  }
  std::istringstream in(text);
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  const TelemetryReadResult r = ParseTelemetryCsv(in, "f.csv", lenient);
  EXPECT_EQ(r.records, 1);
  EXPECT_EQ(r.skipped_records, 2);
  EXPECT_EQ(r.telemetry[0].frame_index, 3);
}

// Only a malformed record is a MalformedRecordError (what lenient mode would skip, and what the
// runner's "--lenient-telemetry" hint is for); a file that is not telemetry at all is not.
TEST(Csv, OnlyMalformedRecordsAreMalformedRecordErrors) {
  std::istringstream bad_value("frame,time_s,lat,lon\n0,0,43.5,6.5\n1,0.5,x,6.6\n");
  EXPECT_THROW(ParseTelemetryCsv(bad_value, "v.csv"), MalformedRecordError);
  std::istringstream no_position("frame,time_s,notes\n0,0,a\n");
  try {
    ParseTelemetryCsv(no_position, "h.csv");
    ADD_FAILURE() << "a CSV without positions was accepted";
  } catch (const MalformedRecordError& e) {
    ADD_FAILURE() << "a header problem reported as a malformed record: " << e.what();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("h.csv"));
  }
}

}  // namespace
}  // namespace aerovo::telemetry_readers_test
