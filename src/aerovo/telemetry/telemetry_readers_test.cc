#include "aerovo/telemetry/telemetry_readers.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"
#include "aerovo/telemetry/parse_util.h"

namespace aerovo {
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

TEST(ParseUtil, Numbers) {
  using io_detail::ParseDouble;
  EXPECT_DOUBLE_EQ(*ParseDouble(" +44.47 "), 44.47);
  EXPECT_DOUBLE_EQ(*ParseDouble("-1e3"), -1000.0);
  EXPECT_FALSE(ParseDouble("nan"));
  EXPECT_FALSE(ParseDouble("inf"));
  EXPECT_FALSE(ParseDouble("0x10"));
  EXPECT_FALSE(ParseDouble("1.5m"));
  EXPECT_FALSE(ParseDouble(""));
  EXPECT_FALSE(ParseDouble("1e999"));
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
  ExpectInputError([&] { ReadDjiSrt(dir / "missing.srt"); },
                   {"cannot open", "missing.srt", "no such file"});
  ExpectInputError([&] { ReadGpx(dir); }, {"is a directory"});
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
}  // namespace aerovo
