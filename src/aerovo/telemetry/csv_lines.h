// A CSV text with a header row, read record by record: the one CSV tokenizer of aerovo, shared
// by the readers of named-column files (ParseTelemetryCsv in telemetry_readers.h,
// ReadGroundTruthCsv in reference_track.h, the run folder reader in report/run_reader.h), which
// differ only in what the columns mean and how they treat a bad record.
#pragma once

#include <istream>
#include <string>
#include <vector>

#include "aerovo/telemetry/parse_util.h"

namespace aerovo {

/// Splits one CSV record on `sep`, honouring "..." quotes ("" inside quotes is a quote). Cells
/// are not trimmed. Returns false on an unterminated quote (`cells` then holds what was read).
bool SplitCsv(const std::string& line, char sep, std::vector<std::string>& cells);

/// A CSV text with a header row, read through io_detail::TextLines (telemetry/parse_util.h:
/// UTF-8 or UTF-16 with a byte-order mark, any line end; a NUL byte or a line over 1 MiB is an
/// InputError naming the line). The header is the first line that is neither blank nor a
/// comment (first non-blank character '#'), with a UTF-8 byte-order mark on line 1 removed; the
/// separator is ';' when the header holds more ';' than ',', else ','. A first line "sep=," or
/// "sep=;" (the separator hint of spreadsheet exports, e.g. DJI flight record CSVs) sets the
/// separator and the header is the line after it. Data records are the
/// following lines, blank and comment lines skipped.
class CsvLines {
 public:
  /// Reads up to and including the header. Throws InputError "<source>: empty CSV file (no
  /// header)" or "<source>:<line>: unterminated quote in header" (and TextLines' errors, here
  /// and in Next). `in` must outlive this.
  CsvLines(std::istream& in, std::string source_name);

  const std::vector<std::string>& header() const { return header_; }  ///< Cells, untrimmed.
  long header_line() const { return header_line_; }                   ///< 1-based.
  char separator() const { return sep_; }

  /// Reads the next data record into `cells`; false at the end of the input. After it,
  /// line() is the record's 1-based line number and unterminated_quote() tells whether the
  /// record had an unterminated quote (the caller reports it: strict or lenient).
  bool Next(std::vector<std::string>& cells);
  long line() const { return line_; }
  bool unterminated_quote() const { return unterminated_quote_; }

 private:
  io_detail::TextLines lines_;
  std::vector<std::string> header_;
  long header_line_ = 0;
  long line_ = 0;
  char sep_ = ',';
  bool unterminated_quote_ = false;
};

}  // namespace aerovo
