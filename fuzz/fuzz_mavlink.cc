// libFuzzer target: the MAVLink 2 stream parser (aerovo::mavlink::Parser) on what a serial link
// or a UDP port may deliver, and the decoding of every message aerovo reads. Invariants checked
// (abort on violation): every delivered packet is of a known id, its payload is padded to the
// message's length, and re-encoding a decoded message gives a packet the parser accepts again.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/protocol.h"

namespace {

template <class M>
void RoundTrip(const aerovo::mavlink::Packet& p) {
  const auto m = aerovo::mavlink::Decode<M>(p);
  if (!m) return;
  const auto bytes = aerovo::mavlink::Encode(*m, p.header.seq, p.header.sysid, p.header.compid);
  aerovo::mavlink::Parser again;
  int n = 0;
  again.Feed(bytes.data(), bytes.size(), [&](const aerovo::mavlink::Packet& q) {
    if (q.header.msgid != M::kId) std::abort();
    ++n;
  });
  if (n != 1) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aerovo::mavlink;
  Parser parser;
  parser.Feed(data, size, [](const Packet& p) {
    const MessageInfo* info = FindMessageInfo(p.header.msgid);
    if (info == nullptr || p.payload.size() != info->max_length) std::abort();
    RoundTrip<Heartbeat>(p);
    RoundTrip<Attitude>(p);
    RoundTrip<GlobalPositionInt>(p);
    RoundTrip<VisionPositionEstimate>(p);
    RoundTrip<Timesync>(p);
    RoundTrip<DistanceSensor>(p);
    RoundTrip<Odometry>(p);
    RoundTrip<VisionPositionDelta>(p);
  });
  return 0;
}
