// MAVLink 2 signing against signatures computed independently of aerovo's code: golden signed
// packets written by node-mavlink 2.3.0's own signing (tests/mavlink/golden.cjs, the end of it:
// key 00 01 .. 1f, fixed times), pasted as hex. Then the receiver's rules (forged, unsigned,
// replayed, the one-minute window of a new stream), the sender's timestamps, and the key file.
#include "aerovo/mavlink/signing.h"

#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/testing.h"

namespace aerovo::mavlink::signing_test {
namespace {

using testing::Bytes;
using testing::Hex;
using testing::ParseOne;

namespace golden {
// DISTANCE_SENSOR as in messages_test.cc (seq 9, sysid 1, compid 1), link id 0, Unix time
// 1764806400.123 s; HEARTBEAT (seq 7, sysid 42, compid 197), link id 3, 1764806400.124 s.
constexpr const char* kDistanceSensorSigned =
    "fd0e010009010184000060ea00001400a00fbb1f000119ffbdd1000cd0ae825a1f06cd435950ff";
constexpr const char* kHeartbeatSigned =
    "fd090100072ac50000000000000012080004036f6a0370d0ae825a1fbaf0ddcb0bb1";
// (1764806400123 ms - 1420070400000 ms) * 100: the timestamps in 10 us units.
constexpr uint64_t kDistanceSensorTimestamp = 34473600012300ULL;
constexpr uint64_t kHeartbeatTimestamp = 34473600012400ULL;
}  // namespace golden

SigningKey TestKey() {
  SigningKey k{};
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = static_cast<uint8_t>(i);
  return k;
}

DistanceSensor GoldenDistance() {  // the field values of golden.cjs
  DistanceSensor d;
  d.time_boot_ms = 60000;
  d.min_distance = 20;
  d.max_distance = 4000;
  d.current_distance = 8123;
  d.type = 0;
  d.id = 1;
  d.orientation = 25;
  d.covariance = 255;
  return d;
}

// Unix seconds of a signing timestamp (for the clock argument).
double UnixOf(uint64_t timestamp) { return kSigningEpochUnixS + 1e-5 * timestamp; }

TEST(MavlinkSigning, SignaturesEqualNodeMavlinks) {
  std::vector<uint8_t> ds = Encode(GoldenDistance(), 9, 1, 1);
  SignPacket(&ds, DistanceSensor::kCrcExtra, TestKey(), 0, golden::kDistanceSensorTimestamp);
  EXPECT_EQ(Hex(ds), golden::kDistanceSensorSigned);
  Heartbeat hb;
  hb.type = 18;
  hb.autopilot = 8;
  hb.system_status = 4;
  hb.mavlink_version = 3;
  std::vector<uint8_t> h = Encode(hb, 7, 42, 197);
  SignPacket(&h, Heartbeat::kCrcExtra, TestKey(), 3, golden::kHeartbeatTimestamp);
  EXPECT_EQ(Hex(h), golden::kHeartbeatSigned);
  // The 13 bytes: link id, 48-bit timestamp (LE), 6 bytes of signature.
  ASSERT_EQ(h.size(), kHeaderBytes + 9 + kChecksumBytes + kSignatureBytes);
  EXPECT_EQ(h[2], kIncompatSigned);
  EXPECT_EQ(h[kHeaderBytes + 9 + 2], 3);
}

TEST(MavlinkSigning, TimestampIsTenMicrosecondsSince2015) {
  EXPECT_EQ(SigningTimestampFromUnixS(1420070400.0), 0u);
  EXPECT_EQ(SigningTimestampFromUnixS(1420070401.0), 100000u);
  EXPECT_EQ(SigningTimestampFromUnixS(1000.0), 0u);  // before 2015
  EXPECT_NEAR(static_cast<double>(SigningTimestampFromUnixS(1764806400.123)),
              static_cast<double>(golden::kDistanceSensorTimestamp), 1.0);
}

TEST(MavlinkSigning, AcceptsOnlySignedForwardPackets) {
  const std::vector<uint8_t> good = Bytes(golden::kDistanceSensorSigned);
  const double now = UnixOf(golden::kDistanceSensorTimestamp);
  SigningState s(TestKey(), 0);
  const Packet p = ParseOne(good);
  ASSERT_TRUE(p.is_signed);
  EXPECT_EQ(p.frame, good);
  ASSERT_TRUE(Decode<DistanceSensor>(p));
  EXPECT_EQ(Decode<DistanceSensor>(p)->current_distance, 8123);
  EXPECT_EQ(s.Check(p, now), SignatureCheck::kAccepted);
  // The same bytes again: a replay.
  EXPECT_EQ(s.Check(ParseOne(good), now), SignatureCheck::kReplayed);
  // Unsigned, same message.
  EXPECT_EQ(s.Check(ParseOne(Encode(GoldenDistance(), 10, 1, 1)), now), SignatureCheck::kUnsigned);
  // Forged: signed with another key, a later timestamp.
  SigningKey other = TestKey();
  other[31] ^= 0x01;
  std::vector<uint8_t> forged = Encode(GoldenDistance(), 11, 1, 1);
  SignPacket(&forged, DistanceSensor::kCrcExtra, other, 0, golden::kDistanceSensorTimestamp + 5);
  EXPECT_EQ(s.Check(ParseOne(forged), now), SignatureCheck::kBadSignature);
  // One bit of the signed timestamp changed (the checksum does not cover the signature block).
  std::vector<uint8_t> tampered = good;
  tampered[tampered.size() - 12] ^= 0x40;
  EXPECT_EQ(s.Check(ParseOne(tampered), now), SignatureCheck::kBadSignature);
  // The real key, a later timestamp: accepted, and an earlier one after it is not.
  std::vector<uint8_t> later = Encode(GoldenDistance(), 12, 1, 1);
  SignPacket(&later, DistanceSensor::kCrcExtra, TestKey(), 0, golden::kDistanceSensorTimestamp + 7);
  EXPECT_EQ(s.Check(ParseOne(later), now), SignatureCheck::kAccepted);
  std::vector<uint8_t> older = Encode(GoldenDistance(), 13, 1, 1);
  SignPacket(&older, DistanceSensor::kCrcExtra, TestKey(), 0, golden::kDistanceSensorTimestamp + 6);
  EXPECT_EQ(s.Check(ParseOne(older), now), SignatureCheck::kReplayed);
  // Another stream (link id 1) has its own last timestamp.
  std::vector<uint8_t> link1 = Encode(GoldenDistance(), 14, 1, 1);
  SignPacket(&link1, DistanceSensor::kCrcExtra, TestKey(), 1, golden::kDistanceSensorTimestamp + 6);
  EXPECT_EQ(s.Check(ParseOne(link1), now), SignatureCheck::kAccepted);
}

TEST(MavlinkSigning, NewStreamWithinOneMinuteOfTheLocalTimestamp) {
  const uint64_t t = golden::kDistanceSensorTimestamp;
  SigningState s(TestKey(), 0);
  const double now = UnixOf(t + kSigningNewStreamWindow + 100);  // the clock: 1 min + 1 ms later
  EXPECT_EQ(s.Check(ParseOne(Bytes(golden::kDistanceSensorSigned)), now), SignatureCheck::kReplayed);
  std::vector<uint8_t> recent = Encode(GoldenDistance(), 1, 1, 2);        // compid 2: a new stream
  SignPacket(&recent, DistanceSensor::kCrcExtra, TestKey(), 0, t + 200);  // 59.999 s old
  EXPECT_EQ(s.Check(ParseOne(recent), now), SignatureCheck::kAccepted);
  // The local timestamp also follows what was accepted: a clock far behind does not reopen the
  // window for a stream older than a minute before the accepted one.
  SigningState s2(TestKey(), 0);
  std::vector<uint8_t> ahead = Encode(GoldenDistance(), 1, 1, 3);
  SignPacket(&ahead, DistanceSensor::kCrcExtra, TestKey(), 0, t + 2 * kSigningNewStreamWindow);
  EXPECT_EQ(s2.Check(ParseOne(ahead), UnixOf(t)), SignatureCheck::kAccepted);
  EXPECT_EQ(s2.Check(ParseOne(Bytes(golden::kDistanceSensorSigned)), UnixOf(t)),
            SignatureCheck::kReplayed);
}

TEST(MavlinkSigning, SentTimestampsIncreaseAndFollowAcceptedOnes) {
  SigningState s(TestKey(), 5);
  SigningState receiver(TestKey(), 0);
  const double clock = UnixOf(golden::kDistanceSensorTimestamp);
  uint64_t last = 0;
  for (int i = 0; i < 4; ++i) {
    std::vector<uint8_t> b = Encode(Heartbeat{}, static_cast<uint8_t>(i), 1, 197);
    // The same clock reading each time, then one going backwards by a second.
    s.Sign(&b, Heartbeat::kCrcExtra, i < 3 ? clock : clock - 1.0);
    const Packet p = ParseOne(b);
    ASSERT_TRUE(p.is_signed);
    EXPECT_EQ(receiver.Check(p, clock), SignatureCheck::kAccepted) << i;
    uint64_t ts = 0;
    for (int k = 5; k >= 0; --k) ts = (ts << 8) | b[b.size() - 12 + k];
    EXPECT_EQ(b[b.size() - 13], 5);  // our link id
    if (i == 0) {
      EXPECT_EQ(ts, golden::kDistanceSensorTimestamp);
    } else {
      EXPECT_EQ(ts, last + 1);
    }
    last = ts;
  }
  // An accepted packet from the autopilot with a later timestamp moves ours past it.
  std::vector<uint8_t> fc = Encode(GoldenDistance(), 0, 1, 1);
  SignPacket(&fc, DistanceSensor::kCrcExtra, TestKey(), 0, last + 1000);
  EXPECT_EQ(s.Check(ParseOne(fc), clock), SignatureCheck::kAccepted);
  std::vector<uint8_t> b = Encode(Heartbeat{}, 9, 1, 197);
  s.Sign(&b, Heartbeat::kCrcExtra, clock);
  EXPECT_EQ(receiver.Check(ParseOne(b), clock), SignatureCheck::kAccepted);
  uint64_t ts = 0;
  for (int k = 5; k >= 0; --k) ts = (ts << 8) | b[b.size() - 12 + k];
  EXPECT_EQ(ts, last + 1001);
}

// The timestamp kept across runs: a restart whose clock is behind the last run's timestamps
// (a companion without a real-time clock) still signs after them, so that the autopilot, which
// remembers this stream's last timestamp, does not reject the new packets as replays.
TEST(MavlinkSigning, AStoredTimestampOutranksAClockThatIsBehind) {
  const uint64_t stored = golden::kDistanceSensorTimestamp + 500000;  // 5 s after the clock
  SigningState s(TestKey(), 0, stored);
  EXPECT_EQ(s.local_timestamp(), stored);
  std::vector<uint8_t> b = Encode(Heartbeat{}, 0, 1, 197);
  s.Sign(&b, Heartbeat::kCrcExtra, UnixOf(golden::kDistanceSensorTimestamp));
  uint64_t ts = 0;
  for (int k = 5; k >= 0; --k) ts = (ts << 8) | b[b.size() - 12 + k];
  EXPECT_EQ(ts, stored + 1);
  EXPECT_EQ(s.local_timestamp(), stored + 1);
  // A receiver that saw the stored timestamp on this stream accepts the restarted stream.
  SigningState receiver(TestKey(), 0);
  std::vector<uint8_t> before = Encode(Heartbeat{}, 9, 1, 197);
  SignPacket(&before, Heartbeat::kCrcExtra, TestKey(), 0, stored);
  const double clock = UnixOf(golden::kDistanceSensorTimestamp);
  ASSERT_EQ(receiver.Check(ParseOne(before), clock), SignatureCheck::kAccepted);
  EXPECT_EQ(receiver.Check(ParseOne(b), clock), SignatureCheck::kAccepted);
}

class MavlinkTimestampFile : public ::testing::Test {
 protected:
  void TearDown() override {
    std::remove(path_.c_str());
    std::remove((path_ + ".tmp").c_str());
  }
  std::string path_ =
      ::testing::TempDir() + "aerovo_signing_timestamp_" + std::to_string(getpid());
};

TEST_F(MavlinkTimestampFile, WrittenAndReadBack) {
  std::string problem;
  EXPECT_FALSE(ReadSigningTimestamp(path_, &problem));  // no file yet: no problem either
  EXPECT_EQ(problem, "");
  WriteSigningTimestamp(path_, golden::kHeartbeatTimestamp);
  std::ifstream in(path_);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, std::to_string(golden::kHeartbeatTimestamp) + "\n");
  EXPECT_EQ(ReadSigningTimestamp(path_, &problem), golden::kHeartbeatTimestamp);
  EXPECT_EQ(problem, "");
  WriteSigningTimestamp(path_, kMaxSigningTimestamp);
  EXPECT_EQ(ReadSigningTimestamp(path_, &problem), kMaxSigningTimestamp);
  EXPECT_FALSE(std::ifstream(path_ + ".tmp"));  // renamed into place
}

TEST_F(MavlinkTimestampFile, AFileThatIsNotATimestampIsNamedAndIgnored) {
  for (const std::string& text :
       {std::string(""), std::string("12x\n"), std::string("-5\n"), std::string("1 2\n"),
        std::to_string(kMaxSigningTimestamp + 1) + "\n", std::string(40, '9')}) {
    std::ofstream(path_, std::ios::binary | std::ios::trunc) << text;
    std::string problem;
    EXPECT_FALSE(ReadSigningTimestamp(path_, &problem)) << text;
    EXPECT_NE(problem.find(path_), std::string::npos) << text << ": " << problem;
    EXPECT_NE(problem.find("48 bits"), std::string::npos) << problem;
  }
}

TEST_F(MavlinkTimestampFile, AnUnwritableFolderIsAnErrorNamingTheFile) {
  const std::string path = "/nonexistent-folder-of-aerovo/ts";
  try {
    WriteSigningTimestamp(path, 1);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

class MavlinkKeyFile : public ::testing::Test {
 protected:
  std::string Write(const std::string& text, mode_t mode) {
    std::ofstream(path_, std::ios::binary) << text;
    chmod(path_.c_str(), mode);
    return path_;
  }
  void TearDown() override { std::remove(path_.c_str()); }
  std::string path_ = ::testing::TempDir() + "aerovo_signing_key_" + std::to_string(getpid());
};

std::string ErrorOf(const std::string& path) {
  try {
    ReadSigningKey(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_F(MavlinkKeyFile, ReadsSixtyFourHexDigits) {
  const std::string hex = "000102030405060708090a0b0c0d0e0f101112131415161718191A1B1C1D1E1F";
  EXPECT_EQ(ReadSigningKey(Write(hex + "\n", 0600)), TestKey());
  EXPECT_EQ(ReadSigningKey(Write(hex, 0400)), TestKey());
}

TEST_F(MavlinkKeyFile, BadFilesAreErrorsNamingTheFile) {
  const std::string hex = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";
  std::string e = ErrorOf(Write(hex, 0644));
  EXPECT_NE(e.find(path_), std::string::npos) << e;
  EXPECT_NE(e.find("644"), std::string::npos) << e;
  EXPECT_NE(e.find("chmod 600"), std::string::npos) << e;
  e = ErrorOf(Write(hex, 0620));  // group may write
  EXPECT_NE(e.find("620"), std::string::npos) << e;
  e = ErrorOf(Write(hex.substr(0, 62), 0600));
  EXPECT_NE(e.find(path_), std::string::npos) << e;
  EXPECT_NE(e.find("62 characters"), std::string::npos) << e;
  e = ErrorOf(Write(std::string(32, 'k'), 0600));  // 32 raw bytes are not the format
  EXPECT_NE(e.find("32 characters"), std::string::npos) << e;
  e = ErrorOf(Write(hex.substr(0, 10) + "zz" + hex.substr(12), 0600));
  EXPECT_NE(e.find("character 11 is not a hexadecimal digit"), std::string::npos) << e;
  e = ErrorOf(Write(std::string(300, '0'), 0600));
  EXPECT_NE(e.find("larger than a key"), std::string::npos) << e;
  e = ErrorOf(path_ + ".missing");
  EXPECT_NE(e.find(path_ + ".missing"), std::string::npos) << e;
  EXPECT_NE(e.find("No such file"), std::string::npos) << e;
}

}  // namespace
}  // namespace aerovo::mavlink::signing_test
