// MAVLink 2 framing (https://mavlink.io/en/guide/serialization.html): a packet is
//   0xFD | len | incompat_flags | compat_flags | seq | sysid | compid | msgid (24 bit, LE) |
//   payload (len bytes) | checksum (16 bit, LE) [| signature (13 bytes) when incompat_flags & 1]
// The checksum is CRC-16/MCRF4XX (the X.25 CRC of MAVLink: poly 0x1021 reflected, init 0xFFFF,
// no final XOR) over every byte after the magic up to the payload's end, then the message's
// CRC_EXTRA byte (a hash of its definition, common.xml). Trailing zero bytes of the payload are
// not sent (at least one byte stays); the receiver pads the payload with zeros back to the
// message's length, which is what makes extension fields optional.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace aerovo::mavlink {

constexpr uint8_t kMagicV2 = 0xFD;
/// MAVLink 1's start byte (same page, "MAVLink 1 Packet Format"): 0xFE | len | seq | sysid |
/// compid | msgid (8 bit) | payload (len bytes, never truncated) | checksum (the same CRC over
/// len..payload, then CRC_EXTRA). aerovo reads and writes MAVLink 2 only; MAVLink 1 packets of
/// the messages it knows are recognised to be counted (ParserStats::v1_packets), not delivered.
constexpr uint8_t kMagicV1 = 0xFE;
constexpr std::size_t kHeaderBytesV1 = 6;   ///< Magic to msgid.
constexpr std::size_t kHeaderBytes = 10;    ///< Magic to msgid.
constexpr std::size_t kChecksumBytes = 2;
constexpr std::size_t kSignatureBytes = 13;
constexpr uint8_t kIncompatSigned = 0x01;
constexpr std::size_t kMaxPayloadBytes = 255;

/// CRC-16/MCRF4XX of `n` bytes, continuing from `crc` (0xFFFF to start).
uint16_t Crc16Mcrf4xx(const uint8_t* data, std::size_t n, uint16_t crc = 0xFFFF);
/// Continues `crc` with one byte.
uint16_t Crc16Accumulate(uint8_t byte, uint16_t crc);

/// Where a packet comes from / is sent as.
struct PacketHeader {
  uint8_t seq = 0;
  uint8_t sysid = 0;
  uint8_t compid = 0;
  uint32_t msgid = 0;  ///< 24 bits.
};

/// One received packet: header and payload padded with zeros to the message's full length
/// (MessageInfo::max_length), so that absent extension fields read as 0.
struct Packet {
  PacketHeader header;
  uint8_t wire_length = 0;       ///< Payload bytes that were on the wire (after truncation).
  std::vector<uint8_t> payload;  ///< Padded payload.
  bool is_signed = false;        ///< incompat_flags & kIncompatSigned: 13 signature bytes follow.
  bool mavlink1 = false;         ///< A MAVLink 1 packet (CheckFrame only; the Parser reads v2).
  std::vector<uint8_t> frame;    ///< The whole packet as received, magic to signature.
};

/// What the parser must know of a message to check it: its CRC_EXTRA and payload lengths
/// (`min_length`: the fields of MAVLink 1, `max_length`: with the extension fields).
struct MessageInfo {
  uint32_t id;
  uint8_t crc_extra;
  uint8_t min_length;
  uint8_t max_length;
};
/// The messages aerovo knows (those of messages.h), nullptr for another id.
const MessageInfo* FindMessageInfo(uint32_t msgid);

/// Frames `payload` (`length` bytes, the message's full length; trailing zeros are truncated
/// here) as a MAVLink 2 packet with `header` (msgid included) and `crc_extra`. Unsigned.
std::vector<uint8_t> EncodePacket(const PacketHeader& header, uint8_t crc_extra,
                                  const uint8_t* payload, std::size_t length);

/// What CheckFrame found at the start of a buffer.
enum class FrameStatus {
  kOk,              ///< A whole packet of a known message with the right checksum.
  kNeedMore,        ///< The buffer ends before the packet its header announces.
  kNotAFrame,       ///< No magic byte, or MAVLink 2 incompatibility flags aerovo does not know.
  kUnknownMessage,  ///< A packet of a message FindMessageInfo does not know: not checkable.
  kBadChecksum,     ///< A known message whose checksum is wrong, or longer than its definition.
};
struct FrameCheck {
  FrameStatus status = FrameStatus::kNotAFrame;
  /// Bytes of the packet, magic to checksum (and signature), once its header is in (kOk,
  /// kUnknownMessage, kBadChecksum, and kNeedMore when the header was complete); else 0.
  std::size_t size = 0;
  uint32_t msgid = 0;  ///< The packet's message id (once its header is in).
};
/// Checks the `n` bytes at `data` as one packet starting at data[0]: MAVLink 2 (0xFD) or
/// MAVLink 1 (0xFE, kMagicV1: its payload is never truncated, its length is the message's
/// MAVLink 1 length; a shorter or longer one, up to max_length, is read padded like a MAVLink 2
/// one and must still pass the checksum). On kOk `packet` (when not null) receives the header,
/// the payload padded with zeros to the message's max_length, is_signed, mavlink1 and the
/// frame. The signature of a signed packet is counted in `size`, not checked (signing.h). For
/// a file of packets (a telemetry log) where the Parser's stream state does not fit.
FrameCheck CheckFrame(const uint8_t* data, std::size_t n, Packet* packet);

/// Counts of what a Parser saw.
struct ParserStats {
  uint64_t packets = 0;        ///< Valid packets of known messages delivered.
  uint64_t crc_errors = 0;     ///< Known message id, checksum wrong (dropped, resynced).
  uint64_t unknown = 0;        ///< Candidates of other message ids (rescanned, not delivered).
  uint64_t bytes_skipped = 0;  ///< Bytes outside any packet (garbage, MAVLink 1).
  /// Of those, whole MAVLink 1 packets of a message FindMessageInfo knows (its MAVLink 1
  /// length, checksum right): an autopilot port set to MAVLink 1.
  uint64_t v1_packets = 0;
};

/// A streaming MAVLink 2 parser: bytes in one at a time (or in chunks split anywhere), packets
/// out. It resynchronises on garbage (scans for the magic byte), checks the checksum of the
/// message ids FindMessageInfo knows; a wrong one, an unknown id or unknown incompatibility
/// flags drop the candidate and rescan from the byte after its magic, so a packet hidden behind
/// a false start is still found (once the false start's claimed length has arrived: at most
/// 280 bytes of delay, as in every MAVLink parser). Signed packets are delivered with their frame;
/// the signature is checked by the link when it has a key (signing.h), not here.
/// No allocation per byte once warm.
class Parser {
 public:
  /// Feeds one byte; true when a packet is complete, then readable with packet() until the
  /// next call. After a checksum error the candidate's bytes are scanned again, so one byte can
  /// complete more than one packet: call Next() until it returns false to get the others.
  bool Push(uint8_t byte);
  /// Goes on with the bytes still to rescan; true when that completed a packet.
  bool Next();
  const Packet& packet() const { return packet_; }
  /// Feeds `n` bytes, calling on_packet(const Packet&) for each packet completed.
  template <class F>
  void Feed(const uint8_t* data, std::size_t n, F&& on_packet) {
    for (std::size_t i = 0; i < n; ++i) {
      if (Push(data[i])) on_packet(packet_);
      while (Next()) on_packet(packet_);
    }
  }
  const ParserStats& stats() const { return stats_; }

 private:
  bool Step(uint8_t byte);  // the state machine on one byte
  bool Complete();          // a whole candidate is in buf_: check and deliver
  void StepV1(uint8_t byte);  // the MAVLink 1 counter, on every byte as it arrives

  std::vector<uint8_t> v1_;  // a MAVLink 1 candidate, from its magic byte

  std::vector<uint8_t> buf_;     // the current candidate, from its magic byte
  std::size_t expected_ = 0;     // its total length once the header is in (0: not yet)
  std::vector<uint8_t> replay_;  // bytes of a rejected candidate still to scan
  std::size_t replay_pos_ = 0;
  Packet packet_;
  ParserStats stats_;
};

}  // namespace aerovo::mavlink
