// ArduPilot DataFlash logs (dataflash_reader.cc): logs written here byte for byte, with the
// message layouts of a current ArduPilot (libraries/AP_GPS/LogStructure.h,
// libraries/AP_AHRS/LogStructure.h, libraries/AP_Camera/LogStructure.h), and their text form as
// Mission Planner writes it.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {

using io_test::ExpectInputError;
using ::testing::HasSubstr;

// Message layouts of a current ArduPilot (format and columns as its FMT messages write them;
// ATT in float degrees, older versions write int16/uint16 centidegrees).
constexpr int kGps = 130, kAtt = 131, kPos = 132, kCam = 133;
constexpr char kGpsFormat[] = "QBBIHBcLLeffffB";
constexpr char kGpsColumns[] = "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U";
constexpr char kAttFormat[] = "QffffffB";
constexpr char kAttColumns[] = "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,AEKF";
constexpr char kPosFormat[] = "QLLfff";
constexpr char kPosColumns[] = "TimeUS,Lat,Lng,Alt,RelHomeAlt,RelOriginAlt";
constexpr char kCamFormat[] = "QBHIHLLeeeccC";
constexpr char kCamColumns[] = "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y";

int Size(char c) {
  switch (c) {
    case 'b':
    case 'B':
    case 'M':
      return 1;
    case 'h':
    case 'H':
    case 'c':
    case 'C':
      return 2;
    case 'i':
    case 'I':
    case 'f':
    case 'e':
    case 'E':
    case 'L':
    case 'n':
      return 4;
    case 'd':
    case 'q':
    case 'Q':
      return 8;
    case 'N':
      return 16;
    default:
      return 64;  // a, Z
  }
}

// Writes a binary DataFlash log. Values are given as stored: integers as the integer written
// (Lat 435367000 for 43.5367 degrees, Alt 35012 for 350.12 m), floats as the float.
class BinLog {
 public:
  BinLog() { Define(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"); }

  void Define(int type, const std::string& name, const std::string& format,
              const std::string& columns, int length = -1) {
    int size = 3;
    for (char c : format) size += Size(c);
    formats_[type] = format;
    Header(128);
    Byte(type);
    Byte(length >= 0 ? length : size);
    Text(name, 4);
    Text(format, 16);
    Text(columns, 64);
  }

  void Message(int type, const std::vector<double>& values) {
    const std::string& format = formats_[type];
    ASSERT_EQ(values.size(), format.size());
    Header(type);
    for (std::size_t i = 0; i < format.size(); ++i) {
      const double v = values[i];
      switch (format[i]) {
        case 'f': {
          const float x = static_cast<float>(v);
          std::uint32_t bits;
          std::memcpy(&bits, &x, 4);
          Le(bits, 4);
          break;
        }
        case 'd': {
          std::uint64_t bits;
          std::memcpy(&bits, &v, 8);
          Le(bits, 8);
          break;
        }
        default:
          Le(static_cast<std::uint64_t>(static_cast<std::int64_t>(v)), Size(format[i]));
      }
    }
  }
  void Raw(const std::string& bytes) { bytes_ += bytes; }
  const std::string& bytes() const { return bytes_; }
  std::size_t size() const { return bytes_.size(); }

 private:
  void Header(int type) {
    bytes_ += '\xA3';
    bytes_ += '\x95';
    Byte(type);
  }
  void Byte(int b) { bytes_ += static_cast<char>(b); }
  void Le(std::uint64_t v, int n) {
    for (int k = 0; k < n; ++k) bytes_ += static_cast<char>((v >> (8 * k)) & 0xFF);
  }
  void Text(const std::string& s, int n) {
    std::string t = s.substr(0, n);
    t.resize(n, '\0');
    bytes_ += t;
  }

  std::string bytes_;
  std::map<int, std::string> formats_;
};

constexpr double kWeek = 2300;
constexpr double kWeekMs0 = 216000000;  // Tuesday 12:00:00 of the GPS week

// A GPS message at `time_us` (stored values: lat/lng in 1e-7 degrees, alt in cm).
std::vector<double> Gps(double time_us, int status, double lat_e7, double lng_e7, double alt_cm,
                        int instance = 0) {
  const double ms = kWeekMs0 + (time_us - 10e6) / 1000.0;
  return {time_us, double(instance), double(status), ms,  kWeek, 14,  79,
          lat_e7,  lng_e7,           alt_cm,         5.0, 90.0,  0.0, 0.0,
          1};
}

TelemetryReadResult Parse(const std::string& bytes, bool lenient = false) {
  std::istringstream in(bytes);
  TelemetryReadOptions o;
  o.lenient = lenient;
  return ParseDataFlash(in, "flight.bin", o);
}

// Three GPS fixes 1 s apart after one without a fix, ATT at 10 Hz whose yaw crosses north, POS
// at 5 Hz, a camera trigger and a second receiver's fix (not read).
BinLog Flight(std::size_t* first_fix_at = nullptr) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Define(kAtt, "ATT", kAttFormat, kAttColumns);
  log.Define(kPos, "POS", kPosFormat, kPosColumns);
  log.Define(kCam, "CAM", kCamFormat, kCamColumns);
  log.Message(kGps, Gps(9e6, 1, 0, 0, 0));  // no fix yet
  for (int k = 0; k <= 30; ++k) {
    const double t_us = 9.5e6 + k * 1e5;
    // Yaw 358 deg at 9.5 s, +0.2 deg per 0.1 s: 0.0 at 10.5 s; roll 2, pitch -3 + 0.1 k.
    const double yaw = std::fmod(358.0 + 0.2 * k, 360.0);
    log.Message(kAtt, {t_us, 0, 2.0, 0, -3.0 + 0.1 * k, 0, yaw, 0});
    if (k % 2 == 0) log.Message(kPos, {t_us, 435367000, 65567000, 350.0, 100.0 + 0.1 * k, 99.0});
    if (k % 10 == 5) {
      const double s = (t_us - 10e6) / 1e6;  // 0, 1, 2 s after 10 s
      if (s == 0.0 && first_fix_at != nullptr) *first_fix_at = log.size();
      log.Message(kGps, Gps(t_us, 3, 435367000 + 1000 * s, 65567000 + 2000 * s, 35012 + 50 * s));
      log.Message(kGps, Gps(t_us, 3, 1, 1, 0, 1));  // second receiver: not read
    }
  }
  log.Message(kCam, {10.5e6, 0, 1, kWeekMs0 + 500, kWeek, 435368000, 65569000, 35062, 10050, 35062,
                     -120, 250, 9000});
  return log;
}

TEST(DataFlash, ReadsGpsFixesWithAttitudeAndHeightAboveHome) {
  std::size_t first_fix_at = 0;
  const TelemetryReadResult r = Parse(Flight(&first_fix_at).bytes());
  ASSERT_EQ(r.records, 3);
  EXPECT_EQ(r.no_fix_records, 1);
  EXPECT_EQ(r.skipped_records, 0);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  const Telemetry& t = r.telemetry;
  // time_s = TimeUS / 1e6: seconds since boot.
  EXPECT_DOUBLE_EQ(t[0].time_s, 10.0);
  EXPECT_DOUBLE_EQ(t[2].time_s, 12.0);
  // Lat/Lng int32 in 1e-7 degrees; Alt int32 in cm ('e').
  EXPECT_NEAR(t[0].lat_deg, 43.5367, 1e-9);
  EXPECT_NEAR(t[0].lon_deg, 6.5567, 1e-9);
  EXPECT_NEAR(t[2].lat_deg, 43.5369, 1e-9);
  EXPECT_NEAR(t[2].lon_deg, 6.5571, 1e-9);
  EXPECT_NEAR(*t[0].abs_alt_m, 350.12, 1e-9);
  EXPECT_NEAR(*t[2].abs_alt_m, 351.12, 1e-9);
  // GPS week 2300 (from Sunday 2024-02-04), 216000 s into it, minus 18 leap seconds:
  // 2024-02-06T11:59:42Z.
  ASSERT_TRUE(t[0].unix_time_s);
  EXPECT_NEAR(*t[0].unix_time_s, 315964800.0 + 2300 * 604800.0 + 216000.0 - 18.0, 1e-6);
  EXPECT_NEAR(*t[0].unix_time_s, 1707220782.0, 1e-6);
  EXPECT_NEAR(*t[1].unix_time_s - *t[0].unix_time_s, 1.0, 1e-6);
  // ATT at 10 s is record 5: roll 2, pitch -2.5, yaw 359; at 11 s yaw 1 (across north).
  EXPECT_NEAR(*t[0].roll_deg, 2.0, 1e-5);
  EXPECT_NEAR(*t[0].pitch_deg, -2.5, 1e-5);
  EXPECT_NEAR(*t[0].yaw_deg, 359.0, 1e-4);
  EXPECT_NEAR(*t[1].yaw_deg, 1.0, 1e-4);
  EXPECT_NEAR(*t[1].pitch_deg, -1.5, 1e-5);
  // POS RelHomeAlt at 10 s (k = 5, between the 5 Hz records k = 4 and 6): 100.5 m.
  EXPECT_NEAR(*t[0].rel_alt_m, 100.5, 1e-4);
  EXPECT_NEAR(*t[2].rel_alt_m, 102.5, 1e-4);
  EXPECT_EQ(t[0].origin, fmt::format("flight.bin at byte {}", first_fix_at));
  EXPECT_EQ(first_fix_at, 5 * 89 + 51 + 6 * 36 + 3 * 31);  // FMTs, no-fix GPS, ATT, POS
  EXPECT_FALSE(t[0].frame_index);
}

TEST(DataFlash, InterpolatesAttitudeBetweenMessagesAndNotAcrossGaps) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Define(kAtt, "ATT", kAttFormat, kAttColumns);
  log.Message(kAtt, {1.0e6, 0, 10.0, 0, 0.0, 0, 350.0, 0});
  log.Message(kAtt, {1.2e6, 0, 20.0, 0, 4.0, 0, 10.0, 0});
  log.Message(kGps, Gps(1.05e6, 3, 435367000, 65567000, 35000));
  log.Message(kAtt, {5.0e6, 0, 0.0, 0, 0.0, 0, 0.0, 0});  // 3.8 s later: a gap
  log.Message(kGps, Gps(3.0e6, 3, 435368000, 65567000, 35000));
  const TelemetryReadResult r = Parse(log.bytes());
  ASSERT_EQ(r.records, 2);
  EXPECT_NEAR(*r.telemetry[0].roll_deg, 12.5, 1e-5);
  EXPECT_NEAR(*r.telemetry[0].pitch_deg, 1.0, 1e-5);
  EXPECT_NEAR(*r.telemetry[0].yaw_deg, 355.0, 1e-4);  // 350 -> 10 through north
  EXPECT_FALSE(r.telemetry[1].yaw_deg);
  EXPECT_FALSE(r.telemetry[1].rel_alt_m);  // no POS message
}

TEST(DataFlash, ReadsOlderLayoutsInCentidegrees) {
  // ATT of older ArduPilot versions (int16/uint16 centidegrees) and a GPS without I, GWk, GMS.
  BinLog log;
  log.Define(kGps, "GPS", "QBLLe", "TimeUS,Status,Lat,Lng,Alt");
  log.Define(kAtt, "ATT", "QccccCCCCB",
             "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,"
             "ErrYaw,AEKF");
  log.Message(kAtt, {2e6, 0, -1234, 0, 567, 0, 35999, 0, 0, 0});
  log.Message(kGps, {2e6, 4, -335367000, -1795567000, -1250});
  const TelemetryReadResult r = Parse(log.bytes());
  ASSERT_EQ(r.records, 1);
  const TelemetrySample& s = r.telemetry[0];
  EXPECT_NEAR(s.lat_deg, -33.5367, 1e-9);
  EXPECT_NEAR(s.lon_deg, -179.5567, 1e-9);
  EXPECT_NEAR(*s.abs_alt_m, -12.5, 1e-9);
  EXPECT_NEAR(*s.roll_deg, -12.34, 1e-9);
  EXPECT_NEAR(*s.pitch_deg, 5.67, 1e-9);
  EXPECT_NEAR(*s.yaw_deg, 359.99, 1e-9);
  EXPECT_FALSE(s.unix_time_s);
}

TEST(DataFlash, GarbageBetweenMessagesIsSkippedWithAWarningNamingTheOffset) {
  BinLog log = Flight();
  // 37 bytes written over: a header with an undefined type among them, then a last fix. The
  // message before them (Flight()'s last, CAM: 46 bytes) is not followed by a header: bytes
  // inserted into it could not be told from bytes after it, so it is skipped with them.
  const std::size_t at = log.size() - 46;
  log.Raw(std::string(20, '\x55') + "\xA3\x95\xF0" + std::string(14, '\0'));
  log.Message(kGps, Gps(13e6, 3, 435367300, 65567600, 35162));
  for (bool lenient : {false, true}) {
    const TelemetryReadResult r = Parse(log.bytes(), lenient);
    EXPECT_EQ(r.records, 4);
    EXPECT_EQ(r.skipped_records, 0);
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_THAT(r.warnings[0],
                HasSubstr(fmt::format("flight.bin at byte {}: 83 byte(s) skipped", at)));
    EXPECT_NEAR(r.telemetry[3].lat_deg, 43.53673, 1e-9);
  }
}

TEST(DataFlash, ManyGapsAreCountedAndTheWarningsBounded) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  // 10 gaps of 58 bytes: 7 bytes of garbage and the fix before them (not followed by a header).
  for (int k = 0; k < 10; ++k) {
    log.Message(kGps, Gps(1e6 * (k + 1), 3, 435367000 + 100 * k, 65567000, 35000));
    log.Message(kGps, Gps(1e6 * (k + 1.5), 3, 435367050 + 100 * k, 65567000, 35000));
    log.Raw(std::string(7, '\x55'));
  }
  log.Message(kGps, Gps(20e6, 3, 435368000, 65567000, 35000));
  const TelemetryReadResult r = Parse(log.bytes());
  EXPECT_EQ(r.records, 11);
  ASSERT_EQ(r.warnings.size(), 6u);
  EXPECT_THAT(r.warnings[5], HasSubstr("flight.bin: 10 gaps of unreadable bytes in all (580 "
                                       "bytes), 5 of them listed"));
  std::istringstream in(log.bytes());
  TelemetryReadOptions few;
  few.max_warnings = 2;
  const TelemetryReadResult r2 = ParseDataFlash(in, "flight.bin", few);
  ASSERT_EQ(r2.warnings.size(), 2u);
  EXPECT_THAT(r2.warnings[1], HasSubstr("10 gaps of unreadable bytes in all (580 bytes), 1 of"));
}

TEST(DataFlash, BytesInsertedIntoAMessageDropItWithAWarning) {
  // 37 bytes inserted 20 bytes into a GPS message (51 bytes): read at its length, its fields
  // would be shifted (a latitude of 143 degrees); it is dropped, and the next one read.
  BinLog log = Flight();
  const std::size_t at = log.size();
  BinLog tail;
  tail.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  const std::size_t start = tail.size();
  tail.Message(kGps, Gps(13e6, 3, 435367300, 65567600, 35162));
  tail.Message(kGps, Gps(14e6, 3, 435367400, 65567800, 35212));
  std::string bytes = tail.bytes().substr(start);
  bytes.insert(20, std::string(37, '\x55'));
  const TelemetryReadResult r = Parse(log.bytes() + bytes);
  EXPECT_EQ(r.records, 4);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr(fmt::format("at byte {}: 88 byte(s) skipped", at)));
  EXPECT_NEAR(r.telemetry[3].lat_deg, 43.53674, 1e-9);
  EXPECT_DOUBLE_EQ(r.telemetry[3].time_s, 14.0);
}

TEST(DataFlash, ACutLastMessageIsSkippedWithAWarning) {
  BinLog log = Flight();
  const std::size_t at = log.size();
  log.Message(kGps, Gps(13e6, 3, 435367300, 65567600, 35162));
  const std::string cut = log.bytes().substr(0, at + 20);
  const TelemetryReadResult r = Parse(cut);
  EXPECT_EQ(r.records, 3);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr(fmt::format("flight.bin at byte {}: 20 byte(s)", at)));
  EXPECT_THAT(r.warnings[0], HasSubstr("cut short"));
  // Cut inside the header itself.
  const TelemetryReadResult r2 = Parse(log.bytes().substr(0, at + 2));
  EXPECT_EQ(r2.records, 3);
  ASSERT_EQ(r2.warnings.size(), 1u);
  EXPECT_THAT(r2.warnings[0], HasSubstr(fmt::format("at byte {}: 2 byte(s) skipped", at)));
}

TEST(DataFlash, ALogWithoutA3dFixIsAnInputError) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  for (int k = 0; k < 5; ++k) log.Message(kGps, Gps(1e6 * k, k % 3, 0, 0, 0));
  ExpectInputError([&] { Parse(log.bytes()); },
                   {"flight.bin", "no GPS message with a 3D fix", "5 GPS messages"});
  BinLog no_gps;
  no_gps.Define(kAtt, "ATT", kAttFormat, kAttColumns);
  no_gps.Message(kAtt, {1e6, 0, 0, 0, 0, 0, 0, 0});
  ExpectInputError([&] { Parse(no_gps.bytes()); }, {"flight.bin", "no GPS message"});
  BinLog bad_columns;
  bad_columns.Define(kGps, "GPS", "QBII", "TimeUS,Status,Latitude,Longitude");
  bad_columns.Message(kGps, {1e6, 3, 1, 1});
  ExpectInputError([&] { Parse(bad_columns.bytes()); }, {"no 'Lat' column", "Latitude"});
}

TEST(DataFlash, AFileThatIsNotADataFlashLogIsAnError) {
  ExpectInputError([&] { Parse(std::string("\xFF\xD8\xFF\xE0\x00\x10JFIF", 10)); },
                   {"flight.bin", "not an ArduPilot DataFlash log", "FF D8 FF E0", "JPEG"});
  ExpectInputError([&] { Parse("time,lat,lon\n0,1,2\n"); },
                   {"flight.bin:1", "not an ArduPilot DataFlash log", "time,lat,lon"});
  ExpectInputError([&] { Parse(""); }, {"flight.bin", "empty"});
  // A PX4 ULog and a MAVLink .tlog (an 8-byte big-endian timestamp, 2026-12-06, then a MAVLink 2
  // packet's magic) given the wrong extension are named.
  ExpectInputError([&] { Parse(std::string("ULog\x01\x12\x35\x01", 8)); },
                   {"not an ArduPilot DataFlash log", "a PX4 ULog: name it .ulg"});
  ExpectInputError([&] { Parse(std::string("\x00\x06\x61\xEB\xCA\x54\x60\x00\xFD\x1C", 10)); },
                   {"not an ArduPilot DataFlash log", "a MAVLink telemetry log: name it .tlog"});
  ExpectInputError([&] { Parse(std::string("\xA3\x95\x82\x00", 4)); },
                   {"flight.bin", "type 130", "not a whole log"});
}

TEST(DataFlash, MalformedMessagesFollowTheStrictOrLenientPolicy) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Message(kGps, Gps(1e6, 3, 435367000, 65567000, 35000));
  const std::size_t bad = log.size();
  log.Message(kGps, Gps(2e6, 3, 950000000, 65567000, 35000));    // latitude 95
  log.Message(kGps, Gps(1.5e6, 3, 435367000, 65567000, 35000));  // after 1 s, the last accepted
  log.Message(kGps, Gps(3e6, 3, 435368000, 65567000, 35000));
  try {
    Parse(log.bytes());
    ADD_FAILURE() << "no error";
  } catch (const MalformedRecordError& e) {
    EXPECT_THAT(e.what(), HasSubstr(fmt::format("flight.bin at byte {}: latitude 95", bad)));
  }
  const TelemetryReadResult r = Parse(log.bytes(), true);
  EXPECT_EQ(r.records, 3);
  EXPECT_EQ(r.skipped_records, 1);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr(fmt::format("flight.bin at byte {}: latitude 95", bad)));
}

TEST(DataFlash, GpsMessagesOutOfOrderAreMalformed) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Message(kGps, Gps(2e6, 3, 435367000, 65567000, 35000));
  const std::size_t back = log.size();
  log.Message(kGps, Gps(1e6, 3, 435368000, 65567000, 35000));
  log.Message(kGps, Gps(3e6, 3, 435369000, 65567000, 35000));
  const std::string message =
      fmt::format("flight.bin at byte {}: GPS time 1.000000 s is earlier", back);
  ExpectInputError([&] { Parse(log.bytes()); }, {message.c_str()});
  const TelemetryReadResult r = Parse(log.bytes(), true);
  EXPECT_EQ(r.records, 2);
  EXPECT_EQ(r.skipped_records, 1);
}

TEST(DataFlash, CamMessagesOfTheFirstCameraAreThePhotosTaken) {
  BinLog log = Flight();
  const std::size_t second = log.size();
  // A second camera's photo (instance 1): not read. A photo without a position (the AHRS had
  // none: latitude = longitude = 0) keeps its heights and angles.
  log.Message(kCam, {11.0e6, 1, 1, kWeekMs0 + 1000, kWeek, 435369000, 65570000, 35100, 10100, 35100,
                     0, 0, 0});
  const std::size_t no_fix = log.size();
  log.Message(kCam,
              {12.25e6, 0, 2, kWeekMs0 + 2250, kWeek, 0, 0, 35162, 10150, 35162, 100, -50, 35950});
  const TelemetryReadResult r = Parse(log.bytes());
  EXPECT_EQ(r.records, 3);  // the GPS samples are unchanged
  ASSERT_EQ(r.camera_triggers.size(), 2u);
  const TelemetrySample& a = r.camera_triggers[0];
  EXPECT_DOUBLE_EQ(a.time_s, 10.5);  // TimeUS / 1e6, the GPS samples' clock
  EXPECT_TRUE(a.has_fix);
  EXPECT_NEAR(a.lat_deg, 43.5368, 1e-9);
  EXPECT_NEAR(a.lon_deg, 6.5569, 1e-9);
  EXPECT_NEAR(*a.abs_alt_m, 350.62, 1e-9);
  EXPECT_NEAR(*a.rel_alt_m, 100.50, 1e-9);
  EXPECT_NEAR(*a.roll_deg, -1.20, 1e-9);  // 'c': centidegrees
  EXPECT_NEAR(*a.pitch_deg, 2.50, 1e-9);
  EXPECT_NEAR(*a.yaw_deg, 90.00, 1e-9);
  ASSERT_TRUE(a.unix_time_s);
  EXPECT_NEAR(*a.unix_time_s, 1707220782.5, 1e-6);
  EXPECT_FALSE(a.frame_index);
  EXPECT_EQ(a.origin, fmt::format("flight.bin at byte {}: CAM 1", second - 46));
  const TelemetrySample& b = r.camera_triggers[1];
  EXPECT_DOUBLE_EQ(b.time_s, 12.25);
  EXPECT_FALSE(b.has_fix);
  EXPECT_NEAR(*b.rel_alt_m, 101.50, 1e-9);
  EXPECT_NEAR(*b.yaw_deg, 359.50, 1e-9);
  EXPECT_EQ(b.origin, fmt::format("flight.bin at byte {}: CAM 2", no_fix));
  // A log without CAM or TRIG has none.
  BinLog plain;
  plain.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  plain.Message(kGps, Gps(1e6, 3, 435367000, 65567000, 35000));
  EXPECT_TRUE(Parse(plain.bytes()).camera_triggers.empty());
}

TEST(DataFlash, TrigMessagesAreReadOnlyWithoutCamAndOlderLayoutsToo) {
  // TRIG (the trigger, logged when a feedback pin is set) in the float layout of ArduPilot 4.5.
  constexpr int kTrig = 134;
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Define(kTrig, "TRIG", "QBHIHLLeeefff", kCamColumns);
  log.Message(kGps, Gps(1e6, 3, 435367000, 65567000, 35000));
  log.Message(kTrig, {2e6, 0, 7, kWeekMs0, kWeek, 435367500, 65567500, 35000, 4000, 35000, 1.5,
                      -2.25, 271.75});
  TelemetryReadResult r = Parse(log.bytes());
  ASSERT_EQ(r.camera_triggers.size(), 1u);
  EXPECT_NEAR(r.camera_triggers[0].lat_deg, 43.53675, 1e-9);
  EXPECT_NEAR(*r.camera_triggers[0].rel_alt_m, 40.0, 1e-9);
  EXPECT_NEAR(*r.camera_triggers[0].roll_deg, 1.5, 1e-6);
  EXPECT_NEAR(*r.camera_triggers[0].pitch_deg, -2.25, 1e-6);
  EXPECT_NEAR(*r.camera_triggers[0].yaw_deg, 271.75, 1e-5);
  EXPECT_THAT(r.camera_triggers[0].origin, HasSubstr(": TRIG 7"));
  // With CAM messages too, CAM is read (the photos the camera confirmed).
  log.Define(kCam, "CAM", "QBHIHLLeeefff", kCamColumns);
  log.Message(kCam,
              {2.1e6, 0, 7, kWeekMs0, kWeek, 435367600, 65567500, 35000, 4000, 35000, 0, 0, 0});
  r = Parse(log.bytes());
  ASSERT_EQ(r.camera_triggers.size(), 1u);
  EXPECT_DOUBLE_EQ(r.camera_triggers[0].time_s, 2.1);
  EXPECT_THAT(r.camera_triggers[0].origin, HasSubstr(": CAM 7"));
  // Before ArduPilot 4.1: no I or Img, the angles named Roll, Pitch, Yaw in centidegrees.
  BinLog old;
  old.Define(kGps, "GPS", "QBLLe", "TimeUS,Status,Lat,Lng,Alt");
  old.Define(kCam, "CAM", "QIHLLeeeccC",
             "TimeUS,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,Roll,Pitch,Yaw");
  old.Message(kGps, {1e6, 3, 435367000, 65567000, 35000});
  old.Message(kCam,
              {3e6, kWeekMs0, kWeek, 435367000, 65567000, 35000, 6020, 35000, -250, 75, 18000});
  r = Parse(old.bytes());
  ASSERT_EQ(r.camera_triggers.size(), 1u);
  EXPECT_NEAR(*r.camera_triggers[0].rel_alt_m, 60.2, 1e-9);
  EXPECT_NEAR(*r.camera_triggers[0].roll_deg, -2.5, 1e-9);
  EXPECT_NEAR(*r.camera_triggers[0].yaw_deg, 180.0, 1e-9);
  EXPECT_THAT(r.camera_triggers[0].origin, ::testing::EndsWith(": CAM"));
}

TEST(DataFlash, MalformedCamMessagesFollowTheStrictOrLenientPolicy) {
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Define(kCam, "CAM", kCamFormat, kCamColumns);
  log.Message(kGps, Gps(1e6, 3, 435367000, 65567000, 35000));
  log.Message(kCam, {2e6, 0, 1, kWeekMs0, kWeek, 435367000, 65567000, 35000, 0, 0, 0, 0, 0});
  const std::size_t bad = log.size();
  log.Message(kCam, {3e6, 0, 2, kWeekMs0, kWeek, 950000000, 65567000, 35000, 0, 0, 0, 0, 0});
  const std::size_t back = log.size();
  log.Message(kCam, {1.5e6, 0, 3, kWeekMs0, kWeek, 435367000, 65567000, 35000, 0, 0, 0, 0, 0});
  log.Message(kCam, {4e6, 0, 4, kWeekMs0, kWeek, 435367000, 65567000, 35000, 0, 0, 0, 0, 0});
  const std::string latitude = fmt::format("flight.bin at byte {}: CAM: latitude 95", bad);
  ExpectInputError([&] { Parse(log.bytes()); }, {latitude.c_str()});
  const TelemetryReadResult r = Parse(log.bytes(), true);
  ASSERT_EQ(r.camera_triggers.size(), 2u);
  EXPECT_DOUBLE_EQ(r.camera_triggers[1].time_s, 4.0);
  EXPECT_EQ(r.skipped_records, 2);
  ASSERT_EQ(r.warnings.size(), 2u);
  EXPECT_THAT(r.warnings[0], HasSubstr(latitude));
  EXPECT_THAT(r.warnings[1], HasSubstr(fmt::format("flight.bin at byte {}: CAM time 1.500000 s is "
                                                   "earlier than the previous CAM message's "
                                                   "2.000000 s",
                                                   back)));
}

TEST(DataFlash, HostileFormatsNeitherCrashNorHang) {
  const auto start = std::chrono::steady_clock::now();
  // Lengths 0, 1 and 2 (shorter than the header), a length that does not match the format,
  // an unknown format character, each followed by messages of that type.
  BinLog log;
  log.Define(kGps, "GPS", kGpsFormat, kGpsColumns);
  log.Define(140, "AAA", "B", "X", 0);
  log.Define(141, "BBB", "B", "X", 2);
  log.Define(142, "CCC", "Qw", "TimeUS,W", 255);
  log.Define(kAtt, "ATT", kAttFormat, kAttColumns, 200);  // inconsistent: not read
  log.Raw("\xA3\x95\x8C\xA3\x95\x8D\xA3\x95\x8C");
  log.Raw(std::string("\xA3\x95\x8E", 3) + std::string(252, '\x01'));
  log.Message(kGps, Gps(1e6, 3, 435367000, 65567000, 35000));
  // A 4 MiB stretch of garbage holding headers of undefined types.
  std::string garbage(std::size_t{4} << 20, '\x00');
  for (std::size_t k = 0; k + 3 < garbage.size(); k += 97) garbage.replace(k, 3, "\xA3\x95\xFE");
  log.Raw(garbage);
  log.Message(kGps, Gps(2e6, 3, 435368000, 65567000, 35000));
  const TelemetryReadResult r = Parse(log.bytes());
  EXPECT_EQ(r.records, 2);
  EXPECT_FALSE(r.telemetry[0].yaw_deg);
  bool said_length = false, said_att = false, said_gap = false;
  for (const std::string& w : r.warnings) {
    said_length |= w.find("type 140 ('AAA') with length 0 < 3") != std::string::npos;
    said_att |= w.find("the FMT of ATT") != std::string::npos;
    said_gap |= w.find(fmt::format("{} byte(s) skipped", garbage.size())) != std::string::npos;
  }
  EXPECT_TRUE(said_length);
  EXPECT_TRUE(said_att);
  EXPECT_TRUE(said_gap);
  // A log of garbage after its first FMT: an error, not a hang.
  const std::string message =
      fmt::format("no GPS message in this DataFlash log ({} of its {} bytes", garbage.size(),
                  garbage.size() + 89);
  ExpectInputError([&] { Parse(BinLog().bytes() + garbage); }, {message.c_str()});
  // A file of one cut FMT message: its 5 bytes are all counted, of a file of 5.
  ExpectInputError([&] { Parse(std::string("\xA3\x95\x80\x80\xFF", 5)); },
                   {"no GPS message in this DataFlash log (5 of its 5 bytes"});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 20.0);
}

// The text form of Flight() as Mission Planner writes it (ExtLibs/Utilities/BinaryLog.cs): ", "
// between values, CRLF, c/C/e/E divided by 100 with two decimals, L in degrees.
std::string FlightText() {
  std::string s =
      "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\r\n"
      "FMT, 130, 51, GPS, QBBIHBcLLeffffB, "
      "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U\r\n"
      "FMT, 131, 36, ATT, QffffffB, TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,AEKF\r\n"
      "FMT, 132, 31, POS, QLLfff, TimeUS,Lat,Lng,Alt,RelHomeAlt,RelOriginAlt\r\n"
      "FMT, 133, 46, CAM, QBHIHLLeeeccC, "
      "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y\r\n"
      "FMT, 200, 73, MSG, QZ, TimeUS,Message\r\n"
      "MSG, 1000, ArduCopter V4.5.7 (2a1e2f3c), with a comma\r\n"
      "GPS, 9000000, 0, 1, 215000000, 2300, 14, 0.79, 0, 0, 0.00, 5, 90, 0, 0, 1\r\n";
  for (int k = 0; k <= 30; ++k) {
    const long long t_us = 9500000 + k * 100000LL;
    s += fmt::format("ATT, {}, 0, 2, 0, {}, 0, {}, 0\r\n", t_us, -3.0 + 0.1 * k,
                     std::fmod(358.0 + 0.2 * k, 360.0));
    if (k % 2 == 0) {
      s += fmt::format("POS, {}, 43.5367, 6.5567, 350, {}, 99\r\n", t_us, 100.0 + 0.1 * k);
    }
    if (k % 10 == 5) {
      const int sec = (k - 5) / 10;
      s += fmt::format("GPS, {}, 0, 3, {}, 2300, 14, 0.79, {}, {}, {:.2f}, 5, 90, 0, 0, 1\r\n",
                       t_us, 216000000 + 1000 * sec, 43.5367 + 1e-4 * sec, 6.5567 + 2e-4 * sec,
                       350.12 + 0.5 * sec);
    }
  }
  s += "CAM, 10500000, 0, 1, 216000500, 2300, 43.5368, 6.5569, 350.62, 100.50, 350.62, -1.20, "
       "2.50, 90.00\r\n";
  return s;
}

TEST(DataFlash, TheTextFormGivesTheSameSamples) {
  std::istringstream in(FlightText());
  const TelemetryReadResult r = ParseDataFlash(in, "flight.log");
  const TelemetryReadResult b = Parse(Flight().bytes());
  ASSERT_EQ(r.records, 3);
  EXPECT_EQ(r.no_fix_records, 1);
  for (std::size_t i = 0; i < 3; ++i) {
    const TelemetrySample& s = r.telemetry[i];
    const TelemetrySample& e = b.telemetry[i];
    EXPECT_DOUBLE_EQ(s.time_s, e.time_s);
    EXPECT_NEAR(s.lat_deg, e.lat_deg, 1e-9);
    EXPECT_NEAR(s.lon_deg, e.lon_deg, 1e-9);
    EXPECT_NEAR(*s.abs_alt_m, *e.abs_alt_m, 1e-9);
    EXPECT_NEAR(*s.rel_alt_m, *e.rel_alt_m, 1e-4);
    EXPECT_NEAR(*s.yaw_deg, *e.yaw_deg, 1e-4);
    EXPECT_NEAR(*s.pitch_deg, *e.pitch_deg, 1e-5);
    EXPECT_NEAR(*s.unix_time_s, *e.unix_time_s, 1e-6);
  }
  EXPECT_EQ(r.telemetry[0].origin, "flight.log:18");
  ASSERT_EQ(r.camera_triggers.size(), 1u);
  ASSERT_EQ(b.camera_triggers.size(), 1u);
  const TelemetrySample& c = r.camera_triggers[0];
  const TelemetrySample& d = b.camera_triggers[0];
  EXPECT_DOUBLE_EQ(c.time_s, d.time_s);
  EXPECT_NEAR(c.lat_deg, d.lat_deg, 1e-9);
  EXPECT_NEAR(c.lon_deg, d.lon_deg, 1e-9);
  EXPECT_NEAR(*c.rel_alt_m, *d.rel_alt_m, 1e-9);
  EXPECT_NEAR(*c.roll_deg, *d.roll_deg, 1e-9);
  EXPECT_NEAR(*c.yaw_deg, *d.yaw_deg, 1e-9);
  EXPECT_EQ(c.origin, "flight.log:59: CAM 1");
}

TEST(DataFlash, TextLinesThatDoNotMatchTheirFmtAreMalformed) {
  const std::string text =
      "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n"
      "FMT, 130, 20, GPS, QBLLe, TimeUS,Status,Lat,Lng,Alt\n"
      "GPS, 1000000, 3, 43.5367, 6.5567, 350.12\n"
      "GPS, 2000000, 3, 43.5368, 6.5567\n"
      "GPS, 3000000, 3, north, 6.5567, 350.12\n"
      "GPS, 4000000, 3, 43.5369, 6.5567, 350.12\n";
  std::istringstream in(text);
  ExpectInputError([&] { ParseDataFlash(in, "f.log"); },
                   {"f.log:4: GPS line with 4 values, its FMT names 5 columns"});
  std::istringstream in2(text);
  TelemetryReadOptions lenient;
  lenient.lenient = true;
  const TelemetryReadResult r = ParseDataFlash(in2, "f.log", lenient);
  EXPECT_EQ(r.records, 2);
  EXPECT_EQ(r.skipped_records, 2);
  ASSERT_EQ(r.warnings.size(), 2u);
  EXPECT_THAT(r.warnings[1], HasSubstr("f.log:5: GPS message whose Lat is not a number"));
}

TEST(DataFlash, ReadTelemetryFilePicksTheReaderByExtensionAndContent) {
  io_test::TempDir dir("dataflash");
  {
    std::ofstream(dir / "00000042.BIN", std::ios::binary) << Flight().bytes();
    std::ofstream(dir / "00000042.log", std::ios::binary) << FlightText();
    std::ofstream(dir / "photo.bin", std::ios::binary) << std::string("\xFF\xD8\xFF\xE1", 4);
  }
  EXPECT_EQ(ReadTelemetryFile(dir / "00000042.BIN").records, 3);
  EXPECT_EQ(ReadTelemetryFile(dir / "00000042.log").records, 3);
  EXPECT_EQ(ReadTelemetryFile(dir / "00000042.BIN").telemetry.source(),
            (dir / "00000042.BIN").string());
  ExpectInputError([&] { ReadTelemetryFile(dir / "photo.bin"); },
                   {"photo.bin", "not an ArduPilot DataFlash log", "JPEG"});
  // A binary log whose name has no extension (or another one) is read by its magic bytes, and
  // the run is told so.
  std::filesystem::copy_file(dir / "00000042.BIN", dir / "00000042");
  const TelemetryReadResult sniffed = ReadTelemetryFile(dir / "00000042");
  EXPECT_EQ(sniffed.records, 3);
  ASSERT_FALSE(sniffed.warnings.empty());
  EXPECT_THAT(sniffed.warnings[0], HasSubstr("00000042: read as .bin by its content"));
}

}  // namespace
}  // namespace aerovo
