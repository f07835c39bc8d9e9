#include "aerovo/mavlink/signing.h"

#include <openssl/sha.h>
#include <sys/stat.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo::mavlink {
namespace {

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

uint64_t ReadLe48(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 5; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

SigningKey ParseSigningKey(const std::string& text, const std::string& source) {
  std::size_t begin = 0, end = text.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  const std::size_t digits = end - begin;
  if (digits != 2 * kSigningKeyBytes) {
    throw InputError(fmt::format(
        "MAVLink key file '{}': {} characters, expected the 32-byte key as 64 hexadecimal digits "
        "(docs/autopilot.md, Message signing)",
        source, digits));
  }
  SigningKey key{};
  for (std::size_t i = 0; i < kSigningKeyBytes; ++i) {
    const int hi = HexDigit(text[begin + 2 * i]);
    const int lo = HexDigit(text[begin + 2 * i + 1]);
    if (hi < 0 || lo < 0) {
      throw InputError(fmt::format(
          "MAVLink key file '{}': character {} is not a hexadecimal digit (the key is 64 "
          "hexadecimal digits)",
          source, begin + 2 * i + (hi < 0 ? 1 : 2)));
    }
    key[i] = static_cast<uint8_t>(hi * 16 + lo);
  }
  return key;
}

SigningKey ReadSigningKey(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    throw InputError(fmt::format("MAVLink key file '{}': {}", path, std::strerror(errno)));
  }
  if (!S_ISREG(st.st_mode)) {
    throw InputError(fmt::format("MAVLink key file '{}': not a regular file", path));
  }
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    throw InputError(fmt::format(
        "MAVLink key file '{}': mode {:03o} lets group or others access the secret key; "
        "allow the owner only (chmod 600 '{}')",
        path, static_cast<unsigned>(st.st_mode & 0777), path));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("MAVLink key file '{}': cannot be read", path));
  std::ostringstream text;
  // A key file is 65 bytes; read a little more than that to name a wrong length, not more.
  char buf[256];
  in.read(buf, sizeof(buf));
  text.write(buf, in.gcount());
  if (in.gcount() == static_cast<std::streamsize>(sizeof(buf))) {
    throw InputError(
        fmt::format("MAVLink key file '{}': larger than a key (64 hexadecimal digits)", path));
  }
  return ParseSigningKey(text.str(), path);
}

uint64_t SigningTimestampFromUnixS(double unix_s) {
  const double t = (unix_s - static_cast<double>(kSigningEpochUnixS)) * 1e5;
  if (!(t > 0.0)) return 0;
  return static_cast<uint64_t>(std::floor(t));
}

std::array<uint8_t, kSignatureValueBytes> ComputeSignature(const SigningKey& key,
                                                           const uint8_t* bytes, std::size_t n) {
  // Key and packet in one buffer: at most 32 + 10 + 255 + 2 + 7 bytes.
  uint8_t buf[kSigningKeyBytes + kHeaderBytes + kMaxPayloadBytes + kChecksumBytes + 7];
  if (n > sizeof(buf) - kSigningKeyBytes) {
    throw InvalidArgument("ComputeSignature: more bytes than a MAVLink packet");
  }
  std::memcpy(buf, key.data(), kSigningKeyBytes);
  std::memcpy(buf + kSigningKeyBytes, bytes, n);
  uint8_t digest[SHA256_DIGEST_LENGTH];
  SHA256(buf, kSigningKeyBytes + n, digest);
  std::array<uint8_t, kSignatureValueBytes> out{};
  std::memcpy(out.data(), digest, kSignatureValueBytes);
  return out;
}

void SignPacket(std::vector<uint8_t>* packet, uint8_t crc_extra, const SigningKey& key,
                uint8_t link_id, uint64_t timestamp) {
  std::vector<uint8_t>& p = *packet;
  if (p.size() < kHeaderBytes + kChecksumBytes || p[0] != kMagicV2 ||
      p.size() != kHeaderBytes + p[1] + kChecksumBytes) {
    throw InvalidArgument("SignPacket: not an unsigned MAVLink 2 packet");
  }
  const std::size_t len = p[1];
  p[2] |= kIncompatSigned;
  uint16_t crc = Crc16Mcrf4xx(p.data() + 1, kHeaderBytes - 1 + len);
  crc = Crc16Accumulate(crc_extra, crc);
  p[kHeaderBytes + len] = static_cast<uint8_t>(crc & 0xFF);
  p[kHeaderBytes + len + 1] = static_cast<uint8_t>(crc >> 8);
  p.push_back(link_id);
  for (int i = 0; i < 6; ++i) p.push_back(static_cast<uint8_t>((timestamp >> (8 * i)) & 0xFF));
  const auto sig = ComputeSignature(key, p.data(), p.size());
  p.insert(p.end(), sig.begin(), sig.end());
}

std::optional<uint64_t> ReadSigningTimestamp(const std::string& path, std::string* problem) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    struct stat st {};
    if (stat(path.c_str(), &st) != 0 && errno == ENOENT) return std::nullopt;
    if (problem) *problem = fmt::format("MAVLink signing timestamp file '{}': cannot be read", path);
    return std::nullopt;
  }
  char buf[64];
  in.read(buf, sizeof(buf));
  const std::string text(buf, static_cast<std::size_t>(in.gcount()));
  std::size_t i = 0;
  uint64_t value = 0;
  while (i < text.size() && text[i] >= '0' && text[i] <= '9' && value <= kMaxSigningTimestamp) {
    value = value * 10 + static_cast<uint64_t>(text[i] - '0');
    ++i;
  }
  std::size_t end = i;
  while (end < text.size() && std::isspace(static_cast<unsigned char>(text[end]))) ++end;
  if (i == 0 || end != text.size() || value > kMaxSigningTimestamp) {
    if (problem) {
      *problem = fmt::format(
          "MAVLink signing timestamp file '{}': not one decimal timestamp of at most 48 bits; "
          "ignored (the timestamps start from the clock)",
          path);
    }
    return std::nullopt;
  }
  return value;
}

void WriteSigningTimestamp(const std::string& path, uint64_t timestamp) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << timestamp << "\n";
    out.flush();
    if (!out) {
      throw InputError(
          fmt::format("MAVLink signing timestamp file '{}': cannot be written", tmp));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw InputError(fmt::format("MAVLink signing timestamp file '{}': {}", path,
                                 std::strerror(errno)));
  }
}

uint64_t SigningState::local_timestamp() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return local_timestamp_;
}

void SigningState::Sign(std::vector<uint8_t>* packet, uint8_t crc_extra, double unix_now_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  local_timestamp_ = std::max(SigningTimestampFromUnixS(unix_now_s), local_timestamp_ + 1);
  SignPacket(packet, crc_extra, key_, link_id_, local_timestamp_);
}

SignatureCheck SigningState::Check(const Packet& packet, double unix_now_s) {
  if (!packet.is_signed) return SignatureCheck::kUnsigned;
  const std::vector<uint8_t>& f = packet.frame;
  if (f.size() < kSignatureBytes) return SignatureCheck::kBadSignature;
  const std::size_t value_at = f.size() - kSignatureValueBytes;
  const auto want = ComputeSignature(key_, f.data(), value_at);
  // Not a secret-dependent early exit: compare every byte.
  uint8_t diff = 0;
  for (std::size_t i = 0; i < kSignatureValueBytes; ++i) diff |= want[i] ^ f[value_at + i];
  if (diff != 0) return SignatureCheck::kBadSignature;
  const uint8_t link_id = f[f.size() - kSignatureBytes];
  const uint64_t timestamp = ReadLe48(f.data() + f.size() - kSignatureBytes + 1);
  const auto stream = std::make_tuple(packet.header.sysid, packet.header.compid, link_id);
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = streams_.find(stream);
  if (it != streams_.end()) {
    if (timestamp <= it->second) return SignatureCheck::kReplayed;
  } else {
    const uint64_t local = std::max(local_timestamp_, SigningTimestampFromUnixS(unix_now_s));
    if (timestamp + kSigningNewStreamWindow < local) return SignatureCheck::kReplayed;
  }
  streams_[stream] = timestamp;
  local_timestamp_ = std::max(local_timestamp_, timestamp);
  return SignatureCheck::kAccepted;
}

}  // namespace aerovo::mavlink
