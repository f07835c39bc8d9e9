// Internal helpers shared by the io readers (not part of the public API): strict integer
// parsing (decimal numbers: ParseDecimal, core/text.h), ISO 8601 / EXIF dates, and the
// strict-or-lenient error policy.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/core/text.h"  // TrimSpace, ParseDecimal: the readers' numbers
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::io_detail {

std::string ToLower(std::string_view s);

std::optional<long long> ParseInt(std::string_view s);
/// True for a whole number in [0, 1e8]: a frame index (the range is checked before any cast, as
/// converting a double outside an integer's range is undefined; NaN is not a frame number).
inline bool IsFrameNumber(double v) { return v >= 0.0 && v <= 1e8 && v == std::floor(v); }

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's days_from_civil).
long long DaysFromCivil(int y, int m, int d);

/// "YYYY-MM-DD[T ]HH:MM:SS[.fff][Z|+HH:MM|-HH:MM|+HHMM]" -> seconds since the epoch (UTC; no
/// zone = UTC). Also accepts "YYYY:MM:DD HH:MM:SS" (EXIF), "YYYY.MM.DD HH:MM:SS" (old DJI),
/// "YYYY/MM/DD HH:MM:SS.fff" (CUSTOM.updateTime of DJI flight record CSVs) and a DJI SRT tail
/// ",mmm,uuu" (milliseconds, microseconds). nullopt when malformed or a
/// field is out of range.
std::optional<double> ParseDateTime(std::string_view s);

/// A CSV header cell split into an optional source prefix, a base name and an optional unit,
/// all trimmed and lower-case: "OSD.height [ft]" -> {"osd", "height", "ft"},
/// "time(millisecond)" -> {"", "time", "millisecond"}, "lat_deg" -> {"", "lat", "deg"}. The
/// unit is written "name(unit)" or "name [unit]"; else a last "_unit" is split off when
/// it is a unit the CSV telemetry reader converts (telemetry CSV columns: "abs_alt_m", "time_s",
/// "yaw_deg"). The prefix is what comes before the last '.' of the name ("OSD.", "GIMBAL.",
/// "CUSTOM." of DJI flight record CSVs). A bracket that does not close the cell ("time(ms",
/// "speed(mph) avg") leaves `malformed` set, `base` the name before it and `unit` empty.
/// Defined in csv_telemetry_reader.cc, beside the units.
struct ColumnName {
  std::string prefix;
  std::string base;
  std::string unit;        ///< Empty when the header gives none.
  bool malformed = false;  ///< A '(' or '[' (or ')' or ']') outside "name(unit)"/"name [unit]".
};
ColumnName SplitColumnName(std::string_view cell);

/// "HH:MM:SS,mmm" (SRT timing) -> seconds.
std::optional<double> ParseSrtClock(std::string_view s);

/// UTF-16 text (code units in the byte order `big_endian`, no byte-order mark) as UTF-8;
/// an unpaired surrogate becomes U+FFFD (The Unicode Standard, section 3.9, "U+FFFD Substitution
/// of Maximal Subparts"). Throws InputError "<source>: UTF-16 text with an odd number of bytes"
/// when the last code unit is cut.
std::string Utf16ToUtf8(std::string_view bytes, bool big_endian, const std::string& source);

/// The longest line TextLines accepts: a CSV row of a DJI flight record (a few hundred columns)
/// is a few kB; a longer line is not telemetry, and reading it whole could exhaust memory.
constexpr std::size_t kMaxTextLineBytes = std::size_t{1} << 20;

/// The most bytes of a telemetry text a reader holds in memory at once: a GPX document (read
/// whole by pugixml), a UTF-16 text (transcoded whole). 512 MiB: a GPX of 10 Hz fixes over 10
/// hours is about 70 MB. A larger input (or one that never ends, /dev/zero) is an InputError.
constexpr std::size_t kMaxWholeTextBytes = std::size_t{512} << 20;

/// The rest of `in` (ReadAtMost, core/text.h), at most kMaxWholeTextBytes; InputError naming
/// `source` ("<source>: more than 512 MiB of text ...") beyond.
std::string ReadWholeText(std::istream& in, const std::string& source);

/// A telemetry text file (CSV, DJI SRT) read line by line, whatever wrote it:
/// - encodings: UTF-8, with or without its byte-order mark (removed); UTF-16 with a byte-order
///   mark (FF FE little-endian, FE FF big-endian: Windows "Unicode" text, and Windows
///   PowerShell 5.1's `Out-File` and `>`, Microsoft Learn "about_Character_Encoding"),
///   transcoded to UTF-8. A UTF-32 byte-order mark is an error;
/// - line ends "\n", "\r\n" or a lone "\r" (the newline functions of The Unicode Standard,
///   section 5.8; a lone CR is the classic Mac OS line end of old spreadsheet exports);
/// - a NUL byte is an InputError "<source>:<line>: a NUL byte ...: not a text file" (binary
///   data, or UTF-16/32 text without a byte-order mark), and so is a line longer than
///   kMaxTextLineBytes.
class TextLines {
 public:
  TextLines(std::istream& in, std::string source);
  /// The next line without its line end; false at the end of the input.
  bool Next(std::string& line);
  long line() const { return line_; }  ///< 1-based number of the line Next returned.
  const std::string& source() const { return source_; }

 private:
  int Get();   // next byte (0..255) or -1 at the end
  int Peek();  // the byte Get would return

  std::istream& in_;
  std::string source_;
  std::string decoded_;  // the whole text, transcoded, when the input is UTF-16
  bool use_decoded_ = false;
  std::string head_;     // bytes read ahead at the start and not yet returned
  std::size_t pos_ = 0;  // in head_ or decoded_
  long line_ = 0;
};

/// Applies TelemetryReadOptions: strict -> throw, lenient -> count and keep the message.
class RecordErrors {
 public:
  RecordErrors(const TelemetryReadOptions& options, std::string source)
      : options_(options), source_(std::move(source)) {}
  /// Throws MalformedRecordError "<source>:<line>: <message>" in strict mode; else records it.
  void Report(long line, const std::string& message);
  /// Same policy for a message that already names the place (from ValidateSample).
  void ReportMessage(const std::string& full_message);
  std::string At(long line) const;  ///< "<source>:<line>"
  const std::string& source() const { return source_; }
  int skipped() const { return skipped_; }
  /// Messages of skipped records and damaged bytes; a reader keeps at most max_warnings here.
  std::vector<std::string>& warnings() { return warnings_; }
  /// A fact about how the file as a whole was read (its dates not read, its times spread, its
  /// document cut short): kept whatever the number of record messages, after them in
  /// TelemetryReadResult::warnings (Finish). A reader notes each fact once, so that a file
  /// gets at most kMaxReadNotes (telemetry_readers.h; the fuzz targets check it).
  void Note(std::string message);
  const std::vector<std::string>& notes() const { return notes_; }

 private:
  TelemetryReadOptions options_;
  std::string source_;
  int skipped_ = 0;
  std::vector<std::string> warnings_;
  std::vector<std::string> notes_;
};

/// ValidateSample at "<source>:<line>"; a failure goes through errors (throw or skip).
bool AcceptSample(const TelemetrySample& sample, long line, RecordErrors& errors);

/// Opens a text file for the readers; throws InputError "cannot open '<path>': <reason>".
std::ifstream OpenInput(const std::filesystem::path& path);

/// Builds the result: sorts, spreads repeated times (a note), fills counts, puts the record
/// messages and then the notes in `warnings`; throws InputError when `samples` is empty.
TelemetryReadResult Finish(std::vector<TelemetrySample> samples, RecordErrors& errors,
                           int no_fix_records, const char* what);

}  // namespace aerovo::io_detail
