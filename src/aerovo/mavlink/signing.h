// MAVLink 2 message signing (https://mavlink.io/en/guide/message_signing.html). A signed packet
// has bit 0x01 of incompat_flags set (covered by the checksum) and 13 bytes after the checksum:
//   link_id (8 bit) | timestamp (48 bit, LE, 10 us units since 2015-01-01 00:00:00 UTC) |
//   signature (48 bit): the first 6 bytes of SHA-256(secret_key (32 bytes) + header + payload +
//   checksum + link_id + timestamp), i.e. of the key followed by every byte of the packet from
//   its magic up to the signature itself.
// Timestamps: a sender's timestamps increase by at least 1 per packet; a receiver keeps the last
// timestamp of every stream (sysid, compid, link_id) and rejects a packet whose timestamp is not
// after it (a replay), and a packet that opens a stream with a timestamp more than one minute
// (6,000,000 units) behind its own local timestamp; the local timestamp is the largest of the
// clock, the last one sent and the last one accepted. SHA-256 is OpenSSL's libcrypto.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "aerovo/mavlink/protocol.h"

namespace aerovo::mavlink {

constexpr std::size_t kSigningKeyBytes = 32;
constexpr std::size_t kSignatureValueBytes = 6;
/// 2015-01-01 00:00:00 UTC, the origin of signing timestamps, in Unix seconds.
constexpr int64_t kSigningEpochUnixS = 1420070400;
/// One minute in timestamp units (10 us): how far behind the local timestamp a new stream may be.
constexpr uint64_t kSigningNewStreamWindow = 6000000;

using SigningKey = std::array<uint8_t, kSigningKeyBytes>;

/// The key file of --mavlink-key: 64 hexadecimal digits (the 32 key bytes in order, upper or
/// lower case) and nothing else but whitespace around them (a final newline). The file must be a
/// regular file that neither group nor others may read, write or execute (mode 600 or 400).
/// InputError naming `path` for a missing or unreadable file, wrong permissions, wrong length or
/// a character that is not a hex digit.
SigningKey ReadSigningKey(const std::string& path);
/// The key in `text` (the file format above); InputError naming `source` when it is not one.
SigningKey ParseSigningKey(const std::string& text, const std::string& source);

/// The signing timestamp of Unix time `unix_s` (10 us units since 2015-01-01 UTC; 0 before).
uint64_t SigningTimestampFromUnixS(double unix_s);
/// The largest signing timestamp (48 bits).
constexpr uint64_t kMaxSigningTimestamp = (uint64_t{1} << 48) - 1;
/// The signing timestamp kept across runs (the MAVLink guide's "Timestamp handling": a signing
/// system stores its timestamp persistently, at least once a minute, and starts from the larger
/// of its clock and the stored one, so that a restart on a companion whose clock is behind, e.g.
/// one without a real-time clock, does not send timestamps the autopilot already saw from this
/// stream and rejects as replays). The file: one decimal number (the timestamp, 10 us units since
/// 2015-01-01 UTC) and a newline. nullopt when the file does not exist; when it exists but is not
/// such a number (or larger than 48 bits) also nullopt, with `problem` (may be null) set to a
/// sentence naming the file: the run goes on from the clock.
std::optional<uint64_t> ReadSigningTimestamp(const std::string& path, std::string* problem);
/// Writes `timestamp` to `path` in that format, atomically (a temporary file in the same folder,
/// then rename: a power cut leaves the old or the new file, never a truncated one). InputError
/// naming the file when it cannot be written.
void WriteSigningTimestamp(const std::string& path, uint64_t timestamp);

/// The 6-byte signature of `n` packet bytes (from the magic through link_id and timestamp).
std::array<uint8_t, kSignatureValueBytes> ComputeSignature(const SigningKey& key,
                                                           const uint8_t* bytes, std::size_t n);

/// Signs the unsigned packet `packet` (as EncodePacket writes it, `crc_extra` its message's):
/// sets the signed flag, recomputes the checksum, appends link_id, timestamp and signature.
void SignPacket(std::vector<uint8_t>* packet, uint8_t crc_extra, const SigningKey& key,
                uint8_t link_id, uint64_t timestamp);

/// The verdict on a received packet.
enum class SignatureCheck {
  kAccepted,      ///< Signed with the key, timestamp after its stream's last one.
  kUnsigned,      ///< No signature.
  kBadSignature,  ///< Signed, but not with the key (forged or corrupted).
  kReplayed,      ///< Signed with the key, but its timestamp is not after its stream's last
                  ///< one, or it opens a stream more than a minute behind the local timestamp.
};

/// One link's signing: the key, our link id, the timestamp of what we send and the last
/// timestamp of every stream we accepted. Thread-safe (sending and receiving threads).
class SigningState {
 public:
  /// `initial_timestamp`: a stored timestamp (ReadSigningTimestamp); the first packet is signed
  /// after it even when the clock is behind.
  SigningState(const SigningKey& key, uint8_t link_id, uint64_t initial_timestamp = 0)
      : key_(key), link_id_(link_id), local_timestamp_(initial_timestamp) {}
  /// The local timestamp: the last sent or accepted, whichever is larger (what is stored).
  uint64_t local_timestamp() const;
  /// Signs `packet` (unsigned, message CRC_EXTRA `crc_extra`) with the next timestamp: the
  /// larger of the clock (`unix_now_s`) and one after the local timestamp.
  void Sign(std::vector<uint8_t>* packet, uint8_t crc_extra, double unix_now_s);
  /// Checks `packet` (as Parser delivers it, with its frame); on kAccepted records its stream's
  /// timestamp and moves the local timestamp up to it.
  SignatureCheck Check(const Packet& packet, double unix_now_s);

 private:
  SigningKey key_;
  uint8_t link_id_;
  mutable std::mutex mutex_;
  uint64_t local_timestamp_ = 0;  // the last sent or accepted, whichever is larger
  std::map<std::tuple<uint8_t, uint8_t, uint8_t>, uint64_t> streams_;  // (sysid, compid, link)
};

}  // namespace aerovo::mavlink
