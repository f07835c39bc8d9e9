#include "aerovo/telemetry/csv_lines.h"

#include <algorithm>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/parse_util.h"

namespace aerovo {
namespace {

bool BlankOrComment(std::string_view line) {
  const std::string_view t = TrimSpace(line);
  return t.empty() || t.front() == '#';
}

}  // namespace

bool SplitCsv(const std::string& line, char sep, std::vector<std::string>& cells) {
  cells.clear();
  std::string cell;
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          cell.push_back('"');
          ++i;
        } else {
          quoted = false;
        }
      } else {
        cell.push_back(c);
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == sep) {
      cells.push_back(std::move(cell));
      cell.clear();
    } else {
      cell.push_back(c);
    }
  }
  cells.push_back(std::move(cell));
  return !quoted;
}

CsvLines::CsvLines(std::istream& in, std::string source_name) : lines_(in, source_name) {
  std::string line;
  bool found = false;
  while (lines_.Next(line)) {
    line_ = lines_.line();
    if (!BlankOrComment(line)) {
      found = true;
      break;
    }
  }
  if (!found) throw InputError(fmt::format("{}: empty CSV file (no header)", source_name));
  // "sep=," / "sep=;": the separator hint of spreadsheet exports (the first line of the DJI
  // flight record CSVs of log viewers); the header is the next line that is not blank/comment.
  std::optional<char> hinted_sep;
  if (const std::string_view t = TrimSpace(line); t.size() == 5 &&
                                                  io_detail::ToLower(t.substr(0, 4)) == "sep=" &&
                                                  (t[4] == ',' || t[4] == ';')) {
    hinted_sep = t[4];
    found = false;
    while (lines_.Next(line)) {
      line_ = lines_.line();
      if (!BlankOrComment(line)) {
        found = true;
        break;
      }
    }
    if (!found) throw InputError(fmt::format("{}: empty CSV file (no header)", source_name));
  }
  header_line_ = line_;
  sep_ = hinted_sep ? *hinted_sep
         : std::count(line.begin(), line.end(), ';') > std::count(line.begin(), line.end(), ',')
             ? ';'
             : ',';
  if (!SplitCsv(line, sep_, header_)) {
    throw InputError(fmt::format("{}:{}: unterminated quote in header", source_name, line_));
  }
}

bool CsvLines::Next(std::vector<std::string>& cells) {
  std::string line;
  while (lines_.Next(line)) {
    line_ = lines_.line();
    if (BlankOrComment(line)) continue;
    unterminated_quote_ = !SplitCsv(line, sep_, cells);
    return true;
  }
  return false;
}

}  // namespace aerovo
