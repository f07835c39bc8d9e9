// Internal helpers shared by the io readers (not part of the public API): strict number
// parsing, ISO 8601 / EXIF dates, and the strict-or-lenient error policy.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::io_detail {

std::string_view Trim(std::string_view s);
std::string ToLower(std::string_view s);

/// Whole-token decimal number (leading/trailing blanks allowed, '+' allowed); finite only.
std::optional<double> ParseDouble(std::string_view s);
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
  std::string unit;  ///< Empty when the header gives none.
  bool malformed = false;  ///< A '(' or '[' (or ')' or ']') outside "name(unit)"/"name [unit]".
};
ColumnName SplitColumnName(std::string_view cell);

/// "HH:MM:SS,mmm" (SRT timing) -> seconds.
std::optional<double> ParseSrtClock(std::string_view s);

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
  std::vector<std::string>& warnings() { return warnings_; }

 private:
  TelemetryReadOptions options_;
  std::string source_;
  int skipped_ = 0;
  std::vector<std::string> warnings_;
};

/// ValidateSample at "<source>:<line>"; a failure goes through errors (throw or skip).
bool AcceptSample(const TelemetrySample& sample, long line, RecordErrors& errors);

/// Opens a text file for the readers; throws InputError "cannot open '<path>': <reason>".
std::ifstream OpenInput(const std::filesystem::path& path);

/// Builds the result: sorts, fills counts; throws InputError when `samples` is empty.
TelemetryReadResult Finish(std::vector<TelemetrySample> samples, RecordErrors& errors,
                           int no_fix_records, const char* what);

}  // namespace aerovo::io_detail
