// MAVLink telemetry logs (tlog_reader.cc): logs written here byte for byte as a ground station
// records them (an 8-byte big-endian timestamp, then the packet), the packets framed and
// checksummed by aerovo's own MAVLink code (mavlink/messages.h, mavlink/protocol.h).
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
