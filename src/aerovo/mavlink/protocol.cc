#include "aerovo/mavlink/protocol.h"

#include <algorithm>

#include "aerovo/mavlink/messages.h"

namespace aerovo::mavlink {

uint16_t Crc16Accumulate(uint8_t byte, uint16_t crc) {
  uint8_t t = byte ^ static_cast<uint8_t>(crc & 0xFF);
  t ^= static_cast<uint8_t>(t << 4);
  return static_cast<uint16_t>((crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4));
}

uint16_t Crc16Mcrf4xx(const uint8_t* data, std::size_t n, uint16_t crc) {
  for (std::size_t i = 0; i < n; ++i) crc = Crc16Accumulate(data[i], crc);
  return crc;
}

const MessageInfo* FindMessageInfo(uint32_t msgid) {
  static const MessageInfo kKnown[] = {
      Info<Heartbeat>(),
      Info<Attitude>(),
      Info<GlobalPositionInt>(),
      Info<VisionPositionEstimate>(),
      Info<Timesync>(),
      Info<DistanceSensor>(),
      Info<GpsInput>(),
      Info<Odometry>(),
      Info<VisionPositionDelta>(),
      Info<SystemTime>(),
      Info<GpsRawInt>(),
      Info<CameraFeedback>(),
      Info<CameraImageCaptured>(),
  };
  for (const MessageInfo& m : kKnown) {
    if (m.id == msgid) return &m;
  }
  return nullptr;
}

std::vector<uint8_t> EncodePacket(const PacketHeader& h, uint8_t crc_extra, const uint8_t* payload,
                                  std::size_t length) {
  std::size_t n = length;
  while (n > 1 && payload[n - 1] == 0) --n;  // truncation keeps at least one byte
  if (length == 0) n = 0;
  std::vector<uint8_t> out(kHeaderBytes + n + kChecksumBytes);
  out[0] = kMagicV2;
  out[1] = static_cast<uint8_t>(n);
  out[2] = 0;  // incompat_flags: not signed
  out[3] = 0;  // compat_flags
  out[4] = h.seq;
  out[5] = h.sysid;
  out[6] = h.compid;
  out[7] = static_cast<uint8_t>(h.msgid & 0xFF);
  out[8] = static_cast<uint8_t>((h.msgid >> 8) & 0xFF);
  out[9] = static_cast<uint8_t>((h.msgid >> 16) & 0xFF);
  for (std::size_t i = 0; i < n; ++i) out[kHeaderBytes + i] = payload[i];
  uint16_t crc = Crc16Mcrf4xx(out.data() + 1, kHeaderBytes - 1 + n);
  crc = Crc16Accumulate(crc_extra, crc);
  out[kHeaderBytes + n] = static_cast<uint8_t>(crc & 0xFF);
  out[kHeaderBytes + n + 1] = static_cast<uint8_t>(crc >> 8);
  return out;
}

FrameCheck CheckFrame(const uint8_t* data, std::size_t n, Packet* packet) {
  FrameCheck r;
  if (n == 0 || (data[0] != kMagicV2 && data[0] != kMagicV1)) return r;
  const bool v1 = data[0] == kMagicV1;
  const std::size_t header = v1 ? kHeaderBytesV1 : kHeaderBytes;
  if (n < header) {
    r.status = FrameStatus::kNeedMore;
    return r;
  }
  const std::size_t len = data[1];
  const bool is_signed = !v1 && (data[2] & kIncompatSigned) != 0;
  if (!v1 && (data[2] & ~kIncompatSigned) != 0) return r;  // a flag aerovo cannot honour
  r.size = header + len + kChecksumBytes + (is_signed ? kSignatureBytes : 0);
  const uint32_t msgid =
      v1 ? data[5]
         : data[7] | (static_cast<uint32_t>(data[8]) << 8) | (static_cast<uint32_t>(data[9]) << 16);
  r.msgid = msgid;
  if (n < r.size) {
    r.status = FrameStatus::kNeedMore;
    return r;
  }
  const MessageInfo* info = FindMessageInfo(msgid);
  if (info == nullptr) {
    r.status = FrameStatus::kUnknownMessage;
    return r;
  }
  uint16_t crc = Crc16Mcrf4xx(data + 1, header - 1 + len);
  crc = Crc16Accumulate(info->crc_extra, crc);
  const uint16_t got = data[header + len] | static_cast<uint16_t>(data[header + len + 1] << 8);
  if (len > info->max_length || crc != got) {
    r.status = FrameStatus::kBadChecksum;
    return r;
  }
  r.status = FrameStatus::kOk;
  if (packet != nullptr) {
    packet->header.seq = data[v1 ? 2 : 4];
    packet->header.sysid = data[v1 ? 3 : 5];
    packet->header.compid = data[v1 ? 4 : 6];
    packet->header.msgid = msgid;
    packet->wire_length = static_cast<uint8_t>(len);
    packet->payload.assign(info->max_length, 0);
    std::copy(data + header, data + header + len, packet->payload.begin());
    packet->is_signed = is_signed;
    packet->mavlink1 = v1;
    packet->frame.assign(data, data + r.size);
  }
  return r;
}

void Parser::StepV1(uint8_t byte) {
  if (v1_.empty() && byte != kMagicV1) return;
  v1_.push_back(byte);
  // Whole candidates (as many bytes as their length says) are checked; a false start (0xFE
  // inside other bytes) is dropped and the rest rescanned from the next 0xFE in it, so a packet
  // behind it is still counted. At most 263 bytes are held.
  while (v1_.size() >= 2 && v1_.size() >= kHeaderBytesV1 + v1_[1] + kChecksumBytes) {
    const std::size_t len = v1_[1];
    const MessageInfo* info = FindMessageInfo(v1_[5]);
    if (info != nullptr && len == info->min_length) {
      uint16_t crc = Crc16Mcrf4xx(v1_.data() + 1, kHeaderBytesV1 - 1 + len);
      crc = Crc16Accumulate(info->crc_extra, crc);
      const uint16_t got =
          v1_[kHeaderBytesV1 + len] | static_cast<uint16_t>(v1_[kHeaderBytesV1 + len + 1] << 8);
      if (crc == got) {
        ++stats_.v1_packets;
        v1_.erase(v1_.begin(),
                  v1_.begin() + static_cast<std::ptrdiff_t>(kHeaderBytesV1 + len + kChecksumBytes));
        v1_.erase(v1_.begin(), std::find(v1_.begin(), v1_.end(), kMagicV1));
        continue;
      }
    }
    v1_.erase(v1_.begin(), std::find(v1_.begin() + 1, v1_.end(), kMagicV1));
  }
}

bool Parser::Push(uint8_t byte) {
  StepV1(byte);
  if (replay_pos_ < replay_.size()) {
    // Bytes of a rejected candidate come first: keep the order of the stream.
    replay_.push_back(byte);
    return Next();
  }
  return Step(byte);
}

bool Parser::Next() {
  while (replay_pos_ < replay_.size()) {
    const uint8_t b = replay_[replay_pos_++];
    if (Step(b)) return true;
  }
  replay_.clear();
  replay_pos_ = 0;
  return false;
}

bool Parser::Step(uint8_t byte) {
  if (buf_.empty()) {
    if (byte != kMagicV2) {
      ++stats_.bytes_skipped;
      return false;
    }
    buf_.push_back(byte);
    return false;
  }
  buf_.push_back(byte);
  if (buf_.size() == 3) {
    const std::size_t len = buf_[1];
    const bool is_signed = (buf_[2] & kIncompatSigned) != 0;
    expected_ = kHeaderBytes + len + kChecksumBytes + (is_signed ? kSignatureBytes : 0);
  }
  if (expected_ != 0 && buf_.size() == expected_) return Complete();
  return false;
}

bool Parser::Complete() {
  const std::size_t len = buf_[1];
  const uint32_t msgid = buf_[7] | (static_cast<uint32_t>(buf_[8]) << 8) |
                         (static_cast<uint32_t>(buf_[9]) << 16);
  const MessageInfo* info = FindMessageInfo(msgid);
  bool ok = false;
  if (info == nullptr) {
    // Cannot be checked: counted, and its bytes after the magic scanned again like a bad
    // candidate's (a false magic in noise looks like an unknown id; a real packet of another
    // message only costs the rescan, a false packet inside it would need a valid CRC).
    ++stats_.unknown;
  } else if (len <= info->max_length && (buf_[2] & ~kIncompatSigned) == 0) {
    uint16_t crc = Crc16Mcrf4xx(buf_.data() + 1, kHeaderBytes - 1 + len);
    crc = Crc16Accumulate(info->crc_extra, crc);
    const uint16_t got = buf_[kHeaderBytes + len] |
                         static_cast<uint16_t>(buf_[kHeaderBytes + len + 1] << 8);
    ok = crc == got;
  }
  if (!ok) {
    if (info != nullptr) ++stats_.crc_errors;
    ++stats_.bytes_skipped;  // the magic
    // Scan the candidate's bytes after its magic again, before what is still to replay.
    std::vector<uint8_t> rest(buf_.begin() + 1, buf_.end());
    rest.insert(rest.end(), replay_.begin() + static_cast<std::ptrdiff_t>(replay_pos_),
                replay_.end());
    replay_.swap(rest);
    replay_pos_ = 0;
    buf_.clear();
    expected_ = 0;
    return false;
  }
  packet_.header.seq = buf_[4];
  packet_.header.sysid = buf_[5];
  packet_.header.compid = buf_[6];
  packet_.header.msgid = msgid;
  packet_.wire_length = static_cast<uint8_t>(len);
  packet_.payload.assign(info->max_length, 0);
  for (std::size_t i = 0; i < len; ++i) packet_.payload[i] = buf_[kHeaderBytes + i];
  packet_.is_signed = (buf_[2] & kIncompatSigned) != 0;
  packet_.frame.assign(buf_.begin(), buf_.end());
  ++stats_.packets;
  buf_.clear();
  expected_ = 0;
  return true;
}

}  // namespace aerovo::mavlink
