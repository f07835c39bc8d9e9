// CSV telemetry with named columns, plus ReadTelemetryFile (choice of reader by extension).
#include <algorithm>
#include <array>
#include <istream>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "aerovo/telemetry/csv_lines.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {

using io_detail::ParseDouble;
using io_detail::RecordErrors;
using io_detail::Trim;

enum Column {
  kLat,
  kLon,
  kAbsAlt,
  kRelAlt,
  kTime,
  kFrame,
  kYaw,
  kPitch,
  kRoll,
  kGimbalYaw,
  kGimbalPitch,
  kGimbalRoll,
  kFocal,
  kFocal35,
  kNumColumns
};

const char* const kColumnNames[kNumColumns] = {
    "latitude",     "longitude", "altitude", "relative altitude", "time",         "frame",
    "yaw",          "pitch",     "roll",     "gimbal_yaw",        "gimbal_pitch", "gimbal_roll",
    "focal_length", "focal_35mm"};

std::optional<Column> ColumnOf(const std::string& name) {
  struct Alias {
    const char* name;
    Column column;
  };
  static const Alias kAliases[] = {{"lat", kLat},
                                   {"latitude", kLat},
                                   {"lat_deg", kLat},
                                   {"lon", kLon},
                                   {"lng", kLon},
                                   {"long", kLon},
                                   {"longitude", kLon},
                                   {"lon_deg", kLon},
                                   {"alt", kAbsAlt},
                                   {"altitude", kAbsAlt},
                                   {"abs_alt", kAbsAlt},
                                   {"abs_alt_m", kAbsAlt},
                                   {"ele", kAbsAlt},
                                   {"elevation", kAbsAlt},
                                   {"rel_alt", kRelAlt},
                                   {"rel_alt_m", kRelAlt},
                                   {"height", kRelAlt},
                                   {"relative_altitude", kRelAlt},
                                   {"height_m", kRelAlt},
                                   {"time", kTime},
                                   {"t", kTime},
                                   {"timestamp", kTime},
                                   {"time_s", kTime},
                                   {"frame", kFrame},
                                   {"frame_index", kFrame},
                                   {"frame_idx", kFrame},
                                   {"yaw", kYaw},
                                   {"heading", kYaw},
                                   {"yaw_deg", kYaw},
                                   {"flight_yaw", kYaw},
                                   {"pitch", kPitch},
                                   {"roll", kRoll},
                                   {"gimbal_yaw", kGimbalYaw},
                                   {"gimbal_pitch", kGimbalPitch},
                                   {"gimbal_roll", kGimbalRoll},
                                   {"focal_length", kFocal},
                                   {"focal_mm", kFocal},
                                   {"focal_35mm", kFocal35},
                                   {"focal35", kFocal35}};
  for (const Alias& a : kAliases) {
    if (name == a.name) return a.column;
  }
  return std::nullopt;
}

using ColumnIndex = std::array<int, kNumColumns>;

// The column of each known field in `header` (-1: absent; unknown columns are ignored). Throws
// InputError "<source>:<line>: ..." for a field named twice, no latitude or longitude column, or
// neither a time nor a frame column.
ColumnIndex IndexColumns(const std::vector<std::string>& header, const std::string& source_name,
                         long header_line) {
  ColumnIndex index;
  index.fill(-1);
  for (std::size_t c = 0; c < header.size(); ++c) {
    const std::string name = io_detail::ToLower(Trim(header[c]));
    const auto col = ColumnOf(name);
    if (!col) continue;  // Unknown columns are allowed and ignored.
    if (index[*col] >= 0) {
      throw InputError(fmt::format("{}:{}: two columns mean {} ('{}' and '{}')", source_name,
                                   header_line, kColumnNames[*col], Trim(header[index[*col]]),
                                   Trim(header[c])));
    }
    index[*col] = static_cast<int>(c);
  }
  if (index[kLat] < 0 || index[kLon] < 0) {
    throw InputError(fmt::format(
        "{}:{}: header has no {} column (accepted names: lat, latitude / lon, lng, longitude)",
        source_name, header_line, index[kLat] < 0 ? "latitude" : "longitude"));
  }
  if (index[kTime] < 0 && index[kFrame] < 0) {
    throw InputError(
        fmt::format("{}:{}: header has neither a time (time, t, timestamp) nor a "
                    "frame column",
                    source_name, header_line));
  }
  return index;
}

// The values of one record's known cells: numbers, or for the time column a date.
struct RecordValues {
  std::array<std::optional<double>, kNumColumns> v;
  std::optional<double> date;
  std::string problem;  ///< Why the record is malformed; empty when it is not.
};

RecordValues ParseRecordValues(const std::vector<std::string>& cells, const ColumnIndex& index) {
  RecordValues r;
  std::string& problem = r.problem;
  std::array<std::optional<double>, kNumColumns>& v = r.v;
  for (int c = 0; c < kNumColumns && problem.empty(); ++c) {
    if (index[c] < 0) continue;
    const std::string_view cell = Trim(cells[index[c]]);
    if (cell.empty()) {
      if (c == kLat || c == kLon || (c == kTime && index[kFrame] < 0) ||
          (c == kFrame && index[kTime] < 0)) {
        problem = fmt::format("empty {} (column {})", kColumnNames[c], index[c] + 1);
      }
      continue;
    }
    v[c] = ParseDouble(cell);
    if (!v[c] && c == kTime) {
      r.date = io_detail::ParseDateTime(cell);
      if (r.date) continue;
    }
    if (!v[c]) {
      problem = fmt::format("{} '{}' is not a number", kColumnNames[c], cell.substr(0, 40));
    }
  }
  if (problem.empty() && v[kFrame] && !io_detail::IsFrameNumber(*v[kFrame])) {
    problem = fmt::format("frame {} is not a non-negative integer", *v[kFrame]);
  }
  return r;
}

}  // namespace

TelemetryReadResult ParseTelemetryCsv(std::istream& in, const std::string& source_name,
                                      const TelemetryReadOptions& options) {
  Validate(options);
  RecordErrors errors(options, source_name);
  CsvLines csv(in, source_name);
  const ColumnIndex index = IndexColumns(csv.header(), source_name, csv.header_line());
  const std::size_t num_header_cells = csv.header().size();

  std::vector<TelemetrySample> samples;
  int no_fix = 0;
  std::optional<double> last_time, first_date;
  std::vector<std::string> cells;
  while (csv.Next(cells)) {
    const long n = csv.line();
    if (csv.unterminated_quote()) {
      errors.Report(n, "unterminated quote");
      continue;
    }
    if (cells.size() != num_header_cells) {
      errors.Report(n, fmt::format("{} fields, the header has {}", cells.size(), num_header_cells));
      continue;
    }
    TelemetrySample s;
    const RecordValues values = ParseRecordValues(cells, index);
    const std::array<std::optional<double>, kNumColumns>& v = values.v;
    const std::optional<double>& date = values.date;
    if (!values.problem.empty()) {
      errors.Report(n, values.problem);
      continue;
    }
    s.lat_deg = *v[kLat];
    s.lon_deg = *v[kLon];
    s.abs_alt_m = v[kAbsAlt];
    s.rel_alt_m = v[kRelAlt];
    s.yaw_deg = v[kYaw];
    s.pitch_deg = v[kPitch];
    s.roll_deg = v[kRoll];
    s.gimbal_yaw_deg = v[kGimbalYaw];
    s.gimbal_pitch_deg = v[kGimbalPitch];
    s.gimbal_roll_deg = v[kGimbalRoll];
    s.focal_length_mm = v[kFocal];
    s.focal_length_35mm_mm = v[kFocal35];
    if (v[kFrame]) s.frame_index = static_cast<int>(*v[kFrame]);
    if (date) {
      if (!first_date) first_date = date;
      s.unix_time_s = date;
      s.time_s = *date - *first_date;
    } else if (v[kTime]) {
      s.time_s = *v[kTime];
    } else {
      s.time_s = static_cast<double>(*s.frame_index);
    }
    if (s.lat_deg == 0.0 && s.lon_deg == 0.0) {
      ++no_fix;
      continue;
    }
    if (!io_detail::AcceptSample(s, n, errors)) continue;
    if (last_time && s.time_s < *last_time) {
      errors.Report(n, fmt::format("time {:.3f} s is earlier than the previous row's {:.3f} s "
                                   "(timestamps out of order)",
                                   s.time_s, *last_time));
      continue;
    }
    last_time = s.time_s;
    s.origin = errors.At(n);
    samples.push_back(s);
  }
  return io_detail::Finish(std::move(samples), errors, no_fix, "CSV file");
}

TelemetryReadResult ReadTelemetryCsv(const std::filesystem::path& path,
                                     const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  return ParseTelemetryCsv(in, path.string(), options);
}

TelemetryReadResult ReadTelemetryFile(const std::filesystem::path& path,
                                      const TelemetryReadOptions& options) {
  const std::string ext = io_detail::ToLower(path.extension().string());
  if (ext == ".srt") return ReadDjiSrt(path, options);
  if (ext == ".gpx") return ReadGpx(path, options);
  if (ext == ".csv" || ext == ".txt") return ReadTelemetryCsv(path, options);
  throw InputError(fmt::format("{}: unknown telemetry format '{}' (expected .srt, .gpx or .csv)",
                               path.string(), ext));
}

}  // namespace aerovo
