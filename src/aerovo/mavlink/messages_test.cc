// The bytes aerovo sends, against bytes computed independently of its encoder: golden packets
// serialised by node-mavlink 2.3.0 (an independent implementation generated from the official
// XML definitions) by tests/mavlink/golden.cjs with the field values set below, pasted as hex;
// and a HEARTBEAT laid out byte by byte here with a bitwise CRC written in this test. Covers
// CRC_EXTRA, the order of fields by size, extension fields and the truncation of trailing zeros.
#include "aerovo/mavlink/messages.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "aerovo/mavlink/protocol.h"
#include "aerovo/mavlink/testing.h"

namespace aerovo::mavlink::messages_test {
namespace {

using testing::Bytes;
using testing::Hex;
using testing::ParseOne;

// Golden packets (node-mavlink; regenerate: the top of tests/mavlink/golden.cjs).
namespace golden {
constexpr const char* kHeartbeat =
      "fd090000072ac50000000000000012080004038892";
constexpr const char* kOdometry =
      "fde90000c801c54b0100cb04fb711f0100000000c03f000010c00000003e0000803f00000000000000000000"
      "003f00004040000080c00000003f0000c07f0000c07f0000803e0000003f0000403f0000803f0000a03f0000"
      "c03f0000e03f00000040000010400000204000003040000040400000c07f0000604000007040000080400000"
      "884000009040000098400000a0400000a8400000b040000080bf000060bf000040bf000020bf000000bf0000"
      "c0be000080be000000be000000000000003e0000803e0000c03e0000003f0000203f0000403f0000603f0000"
      "803f0000903f0000a03f0000b03f0000c03f140c0302ff5b86";
constexpr const char* kOdometryTruncated =
      "fd0c00000001c54b010005000000000000000000803f4ee4";
constexpr const char* kVisionPositionEstimate =
      "fd7500000101c5660000b168de3a00000000000080bf00000040000000bf0000803d000000be000040400000"
      "803f0000004000004040000080400000a0400000c0400000e040000000410000104100002041000030410000"
      "4041000050410000604100007041000080410000884100009041000098410000a0410000a841095740";
constexpr const char* kVisionPositionDelta =
      "fd2c00000201c5032b0040420f000000000035820000000000000000000000000000000000bd0000403f0000"
      "00bf000000000000ae42c721";
constexpr const char* kTimesync =
      "fd1200000301c56f000079df0d8648700000d6ffffffffffffffffbe0a5e";
constexpr const char* kDistanceSensor =
      "fd0e000009010184000060ea00001400a00fbb1f000119ff7458";
constexpr const char* kGlobalPositionInt =
      "fd1c00000a010121000048ee00004c52401c44f41705407207007a39010088ff2300000078697926";
constexpr const char* kGpsInput =
      "fd4100000c01c5e8000040a2930215450600cbb69914c25ff51907f43e04008036430000803f000000000000"
      "98400000a0bf000000000000003e0000c03f0000000094005b0900030aa08c37de";
constexpr const char* kGpsInputNoFix =
      "fd3e00000d01c5e80000050000000000000000000000404e08ec002eb69400000000e1fac742e1fac7420000"
      "00000000000000000000000000000000000000000000ff0000000001e6da";
constexpr const char* kAttitude =
      "fd1000000b01011e000030f200000000803d000000bd0000c03f08f0";

}  // namespace golden

// CRC-16/MCRF4XX bit by bit (reflected polynomial 0x8408, init 0xFFFF), independent of the
// table-free byte-wise formula of protocol.cc.
uint16_t BitwiseCrc(const std::vector<uint8_t>& data) {
  uint16_t crc = 0xFFFF;
  for (uint8_t b : data) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) crc = (crc & 1) ? static_cast<uint16_t>((crc >> 1) ^ 0x8408) : crc >> 1;
  }
  return crc;
}

TEST(MavlinkCrc, CheckValueAndBitwiseAgree) {
  const std::vector<uint8_t> check = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(Crc16Mcrf4xx(check.data(), check.size()), 0x6F91);  // the catalogued check value
  EXPECT_EQ(BitwiseCrc(check), 0x6F91);
}

TEST(MavlinkEncode, HeartbeatLaidOutByHand) {
  // HEARTBEAT: custom_mode (uint32) first, then the uint8 fields in XML order.
  std::vector<uint8_t> b = {0xFD, 9, 0, 0, /*seq*/ 7, /*sysid*/ 42, /*compid*/ 197, 0, 0, 0,
                            /*custom_mode*/ 0, 0, 0, 0, /*type*/ 18, /*autopilot*/ 8,
                            /*base_mode*/ 0, /*system_status*/ 4, /*mavlink_version*/ 3};
  std::vector<uint8_t> crc_input(b.begin() + 1, b.end());
  crc_input.push_back(50);  // CRC_EXTRA of HEARTBEAT
  const uint16_t crc = BitwiseCrc(crc_input);
  b.push_back(crc & 0xFF);
  b.push_back(crc >> 8);
  EXPECT_EQ(Hex(Encode(Heartbeat{}, 7, 42, 197)), Hex(b));
  EXPECT_EQ(Hex(b), golden::kHeartbeat);
}

Odometry GoldenOdometry() {
  Odometry o;
  o.time_usec = 1234567890123ULL;
  o.frame_id = 20;
  o.child_frame_id = 12;
  o.x = 1.5f;
  o.y = -2.25f;
  o.z = 0.125f;
  o.q = {1, 0, 0, 0.5f};
  o.vx = 3;
  o.vy = -4;
  o.vz = 0.5f;
  o.rollspeed = kNaN;
  o.pitchspeed = kNaN;
  o.yawspeed = 0.25f;
  for (int i = 0; i < 21; ++i) {
    o.pose_covariance[i] = 0.5f + 0.25f * i;
    o.velocity_covariance[i] = -1.f + 0.125f * i;
  }
  o.pose_covariance[11] = kNaN;
  o.reset_counter = 3;
  o.estimator_type = 2;
  o.quality = -1;
  return o;
}

TEST(MavlinkEncode, OdometryWithExtensions) {
  // 233 bytes: the 230 of MAVLink 1 (uint64, 41 + 42 floats, two uint8 frame ids last) and the
  // three extensions in XML order; CRC_EXTRA 91.
  const std::vector<uint8_t> got = Encode(GoldenOdometry(), 200, 1, 197);
  EXPECT_EQ(got.size(), 10u + 233u + 2u);
  EXPECT_EQ(Hex(got), golden::kOdometry);
}

TEST(MavlinkEncode, OdometryTruncatedBelowTheVersion1Length) {
  Odometry o;
  o.time_usec = 5;
  o.frame_id = 0;
  o.child_frame_id = 0;
  o.x = 1;
  o.q = {0, 0, 0, 0};
  o.reset_counter = 0;
  o.estimator_type = 0;
  o.quality = 0;
  const std::vector<uint8_t> got = Encode(o, 0, 1, 197);
  EXPECT_EQ(got[1], 12);  // time_usec and x: every later byte is zero
  EXPECT_EQ(Hex(got), golden::kOdometryTruncated);
  // And back: the absent bytes read as zeros.
  const Packet p = ParseOne(got);
  const auto d = Decode<Odometry>(p);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time_usec, 5u);
  EXPECT_EQ(d->x, 1.f);
  EXPECT_EQ(d->quality, 0);
  EXPECT_EQ(d->frame_id, 0);
}

TEST(MavlinkEncode, VisionPositionEstimate) {
  VisionPositionEstimate v;
  v.usec = 987654321ULL;
  v.x = -1;
  v.y = 2;
  v.z = -0.5f;
  v.roll = 0.0625f;
  v.pitch = -0.125f;
  v.yaw = 3;
  for (int i = 0; i < 21; ++i) v.covariance[i] = 1.f + i;
  v.reset_counter = 9;
  EXPECT_EQ(Hex(Encode(v, 1, 1, 197)), golden::kVisionPositionEstimate);
}

TEST(MavlinkEncode, VisionPositionDelta) {
  VisionPositionDelta v;
  v.time_usec = 1000000;
  v.time_delta_usec = 33333;
  v.angle_delta = {0, 0, -0.03125f};
  v.position_delta = {0.75f, -0.5f, 0};
  v.confidence = 87;
  EXPECT_EQ(Hex(Encode(v, 2, 1, 197)), golden::kVisionPositionDelta);
}

TEST(MavlinkEncode, TimesyncAnswer) {
  Timesync t;
  t.tc1 = 123456789012345LL;
  t.ts1 = -42;
  t.target_system = 255;
  t.target_component = 190;
  EXPECT_EQ(Hex(Encode(t, 3, 1, 197)), golden::kTimesync);
}

TEST(MavlinkEncode, GpsInputWithYaw) {
  GpsInput g;
  g.time_usec = 1764806400123456ull;
  g.ignore_flags = kGpsInputIgnoreVdop | kGpsInputIgnoreVelVert | kGpsInputIgnoreVerticalAccuracy;
  g.time_week_ms = 345618123;
  g.time_week = 2395;
  g.fix_type = kGpsFixType3d;
  g.lat = 435511234;
  g.lon = 71234567;
  g.alt = 182.5f;
  g.hdop = 1.0f;
  g.vn = 4.75f;
  g.ve = -1.25f;
  g.speed_accuracy = 0.125f;
  g.horiz_accuracy = 1.5f;
  g.satellites_visible = 10;
  g.yaw = 36000;
  EXPECT_EQ(Hex(Encode(g, 12, 1, 197)), golden::kGpsInput);
  const auto back = Decode<GpsInput>(ParseOne(Bytes(golden::kGpsInput)));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->lat, 435511234);
  EXPECT_EQ(back->time_week, 2395);
  EXPECT_EQ(back->yaw, 36000);
  EXPECT_EQ(back->satellites_visible, 10);
}

TEST(MavlinkEncode, GpsInputNoFixTruncated) {
  // yaw 0 (unknown) and satellites_visible 0 at the end: both cut from the payload (62 bytes).
  GpsInput g;
  g.time_usec = 5;
  g.ignore_flags = 255;
  g.fix_type = kGpsFixTypeNoFix;
  g.lat = -335000000;
  g.lon = -1800000000;
  g.hdop = g.vdop = 99.99f;
  const auto bytes = Encode(g, 13, 1, 197);
  EXPECT_EQ(Hex(bytes), golden::kGpsInputNoFix);
  EXPECT_EQ(bytes[1], 62);
  const auto back = Decode<GpsInput>(ParseOne(bytes));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->fix_type, kGpsFixTypeNoFix);
  EXPECT_EQ(back->lon, -1800000000);
  EXPECT_EQ(back->yaw, 0);
}

TEST(MavlinkDecode, WhatTheAutopilotSends) {
  const auto d = Decode<DistanceSensor>(ParseOne(Bytes(golden::kDistanceSensor)));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->time_boot_ms, 60000u);
  EXPECT_EQ(d->min_distance, 20);
  EXPECT_EQ(d->max_distance, 4000);
  EXPECT_EQ(d->current_distance, 8123);
  EXPECT_EQ(d->id, 1);
  EXPECT_EQ(d->orientation, kMavSensorRotationPitch270);
  EXPECT_EQ(d->covariance, 255);
  const auto g = Decode<GlobalPositionInt>(ParseOne(Bytes(golden::kGlobalPositionInt)));
  ASSERT_TRUE(g);
  EXPECT_EQ(g->lat, 473977420);
  EXPECT_EQ(g->lon, 85455940);
  EXPECT_EQ(g->alt, 488000);
  EXPECT_EQ(g->relative_alt, 80250);
  EXPECT_EQ(g->vx, -120);
  EXPECT_EQ(g->vy, 35);
  EXPECT_EQ(g->hdg, 27000);
  const auto a = Decode<Attitude>(ParseOne(Bytes(golden::kAttitude)));
  ASSERT_TRUE(a);
  EXPECT_EQ(a->time_boot_ms, 62000u);
  EXPECT_EQ(a->roll, 0.0625f);
  EXPECT_EQ(a->pitch, -0.03125f);
  EXPECT_EQ(a->yaw, 1.5f);
  EXPECT_FALSE(Decode<Odometry>(ParseOne(Bytes(golden::kAttitude))));  // another id
  const auto o = Decode<Odometry>(ParseOne(Bytes(golden::kOdometry)));
  ASSERT_TRUE(o);
  EXPECT_EQ(o->reset_counter, 3);
  EXPECT_EQ(o->quality, -1);
  EXPECT_TRUE(std::isnan(o->pose_covariance[11]));
  EXPECT_EQ(o->pose_covariance[20], 5.5f);
}

// --- Parser

TEST(MavlinkParser, GarbageAroundAndBetweenPackets) {
  std::vector<uint8_t> s = {0x00, 0xFD, 0x55, 0xFE, 0x12};  // noise, with a false magic
  const auto hb = Bytes(golden::kHeartbeat), at = Bytes(golden::kAttitude);
  s.insert(s.end(), hb.begin(), hb.end());
  s.insert(s.end(), {0xAA, 0xBB, 0xFD});
  s.insert(s.end(), at.begin(), at.end());
  s.insert(s.end(), {0x01, 0x02});
  // A false magic claims the bytes its length says (0x55 for the first; the attitude's own magic
  // 0xFD for the one before it: 267 bytes): the packets behind come out once that many have
  // arrived (a stream goes on; here, zeros).
  s.resize(s.size() + 300, 0x00);
  Parser p;
  std::vector<uint32_t> ids;
  p.Feed(s.data(), s.size(), [&](const Packet& k) { ids.push_back(k.header.msgid); });
  EXPECT_EQ(ids, (std::vector<uint32_t>{Heartbeat::kId, Attitude::kId}));
  EXPECT_EQ(p.stats().packets, 2u);
}

// A MAVLink 1 packet of `msgid` (mavlink.io/en/guide/serialization.html, "MAVLink 1 Packet
// Format"): 0xFE | len | seq | sysid | compid | msgid | payload | CRC-16/MCRF4XX of len..payload
// then CRC_EXTRA, little-endian (the CRC of MavlinkCrc.CheckValueAndBitwiseAgree).
std::vector<uint8_t> V1Packet(uint8_t msgid, uint8_t crc_extra,
                              const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> p = {0xFE, static_cast<uint8_t>(payload.size()), 7, 1, 1, msgid};
  p.insert(p.end(), payload.begin(), payload.end());
  uint16_t crc = Crc16Mcrf4xx(p.data() + 1, p.size() - 1);
  crc = Crc16Accumulate(crc_extra, crc);
  p.push_back(static_cast<uint8_t>(crc & 0xFF));
  p.push_back(static_cast<uint8_t>(crc >> 8));
  return p;
}

TEST(MavlinkParser, MavlinkOnePacketsAreCountedNotDelivered) {
  // An autopilot port set to MAVLink 1: HEARTBEATs and GLOBAL_POSITION_INTs (relative_alt 100 m)
  // at their MAVLink 1 lengths, between garbage with a false 0xFE.
  std::vector<uint8_t> s = {0x00, 0xFE, 0x00, 0x13};
  for (int i = 0; i < 3; ++i) {
    const auto hb = V1Packet(Heartbeat::kId, Heartbeat::kCrcExtra,
                             {0, 0, 0, 0, 2, 3, 81, 4, 3});  // quadrotor, ArduPilot, v3
    std::vector<uint8_t> gp(GlobalPositionInt::kMinLength, 0);
    gp[16] = 0xA0, gp[17] = 0x86, gp[18] = 0x01;  // relative_alt 100000 mm (offset 16, LE)
    const auto pos = V1Packet(GlobalPositionInt::kId, GlobalPositionInt::kCrcExtra, gp);
    s.insert(s.end(), hb.begin(), hb.end());
    s.insert(s.end(), pos.begin(), pos.end());
  }
  auto bad = V1Packet(Heartbeat::kId, Heartbeat::kCrcExtra, {0, 0, 0, 0, 2, 3, 81, 4, 3});
  bad[8] ^= 0x01;  // a payload bit flipped: not counted
  s.insert(s.end(), bad.begin(), bad.end());
  Parser p;
  int n = 0;
  p.Feed(s.data(), s.size(), [&](const Packet&) { ++n; });
  EXPECT_EQ(n, 0);
  EXPECT_EQ(p.stats().packets, 0u);
  EXPECT_EQ(p.stats().v1_packets, 6u);
  // MAVLink 2 packets are not counted as MAVLink 1.
  Parser q;
  const auto hb2 = Bytes(golden::kHeartbeat);
  q.Feed(hb2.data(), hb2.size(), [&](const Packet&) {});
  EXPECT_EQ(q.stats().v1_packets, 0u);
  EXPECT_EQ(q.stats().packets, 1u);
}

TEST(MavlinkParser, BadChecksumIsDroppedAndTheNextPacketFound) {
  auto bad = Bytes(golden::kAttitude);
  bad[15] ^= 0x01;  // a payload bit flipped
  const auto good = Bytes(golden::kDistanceSensor);
  std::vector<uint8_t> s = bad;
  s.insert(s.end(), good.begin(), good.end());
  Parser p;
  std::vector<uint32_t> ids;
  p.Feed(s.data(), s.size(), [&](const Packet& k) { ids.push_back(k.header.msgid); });
  EXPECT_EQ(ids, std::vector<uint32_t>{DistanceSensor::kId});
  EXPECT_EQ(p.stats().crc_errors, 1u);
  // A wrong CRC_EXTRA (another message's) fails the same way.
  auto other = Bytes(golden::kAttitude);
  other[7] = GlobalPositionInt::kId;  // same length, other id: its CRC_EXTRA does not match
  Parser q;
  int n = 0;
  q.Feed(other.data(), other.size(), [&](const Packet&) { ++n; });
  EXPECT_EQ(n, 0);
  EXPECT_EQ(q.stats().crc_errors, 1u);
}

TEST(MavlinkParser, PacketHiddenBehindAFalseStart) {
  // A false magic with a length that swallows the real packet: the rescan finds it.
  std::vector<uint8_t> s = {0xFD, 0x20, 0x00};
  const auto hb = Bytes(golden::kHeartbeat);
  s.insert(s.end(), hb.begin(), hb.end());
  s.resize(s.size() + 40, 0x00);
  Parser p;
  int n = 0;
  p.Feed(s.data(), s.size(), [&](const Packet& k) { n += k.header.msgid == Heartbeat::kId; });
  EXPECT_EQ(n, 1);
}

TEST(MavlinkParser, SplitReadsAnywhere) {
  const auto a = Bytes(golden::kOdometry), b = Bytes(golden::kTimesync);
  std::vector<uint8_t> s = a;
  s.insert(s.end(), b.begin(), b.end());
  for (std::size_t cut = 1; cut < s.size(); cut += 7) {
    Parser p;
    std::vector<uint32_t> ids;
    auto sink = [&](const Packet& k) { ids.push_back(k.header.msgid); };
    p.Feed(s.data(), cut, sink);
    p.Feed(s.data() + cut, s.size() - cut, sink);
    EXPECT_EQ(ids, (std::vector<uint32_t>{Odometry::kId, Timesync::kId})) << "cut at " << cut;
  }
  // Byte at a time.
  Parser p;
  int n = 0;
  for (uint8_t byte : s) {
    if (p.Push(byte)) ++n;
    while (p.Next()) ++n;
  }
  EXPECT_EQ(n, 2);
}

TEST(MavlinkParser, UnknownIdsAreRescannedAndSignedPacketsRead) {
  // An unknown id (a valid-looking packet of message 77, whose payload holds a fake magic).
  std::vector<uint8_t> unknown = {0xFD, 3, 0, 0, 0, 1, 1, 77, 0, 0, 0xFD, 0x01, 0x02, 0x33, 0x44};
  auto signed_hb = Bytes(golden::kHeartbeat);
  signed_hb[2] = kIncompatSigned;
  // The CRC covers the flags: recompute it, then append a 13-byte signature.
  std::vector<uint8_t> crc_in(signed_hb.begin() + 1, signed_hb.end() - 2);
  crc_in.push_back(Heartbeat::kCrcExtra);
  const uint16_t crc = BitwiseCrc(crc_in);
  signed_hb[signed_hb.size() - 2] = crc & 0xFF;
  signed_hb[signed_hb.size() - 1] = crc >> 8;
  signed_hb.resize(signed_hb.size() + 13, 0x5A);
  std::vector<uint8_t> s = unknown;
  s.insert(s.end(), signed_hb.begin(), signed_hb.end());
  Parser p;
  std::vector<uint32_t> ids;
  p.Feed(s.data(), s.size(), [&](const Packet& k) { ids.push_back(k.header.msgid); });
  EXPECT_EQ(ids, std::vector<uint32_t>{Heartbeat::kId});
  EXPECT_GE(p.stats().unknown, 1u);
}

// CRC_EXTRA as mavlink.io "Packet Serialization" ("CRC_EXTRA Calculation") defines it: the
// CRC-16/MCRF4XX of the message name, then the type and name of each field in wire order (the
// extension fields left out), each followed by a space; the two bytes XORed. Written here from
// the definitions in common.xml, independently of the constants of messages.h.
uint8_t CrcExtraOf(const std::string& name,
                   const std::vector<std::pair<std::string, std::string>>& wire_fields) {
  std::string text = name + " ";
  for (const auto& [type, field] : wire_fields) text += type + " " + field + " ";
  const uint16_t crc = Crc16Mcrf4xx(reinterpret_cast<const uint8_t*>(text.data()), text.size());
  return static_cast<uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

TEST(MavlinkDefinitions, CrcExtraOfTheTelemetryLogMessages) {
  EXPECT_EQ(SystemTime::kCrcExtra, CrcExtraOf("SYSTEM_TIME", {{"uint64_t", "time_unix_usec"},
                                                              {"uint32_t", "time_boot_ms"}}));
  EXPECT_EQ(GpsRawInt::kCrcExtra, CrcExtraOf("GPS_RAW_INT", {{"uint64_t", "time_usec"},
                                                             {"int32_t", "lat"},
                                                             {"int32_t", "lon"},
                                                             {"int32_t", "alt"},
                                                             {"uint16_t", "eph"},
                                                             {"uint16_t", "epv"},
                                                             {"uint16_t", "vel"},
                                                             {"uint16_t", "cog"},
                                                             {"uint8_t", "fix_type"},
                                                             {"uint8_t", "satellites_visible"}}));
  EXPECT_EQ(GlobalPositionInt::kCrcExtra,
            CrcExtraOf("GLOBAL_POSITION_INT", {{"uint32_t", "time_boot_ms"},
                                               {"int32_t", "lat"},
                                               {"int32_t", "lon"},
                                               {"int32_t", "alt"},
                                               {"int32_t", "relative_alt"},
                                               {"int16_t", "vx"},
                                               {"int16_t", "vy"},
                                               {"int16_t", "vz"},
                                               {"uint16_t", "hdg"}}));
  EXPECT_EQ(Attitude::kCrcExtra, CrcExtraOf("ATTITUDE", {{"uint32_t", "time_boot_ms"},
                                                         {"float", "roll"},
                                                         {"float", "pitch"},
                                                         {"float", "yaw"},
                                                         {"float", "rollspeed"},
                                                         {"float", "pitchspeed"},
                                                         {"float", "yawspeed"}}));
  // The MAVLink 1 lengths (the fields above) and the full ones (with the extensions).
  EXPECT_EQ(Payload(SystemTime{}).size(), 12u);
  EXPECT_EQ(GpsRawInt::kMinLength, 8 + 3 * 4 + 4 * 2 + 2);
  EXPECT_EQ(Payload(GpsRawInt{}).size(), 30u + 4 * 5 + 2);
}

// CrcExtraOf with arrays: an array field adds its length as one byte after its name (the same
// page, "CRC_EXTRA Calculation"). {type, name, length; 0 = not an array}.
uint8_t CrcExtraWithArrays(const std::string& name,
                           const std::vector<std::tuple<std::string, std::string, int>>& fields) {
  std::string text = name + " ";
  for (const auto& [type, field, length] : fields) {
    text += type + " " + field + " ";
    if (length > 0) text += static_cast<char>(length);
  }
  const uint16_t crc = Crc16Mcrf4xx(reinterpret_cast<const uint8_t*>(text.data()), text.size());
  return static_cast<uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

TEST(MavlinkDefinitions, CrcExtraAndLengthsOfTheCameraMessages) {
  // ardupilotmega.xml CAMERA_FEEDBACK in wire order, without the extension completed_captures.
  EXPECT_EQ(CameraFeedback::kCrcExtra, CrcExtraOf("CAMERA_FEEDBACK", {{"uint64_t", "time_usec"},
                                                                      {"int32_t", "lat"},
                                                                      {"int32_t", "lng"},
                                                                      {"float", "alt_msl"},
                                                                      {"float", "alt_rel"},
                                                                      {"float", "roll"},
                                                                      {"float", "pitch"},
                                                                      {"float", "yaw"},
                                                                      {"float", "foc_len"},
                                                                      {"uint16_t", "img_idx"},
                                                                      {"uint8_t", "target_system"},
                                                                      {"uint8_t", "cam_idx"},
                                                                      {"uint8_t", "flags"}}));
  EXPECT_EQ(CameraFeedback::kMinLength, 8 + 8 * 4 + 2 + 3);
  EXPECT_EQ(Payload(CameraFeedback{}).size(), 45u + 2);
  // common.xml CAMERA_IMAGE_CAPTURED in wire order.
  EXPECT_EQ(CameraImageCaptured::kCrcExtra,
            CrcExtraWithArrays("CAMERA_IMAGE_CAPTURED", {{"uint64_t", "time_utc", 0},
                                                         {"uint32_t", "time_boot_ms", 0},
                                                         {"int32_t", "lat", 0},
                                                         {"int32_t", "lon", 0},
                                                         {"int32_t", "alt", 0},
                                                         {"int32_t", "relative_alt", 0},
                                                         {"float", "q", 4},
                                                         {"int32_t", "image_index", 0},
                                                         {"uint8_t", "camera_id", 0},
                                                         {"int8_t", "capture_result", 0},
                                                         {"char", "file_url", 205}}));
  EXPECT_EQ(Payload(CameraImageCaptured{}).size(), 8u + 4 * 5 + 16 + 4 + 2 + 205);
  // A truncated MAVLink 2 packet reads back zero-filled.
  CameraFeedback f;
  f.lat = 435367000;
  f.img_idx = 12;
  Packet p;
  const auto bytes = Encode(f, 0, 1, 1);
  ASSERT_EQ(CheckFrame(bytes.data(), bytes.size(), &p).status, FrameStatus::kOk);
  EXPECT_LT(p.wire_length, CameraFeedback::kMinLength);
  ASSERT_TRUE(Decode<CameraFeedback>(p));
  EXPECT_EQ(Decode<CameraFeedback>(p)->lat, 435367000);
  EXPECT_EQ(Decode<CameraFeedback>(p)->img_idx, 12);
  EXPECT_EQ(Decode<CameraFeedback>(p)->cam_idx, 0);
}

TEST(MavlinkCheckFrame, VersionsChecksumsAndLengths) {
  GpsRawInt raw;
  raw.lat = 435367000;
  raw.fix_type = 3;
  const auto v2 = Encode(raw, 4, 1, 1);
  Packet p;
  FrameCheck c = CheckFrame(v2.data(), v2.size() + 5, &p);  // bytes after it: ignored
  EXPECT_EQ(c.status, FrameStatus::kOk);
  EXPECT_EQ(c.size, v2.size());
  EXPECT_EQ(c.msgid, GpsRawInt::kId);
  EXPECT_FALSE(p.mavlink1);
  ASSERT_EQ(p.payload.size(), GpsRawInt::kLength);  // padded back
  EXPECT_EQ(Decode<GpsRawInt>(p)->lat, 435367000);
  EXPECT_EQ(Decode<GpsRawInt>(p)->fix_type, 3);

  const auto payload = Payload(raw);
  const auto v1 = V1Packet(GpsRawInt::kId, GpsRawInt::kCrcExtra,
                           std::vector<uint8_t>(payload.begin(), payload.begin() + 30));
  c = CheckFrame(v1.data(), v1.size(), &p);
  EXPECT_EQ(c.status, FrameStatus::kOk);
  EXPECT_EQ(c.size, 6u + 30 + 2);
  EXPECT_TRUE(p.mavlink1);
  EXPECT_EQ(p.header.sysid, 1);
  EXPECT_EQ(Decode<GpsRawInt>(p)->fix_type, 3);

  EXPECT_EQ(CheckFrame(v1.data(), v1.size() - 1, &p).status, FrameStatus::kNeedMore);
  EXPECT_EQ(CheckFrame(v2.data(), 5, &p).status, FrameStatus::kNeedMore);
  auto bad = v2;
  bad[12] ^= 1;
  c = CheckFrame(bad.data(), bad.size(), &p);
  EXPECT_EQ(c.status, FrameStatus::kBadChecksum);
  EXPECT_EQ(c.msgid, GpsRawInt::kId);
  auto unknown = v2;
  unknown[7] = 74;  // VFR_HUD: not known to aerovo
  EXPECT_EQ(CheckFrame(unknown.data(), unknown.size(), &p).status, FrameStatus::kUnknownMessage);
  auto flags = v2;
  flags[2] = 0x02;  // an incompatibility flag aerovo does not know
  EXPECT_EQ(CheckFrame(flags.data(), flags.size(), &p).status, FrameStatus::kNotAFrame);
  const uint8_t text[] = "hello";
  EXPECT_EQ(CheckFrame(text, 5, &p).status, FrameStatus::kNotAFrame);
}

}  // namespace
}  // namespace aerovo::mavlink::messages_test
