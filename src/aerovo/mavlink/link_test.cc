// The link over real UDP sockets on 127.0.0.1: URLs, heartbeat, TIMESYNC answers, the
// autopilot's height and attitude, udp (send to) and udpin (answer the last sender).
#include "aerovo/mavlink/link.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/mavlink/transport.h"

namespace aerovo::mavlink::link_test {
namespace {

// A UDP socket of the test on 127.0.0.1 (port 0: any free port).
struct TestSocket {
  int fd = -1;
  int port = 0;
  explicit TestSocket(int bind_port = 0) {
    fd = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<uint16_t>(bind_port));
    EXPECT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    socklen_t len = sizeof(a);
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~TestSocket() { close(fd); }
  void SendTo(int to_port, const std::vector<uint8_t>& b) const {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<uint16_t>(to_port));
    sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&a), sizeof(a));
  }
  // Packets received within `timeout_ms`, until `until` says stop.
  template <class F>
  void Receive(int timeout_ms, F&& until) {
    Parser parser;
    std::vector<uint8_t> buf(2048);
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    bool done = false;
    while (!done && std::chrono::steady_clock::now() < end) {
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      const ssize_t n = recv(fd, buf.data(), buf.size(), 0);
      if (n <= 0) continue;
      parser.Feed(buf.data(), static_cast<std::size_t>(n), [&](const Packet& k) {
        if (!done) done = until(k);
      });
    }
  }
};

int FreePort() {
  TestSocket s;
  return s.port;
}

TEST(MavlinkUrl, ParsesAndNamesTheUrlInErrors) {
  const LinkUrl a = ParseLinkUrl("udp:127.0.0.1:14550");
  EXPECT_EQ(a.kind, LinkUrl::Kind::kUdpOut);
  EXPECT_EQ(a.host, "127.0.0.1");
  EXPECT_EQ(a.port, 14550);
  EXPECT_FALSE(a.reads_autopilot());
  const LinkUrl b = ParseLinkUrl("udpin:0.0.0.0:14540");
  EXPECT_EQ(b.kind, LinkUrl::Kind::kUdpIn);
  EXPECT_TRUE(b.reads_autopilot());
  const LinkUrl c = ParseLinkUrl("serial:/dev/ttyAMA0:921600");
  EXPECT_EQ(c.kind, LinkUrl::Kind::kSerial);
  EXPECT_EQ(c.device, "/dev/ttyAMA0");
  EXPECT_EQ(c.baud, 921600);
  for (const char* bad : {"tcp:1.2.3.4:5760", "udp:127.0.0.1", "udp:host:0", "udp:host:99999",
                          "udp:host:x", "serial:/dev/ttyS0:12345", "serial:/dev/ttyS0", ""}) {
    try {
      ParseLinkUrl(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos)
          << e.what();
    }
  }
}

TEST(MavlinkUrl, OpenFailuresNameTheUrl) {
  try {
    OpenTransport(ParseLinkUrl("serial:/nonexistent/ttyX:57600"));
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("serial:/nonexistent/ttyX:57600"), std::string::npos);
  }
  TestSocket taken;
  try {
    OpenTransport(ParseLinkUrl("udpin:127.0.0.1:" + std::to_string(taken.port)));
    ADD_FAILURE() << "bound a port in use";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot listen"), std::string::npos) << e.what();
  }
}

TEST(MavlinkLink, UdpSendsHeartbeatsAndMessages) {
  TestSocket gcs;
  AutopilotLink::Options o;
  o.sysid = 7;
  o.heartbeat_period_s = 0.05;
  AutopilotLink link(OpenTransport(ParseLinkUrl("udp:127.0.0.1:" + std::to_string(gcs.port))), o);
  Odometry odo;
  odo.x = 2.5f;
  int heartbeats = 0;
  bool odometry = false;
  EXPECT_TRUE(link.Send(odo));
  gcs.Receive(2000, [&](const Packet& k) {
    if (const auto h = Decode<Heartbeat>(k)) {
      EXPECT_EQ(k.header.sysid, 7);
      EXPECT_EQ(k.header.compid, kMavCompIdVisualInertialOdometry);
      EXPECT_EQ(h->type, kMavTypeOnboardController);
      ++heartbeats;
    }
    if (const auto d = Decode<Odometry>(k)) odometry = d->x == 2.5f;
    return heartbeats >= 3 && odometry;
  });
  EXPECT_GE(heartbeats, 3);
  EXPECT_TRUE(odometry);
}

TEST(MavlinkLink, UdpinReadsTheAutopilotAndAnswersTimesync) {
  const int port = FreePort();
  AutopilotLink::Options o;
  o.heartbeat_period_s = 0.05;
  AutopilotLink link(OpenTransport(ParseLinkUrl("udpin:127.0.0.1:" + std::to_string(port))), o);
  EXPECT_FALSE(link.HeightNear(MonotonicNowS(), 1.0));
  EXPECT_FALSE(link.Send(Odometry{}));  // nobody to send to yet
  TestSocket fc;
  DistanceSensor up;  // facing up: not a height
  up.orientation = 24;
  up.min_distance = 10;
  up.max_distance = 1000;
  up.current_distance = 300;
  DistanceSensor down = up;
  down.orientation = kMavSensorRotationPitch270;
  down.current_distance = 8123;  // 81.23 m
  down.max_distance = 10000;
  DistanceSensor out_of_range = down;
  out_of_range.current_distance = 20000;
  Attitude att;
  att.roll = 0.0625f;
  att.pitch = -0.125f;
  att.yaw = 1.0f;
  Timesync request;
  request.ts1 = 123456789;
  const double t0 = MonotonicNowS();
  fc.SendTo(port, Encode(up, 0, 1, 1));
  fc.SendTo(port, Encode(down, 1, 1, 1));
  fc.SendTo(port, Encode(out_of_range, 2, 1, 1));
  fc.SendTo(port, Encode(att, 3, 1, 1));
  fc.SendTo(port, Encode(request, 4, 1, 1));
  bool answered = false;
  int heartbeats = 0;
  fc.Receive(2000, [&](const Packet& k) {
    if (const auto t = Decode<Timesync>(k)) {
      EXPECT_EQ(t->ts1, 123456789);
      EXPECT_GT(t->tc1, 0);
      EXPECT_EQ(t->target_system, 1);
      EXPECT_EQ(t->target_component, 1);
      answered = true;
    }
    if (Decode<Heartbeat>(k)) ++heartbeats;
    return answered && heartbeats >= 2;
  });
  EXPECT_TRUE(answered);
  EXPECT_GE(heartbeats, 2);  // sent to the last sender
  ASSERT_TRUE(link.WaitForHeight(1.0));
  const auto h = link.HeightNear(t0, 1.0);
  ASSERT_TRUE(h);
  EXPECT_NEAR(h->height_m, 81.23, 1e-9);
  EXPECT_EQ(h->source, HeightSourceKind::kDistanceSensor);
  EXPECT_FALSE(link.HeightNear(t0 + 100.0, 1.0));  // none that close in time
  const auto a = link.AttitudeNear(t0, 1.0);
  ASSERT_TRUE(a);
  EXPECT_NEAR(a->roll_rad, 0.0625, 1e-9);
  EXPECT_NEAR(a->pitch_rad, -0.125, 1e-9);
  const LinkStats s = link.stats();
  EXPECT_EQ(s.distance_samples, 1u);
  EXPECT_EQ(s.attitude_samples, 1u);
  EXPECT_EQ(s.timesync_answers, 1u);
  // Relative altitude when there is no rangefinder reading near the time.
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  GlobalPositionInt g;
  g.relative_alt = 45500;
  fc.SendTo(port, Encode(g, 5, 1, 1));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto r = link.HeightNear(MonotonicNowS(), 0.5);  // the distance reading is older
  ASSERT_TRUE(r);
  EXPECT_EQ(r->source, HeightSourceKind::kRelativeAlt);
  EXPECT_NEAR(r->height_m, 45.5, 1e-9);
}

// --mavlink-key on udpin: only the signed packets of the key are used; unsigned, forged and
// replayed ones are counted, and their senders never become the peer aerovo sends to.
TEST(MavlinkLink, SignedUdpinUsesAndAnswersOnlySignedPackets) {
  SigningKey key{};
  for (std::size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(0xA0 + i);
  SigningKey other = key;
  other[0] ^= 0xFF;
  const int port = FreePort();
  AutopilotLink::Options o;
  o.heartbeat_period_s = 0.05;
  o.signing_key = key;
  AutopilotLink link(OpenTransport(ParseLinkUrl("udpin:127.0.0.1:" + std::to_string(port))), o);
  DistanceSensor d;
  d.orientation = kMavSensorRotationPitch270;
  d.min_distance = 10;
  d.max_distance = 10000;
  d.current_distance = 5000;  // 50 m: the genuine reading
  const auto signed_bytes = [&](const DistanceSensor& m, uint8_t seq, const SigningKey& k,
                                uint64_t ts) {
    std::vector<uint8_t> b = Encode(m, seq, 1, 1);
    SignPacket(&b, DistanceSensor::kCrcExtra, k, 0, ts);
    return b;
  };
  const uint64_t now = SigningTimestampFromUnixS(UnixNowS());
  DistanceSensor fake = d;
  fake.current_distance = 900;  // 9 m: what the attacker wants used
  TestSocket attacker, fc;
  attacker.SendTo(port, Encode(fake, 0, 1, 1));                   // unsigned
  attacker.SendTo(port, signed_bytes(fake, 1, other, now + 10));  // forged
  const std::vector<uint8_t> genuine = signed_bytes(d, 2, key, now + 20);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  EXPECT_FALSE(link.Send(Odometry{}));  // no peer yet: the attacker's datagrams do not count
  fc.SendTo(port, genuine);
  ASSERT_TRUE(link.WaitForHeight(1.0));
  // Heartbeats go to the flight controller, signed with the key, timestamps increasing.
  SigningState verifier(key, 0);
  int heartbeats = 0;
  fc.Receive(2000, [&](const Packet& k) {
    if (Decode<Heartbeat>(k)) {
      EXPECT_EQ(verifier.Check(k, UnixNowS()), SignatureCheck::kAccepted);
      ++heartbeats;
    }
    return heartbeats >= 2;
  });
  EXPECT_GE(heartbeats, 2);
  // The attacker's forged datagram, then the genuine packet again (a replay).
  attacker.SendTo(port, signed_bytes(fake, 3, other, now + 30));
  fc.SendTo(port, genuine);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  int to_attacker = 0;
  attacker.Receive(200, [&](const Packet&) { return ++to_attacker > 0; });
  EXPECT_EQ(to_attacker, 0);
  const auto h = link.HeightNear(MonotonicNowS(), 10.0);
  ASSERT_TRUE(h);
  EXPECT_NEAR(h->height_m, 50.0, 1e-9);
  const LinkStats s = link.stats();
  EXPECT_TRUE(s.signing);
  EXPECT_EQ(s.distance_samples, 1u);
  EXPECT_EQ(s.rejected_unsigned, 1u);
  EXPECT_EQ(s.rejected_bad_signature, 2u);
  EXPECT_EQ(s.rejected_replayed, 1u);
  EXPECT_EQ(s.signed_accepted, 1u);
}

// Signing with a timestamp file: the first packet is signed after the stored timestamp (a day
// ahead of the clock here), the file follows the timestamps while the link runs and holds the
// last one sent after the link is closed.
TEST(MavlinkLink, SigningTimestampIsKeptInItsFile) {
  const std::string file =
      ::testing::TempDir() + "aerovo_link_timestamp_" + std::to_string(getpid());
  const uint64_t stored = SigningTimestampFromUnixS(UnixNowS()) + 8640000000ULL;  // + 1 day
  WriteSigningTimestamp(file, stored);
  TestSocket gcs;
  uint64_t first = 0, last = 0;
  {
    AutopilotLink::Options o;
    o.heartbeat_period_s = 0.02;
    o.signing_key = SigningKey{};
    o.signing_initial_timestamp = *ReadSigningTimestamp(file, nullptr);
    o.signing_timestamp_file = file;
    o.signing_timestamp_period_s = 0.05;
    AutopilotLink link(OpenTransport(ParseLinkUrl("udp:127.0.0.1:" + std::to_string(gcs.port))),
                       o);
    int heartbeats = 0;
    gcs.Receive(3000, [&](const Packet& k) {
      EXPECT_TRUE(k.is_signed);
      uint64_t ts = 0;
      for (int b = 5; b >= 0; --b) ts = (ts << 8) | k.frame[k.frame.size() - 12 + b];
      if (first == 0) first = ts;
      last = ts;
      return ++heartbeats >= 8;
    });
    EXPECT_EQ(first, stored + 1);
    EXPECT_GE(link.stats().signing_timestamp_saves, 1u);  // periodic saves while running
    const std::optional<uint64_t> meanwhile = ReadSigningTimestamp(file, nullptr);
    ASSERT_TRUE(meanwhile);
    EXPECT_GT(*meanwhile, stored);
  }
  std::string problem;
  const std::optional<uint64_t> kept = ReadSigningTimestamp(file, &problem);
  ASSERT_TRUE(kept) << problem;
  EXPECT_GE(*kept, last);
  EXPECT_LE(*kept, last + 100);  // a heartbeat or two may have gone out after the test's last
  std::remove(file.c_str());
}

TEST(MavlinkLink, NoHeightSaysWhatArrivedInstead) {
  LinkStats st;
  EXPECT_EQ(DescribeNoHeight(st), "nothing received");
  st.parser.bytes_skipped = 4000;
  EXPECT_EQ(DescribeNoHeight(st),
            "4000 bytes, no MAVLink packet in them (another protocol, or a wrong baud rate?)");
  st.parser.v1_packets = 12;
  EXPECT_EQ(DescribeNoHeight(st),
            "12 MAVLink 1 packets, not read: aerovo reads MAVLink 2 (ArduPilot: SERIALn_PROTOCOL "
            "= 2, docs/autopilot.md)");
  st = LinkStats{};
  st.parser.packets = 5;
  st.autopilot_heartbeats = 5;
  st.rejected_unsigned = 3;
  st.parser.crc_errors = 2;
  EXPECT_EQ(DescribeNoHeight(st),
            "2 packets with a wrong checksum (a damaged link, a wrong baud rate or another "
            "dialect); 3 packets refused by signing (3 unsigned, 0 signed with another key, 0 "
            "replayed): does the autopilot have the key of --mavlink-key?; 5 packets read (5 "
            "heartbeats), none a height: no DISTANCE_SENSOR facing down nor GLOBAL_POSITION_INT");
}

}  // namespace
}  // namespace aerovo::mavlink::link_test
