#include "aerovo/telemetry/file_kind.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace aerovo::io_detail {
namespace {

FileKind Kind(const std::string& bytes) {
  return RecognizeFile(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
}

// A MAVLink 1 packet of `payload` bytes (the checksum is not looked at).
std::string V1(int payload) {
  std::string p = {'\xFE', static_cast<char>(payload), '\x00', '\x01', '\x01', '\x1E'};
  p += std::string(static_cast<std::size_t>(payload) + 2, '\x11');
  return p;
}

// A MAVLink 2 packet of `payload` bytes, signed or not.
std::string V2(int payload, bool is_signed = false) {
  std::string p = {'\xFD',
                   static_cast<char>(payload),
                   is_signed ? '\x01' : '\x00',
                   '\x00',
                   '\x07',
                   '\x01',
                   '\x01',
                   '\x21',
                   '\x00',
                   '\x00'};
  p += std::string(static_cast<std::size_t>(payload) + 2 + (is_signed ? 13 : 0), '\x22');
  return p;
}

TEST(FileKind, BinaryLogsByTheirMagic) {
  EXPECT_EQ(Kind(std::string("\xA3\x95\x80\x80\x59", 5)), FileKind::kDataFlash);
  EXPECT_EQ(Kind(std::string("ULog\x01\x12\x35\x01", 8)), FileKind::kULog);
  EXPECT_EQ(Kind("ULog is a word"), FileKind::kUnknown);  // the magic is 7 bytes
  // A .tlog: 2026-12-06 in big-endian microseconds, then a MAVLink 2 packet's magic.
  EXPECT_EQ(Kind(std::string("\x00\x06\x61\xEB\xCA\x54\x60\x00\xFD\x1C", 10)), FileKind::kTlog);
  // A "timestamp" after 2100 is no ground station's clock.
  EXPECT_EQ(Kind(std::string("\x10\x00\x00\x00\x00\x00\x00\x00\xFD\x1C", 10)), FileKind::kUnknown);
  EXPECT_EQ(Kind(std::string("\xFF\xD8\xFF\xE0\x00\x10JFIF", 10)), FileKind::kJpeg);
  EXPECT_EQ(Kind(std::string("PK\x03\x04\x14\x00", 6)), FileKind::kZip);
  EXPECT_EQ(Kind(""), FileKind::kUnknown);
}

// Video containers (a DJI video given as telemetry holds its captions in a text track): an ISO
// base media file's first box (ISO/IEC 14496-12 section 4.2) and Matroska's EBML magic.
TEST(FileKind, VideoContainers) {
  // DJI's MP4: a 32-byte "ftyp" box of brand "isom"; a QuickTime MOV: "ftyp" brand "qt  ".
  EXPECT_EQ(Kind(std::string("\x00\x00\x00\x20"
                             "ftypisom\x00\x00\x02\x00",
                             16)),
            FileKind::kVideo);
  EXPECT_EQ(Kind(std::string("\x00\x00\x00\x14"
                             "ftypqt  ",
                             12)),
            FileKind::kVideo);
  // An old QuickTime file starting with its "moov" box, one with a 64-bit "mdat" size (1).
  EXPECT_EQ(Kind(std::string("\x00\x01\x02\x03moov", 8)), FileKind::kVideo);
  EXPECT_EQ(Kind(std::string("\x00\x00\x00\x01mdat", 8)), FileKind::kVideo);
  // Matroska / WebM: the EBML header's ID.
  EXPECT_EQ(Kind(std::string("\x1A\x45\xDF\xA3\x9F\x42\x86\x81", 8)), FileKind::kVideo);
  // A box size of 2..7 is no box; another type is no ISO file.
  EXPECT_EQ(Kind(std::string("\x00\x00\x00\x04"
                             "ftypisom",
                             12)),
            FileKind::kUnknown);
  EXPECT_EQ(Kind(std::string("\x00\x00\x00\x20"
                             "ftup",
                             8)),
            FileKind::kUnknown);
  EXPECT_NE(std::string(KindHint(FileKind::kVideo)).find("subtitle track"), std::string::npos);
  EXPECT_STREQ(TelemetryExtension(FileKind::kVideo), "");
}

// A raw capture of a link: packets back to back without timestamps, from the first byte or from
// inside a packet the capture started in (node-mavlink's examples/GH-5.bin starts 5 bytes before
// its first packet).
TEST(FileKind, RawMavlinkCaptures) {
  EXPECT_EQ(Kind(V2(28) + V2(9) + V2(30, true) + V2(4)), FileKind::kRawMavlink);
  EXPECT_EQ(Kind(V1(62) + V1(22) + V1(37)), FileKind::kRawMavlink);
  EXPECT_EQ(Kind(std::string("\x00\x00\x00\x21\xB4", 5) + V1(62) + V1(22) + V1(37)),
            FileKind::kRawMavlink);
  // Two packets are not enough, nor packets of mixed versions, nor a magic byte in text.
  EXPECT_EQ(Kind(V2(28) + V2(9)), FileKind::kUnknown);
  EXPECT_EQ(Kind(V2(28) + V1(9) + V2(3)), FileKind::kUnknown);
  EXPECT_EQ(Kind("time,lat,lon\n\xFE,1,2\n"), FileKind::kUnknown);
  // A MAVLink 2 header with an undefined incompatibility flag is no packet.
  std::string bad = V2(28);
  bad[2] = '\x02';
  EXPECT_EQ(Kind(bad + V2(9) + V2(3)), FileKind::kUnknown);
}

TEST(FileKind, TextFormats) {
  EXPECT_EQ(Kind("\xEF\xBB\xBF<?xml version=\"1.0\"?>\n<!-- a track -->\n<gpx version=\"1.1\">"),
            FileKind::kGpx);
  EXPECT_EQ(Kind("1\n00:00:00,000 --> 00:00:00,033\n<font size=\"28\">"), FileKind::kSrt);
  EXPECT_EQ(Kind("\r\n1\r\n00:00:00,000 --> 00:00:00,033\r\n"), FileKind::kSrt);
  EXPECT_EQ(Kind("1\nhello\n"), FileKind::kUnknown);
  EXPECT_EQ(Kind("timestamp,lat,lon,alt\n1000,475000000,85000000,500\n"), FileKind::kUlog2CsvCsv);
  EXPECT_EQ(Kind("time_s,lat,lon\n0,47.5,8.5\n"), FileKind::kUnknown);  // CSV is never guessed
}

TEST(FileKind, ExtensionsAndHints) {
  EXPECT_STREQ(TelemetryExtension(FileKind::kDataFlash), ".bin");
  EXPECT_STREQ(TelemetryExtension(FileKind::kULog), ".ulg");
  EXPECT_STREQ(TelemetryExtension(FileKind::kTlog), ".tlog");
  EXPECT_STREQ(TelemetryExtension(FileKind::kGpx), ".gpx");
  EXPECT_STREQ(TelemetryExtension(FileKind::kSrt), ".srt");
  for (const FileKind k : {FileKind::kUnknown, FileKind::kRawMavlink, FileKind::kUlog2CsvCsv,
                           FileKind::kJpeg, FileKind::kZip}) {
    EXPECT_STREQ(TelemetryExtension(k), "") << static_cast<int>(k);
  }
  EXPECT_STREQ(KindHint(FileKind::kULog), " (a PX4 ULog: name it .ulg)");
  EXPECT_STREQ(KindHint(FileKind::kUnknown), "");
}

// ReadHead leaves the stream where it was, whatever the file's size.
TEST(FileKind, ReadHeadPutsTheStreamBack) {
  std::istringstream small("ULog\x01\x12\x35");
  EXPECT_EQ(ReadHead(small), "ULog\x01\x12\x35");
  EXPECT_EQ(small.tellg(), 0);
  std::istringstream large(std::string(5000, 'x'));
  large.seekg(10);
  EXPECT_EQ(ReadHead(large).size(), kRecognizeBytes);
  EXPECT_EQ(large.tellg(), 10);
  EXPECT_EQ(HintFor(small), " (a PX4 ULog: name it .ulg)");
}

}  // namespace
}  // namespace aerovo::io_detail
