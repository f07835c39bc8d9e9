// CSV telemetry with named columns, units in the names and the exports of flight log tools
// (docs/inputs.md "CSV exports of flight logs"), plus ReadTelemetryFile (choice of reader by
// extension).
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <istream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/telemetry/csv_lines.h"
#include "aerovo/telemetry/file_kind.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {

using io_detail::ColumnName;
using io_detail::RecordErrors;

// The fields a CSV column can give. kTime is an elapsed time (a number, converted to seconds;
// an ISO 8601 date is also accepted there, as before units were read), kDate an absolute date.
enum Column {
  kLat,
  kLon,
  kAbsAlt,
  kRelAlt,
  kTime,
  kDate,
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
    "latitude",    "longitude",    "altitude",   "relative altitude",
    "time",        "date",         "frame",      "yaw",
    "pitch",       "roll",         "gimbal_yaw", "gimbal_pitch",
    "gimbal_roll", "focal_length", "focal_35mm"};

// What a unit in a column name measures.
enum class Quantity { kLength, kTime, kAngle, kDegE7, kYaw360, kZone };

// A unit aerovo converts: `factor` takes a value to metres, seconds or degrees (kZone: a date
// column's clock, no factor). `rank` is added to the column's precedence (0 = preferred):
// DJI's "OSD.yaw [360]" (0..360) yields to "OSD.yaw", "datetime(local)" to "datetime(utc)".
struct Unit {
  const char* name;
  Quantity quantity;
  double factor;
  int rank;
};

const Unit kUnits[] = {
    {"m", Quantity::kLength, 1.0, 0},
    {"meter", Quantity::kLength, 1.0, 0},
    {"meters", Quantity::kLength, 1.0, 0},
    {"metre", Quantity::kLength, 1.0, 0},
    {"metres", Quantity::kLength, 1.0, 0},
    {"ft", Quantity::kLength, 0.3048, 0},  // international foot (exact)
    {"feet", Quantity::kLength, 0.3048, 0},
    {"foot", Quantity::kLength, 0.3048, 0},
    {"mm", Quantity::kLength, 1e-3, 0},
    {"millimeter", Quantity::kLength, 1e-3, 0},
    {"millimeters", Quantity::kLength, 1e-3, 0},
    {"millimetre", Quantity::kLength, 1e-3, 0},
    {"millimetres", Quantity::kLength, 1e-3, 0},
    {"s", Quantity::kTime, 1.0, 0},
    {"sec", Quantity::kTime, 1.0, 0},
    {"second", Quantity::kTime, 1.0, 0},
    {"seconds", Quantity::kTime, 1.0, 0},
    {"ms", Quantity::kTime, 1e-3, 0},
    {"msec", Quantity::kTime, 1e-3, 0},
    {"millisecond", Quantity::kTime, 1e-3, 0},
    {"milliseconds", Quantity::kTime, 1e-3, 0},
    {"us", Quantity::kTime, 1e-6, 0},
    {"usec", Quantity::kTime, 1e-6, 0},
    {"\xC2\xB5s", Quantity::kTime, 1e-6, 0},  // "µs"
    {"microsecond", Quantity::kTime, 1e-6, 0},
    {"microseconds", Quantity::kTime, 1e-6, 0},
    {"deg", Quantity::kAngle, 1.0, 0},
    {"degree", Quantity::kAngle, 1.0, 0},
    {"degrees", Quantity::kAngle, 1.0, 0},
    {"\xC2\xB0", Quantity::kAngle, 1.0, 0},  // "°"
    {"rad", Quantity::kAngle, kRadToDeg, 0},
    {"radian", Quantity::kAngle, kRadToDeg, 0},
    {"radians", Quantity::kAngle, kRadToDeg, 0},
    {"dege7", Quantity::kDegE7, 1e-7, 0},  // MAVLink's name for integer 1e-7 degrees
    {"360", Quantity::kYaw360, 1.0, 1},    // DJI "OSD.yaw [360]": degrees in [0, 360)
    {"utc", Quantity::kZone, 0.0, 0},
    {"local", Quantity::kZone, 0.0, 1},  // the drone's clock, stored as if UTC (as DJI SRT)
};

const Unit* FindUnit(std::string_view name) {
  for (const Unit& u : kUnits) {
    if (name == u.name) return &u;
  }
  return nullptr;
}

// The units a column accepts, and the factor to its field's unit (focal lengths in mm).
std::optional<double> FactorFor(Column c, const Unit& u) {
  switch (c) {
    case kLat:
    case kLon:
      if (u.quantity == Quantity::kAngle || u.quantity == Quantity::kDegE7) return u.factor;
      return std::nullopt;
    case kAbsAlt:
    case kRelAlt:
      if (u.quantity == Quantity::kLength) return u.factor;
      return std::nullopt;
    case kFocal:
    case kFocal35:
      if (u.quantity == Quantity::kLength) return u.factor * 1000.0;
      return std::nullopt;
    case kTime:
      if (u.quantity == Quantity::kTime) return u.factor;
      return std::nullopt;
    case kDate:
      if (u.quantity == Quantity::kZone) return 1.0;
      return std::nullopt;
    case kYaw:
    case kGimbalYaw:
      if (u.quantity == Quantity::kAngle || u.quantity == Quantity::kYaw360) return u.factor;
      return std::nullopt;
    case kPitch:
    case kRoll:
    case kGimbalPitch:
    case kGimbalRoll:
      if (u.quantity == Quantity::kAngle) return u.factor;
      return std::nullopt;
    case kFrame:
    case kNumColumns:
      break;
  }
  return std::nullopt;
}

// The unit names a column accepts, for messages.
std::string KnownUnits(Column c) {
  std::string r;
  for (const Unit& u : kUnits) {
    if (FactorFor(c, u)) r += (r.empty() ? "" : ", ") + std::string(u.name);
  }
  return r.empty() ? "none" : r;
}

// The layouts whose column names mean something else than in a generic file, recognised by
// their columns (docs/inputs.md "Flight log exports").
struct Layout {
  // Litchi flight logs (a column "ultrasonicHeight"): "altitude" is the height above the
  // take-off point, not above sea level.
  bool litchi = false;
  // PX4 ulog2csv of a position topic (first column "timestamp", a column "eph"): "timestamp"
  // is in microseconds since boot, angles ("yaw") in radians (uORB message definitions,
  // PX4-Autopilot msg/*.msg, docs.px4.io "uORB Message Reference").
  bool px4 = false;
  // PX4 vehicle_gps_position before v1.14 (px4 and a column "fix_type"): "lat", "lon" are
  // integers in 1e-7 degrees, "alt", "alt_ellipsoid" integers in millimetres.
  bool px4_integer_gps = false;
};

Layout RecogniseLayout(const std::vector<ColumnName>& names) {
  Layout l;
  bool eph = false, fix_type = false;
  for (const ColumnName& n : names) {
    if (!n.prefix.empty()) continue;
    if (n.base == "ultrasonicheight") l.litchi = true;
    if (n.base == "eph") eph = true;
    if (n.base == "fix_type") fix_type = true;
  }
  l.px4 = !names.empty() && names[0].prefix.empty() && names[0].base == "timestamp" &&
          names[0].unit.empty() && eph;
  l.px4_integer_gps = l.px4 && fix_type;
  return l;
}

struct Alias {
  const char* prefix;  ///< "" = none; "osd", "gimbal", "custom": DJI flight record CSVs.
  const char* base;
  Column column;
  int rank;  ///< Precedence among the columns of one field: the lowest rank is read.
};

// Names are compared lower-case, after SplitColumnName took off the unit and the prefix.
const Alias kAliases[] = {
    {"", "lat", kLat, 0},
    {"", "latitude", kLat, 0},
    {"", "lon", kLon, 0},
    {"", "lng", kLon, 0},
    {"", "long", kLon, 0},
    {"", "longitude", kLon, 0},
    {"", "abs_alt", kAbsAlt, 0},
    {"", "altitude_above_sealevel", kAbsAlt, 0},  // Airdata
    {"", "altitude_msl", kAbsAlt, 0},             // PX4 sensor_gps altitude_msl_m
    {"", "alt", kAbsAlt, 1},
    {"", "altitude", kAbsAlt, 1},  // Airdata's altitude(feet) = altitude_above_seaLevel
    {"", "ele", kAbsAlt, 1},
    {"", "elevation", kAbsAlt, 1},
    {"", "alt_ellipsoid", kAbsAlt, 2},
    {"", "altitude_ellipsoid", kAbsAlt, 2},
    {"", "rel_alt", kRelAlt, 0},
    {"", "relative_altitude", kRelAlt, 0},
    {"", "height_above_takeoff", kRelAlt, 0},  // Airdata
    {"", "height", kRelAlt, 1},
    {"", "time", kTime, 0},
    {"", "t", kTime, 0},
    {"", "timestamp", kTime, 1},  // Litchi writes time(millisecond) and a timestamp
    {"", "datetime", kDate, 0},   // Airdata, Litchi: datetime(utc), datetime(local)
    {"", "frame", kFrame, 0},
    {"", "frame_index", kFrame, 0},
    {"", "frame_idx", kFrame, 0},
    {"", "yaw", kYaw, 0},
    {"", "heading", kYaw, 0},
    {"", "flight_yaw", kYaw, 0},
    {"", "compass_heading", kYaw, 0},  // Airdata
    {"", "pitch", kPitch, 0},
    {"", "roll", kRoll, 0},
    {"", "gimbal_yaw", kGimbalYaw, 0},
    {"", "gimbal_heading", kGimbalYaw, 0},  // Airdata
    {"", "gimbal_pitch", kGimbalPitch, 0},
    {"", "gimbal_roll", kGimbalRoll, 0},
    {"", "focal_length", kFocal, 0},
    {"", "focal", kFocal, 0},  // "focal_mm" = focal + mm
    {"", "focal_35mm", kFocal35, 0},
    {"", "focal35", kFocal35, 0},
    // DJI flight record CSVs (TXTlogToCSVtool, PhantomHelp, Airdata "original" exports).
    {"osd", "latitude", kLat, 0},
    {"osd", "longitude", kLon, 0},
    {"osd", "height", kRelAlt, 0},    // above the take-off point (OSD.vpsHeight: not read)
    {"osd", "altitude", kAbsAlt, 0},  // take-off altitude + height
    {"osd", "flytime", kTime, 0},     // the flight time
    {"osd", "yaw", kYaw, 0},
    {"osd", "pitch", kPitch, 0},
    {"osd", "roll", kRoll, 0},
    {"gimbal", "yaw", kGimbalYaw, 0},
    {"gimbal", "pitch", kGimbalPitch, 0},
    {"gimbal", "roll", kGimbalRoll, 0},
    {"custom", "updatetime", kDate, 0},  // "2018/07/04 09:19:32.113", the drone's clock
};

struct Candidate {
  Column column;
  int rank;
};

std::optional<Candidate> CandidateOf(const ColumnName& n, const Layout& layout) {
  if (layout.litchi && n.prefix.empty() && n.base == "altitude") return Candidate{kRelAlt, 0};
  if (layout.px4 && n.prefix.empty() && n.base == "timestamp") return Candidate{kTime, 0};
  // vehicle_gps_position's heading: dual-antenna receivers only, NaN otherwise; not read.
  if (layout.px4 && n.prefix.empty() && n.base == "heading") return std::nullopt;
  for (const Alias& a : kAliases) {
    if (n.prefix == a.prefix && n.base == a.base) return Candidate{a.column, a.rank};
  }
  return std::nullopt;
}

// How the file's columns are read: the column of each field (-1: absent) and the factor to the
// field's unit (metres, seconds, degrees, mm for focal lengths).
struct ColumnPlan {
  std::array<int, kNumColumns> index;
  std::array<double, kNumColumns> factor;
  /// The field's values are integers in 1e-7 degrees / mm (PX4 vehicle_gps_position).
  std::array<bool, kNumColumns> integer;
};

// The plan of `header`. Unknown columns are ignored, and so are their units. Throws InputError
// "<source>:<line>: ..." for a recognised column whose unit is not one of its field's, two
// columns of the same precedence for one field, no latitude or longitude column, or no time,
// date or frame column.
ColumnPlan PlanColumns(const std::vector<std::string>& header, const std::string& source_name,
                       long header_line) {
  std::vector<ColumnName> names;
  names.reserve(header.size());
  for (const std::string& cell : header) names.push_back(io_detail::SplitColumnName(cell));
  const Layout layout = RecogniseLayout(names);

  ColumnPlan plan;
  plan.index.fill(-1);
  plan.factor.fill(1.0);
  plan.integer.fill(false);
  std::array<int, kNumColumns> best_rank;
  best_rank.fill(1 << 20);
  std::array<int, kNumColumns> tie;  // a second column at the best rank, -1: none
  tie.fill(-1);
  for (std::size_t c = 0; c < names.size(); ++c) {
    const ColumnName& n = names[c];
    const auto cand = CandidateOf(n, layout);
    if (!cand) continue;  // Unknown columns are allowed and ignored.
    const Column col = cand->column;
    if (n.malformed) {
      throw InputError(fmt::format(
          "{}:{}: column '{}' would be read as the {}, but its unit is not written "
          "'name(unit)' or 'name [unit]' (a bracket is not closed, or text follows it); fix the "
          "header",
          source_name, header_line, Printable(TrimSpace(header[c])), kColumnNames[col]));
    }
    double factor = 1.0;
    int rank = cand->rank;
    bool integer = false;
    if (!n.unit.empty()) {
      const Unit* u = FindUnit(n.unit);
      const auto f = u ? FactorFor(col, *u) : std::nullopt;
      if (!f) {
        throw InputError(fmt::format(
            "{}:{}: column '{}' would be read as the {}, but its unit '{}' is not one aerovo "
            "knows for it (known: {}); rename the column or convert its values",
            source_name, header_line, Printable(TrimSpace(header[c])), kColumnNames[col],
            Printable(n.unit), KnownUnits(col)));
      }
      factor = *f;
      rank += u->rank;
      integer = u->quantity == Quantity::kDegE7;
    } else if (layout.px4_integer_gps && (n.base == "lat" || n.base == "lon")) {
      factor = 1e-7;
      integer = true;
    } else if (layout.px4_integer_gps && (n.base == "alt" || n.base == "alt_ellipsoid")) {
      factor = 1e-3;
      integer = true;
    } else if (layout.px4 && col == kTime) {
      factor = 1e-6;
    } else if (layout.px4 && (col == kYaw || col == kPitch || col == kRoll)) {
      factor = kRadToDeg;  // uORB angles are radians (vehicle_global_position yaw)
    }
    if (rank < best_rank[col]) {
      best_rank[col] = rank;
      tie[col] = -1;
      plan.index[col] = static_cast<int>(c);
      plan.factor[col] = factor;
      plan.integer[col] = integer;
    } else if (rank == best_rank[col] && tie[col] < 0) {
      tie[col] = static_cast<int>(c);
    }
  }
  for (int col = 0; col < kNumColumns; ++col) {
    if (tie[col] >= 0) {
      throw InputError(fmt::format(
          "{}:{}: two columns mean {} ('{}' and '{}')", source_name, header_line, kColumnNames[col],
          Printable(TrimSpace(header[plan.index[col]])), Printable(TrimSpace(header[tie[col]]))));
    }
  }
  if (plan.index[kLat] < 0 || plan.index[kLon] < 0) {
    throw InputError(fmt::format(
        "{}:{}: header has no {} column (accepted names: lat, latitude, OSD.latitude / lon, "
        "lng, longitude, OSD.longitude; a unit may follow: 'latitude(deg)', 'lat_deg')",
        source_name, header_line, plan.index[kLat] < 0 ? "latitude" : "longitude"));
  }
  if (plan.index[kTime] < 0 && plan.index[kDate] < 0 && plan.index[kFrame] < 0) {
    throw InputError(
        fmt::format("{}:{}: header has neither a time (time, t, timestamp, OSD.flyTime, with "
                    "an optional unit such as 'time(millisecond)'), a date (datetime, "
                    "CUSTOM.updateTime) nor a frame column",
                    source_name, header_line));
  }
  return plan;
}

// The values of one record's known cells, converted to the fields' units; dates for the time
// column (an ISO 8601 date written there) or the date column.
struct RecordValues {
  std::array<std::optional<double>, kNumColumns> v;
  std::optional<double> time_date;  ///< An ISO 8601 date written in the time column.
  std::optional<double> date;       ///< The date column's date.
  bool bad_date = false;            ///< The date column's cell is not empty and not a date.
  std::string problem;              ///< Why the record is malformed; empty when it is not.
};

RecordValues ParseRecordValues(const std::vector<std::string>& cells, const ColumnPlan& plan) {
  const std::array<int, kNumColumns>& index = plan.index;
  RecordValues r;
  std::string& problem = r.problem;
  std::array<std::optional<double>, kNumColumns>& v = r.v;
  // The time of a record: the time column, else the date column, else the frame column.
  const bool time_needed = index[kTime] >= 0;
  const bool date_needed = !time_needed && index[kDate] >= 0;
  const bool frame_needed = !time_needed && !date_needed;
  for (int c = 0; c < kNumColumns && problem.empty(); ++c) {
    if (index[c] < 0) continue;
    const std::string_view cell = TrimSpace(cells[index[c]]);
    if (cell.empty()) {
      if (c == kLat || c == kLon || (c == kTime && time_needed && index[kFrame] < 0) ||
          (c == kDate && date_needed && index[kFrame] < 0) || (c == kFrame && frame_needed)) {
        problem = fmt::format("empty {} (column {})", kColumnNames[c], index[c] + 1);
      }
      continue;
    }
    if (c == kDate) {
      const auto d = io_detail::ParseDateTime(cell);
      r.date = d;
      if (!d && date_needed) {
        problem = fmt::format("date '{}' is not a date", Printable(cell, 40));
      }
      r.bad_date = !d;
      continue;
    }
    v[c] = ParseDecimal(cell);
    if (!v[c] && c == kTime) {
      r.time_date = io_detail::ParseDateTime(cell);
      if (r.time_date) continue;
    }
    if (!v[c]) {
      problem = fmt::format("{} '{}' is not a number", kColumnNames[c], Printable(cell, 40));
      continue;
    }
    if (plan.integer[c] && *v[c] != std::floor(*v[c])) {
      problem = fmt::format(
          "{} {} is not an integer, but this PX4 vehicle_gps_position layout (a 'fix_type' "
          "column) writes integers in 1e-7 degrees / millimetres",
          kColumnNames[c], Printable(cell, 40));
      continue;
    }
    *v[c] *= plan.factor[c];
  }
  if (problem.empty() && v[kFrame] && !io_detail::IsFrameNumber(*v[kFrame])) {
    problem = fmt::format("frame {} is not a non-negative integer", *v[kFrame]);
  }
  if (problem.empty() && !v[kTime] && !r.time_date && !(index[kTime] < 0 && r.date) && !v[kFrame]) {
    problem = "no time, date or frame";
  }
  return r;
}

// An out-of-range latitude or longitude that is an integer of at least 1e4 and within 1e7 times
// the range: the integer 1e-7 degrees of PX4 / MAVLink written in a column aerovo reads as
// degrees (a smaller integer, e.g. 200, is a plain bad value). The message says what was found
// and what to do (never a silent rescale).
std::string IntegerDegE7Hint(const TelemetrySample& s) {
  const bool lat_out = std::abs(s.lat_deg) > 90.0, lon_out = std::abs(s.lon_deg) > 180.0;
  if (!lat_out && !lon_out) return {};
  const double v = lat_out ? s.lat_deg : s.lon_deg;
  const double limit = lat_out ? 90e7 : 180e7;
  if (v != std::floor(v) || std::abs(v) < 1e4 || std::abs(v) > limit) return {};
  return fmt::format(
      "{} {:.0f} out of range [{}, {}], an integer: 1e-7 degrees (degE7) as PX4 and "
      "MAVLink write them? Name the columns 'lat(degE7)' and 'lon(degE7)' (an altitude in "
      "millimetres 'alt(mm)') to read them so",
      lat_out ? "latitude" : "longitude", v, lat_out ? -90 : -180, lat_out ? 90 : 180);
}

}  // namespace

namespace io_detail {

ColumnName SplitColumnName(std::string_view cell) {
  std::string s = ToLower(TrimSpace(cell));
  ColumnName r;
  if (!s.empty() && (s.back() == ')' || s.back() == ']')) {
    const char open = s.back() == ')' ? '(' : '[';
    const std::size_t p = s.rfind(open);
    if (p != std::string::npos && p > 0) {
      r.unit = std::string(TrimSpace(std::string_view(s).substr(p + 1, s.size() - p - 2)));
      s = std::string(TrimSpace(std::string_view(s).substr(0, p)));
    }
  }
  const std::size_t bracket = s.find_first_of("()[]");
  if (bracket != std::string::npos) {  // "time(ms", "speed(mph) avg": no unit can be read
    r.malformed = true;
    s = std::string(TrimSpace(std::string_view(s).substr(0, bracket)));
  }
  const std::size_t dot = s.rfind('.');
  if (dot != std::string::npos) {
    r.prefix = std::string(TrimSpace(std::string_view(s).substr(0, dot)));
    s = std::string(TrimSpace(std::string_view(s).substr(dot + 1)));
  }
  if (r.unit.empty() && !r.malformed) {
    const std::size_t us = s.rfind('_');
    if (us != std::string::npos && us > 0 &&
        FindUnit(std::string_view(s).substr(us + 1)) != nullptr) {
      r.unit = s.substr(us + 1);
      s.erase(us);
    }
  }
  r.base = std::move(s);
  return r;
}

}  // namespace io_detail

TelemetryReadResult ParseTelemetryCsv(std::istream& in, const std::string& source_name,
                                      const TelemetryReadOptions& options) {
  Validate(options);
  RecordErrors errors(options, source_name);
  CsvLines csv(in, source_name);
  const ColumnPlan plan = PlanColumns(csv.header(), source_name, csv.header_line());
  const std::size_t num_header_cells = csv.header().size();
  // With both an elapsed time and a date column (Airdata, Litchi, DJI), time_s is the elapsed
  // time and unix_time_s = time_s + (date - time_s) of the first record that has both: the
  // dates are often whole seconds (Airdata's datetime(utc)), the elapsed time is not.
  const bool elapsed_and_date = plan.index[kTime] >= 0 && plan.index[kDate] >= 0;
  std::optional<double> unix_minus_time;
  std::string first_bad_date;
  long first_bad_date_line = 0;

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
    const RecordValues values = ParseRecordValues(cells, plan);
    const std::array<std::optional<double>, kNumColumns>& v = values.v;
    if (!values.problem.empty()) {
      errors.Report(n, values.problem);
      continue;
    }
    if (values.bad_date && first_bad_date.empty()) {
      first_bad_date = Printable(TrimSpace(cells[plan.index[kDate]]), 40);
      first_bad_date_line = n;
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
    // The time: the time column (seconds, or an ISO 8601 date as before units), else the date
    // column when there is no time column, else the frame (ParseRecordValues checked one is).
    const std::optional<double> date = values.time_date        ? values.time_date
                                       : plan.index[kTime] < 0 ? values.date
                                                               : std::nullopt;
    if (v[kTime]) {
      s.time_s = *v[kTime];
      if (elapsed_and_date && values.date && !unix_minus_time) {
        unix_minus_time = *values.date - s.time_s;
      }
    } else if (date) {
      if (!first_date) first_date = date;
      s.unix_time_s = date;
      s.time_s = *date - *first_date;
    } else {
      s.time_s = static_cast<double>(*s.frame_index);
    }
    if (s.lat_deg == 0.0 && s.lon_deg == 0.0) {
      ++no_fix;
      continue;
    }
    if (const std::string hint = IntegerDegE7Hint(s); !hint.empty()) {
      errors.Report(n, hint);
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
  if (unix_minus_time) {
    for (TelemetrySample& s : samples) s.unix_time_s = s.time_s + *unix_minus_time;
  } else if (elapsed_and_date && !first_bad_date.empty()) {
    // The elapsed time is read; the dates are not (another clock format): said, not hidden.
    errors.Note(fmt::format(
        "{}:{}: column '{}' holds '{}', not a date aerovo reads: absolute times (unix_time_s) "
        "not set",
        source_name, first_bad_date_line, Printable(TrimSpace(csv.header()[plan.index[kDate]])),
        first_bad_date));
  }
  return io_detail::Finish(std::move(samples), errors, no_fix, "CSV file");
}

TelemetryReadResult ReadTelemetryCsv(const std::filesystem::path& path,
                                     const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  // The DJI GO / DJI Fly apps' own flight records are binary files named
  // DJIFlightRecord_<date>_[<time>].txt (encrypted since 2019): their CSV exports are read, not
  // the records (docs/inputs.md "CSV exports of flight logs").
  if (io_detail::ToLower(path.filename().string()).rfind("djiflightrecord", 0) == 0) {
    const std::string head = io_detail::ReadHead(in);
    if (head.find('\0') != std::string::npos) {
      throw InputError(fmt::format(
          "{}: a DJI flight record (the DJI GO / DJI Fly app's binary log), not a CSV file: "
          "aerovo reads its CSV export (a DJI flight log viewer's \"sep=,\" CSV with OSD. and "
          "GIMBAL. columns, or Airdata's), see docs/inputs.md \"CSV exports of flight logs\"",
          path.string()));
    }
  }
  return ParseTelemetryCsv(in, path.string(), options);
}

namespace {

// The kind of a file whose extension names no telemetry format, by its first bytes
// (file_kind.h: DataFlash, ULog and .tlog by their magic bytes, GPX by a <gpx element within the
// first KiB, DJI SRT by a counter line then a timing line; never CSV).
io_detail::FileKind SniffedKind(const std::filesystem::path& path) {
  std::ifstream in = io_detail::OpenInput(path);
  const std::string head = io_detail::ReadHead(in);
  return io_detail::RecognizeFile(reinterpret_cast<const unsigned char*>(head.data()), head.size());
}

// "; it is <what>" for a file of a kind aerovo does not read as telemetry, "" for kUnknown.
std::string OtherKind(io_detail::FileKind kind) {
  std::string hint = io_detail::KindHint(kind);  // " (what)"
  if (hint.size() < 3) return "";
  return "; it is " + hint.substr(2, hint.size() - 3);
}

TelemetryReadResult ReadByExtension(const std::string& ext, const std::filesystem::path& path,
                                    const TelemetryReadOptions& options) {
  if (ext == ".srt") return ReadDjiSrt(path, options);
  if (ext == ".gpx") return ReadGpx(path, options);
  if (ext == ".csv" || ext == ".txt") return ReadTelemetryCsv(path, options);
  if (ext == ".bin" || ext == ".log") return ReadDataFlash(path, options);
  if (ext == ".tlog") return ReadTlog(path, options);
  if (ext == ".ulg") return ReadULog(path, options);
  throw std::logic_error("ReadByExtension: " + ext);
}

bool KnownExtension(const std::string& ext) {
  for (const char* known : {".srt", ".gpx", ".csv", ".txt", ".bin", ".log", ".tlog", ".ulg"}) {
    if (ext == known) return true;
  }
  return false;
}

}  // namespace

TelemetryReadResult ReadTelemetryFile(const std::filesystem::path& path,
                                      const TelemetryReadOptions& options) {
  const std::string ext = io_detail::ToLower(path.extension().string());
  if (KnownExtension(ext)) return ReadByExtension(ext, path, options);
  const io_detail::FileKind kind = SniffedKind(path);  // "no such file" before the extension
  const std::string sniffed = io_detail::TelemetryExtension(kind);
  if (sniffed.empty()) {
    throw InputError(
        fmt::format("{}: unknown telemetry format '{}' (expected .srt, .gpx, .csv, an ArduPilot "
                    ".bin/.log, a PX4 .ulg or a MAVLink .tlog; the content is none of the binary "
                    "logs, GPX or SRT either{})",
                    path.string(), ext, OtherKind(kind)));
  }
  TelemetryReadResult r = ReadByExtension(sniffed, path, options);
  r.warnings.insert(r.warnings.begin(),
                    fmt::format("{}: read as {} by its content (its extension '{}' names no "
                                "telemetry format)",
                                path.string(), sniffed, ext));
  return r;
}

}  // namespace aerovo
