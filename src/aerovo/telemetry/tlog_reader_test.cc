// MAVLink telemetry logs (tlog_reader.cc): logs written here byte for byte as a ground station
// records them (an 8-byte big-endian timestamp, then the packet), the packets framed and
// checksummed by aerovo's own MAVLink code (mavlink/messages.h, mavlink/protocol.h).
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/protocol.h"
#include "aerovo/telemetry/io_test_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {
// Its own namespace: the module's tests are compiled as one unity source.
namespace tlog_test {

namespace mav = aerovo::mavlink;
using io_test::ExpectInputError;
using ::testing::HasSubstr;

constexpr std::uint8_t kMavTypeQuadrotor = 2;              // MAV_TYPE_QUADROTOR
constexpr std::uint8_t kMavTypeGcs = 6;                    // MAV_TYPE_GCS
constexpr std::uint8_t kAutopilotArdupilot = 3;            // MAV_AUTOPILOT_ARDUPILOTMEGA
constexpr std::uint8_t kGcsSysid = 255, kGcsCompid = 190;  // Mission Planner's
// The ground station's clock at the first record: 2026-05-03 10:20:00 UTC.
constexpr std::uint64_t kStartUs = 1777803600ull * 1000000ull;

// Writes a .tlog: each packet after its record timestamp (big-endian microseconds).
class TlogWriter {
 public:
  template <class M>
  std::size_t V2(const M& m, std::uint64_t us, std::uint8_t sysid = 1, std::uint8_t compid = 1) {
    return Record(us, mav::Encode(m, seq_++, sysid, compid));
  }
  // A MAVLink 1 packet: 0xFE, len, seq, sysid, compid, msgid (8 bit), the whole MAVLink 1
  // payload (never truncated), the checksum (mavlink.io "Packet Serialization").
  template <class M>
  std::size_t V1(const M& m, std::uint64_t us, std::uint8_t sysid = 1, std::uint8_t compid = 1) {
    const auto payload = mav::Payload(m);
    std::vector<std::uint8_t> b = {mav::kMagicV1, M::kMinLength, seq_++,
                                   sysid,         compid,        static_cast<std::uint8_t>(M::kId)};
    b.insert(b.end(), payload.begin(), payload.begin() + M::kMinLength);
    std::uint16_t crc = mav::Crc16Mcrf4xx(b.data() + 1, b.size() - 1);
    crc = mav::Crc16Accumulate(M::kCrcExtra, crc);
    b.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    b.push_back(static_cast<std::uint8_t>(crc >> 8));
    return Record(us, b);
  }
  // Returns the byte offset of the record.
  std::size_t Record(std::uint64_t us, const std::vector<std::uint8_t>& packet) {
    const std::size_t at = bytes_.size();
    for (int k = 7; k >= 0; --k) bytes_ += static_cast<char>((us >> (8 * k)) & 0xFF);
    bytes_.append(packet.begin(), packet.end());
    return at;
  }
  void Raw(const std::string& b) { bytes_ += b; }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
  std::uint8_t seq_ = 0;
};

mav::Heartbeat GcsHeartbeat() {
  mav::Heartbeat h;
  h.type = kMavTypeGcs;
  h.autopilot = mav::kMavAutopilotInvalid;
  return h;
}
mav::Heartbeat AutopilotHeartbeat() {
  mav::Heartbeat h;
  h.type = kMavTypeQuadrotor;
  h.autopilot = kAutopilotArdupilot;
  return h;
}
mav::GlobalPositionInt Position(std::uint32_t ms, double lat, double lon) {
  mav::GlobalPositionInt g;
  g.time_boot_ms = ms;
  g.lat = static_cast<std::int32_t>(std::lround(lat * 1e7));
  g.lon = static_cast<std::int32_t>(std::lround(lon * 1e7));
  g.alt = 350123;           // 350.123 m MSL
  g.relative_alt = 100000;  // 100 m above home
  g.hdg = 9000;             // 90 degrees
  return g;
}
mav::Attitude AttitudeAt(std::uint32_t ms, double yaw_rad) {
  mav::Attitude a;
  a.time_boot_ms = ms;
  a.roll = 0.1f;
  a.pitch = -0.05f;
  a.yaw = static_cast<float>(yaw_rad);
  return a;
}
mav::GpsRawInt Fix(std::uint8_t fix_type) {
  mav::GpsRawInt r;
  r.fix_type = fix_type;
  return r;
}

TelemetryReadResult Parse(const std::string& bytes, bool lenient = false) {
  std::istringstream in(bytes);
  TelemetryReadOptions o;
  o.lenient = lenient;
  return ParseTlog(in, "f.tlog", o);
}

// A flight log: GCS and autopilot heartbeats, SYSTEM_TIME, GPS_RAW_INT with a 3D fix, positions
// every 200 ms from boot time 1.0 s to 2.0 s (latitude rising 1e-5 degrees each), attitude every
// 100 ms from 0.9 s to 2.1 s (yaw 0.1 rad/s from 0.5 rad); some packets in MAVLink 1 framing.
TlogWriter Flight(bool system_time = true) {
  TlogWriter w;
  const auto us = [](double boot_s) {
    // The ground station receives each packet 50 ms after the autopilot's boot time + 10 s.
    return kStartUs + static_cast<std::uint64_t>(std::llround((boot_s + 10.05) * 1e6));
  };
  w.V2(GcsHeartbeat(), us(0.8), kGcsSysid, kGcsCompid);
  w.V2(AutopilotHeartbeat(), us(0.8));
  if (system_time) {
    mav::SystemTime t;
    t.time_unix_usec = 1777803610ull * 1000000ull;  // at boot time 0.85 s
    t.time_boot_ms = 850;
    w.V2(t, us(0.85));
  }
  w.V1(Fix(3), us(0.86));
  for (int k = 0; k <= 12; ++k) {
    const double t = 0.9 + 0.1 * k;
    const auto ms = static_cast<std::uint32_t>(std::lround(t * 1000));
    if (k % 2 == 0) {
      w.V2(AttitudeAt(ms, 0.5 + 0.1 * t), us(t));
    } else {
      w.V1(AttitudeAt(ms, 0.5 + 0.1 * t), us(t));
    }
    if (k >= 1 && k <= 11 && k % 2 == 1) {
      const int i = (k - 1) / 2;  // 0..5 at 1.0, 1.2, .. 2.0 s
      const auto g = Position(ms, 43.5367 + 1e-5 * i, 6.5567);
      if (i == 3) {
        w.V1(g, us(t));
      } else {
        w.V2(g, us(t));
      }
    }
  }
  return w;
}

TEST(Tlog, ReadsTheAutopilotsPositionsAttitudeAndDate) {
  const TelemetryReadResult r = Parse(Flight().bytes());
  ASSERT_EQ(r.records, 6);
  EXPECT_EQ(r.no_fix_records, 0);
  EXPECT_EQ(r.skipped_records, 0);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  const auto& s = r.telemetry.samples();
  for (int i = 0; i < 6; ++i) {
    const double t = 1.0 + 0.2 * i;
    EXPECT_NEAR(s[i].time_s, t, 1e-9);  // time_boot_ms / 1000
    EXPECT_NEAR(s[i].lat_deg, 43.5367 + 1e-5 * i, 1e-9);
    EXPECT_NEAR(s[i].lon_deg, 6.5567, 1e-9);
    ASSERT_TRUE(s[i].abs_alt_m && s[i].rel_alt_m);
    EXPECT_NEAR(*s[i].abs_alt_m, 350.123, 1e-9);
    EXPECT_NEAR(*s[i].rel_alt_m, 100.0, 1e-9);
    ASSERT_TRUE(s[i].roll_deg && s[i].pitch_deg && s[i].yaw_deg);
    EXPECT_NEAR(*s[i].roll_deg, 0.1 * 180 / M_PI, 1e-4);
    EXPECT_NEAR(*s[i].pitch_deg, -0.05 * 180 / M_PI, 1e-4);
    // ATTITUDE, not hdg (90): yaw = 0.5 + 0.1 t rad.
    EXPECT_NEAR(*s[i].yaw_deg, (0.5 + 0.1 * t) * 180 / M_PI, 1e-4);
    // SYSTEM_TIME: Unix 1777803610 s at boot time 0.85 s.
    ASSERT_TRUE(s[i].unix_time_s);
    EXPECT_NEAR(*s[i].unix_time_s, 1777803610.0 + (t - 0.85), 1e-6);
    EXPECT_EQ(s[i].origin.rfind("f.tlog at byte ", 0), 0u) << s[i].origin;
  }
}

TEST(Tlog, DateFromTheRecordsWithoutSystemTime) {
  const TelemetryReadResult r = Parse(Flight(/*system_time=*/false).bytes());
  ASSERT_EQ(r.records, 6);
  // The ground station's clock when the packet arrived: boot time + 10.05 s after kStartUs.
  ASSERT_TRUE(r.telemetry.samples()[0].unix_time_s);
  EXPECT_NEAR(*r.telemetry.samples()[0].unix_time_s, kStartUs / 1e6 + 11.05, 1e-6);
}

TEST(Tlog, HeadingWhenNoAttitude) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(Position(1000, 43.5, 6.5), kStartUs + 1000);
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 1);
  ASSERT_TRUE(r.telemetry.samples()[0].yaw_deg);
  EXPECT_DOUBLE_EQ(*r.telemetry.samples()[0].yaw_deg, 90.0);
  EXPECT_FALSE(r.telemetry.samples()[0].roll_deg);
}

TEST(Tlog, WrongChecksumSkippedAndCounted) {
  TlogWriter w = Flight();
  // The third position's record: flip a latitude byte of its packet.
  const std::string& b = w.bytes();
  std::vector<std::size_t> positions;
  for (std::size_t i = 0; i + 18 < b.size(); ++i) {
    if (static_cast<unsigned char>(b[i]) == mav::kMagicV2 && b[i + 7] == 33 && b[i + 8] == 0 &&
        b[i + 9] == 0) {
      positions.push_back(i);
    }
  }
  ASSERT_GE(positions.size(), 3u);
  w.bytes()[positions[2] + 10 + 5] ^= 0x40;
  const TelemetryReadResult r = Parse(w.bytes());
  EXPECT_EQ(r.records, 5);
  EXPECT_EQ(r.skipped_records, 0);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_THAT(r.warnings[0],
              HasSubstr(fmt::format("f.tlog at byte {}: MAVLink packet of message 33 with a "
                                    "wrong checksum",
                                    positions[2])));
  for (const TelemetrySample& s : r.telemetry.samples()) EXPECT_NE(s.time_s, 1.4);
}

TEST(Tlog, GarbageBetweenRecordsIsSkipped) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(Position(1000, 43.5, 6.5), kStartUs + 1000);
  const std::size_t at = w.bytes().size();
  const std::string garbage = "garbage \xFD\xFE\x01 more garbage";
  w.Raw(garbage);
  w.V2(Position(1200, 43.6, 6.6), kStartUs + 201000);
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 2);
  EXPECT_NEAR(r.telemetry.samples()[1].lat_deg, 43.6, 1e-9);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_THAT(r.warnings[0],
              HasSubstr(fmt::format("f.tlog at byte {}: {} byte(s) skipped: not a tlog record", at,
                                    garbage.size())));
}

TEST(Tlog, UnknownMessagesAreSkippedByTheirLength) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  // A VFR_HUD-like packet of a message aerovo does not know (id 74), its payload holding magic
  // bytes.
  mav::PacketHeader h;
  h.sysid = 1;
  h.compid = 1;
  h.msgid = 74;
  const std::vector<std::uint8_t> payload(20, mav::kMagicV2);
  w.Record(kStartUs + 10, mav::EncodePacket(h, 20, payload.data(), payload.size()));
  w.V2(Position(1000, 43.5, 6.5), kStartUs + 1000);
  const TelemetryReadResult r = Parse(w.bytes());
  EXPECT_EQ(r.records, 1);
  EXPECT_TRUE(r.warnings.empty());
}

TEST(Tlog, CutLastRecord) {
  TlogWriter w = Flight();
  const std::size_t size = w.bytes().size();
  w.bytes().resize(size - 20);  // into the last ATTITUDE
  const TelemetryReadResult r = Parse(w.bytes());
  EXPECT_EQ(r.records, 6);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_THAT(r.warnings.back(), HasSubstr("the last record is cut short"));
  // Cut inside a timestamp.
  TlogWriter v = Flight();
  v.Raw(std::string("\x00\x06\x4f", 3));
  const TelemetryReadResult q = Parse(v.bytes());
  EXPECT_EQ(q.records, 6);
  ASSERT_FALSE(q.warnings.empty());
  EXPECT_THAT(q.warnings.back(), HasSubstr("3 byte(s) skipped"));
}

TEST(Tlog, GroundStationOnlyIsAnError) {
  TlogWriter w;
  for (int k = 0; k < 3; ++k) w.V2(GcsHeartbeat(), kStartUs + k * 1000000, kGcsSysid, kGcsCompid);
  // A position from another component of a system whose autopilot never sent a HEARTBEAT.
  w.V2(Position(1000, 43.5, 6.5), kStartUs + 10, 1, 154);
  ExpectInputError([&] { Parse(w.bytes()); },
                   {"f.tlog: no HEARTBEAT of an autopilot", "3 HEARTBEATs", "ground station"});
}

TEST(Tlog, OnlyTheFirstAutopilotIsRead) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs, 7);
  w.V2(AutopilotHeartbeat(), kStartUs + 10, 8);
  w.V2(Position(1000, 43.5, 6.5), kStartUs + 20, 8);
  w.V2(Position(1000, 44.5, 7.5), kStartUs + 30, 7);
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 1);
  EXPECT_NEAR(r.telemetry.samples()[0].lat_deg, 44.5, 1e-9);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("1 GLOBAL_POSITION_INT messages of system 8 ignored"));
}

TEST(Tlog, NoFix) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(Position(1000, 0.0, 0.0), kStartUs + 1);   // before any position: 0, 0
  w.V2(Fix(1), kStartUs + 2);                     // GPS_FIX_TYPE_NO_FIX
  w.V2(Position(1200, 43.5, 6.5), kStartUs + 3);  // dead reckoning
  ExpectInputError([&] { Parse(w.bytes()); },
                   {"no GLOBAL_POSITION_INT with a GPS fix", "2 without one"});
  w.V2(Fix(3), kStartUs + 4);
  w.V2(Position(1400, 43.6, 6.6), kStartUs + 5);
  const TelemetryReadResult r = Parse(w.bytes());
  EXPECT_EQ(r.records, 1);
  EXPECT_EQ(r.no_fix_records, 2);
}

TEST(Tlog, NoPositionStream) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(AttitudeAt(1000, 0.1), kStartUs + 1);
  ExpectInputError([&] { Parse(w.bytes()); },
                   {"no GLOBAL_POSITION_INT from the autopilot (system 1, component 1)"});
}

TEST(Tlog, RebootGoesOnFromTheGroundStationsClock) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(Position(60000, 43.5, 6.5), kStartUs + 1000000);
  // 20 s later (ground station clock) the autopilot has rebooted: boot time 3 s.
  const std::size_t at = w.V2(Position(3000, 43.6, 6.6), kStartUs + 21000000);
  w.V2(Position(3200, 43.7, 6.7), kStartUs + 21200000);
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 3);
  EXPECT_NEAR(r.telemetry.samples()[0].time_s, 60.0, 1e-9);
  EXPECT_NEAR(r.telemetry.samples()[1].time_s, 80.0, 1e-9);
  EXPECT_NEAR(r.telemetry.samples()[2].time_s, 80.2, 1e-9);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0],
              HasSubstr(fmt::format("f.tlog at byte {}: the autopilot (system 1) rebooted", at)));
}

// A link that delivers packets late (a radio's buffer, a router merging two links) is not an
// autopilot reboot: by the records' clock the late packet arrived seconds, not an uptime, after
// its time. Such packets are put in the autopilot's time order; one received twice is read once.
TEST(Tlog, PacketsTheLinkDeliveredLateAreReadInTheAutopilotsTimeOrder) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  // Time since boot 100.0-100.4 s received at 1.0-1.4 s of the ground station's clock.
  w.V2(Position(100000, 43.0, 6.0), kStartUs + 1000000);
  w.V2(Position(100200, 43.2, 6.0), kStartUs + 1200000);
  w.V2(Position(100400, 43.4, 6.0), kStartUs + 1400000);
  // 3.4 s of the autopilot's time late (more than a reboot's drop alone), received 3.6 s late.
  w.V2(Position(97000, 42.9, 6.0), kStartUs + 1600000);
  w.V2(Position(100200, 43.2, 6.0), kStartUs + 1700000);  // 100.2 s again
  w.V2(Position(100600, 43.6, 6.0), kStartUs + 1800000);
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 5);
  const double times[] = {97.0, 100.0, 100.2, 100.4, 100.6};
  const double lats[] = {42.9, 43.0, 43.2, 43.4, 43.6};
  for (int k = 0; k < 5; ++k) {
    EXPECT_NEAR(r.telemetry.samples()[k].time_s, times[k], 1e-9) << k;
    EXPECT_NEAR(r.telemetry.samples()[k].lat_deg, lats[k], 1e-9) << k;
  }
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0],
              HasSubstr("f.tlog: 2 GLOBAL_POSITION_INT message(s) of the autopilot (system 1) "
                        "arrived after later ones (by up to 3.400 s of its time since boot"));
}

// A reboot after a short uptime: 10 s since boot, then 3 s since boot 18 s later by the records'
// clock (later than any link delays a packet, relative to that uptime).
TEST(Tlog, ARebootAfterAShortUptimeIsARebootNotALatePacket) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(Position(10000, 43.5, 6.5), kStartUs + 12000000);
  const std::size_t at = w.V2(Position(3000, 43.6, 6.6), kStartUs + 30000000);
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 2);
  EXPECT_NEAR(r.telemetry.samples()[0].time_s, 10.0, 1e-9);
  EXPECT_NEAR(r.telemetry.samples()[1].time_s, 28.0, 1e-9);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0],
              HasSubstr(fmt::format("f.tlog at byte {}: the autopilot (system 1) rebooted", at)));
}

TEST(Tlog, MalformedPositionStrictAndLenient) {
  TlogWriter w;
  w.V2(AutopilotHeartbeat(), kStartUs);
  w.V2(Position(1000, 43.5, 6.5), kStartUs + 1);
  mav::GlobalPositionInt bad = Position(1200, 43.5, 6.5);
  bad.lat = 950000000;  // 95 degrees
  const std::size_t at = w.V2(bad, kStartUs + 2);
  w.V2(Position(1400, 43.5, 6.5), kStartUs + 3);
  try {
    Parse(w.bytes());
    ADD_FAILURE() << "no MalformedRecordError";
  } catch (const MalformedRecordError& e) {
    EXPECT_THAT(e.what(), HasSubstr(fmt::format("f.tlog at byte {}: latitude", at)));
  }
  const TelemetryReadResult r = Parse(w.bytes(), /*lenient=*/true);
  EXPECT_EQ(r.records, 2);
  EXPECT_EQ(r.skipped_records, 1);
}

// The record time of a packet the autopilot sent at boot time `boot_s` in Flight().
std::uint64_t FlightUs(double boot_s) {
  return kStartUs + static_cast<std::uint64_t>(std::llround((boot_s + 10.05) * 1e6));
}
// SYSTEM_TIME of Flight(): Unix 1777803610 s at boot time 0.85 s.
constexpr double kUnixAtBoot0 = 1777803610.0 - 0.85;

mav::CameraFeedback Feedback(int img, double lat, double lon, double unix_s) {
  mav::CameraFeedback f;
  f.time_usec = static_cast<std::uint64_t>(std::llround(unix_s * 1e6));
  f.lat = static_cast<std::int32_t>(std::lround(lat * 1e7));
  f.lng = static_cast<std::int32_t>(std::lround(lon * 1e7));
  f.alt_msl = 352.5f;
  f.alt_rel = 102.25f;
  f.roll = 5.5f;
  f.pitch = -3.25f;
  f.yaw = 271.0f;
  f.img_idx = static_cast<std::uint16_t>(img);
  f.target_system = 1;
  return f;  // cam_idx 0, flags 0, completed_captures 0: truncated on the wire
}

// The quaternion (w, x, y, z) of the 3-2-1 rotation yaw, pitch, roll (degrees).
std::array<float, 4> QuaternionOf(double yaw_deg, double pitch_deg, double roll_deg) {
  const double d = M_PI / 360.0;  // half angle, radians per degree
  const double cy = std::cos(yaw_deg * d), sy = std::sin(yaw_deg * d);
  const double cp = std::cos(pitch_deg * d), sp = std::sin(pitch_deg * d);
  const double cr = std::cos(roll_deg * d), sr = std::sin(roll_deg * d);
  return {static_cast<float>(cr * cp * cy + sr * sp * sy),
          static_cast<float>(sr * cp * cy - cr * sp * sy),
          static_cast<float>(cr * sp * cy + sr * cp * sy),
          static_cast<float>(cr * cp * sy - sr * sp * cy)};
}

mav::CameraImageCaptured Captured(int index, std::uint32_t ms, double lat, double lon,
                                  std::int8_t result) {
  mav::CameraImageCaptured c;
  c.time_boot_ms = ms;
  c.lat = static_cast<std::int32_t>(std::lround(lat * 1e7));
  c.lon = static_cast<std::int32_t>(std::lround(lon * 1e7));
  c.alt = 352500;          // 352.5 m MSL
  c.relative_alt = 98000;  // 98 m above the ground: not read
  c.image_index = index;
  c.camera_id = 1;
  c.capture_result = result;
  return c;
}

// Flips a byte of the payload of the record at `at` (its checksum no longer matches).
void Damage(TlogWriter& w, std::size_t at) { w.bytes()[at + 8 + 10 + 9] ^= 0x40; }

TEST(Tlog, ReadsCameraFeedbackOnTheSamplesClock) {
  TlogWriter w = Flight();
  // img 1, taken at boot time 1.3 s (by its UTC time), received at 1.5 s.
  const std::size_t at1 = w.V2(Feedback(1, 43.53672, 6.55671, kUnixAtBoot0 + 1.3), FlightUs(1.5));
  // The same report again (two links): read once.
  w.V2(Feedback(1, 43.53672, 6.55671, kUnixAtBoot0 + 1.3), FlightUs(1.5));
  // A second camera, another system, the ground station: not read.
  mav::CameraFeedback other = Feedback(9, 43.6, 6.6, kUnixAtBoot0 + 1.4);
  other.cam_idx = 1;
  w.V2(other, FlightUs(1.55));
  w.V2(Feedback(8, 43.6, 6.6, kUnixAtBoot0 + 1.4), FlightUs(1.55), 2, 1);
  w.V2(Feedback(7, 43.6, 6.6, kUnixAtBoot0 + 1.4), FlightUs(1.55), kGcsSysid, kGcsCompid);
  // A damaged packet: not read.
  Damage(w, w.V2(Feedback(6, 43.6, 6.6, kUnixAtBoot0 + 1.5), FlightUs(1.6)));
  // img 2 at 1.7 s with no position (ArduPilot's zeros), focal length 8.8 mm.
  mav::CameraFeedback none = Feedback(2, 0.0, 0.0, kUnixAtBoot0 + 1.7);
  none.foc_len = 8.8f;
  const std::size_t at2 = w.V2(none, FlightUs(1.9));
  // CAMERA_IMAGE_CAPTURED is not read when there is CAMERA_FEEDBACK.
  w.V2(Captured(0, 1800, 43.5, 6.5, 1), FlightUs(1.8));
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 6);
  const std::vector<TelemetrySample>& c = r.camera_triggers;
  ASSERT_EQ(c.size(), 2u);
  // time_usec through SYSTEM_TIME's relation: the clock of the samples (time_boot_ms / 1000).
  EXPECT_NEAR(c[0].time_s, 1.3, 1e-6);
  EXPECT_NEAR(c[1].time_s, 1.7, 1e-6);
  EXPECT_EQ(c[0].origin, fmt::format("f.tlog at byte {}: CAMERA_FEEDBACK 1", at1));
  EXPECT_EQ(c[1].origin, fmt::format("f.tlog at byte {}: CAMERA_FEEDBACK 2", at2));
  EXPECT_TRUE(c[0].has_fix);
  EXPECT_NEAR(c[0].lat_deg, 43.53672, 1e-9);
  EXPECT_NEAR(c[0].lon_deg, 6.55671, 1e-9);
  ASSERT_TRUE(c[0].abs_alt_m && c[0].rel_alt_m);
  EXPECT_NEAR(*c[0].abs_alt_m, 352.5, 1e-6);
  EXPECT_NEAR(*c[0].rel_alt_m, 102.25, 1e-6);
  ASSERT_TRUE(c[0].roll_deg && c[0].pitch_deg && c[0].yaw_deg);
  EXPECT_NEAR(*c[0].roll_deg, 5.5, 1e-6);
  EXPECT_NEAR(*c[0].pitch_deg, -3.25, 1e-6);
  EXPECT_NEAR(*c[0].yaw_deg, 271.0, 1e-6);
  EXPECT_FALSE(c[0].focal_length_mm);  // foc_len 0: unknown
  ASSERT_TRUE(c[0].unix_time_s);
  EXPECT_NEAR(*c[0].unix_time_s, kUnixAtBoot0 + 1.3, 1e-6);
  EXPECT_FALSE(c[1].has_fix);
  EXPECT_FALSE(c[1].abs_alt_m);
  EXPECT_FALSE(c[1].rel_alt_m);
  ASSERT_TRUE(c[1].yaw_deg && c[1].focal_length_mm);
  EXPECT_NEAR(*c[1].yaw_deg, 271.0, 1e-6);
  EXPECT_NEAR(*c[1].focal_length_mm, 8.8, 1e-6);
  // The damaged packet and the second camera are said.
  EXPECT_THAT(::testing::PrintToString(r.warnings), HasSubstr("message 180 with a wrong checksum"));
  EXPECT_THAT(::testing::PrintToString(r.warnings),
              HasSubstr("1 CAMERA_FEEDBACK message(s) of camera 1 ignored"));
}

TEST(Tlog, CameraFeedbackWithoutSystemTimeIsPlacedByItsRecord) {
  TlogWriter w = Flight(/*system_time=*/false);
  // Received at boot time 1.45 s + the link's 50 ms: the ground station's clock maps it back to
  // 1.45 s whatever its time_usec says.
  w.V2(Feedback(1, 43.53672, 6.55671, 1777803000.0), FlightUs(1.45));
  w.V2(Feedback(2, 43.53673, 6.55671, 0.0), FlightUs(1.85));  // no UTC time
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.camera_triggers.size(), 2u);
  EXPECT_NEAR(r.camera_triggers[0].time_s, 1.45, 1e-6);
  EXPECT_NEAR(r.camera_triggers[1].time_s, 1.85, 1e-6);
  ASSERT_TRUE(r.camera_triggers[0].unix_time_s && r.camera_triggers[1].unix_time_s);
  EXPECT_NEAR(*r.camera_triggers[0].unix_time_s, 1777803000.0, 1e-6);          // its own
  EXPECT_NEAR(*r.camera_triggers[1].unix_time_s, FlightUs(1.85) / 1e6, 1e-6);  // the record's
}

TEST(Tlog, ReadsCameraImageCapturedWhenThereIsNoCameraFeedback) {
  TlogWriter w = Flight();
  mav::CameraImageCaptured first = Captured(0, 1250, 43.53672, 6.55671, 1);
  first.q = QuaternionOf(-120, 25, 40);
  first.time_utc = 1777803700ull * 1000000ull;
  const std::size_t at0 = w.V2(first, FlightUs(1.3));
  w.V2(first, FlightUs(1.31));                           // the same again: read once
  w.V2(Captured(1, 1450, 43.6, 6.6, 0), FlightUs(1.5));  // failed
  mav::CameraImageCaptured second_camera = Captured(0, 1500, 43.6, 6.6, 1);
  second_camera.camera_id = 2;
  w.V2(second_camera, FlightUs(1.55));
  w.V2(Captured(5, 1500, 43.6, 6.6, 1), FlightUs(1.55), 1, 100);  // a camera component
  Damage(w, w.V2(Captured(6, 1550, 43.6, 6.6, 1), FlightUs(1.6)));
  // No feedback from the camera (-1), no position, no attitude, no UTC time.
  const std::size_t at2 = w.V2(Captured(2, 1650, 0.0, 0.0, -1), FlightUs(1.7));
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 6);
  const std::vector<TelemetrySample>& c = r.camera_triggers;
  ASSERT_EQ(c.size(), 2u);
  EXPECT_NEAR(c[0].time_s, 1.25, 1e-9);  // time_boot_ms / 1000, as the samples'
  EXPECT_NEAR(c[1].time_s, 1.65, 1e-9);
  EXPECT_EQ(c[0].origin, fmt::format("f.tlog at byte {}: CAMERA_IMAGE_CAPTURED 0", at0));
  EXPECT_EQ(c[1].origin, fmt::format("f.tlog at byte {}: CAMERA_IMAGE_CAPTURED 2", at2));
  EXPECT_TRUE(c[0].has_fix);
  EXPECT_NEAR(c[0].lat_deg, 43.53672, 1e-9);
  EXPECT_NEAR(c[0].lon_deg, 6.55671, 1e-9);
  ASSERT_TRUE(c[0].abs_alt_m);
  EXPECT_NEAR(*c[0].abs_alt_m, 352.5, 1e-9);
  EXPECT_FALSE(c[0].rel_alt_m);  // relative_alt is above the ground
  // q is the camera's orientation (the gimbal's on one): not read as the aircraft's attitude.
  EXPECT_FALSE(c[0].yaw_deg || c[0].pitch_deg || c[0].roll_deg);
  ASSERT_TRUE(c[0].unix_time_s);
  EXPECT_NEAR(*c[0].unix_time_s, 1777803700.0, 1e-6);
  EXPECT_FALSE(c[1].has_fix);
  EXPECT_FALSE(c[1].abs_alt_m);
  ASSERT_TRUE(c[1].unix_time_s);  // time_utc 0: by SYSTEM_TIME's relation
  EXPECT_NEAR(*c[1].unix_time_s, kUnixAtBoot0 + 1.65, 1e-6);
  EXPECT_THAT(::testing::PrintToString(r.warnings),
              HasSubstr("1 CAMERA_IMAGE_CAPTURED message(s) of camera 2 ignored"));
}

TEST(Tlog, CameraTriggerWithABadValueStrictOrLenient) {
  for (const bool captured : {false, true}) {
    SCOPED_TRACE(captured ? "CAMERA_IMAGE_CAPTURED latitude 95" : "CAMERA_FEEDBACK latitude 95");
    TlogWriter w = Flight();
    std::size_t at;
    if (captured) {
      w.V2(Captured(0, 1250, 43.5, 6.5, 1), FlightUs(1.3));
      at = w.V2(Captured(1, 1450, 95.0, 6.5, 1), FlightUs(1.5));
    } else {
      w.V2(Feedback(0, 43.5, 6.5, kUnixAtBoot0 + 1.25), FlightUs(1.3));
      at = w.V2(Feedback(1, 95.0, 6.5, kUnixAtBoot0 + 1.45), FlightUs(1.5));
    }
    const std::string where = fmt::format("f.tlog at byte {}: {} 1", at,
                                          captured ? "CAMERA_IMAGE_CAPTURED" : "CAMERA_FEEDBACK");
    try {
      Parse(w.bytes());
      ADD_FAILURE() << "no MalformedRecordError";
    } catch (const MalformedRecordError& e) {
      EXPECT_THAT(e.what(), HasSubstr(where));
      EXPECT_THAT(e.what(), HasSubstr("latitude 95"));
    }
    const TelemetryReadResult r = Parse(w.bytes(), /*lenient=*/true);
    EXPECT_EQ(r.records, 6);
    EXPECT_EQ(r.skipped_records, 1);
    ASSERT_EQ(r.camera_triggers.size(), 1u);
    EXPECT_NEAR(r.camera_triggers[0].time_s, 1.25, 1e-6);
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_THAT(r.warnings[0], HasSubstr(where));
  }
}

TEST(Tlog, ALogWithoutCameraMessagesHasNoCameraTriggers) {
  const TelemetryReadResult r = Parse(Flight().bytes());
  EXPECT_EQ(r.records, 6);
  EXPECT_TRUE(r.camera_triggers.empty());
}

TEST(Tlog, NotATlog) {
  ExpectInputError([] { Parse("\xFF\xD8\xFF\xE0\x00\x10JFIF\x00\x01\x01"); },
                   {"f.tlog: not a MAVLink telemetry log", "FF D8 FF E0", "(a JPEG image)"});
  ExpectInputError([] { Parse(std::string("\xA3\x95\x80\x80\x59\x46\x4D\x54\x00\x00", 10)); },
                   {"not a MAVLink telemetry log", "DataFlash"});
  ExpectInputError([] { Parse("time,lat,lon\n0,1,2\n"); }, {"not a MAVLink telemetry log"});
  ExpectInputError([] { Parse(""); }, {"f.tlog: an empty file"});
  // MAVLink packets without the records' timestamps (a capture of the link, not a ground
  // station's log): three HEARTBEATs back to back.
  std::string packets;
  for (std::uint8_t seq = 0; seq < 3; ++seq) {
    const auto b = mav::Encode(AutopilotHeartbeat(), seq, 1, 1);
    packets.append(b.begin(), b.end());
  }
  ExpectInputError([&] { Parse(packets); },
                   {"not a MAVLink telemetry log", "FD ", "MAVLink packets without timestamps"});
}

TEST(Tlog, HostileFilesEndQuickly) {
  for (const char fill : {'\xFD', '\xFE', '\x00'}) {
    // A plausible first record, then 4 MB of one byte.
    TlogWriter w;
    w.V2(AutopilotHeartbeat(), kStartUs);
    w.Raw(std::string(std::size_t{4} << 20, fill));
    const auto start = std::chrono::steady_clock::now();
    ExpectInputError([&] { Parse(w.bytes()); },
                     {"f.tlog: no GLOBAL_POSITION_INT from the autopilot",
                      "4194304 of its 4194333 bytes are no tlog record"});
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(s, 20.0) << "fill " << int(static_cast<unsigned char>(fill));
  }
  // Random bytes after a valid flight: the flight is read, the rest skipped with a warning.
  TlogWriter w = Flight();
  std::uint32_t x = 12345;
  std::string noise(std::size_t{1} << 20, '\0');
  for (char& c : noise) {
    x = x * 1664525u + 1013904223u;
    c = static_cast<char>(x >> 24);
  }
  w.Raw(noise);
  const TelemetryReadResult r = Parse(w.bytes());
  EXPECT_EQ(r.records, 6);
  ASSERT_FALSE(r.warnings.empty());
}

TEST(Tlog, ReadTelemetryFilePicksTheReaderByExtension) {
  io_test::TempDir dir("aerovo_tlog");
  const auto path = dir / "2026-05-03 10-20-00.tlog";
  {
    std::ofstream f(path, std::ios::binary);
    f << Flight().bytes();
  }
  const TelemetryReadResult r = ReadTelemetryFile(path);
  EXPECT_EQ(r.records, 6);
  EXPECT_THAT(r.telemetry.samples()[0].origin, HasSubstr("2026-05-03 10-20-00.tlog at byte"));
}

}  // namespace tlog_test
}  // namespace
}  // namespace aerovo
