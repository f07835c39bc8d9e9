// Internal (not part of the public API): what a file is, from its first bytes. One recogniser for
// the readers' "not a ... log" errors (each names what the file is instead, and the extension
// to give it) and for ReadTelemetryFile, which reads a file without a telemetry extension by
// its content (csv_telemetry_reader.cc).
#pragma once

#include <cstddef>
#include <cstdint>
#include <istream>
#include <string>

namespace aerovo::io_detail {

/// Bytes from a file's start that RecognizeFile looks at (GPX's root element may follow an XML
/// declaration and comments; a raw MAVLink capture may start inside a packet).
constexpr std::size_t kRecognizeBytes = 1024;

/// Record timestamps of a MAVLink telemetry log (.tlog: each record an 8-byte big-endian
/// timestamp in microseconds since 1970, then a MAVLink packet) after 2100-01-01 are not a ground
/// station's clock: garbage (all-0xFD or all-0xFE bytes read as a timestamp are ~1.8e19 us).
constexpr std::uint64_t kMaxTlogTimestampUs = 4102444800ull * 1000000ull;
constexpr std::size_t kTlogTimestampBytes = 8;

/// A .tlog record may start at q (`avail` bytes from q): a timestamp that can be a ground
/// station's clock and a MAVLink 1 or 2 magic byte after it.
bool StartsTlogRecord(const unsigned char* q, std::size_t avail);

enum class FileKind {
  kUnknown,
  kDataFlash,    ///< ArduPilot DataFlash .bin: A3 95 (dataflash_reader.cc)
  kULog,         ///< PX4 ULog: "ULog" 01 12 35 (ulog_reader.cc)
  kTlog,         ///< MAVLink telemetry log: a big-endian µs timestamp, a packet (tlog_reader.cc)
  kRawMavlink,   ///< MAVLink packets back to back, without the .tlog's timestamps
  kGpx,          ///< a <gpx element in the first KiB
  kSrt,          ///< a counter line, then an SRT timing line "... --> ..."
  kUlog2CsvCsv,  ///< pyulog's ulog2csv export: a CSV whose header starts "timestamp,"
  kJpeg,
  kZip,
  kVideo,  ///< an MP4/MOV/3GP (ISO base media: a "ftyp" or "moov" box first) or Matroska/WebM file
};

/// What the first `n` bytes at `p` (up to kRecognizeBytes are used) show the file to be.
FileKind RecognizeFile(const unsigned char* p, std::size_t n);

/// Up to kRecognizeBytes from the stream's current place; the stream is put back there.
std::string ReadHead(std::istream& in);

/// The extension of a telemetry format aerovo reads by this kind (".bin", ".ulg", ".tlog",
/// ".gpx", ".srt"); "" for the others (CSV is never guessed: any text has commas).
const char* TelemetryExtension(FileKind kind);

/// What to add to a "not a ... log" error about a file of this kind: " (a PX4 ULog: name it
/// .ulg)", " (a JPEG image)", ...; "" for kUnknown.
const char* KindHint(FileKind kind);

/// KindHint of what the stream holds from its current place (put back there).
std::string HintFor(std::istream& in);

}  // namespace aerovo::io_detail
