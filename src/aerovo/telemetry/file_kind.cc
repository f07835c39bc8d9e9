#include "aerovo/telemetry/file_kind.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "aerovo/mavlink/protocol.h"

namespace aerovo::io_detail {
namespace {

namespace mav = aerovo::mavlink;

// Consecutive MAVLink packets, each starting where the one before ends, that make a raw capture
// (one magic byte followed by a plausible length happens by chance; three chained rarely).
constexpr int kChainedPackets = 3;

// The length of the MAVLink packet (1 or 2) starting at p, or 0 when no packet starts there or
// its header is not all within n bytes.
std::size_t PacketLength(const unsigned char* p, std::size_t n) {
  if (n < mav::kHeaderBytesV1) return 0;
  if (p[0] == mav::kMagicV1) return mav::kHeaderBytesV1 + p[1] + mav::kChecksumBytes;
  if (p[0] != mav::kMagicV2 || n < mav::kHeaderBytes) return 0;
  if ((p[2] & ~mav::kIncompatSigned) != 0) return 0;  // no other incompatibility flag is defined
  return mav::kHeaderBytes + p[1] + mav::kChecksumBytes +
         ((p[2] & mav::kIncompatSigned) ? mav::kSignatureBytes : 0);
}

// kChainedPackets packets of the same MAVLink version back to back from p.
bool ChainedPackets(const unsigned char* p, std::size_t n) {
  std::size_t at = 0;
  for (int k = 0; k < kChainedPackets; ++k) {
    if (at >= n || p[at] != p[0]) return false;
    const std::size_t len = PacketLength(p + at, n - at);
    if (len == 0) return false;
    at += len;
  }
  return true;
}

// An ISO base media file (ISO/IEC 14496-12 section 4.2: each box a big-endian 32-bit size, 1 for
// a 64-bit size after the type, 0 to the file's end, then a four-letter type): MP4, MOV and 3GP
// start with "ftyp"; QuickTime files written before it with "moov", "mdat", "free", "skip",
// "wide" or "pnot".
bool IsoMedia(const unsigned char* p, std::size_t n) {
  if (n < 8) return false;
  const std::uint32_t size = (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) |
                             (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  if (size != 0 && size != 1 && size < 8) return false;
  const std::string_view type(reinterpret_cast<const char*>(p + 4), 4);
  for (const char* t : {"ftyp", "moov", "mdat", "free", "skip", "wide", "pnot"}) {
    if (type == t) return true;
  }
  return false;
}

bool Srt(std::string_view text) {
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos || !std::isdigit(static_cast<unsigned char>(text[first]))) {
    return false;
  }
  const std::size_t eol = text.find('\n', first);
  if (eol == std::string_view::npos ||
      text.substr(first, eol - first).find_first_not_of("0123456789\r \t") !=
          std::string_view::npos) {
    return false;
  }
  const std::size_t eol2 = text.find('\n', eol + 1);
  return text.substr(eol + 1, eol2 == std::string_view::npos ? eol2 : eol2 - eol - 1).find("-->") !=
         std::string_view::npos;
}

}  // namespace

bool StartsTlogRecord(const unsigned char* q, std::size_t avail) {
  if (avail <= kTlogTimestampBytes) return false;
  std::uint64_t us = 0;
  for (std::size_t k = 0; k < kTlogTimestampBytes; ++k) us = (us << 8) | q[k];
  return us <= kMaxTlogTimestampUs &&
         (q[kTlogTimestampBytes] == mav::kMagicV2 || q[kTlogTimestampBytes] == mav::kMagicV1);
}

FileKind RecognizeFile(const unsigned char* p, std::size_t n) {
  n = std::min(n, kRecognizeBytes);
  const auto starts = [&](std::string_view magic) {
    return n >= magic.size() && std::memcmp(p, magic.data(), magic.size()) == 0;
  };
  if (starts("\xA3\x95")) return FileKind::kDataFlash;
  if (starts(std::string_view("ULog\x01\x12\x35", 7))) return FileKind::kULog;
  if (starts("\xFF\xD8\xFF")) return FileKind::kJpeg;
  if (starts("PK\x03\x04")) return FileKind::kZip;
  if (IsoMedia(p, n) || starts("\x1A\x45\xDF\xA3")) return FileKind::kVideo;  // EBML: Matroska
  if (StartsTlogRecord(p, n)) return FileKind::kTlog;
  // A raw capture: packets from the first byte, or from within the first packet's length (the
  // capture started inside one).
  const std::size_t longest =
      mav::kHeaderBytes + mav::kMaxPayloadBytes + mav::kChecksumBytes + mav::kSignatureBytes;
  for (std::size_t k = 0; k < std::min(n, longest); ++k) {
    if ((p[k] == mav::kMagicV1 || p[k] == mav::kMagicV2) && ChainedPackets(p + k, n - k)) {
      return FileKind::kRawMavlink;
    }
  }
  std::string_view text(reinterpret_cast<const char*>(p), n);
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.remove_prefix(3);  // a UTF-8 byte order mark
  if (text.find("<gpx") != std::string_view::npos) return FileKind::kGpx;
  if (Srt(text)) return FileKind::kSrt;
  if (text.rfind("timestamp,", 0) == 0) return FileKind::kUlog2CsvCsv;
  return FileKind::kUnknown;
}

std::string ReadHead(std::istream& in) {
  std::string head(kRecognizeBytes, '\0');
  const std::streampos start = in.tellg();
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  in.clear();
  in.seekg(start);
  return head;
}

std::string HintFor(std::istream& in) {
  const std::string head = ReadHead(in);
  return KindHint(RecognizeFile(reinterpret_cast<const unsigned char*>(head.data()), head.size()));
}

const char* TelemetryExtension(FileKind kind) {
  switch (kind) {
    case FileKind::kDataFlash:
      return ".bin";
    case FileKind::kULog:
      return ".ulg";
    case FileKind::kTlog:
      return ".tlog";
    case FileKind::kGpx:
      return ".gpx";
    case FileKind::kSrt:
      return ".srt";
    default:
      return "";
  }
}

const char* KindHint(FileKind kind) {
  switch (kind) {
    case FileKind::kDataFlash:
      return " (an ArduPilot DataFlash log: name it .bin)";
    case FileKind::kULog:
      return " (a PX4 ULog: name it .ulg)";
    case FileKind::kTlog:
      return " (a MAVLink telemetry log: name it .tlog)";
    case FileKind::kRawMavlink:
      return " (MAVLink packets without timestamps: a raw capture of the link, not a telemetry "
             "log; a ground station records a .tlog)";
    case FileKind::kGpx:
      return " (a GPX track: name it .gpx)";
    case FileKind::kSrt:
      return " (DJI SRT subtitles: name it .srt)";
    case FileKind::kUlog2CsvCsv:
      return " (a ulog2csv export: name it .csv)";
    case FileKind::kJpeg:
      return " (a JPEG image)";
    case FileKind::kZip:
      return " (a ZIP archive)";
    case FileKind::kVideo:
      return " (a video file: `aerovo run` and `aerovo telemetry` read the DJI captions of its "
             "subtitle track as telemetry)";
    case FileKind::kUnknown:
      break;
  }
  return "";
}

}  // namespace aerovo::io_detail
