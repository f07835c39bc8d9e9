// ArduPilot DataFlash logs: the binary log (.bin) the autopilot writes to its SD card, and its
// text form (.log, Mission Planner's "convert .bin to .log"). GPS messages become the samples;
// ATT (attitude) and POS (height above home) are interpolated onto them. See
// telemetry_readers.h (ParseDataFlash) and docs/inputs.md "ArduPilot DataFlash logs".
//
// CAM messages (else TRIG) become the camera triggers (TelemetryReadResult::camera_triggers).
//
// The format, as ArduPilot defines it (libraries/AP_Logger/LogStructure.h, "Format characters in
// the format string for binary log messages"; ardupilot.org "Downloading and Analyzing Data
// Logs in Mission Planner" and "Onboard Message Log Messages"):
//  - every message is the bytes 0xA3 0x95, a type byte, then the fields, little-endian, packed;
//  - type 128 is FMT: type (uint8), length (uint8: the whole message, the 3 header bytes
//    included), name char[4], format char[16], column labels char[64] (comma-separated), all
//    NUL-padded. The file describes itself: names, columns and layouts are read from its FMT
//    messages, never assumed;
//  - format characters (sizes in bytes): a int16[32] (64), b int8, B uint8, h int16, H uint16,
//    i int32, I uint32, f float, d double, n char[4], N char[16], Z char[64], c int16 * 100,
//    C uint16 * 100, e int32 * 100, E uint32 * 100 (the value is stored times 100), L int32
//    latitude/longitude in 1e-7 degrees, M uint8 flight mode, q int64, Q uint64.
// The text form writes one line per message, the fields separated by ", ": "FMT, 128, 89, FMT,
// BBnNZ, Type,Length,Name,Format,Columns" then e.g. "GPS, 123456789, 0, 3, ...". Its values are
// already scaled: c/C/e/E divided by 100, L divided by 1e7 (degrees), M written as the mode's
// name (Mission Planner, ExtLibs/Utilities/BinaryLog.cs, ProcessMessage).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "aerovo/telemetry/binary_log_util.h"
#include "aerovo/telemetry/file_kind.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {

using io_detail::ByteWindow;
using io_detail::LoadLe;
using io_detail::RecordErrors;
using io_detail::SeriesPoint;

constexpr unsigned char kHead1 = 0xA3;
constexpr unsigned char kHead2 = 0x95;
constexpr int kFmtType = 128;
// FMT: 3 header bytes + type + length + name[4] + format[16] + labels[64].
constexpr int kFmtLength = 3 + 1 + 1 + 4 + 16 + 64;
// A message's length is a uint8: no message is longer.
constexpr int kMaxMessageLength = 255;

// GPS time (AP_GPS.h: UNIX_OFFSET_MSEC, GPS_LEAPSECONDS_MILLIS): the GPS epoch 1980-01-06 is
// 315964800 s after the Unix epoch; GPS time runs ahead of UTC by the leap seconds, 18 s since
// 2017-01-01 (IERS Bulletin C). Earlier dates are off by the leap seconds added since.
constexpr double kGpsEpochUnixS = 315964800.0;
constexpr double kGpsWeekS = 604800.0;
constexpr double kGpsLeapSeconds = 18.0;

// GPS Status (AP_GPS::GPS_Status): 0 no GPS, 1 no fix, 2 2D fix, 3 3D fix, 4 DGPS, 5 RTK float,
// 6 RTK fixed. A sample needs a 3D fix.
constexpr double kGps3dFix = 3.0;

using io_detail::kMaxInterpolationGapS;
using io_detail::kMaxListedGaps;
using io_detail::kMinSeriesStepS;

// Size in bytes of a format character (LogStructure.h); 0 when it is not one.
int FieldSize(char c) {
  switch (c) {
    case 'b':
    case 'B':
    case 'M':
      return 1;
    case 'h':
    case 'H':
    case 'c':
    case 'C':
      return 2;
    case 'i':
    case 'I':
    case 'f':
    case 'e':
    case 'E':
    case 'L':
    case 'n':
      return 4;
    case 'd':
    case 'q':
    case 'Q':
      return 8;
    case 'N':
      return 16;
    case 'a':
    case 'Z':
      return 64;
    default:
      return 0;
  }
}

// The value of the field of format character c at p, scaled (c/C/e/E / 100, L / 1e7 degrees);
// nullopt for strings and arrays.
std::optional<double> DecodeField(const unsigned char* p, char c) {
  switch (c) {
    case 'b':
      return static_cast<double>(static_cast<std::int8_t>(p[0]));
    case 'B':
    case 'M':
      return static_cast<double>(p[0]);
    case 'h':
      return static_cast<double>(static_cast<std::int16_t>(LoadLe(p, 2)));
    case 'H':
      return static_cast<double>(LoadLe(p, 2));
    case 'i':
      return static_cast<double>(static_cast<std::int32_t>(LoadLe(p, 4)));
    case 'I':
      return static_cast<double>(LoadLe(p, 4));
    case 'q':
      return static_cast<double>(static_cast<std::int64_t>(LoadLe(p, 8)));
    case 'Q':
      return static_cast<double>(LoadLe(p, 8));
    case 'c':
      return static_cast<std::int16_t>(LoadLe(p, 2)) / 100.0;
    case 'C':
      return static_cast<double>(LoadLe(p, 2)) / 100.0;
    case 'e':
      return static_cast<std::int32_t>(LoadLe(p, 4)) / 100.0;
    case 'E':
      return static_cast<double>(LoadLe(p, 4)) / 100.0;
    case 'L':
      return static_cast<std::int32_t>(LoadLe(p, 4)) / 1e7;
    case 'f':
      return io_detail::LoadFloatLe(p);
    case 'd':
      return io_detail::LoadDoubleLe(p);
    default:
      return std::nullopt;
  }
}

// A NUL-padded char[n] field as a string (up to the first NUL).
std::string FixedString(const unsigned char* p, int n) {
  int len = 0;
  while (len < n && p[len] != 0) ++len;
  return std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(len));
}

std::vector<std::string> SplitTrimmed(std::string_view s, char sep) {
  std::vector<std::string> out;
  std::size_t b = 0;
  while (true) {
    const std::size_t e = s.find(sep, b);
    out.emplace_back(TrimSpace(s.substr(b, e == std::string_view::npos ? s.npos : e - b)));
    if (e == std::string_view::npos) break;
    b = e + 1;
  }
  return out;
}

// What aerovo reads from a message type, by the column names of its FMT.
enum class Kind { kOther, kGps, kAtt, kPos, kCam, kTrig };
struct Roles {
  Kind kind = Kind::kOther;
  // Column indexes, -1 when the message has no such column.
  int time_us = -1, status = -1, lat = -1, lng = -1, alt = -1, week = -1, week_ms = -1,
      instance = -1, roll = -1, pitch = -1, yaw = -1, rel_home_alt = -1, image = -1;
};

int ColumnIndex(const std::vector<std::string>& columns, std::string_view name) {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return static_cast<int>(i);
  }
  return -1;
}

// The roles of a message's columns (ArduPilot's column names: libraries/AP_GPS/LogStructure.h
// GPS "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U"; AP_AHRS/LogStructure.h
// ATT "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,..." and POS
// "TimeUS,Lat,Lng,Alt,RelHomeAlt,RelOriginAlt"). A message missing a column it needs is
// `missing` (named in the error when the log has no usable GPS message).
Roles RolesOf(const std::string& name, const std::vector<std::string>& columns,
              std::string* missing) {
  Roles r;
  const auto col = [&](std::string_view c) { return ColumnIndex(columns, c); };
  r.time_us = col("TimeUS");
  const auto need = [&](std::initializer_list<std::pair<int, const char*>> cols) {
    for (auto [index, label] : cols) {
      if (index < 0) {
        std::string list;
        for (const std::string& c : columns) list += (list.empty() ? "" : ",") + c;
        *missing = fmt::format("the {} messages have no '{}' column (columns: {})", name, label,
                               Printable(list, 200));
        return false;
      }
    }
    return true;
  };
  if (name == "GPS") {
    r.status = col("Status");
    r.lat = col("Lat");
    r.lng = col("Lng");
    r.alt = col("Alt");
    r.week = col("GWk");
    r.week_ms = col("GMS");
    r.instance = col("I");
    if (need({{r.time_us, "TimeUS"}, {r.status, "Status"}, {r.lat, "Lat"}, {r.lng, "Lng"}})) {
      r.kind = Kind::kGps;
    }
  } else if (name == "ATT") {
    r.roll = col("Roll");
    r.pitch = col("Pitch");
    r.yaw = col("Yaw");
    if (need({{r.time_us, "TimeUS"}, {r.roll, "Roll"}, {r.pitch, "Pitch"}, {r.yaw, "Yaw"}})) {
      r.kind = Kind::kAtt;
    }
  } else if (name == "POS") {
    r.rel_home_alt = col("RelHomeAlt");
    if (r.time_us >= 0 && r.rel_home_alt >= 0) r.kind = Kind::kPos;
  } else if (name == "CAM" || name == "TRIG") {
    // AP_Camera/LogStructure.h: "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y"
    // (the instance I and the image number Img since ArduPilot 4.1; Roll, Pitch, Yaw before R,
    // P, Y). Alt is above sea level, RelAlt above home (m), the angles the aircraft's (deg).
    const auto either = [&](std::string_view a, std::string_view b) {
      const int i = col(a);
      return i >= 0 ? i : col(b);
    };
    r.instance = col("I");
    r.image = col("Img");
    r.week = col("GPSWeek");
    r.week_ms = col("GPSTime");
    r.lat = col("Lat");
    r.lng = col("Lng");
    r.alt = col("Alt");
    r.rel_home_alt = col("RelAlt");
    r.roll = either("R", "Roll");
    r.pitch = either("P", "Pitch");
    r.yaw = either("Y", "Yaw");
    if (r.time_us >= 0) r.kind = name == "CAM" ? Kind::kCam : Kind::kTrig;
  }
  return r;
}

// The UTC time (s since 1970) of a message's GPS week and milliseconds into it (columns r.week,
// r.week_ms); nullopt without them or before the receiver has a time (week 0).
template <typename Value>
std::optional<double> UnixTimeOf(const Roles& r, const Value& value) {
  if (r.week < 0 || r.week_ms < 0) return std::nullopt;
  const std::optional<double> week = value(r.week), ms = value(r.week_ms);
  if (!week || !ms || !(*week > 0.0) || !(*ms >= 0.0 && *ms < kGpsWeekS * 1000.0)) {
    return std::nullopt;
  }
  return kGpsEpochUnixS + *week * kGpsWeekS + *ms / 1000.0 - kGpsLeapSeconds;
}

// Collects what the messages say, whichever form they came in, and builds the samples.
class Collector {
 public:
  Collector(RecordErrors& errors, bool binary) : errors_(errors), binary_(binary) {}

  // "<source> at byte <offset>" (binary) or "<source>:<line>" (text).
  std::string Where(long long place) const {
    return binary_ ? fmt::format("{} at byte {}", errors_.source(), place)
                   : errors_.At(static_cast<long>(place));
  }
  void Malformed(long long place, const std::string& message) {
    errors_.ReportMessage(fmt::format("{}: {}", Where(place), message));
  }

  // One message of a type with `roles`; value(i) is column i's (scaled) value, nullopt when it
  // is not a number.
  template <typename Value>
  void Message(const Roles& roles, const Value& value, long long place) {
    switch (roles.kind) {
      case Kind::kGps:
        Gps(roles, value, place);
        break;
      case Kind::kAtt:
        Att(roles, value, place);
        break;
      case Kind::kPos:
        Pos(roles, value, place);
        break;
      case Kind::kCam:
        Camera(roles, value, place, cam_);
        break;
      case Kind::kTrig:
        Camera(roles, value, place, trig_);
        break;
      case Kind::kOther:
        break;
    }
  }

  void NoteMissing(const std::string& m) {
    if (missing_.empty()) missing_ = m;
  }
  // Bytes of the file skipped as no message, and the file's size: said when nothing is read.
  void NoteUnreadable(long long skipped, long long total) {
    unreadable_ = skipped;
    total_ = total;
  }

  TelemetryReadResult Finish() {
    std::stable_sort(att_.begin(), att_.end(), io_detail::SeriesByTime);
    std::stable_sort(pos_.begin(), pos_.end(), io_detail::SeriesByTime);
    for (TelemetrySample& s : samples_) {
      if (const auto a =
              io_detail::InterpolateSeries(att_, s.time_s, true, kMaxInterpolationGapS)) {
        s.roll_deg = a->v[0];
        s.pitch_deg = a->v[1];
        s.yaw_deg = a->v[2];
      }
      if (const auto p = io_detail::InterpolateSeries(pos_, s.time_s, false, kMaxInterpolationGapS))
        s.rel_alt_m = p->v[0];
    }
    if (samples_.empty() && gps_messages_ == 0 && !missing_.empty()) {
      throw InputError(
          fmt::format("{}: no GPS position in this DataFlash log: {}", errors_.source(), missing_));
    }
    if (samples_.empty() && gps_messages_ == 0 && errors_.skipped() == 0) {
      throw InputError(fmt::format(
          "{}: no GPS message in this DataFlash log ({})", errors_.source(),
          unreadable_ > 0
              ? fmt::format("{} of its {} bytes are no DataFlash message: a damaged log, or not "
                            "a log",
                            unreadable_, total_)
              : std::string("GPS logging off in LOG_BITMASK, or a log written before the GPS "
                            "was connected")));
    }
    if (samples_.empty() && no_fix_ > 0 && errors_.skipped() == 0) {
      throw InputError(fmt::format(
          "{}: no GPS message with a 3D fix in this DataFlash log ({} GPS messages without one: "
          "Status < 3, no fix yet, or at latitude = longitude = 0)",
          errors_.source(), no_fix_));
    }
    TelemetryReadResult r =
        io_detail::Finish(std::move(samples_), errors_, no_fix_, "DataFlash log");
    // CAM is the photo taken (with a feedback pin, the camera's own signal), TRIG the trigger
    // sent when a feedback pin is set (AP_Camera_Backend.cpp log_picture, check_feedback).
    r.camera_triggers = std::move(!cam_.empty() ? cam_ : trig_);
    return r;
  }

 private:
  template <typename Value>
  std::optional<double> Time(const Roles& roles, const Value& value, long long place,
                             const char* what) {
    const std::optional<double> us = value(roles.time_us);
    if (!us || *us < 0.0) {
      Malformed(place, fmt::format("{} message without a valid TimeUS", what));
      return std::nullopt;
    }
    return *us / 1e6;
  }

  template <typename Value>
  void Gps(const Roles& r, const Value& value, long long place) {
    // Several receivers are logged as GPS instances 0, 1, ... (column I): the first one is read.
    if (r.instance >= 0) {
      const std::optional<double> instance = value(r.instance);
      if (instance && *instance != 0.0) return;
    }
    ++gps_messages_;
    const std::optional<double> t = Time(r, value, place, "GPS");
    if (!t) return;
    const std::optional<double> status = value(r.status);
    if (!status) {
      Malformed(place, "GPS message whose Status is not a number");
      return;
    }
    if (*status < kGps3dFix) {
      ++no_fix_;
      return;
    }
    const std::optional<double> lat = value(r.lat), lon = value(r.lng);
    if (!lat || !lon) {
      Malformed(place, fmt::format("GPS message whose {} is not a number", !lat ? "Lat" : "Lng"));
      return;
    }
    if (*lat == 0.0 && *lon == 0.0) {
      ++no_fix_;
      return;
    }
    if (last_gps_time_ && *t < *last_gps_time_) {
      Malformed(place, fmt::format("GPS time {:.6f} s is earlier than the previous GPS "
                                   "message's {:.6f} s (messages out of order)",
                                   *t, *last_gps_time_));
      return;
    }
    TelemetrySample s;
    s.time_s = *t;
    s.lat_deg = *lat;
    s.lon_deg = *lon;
    if (r.alt >= 0) s.abs_alt_m = value(r.alt);
    s.unix_time_s = UnixTimeOf(r, value);
    const std::string where = Where(place);
    try {
      ValidateSample(s, where);
    } catch (const InputError& e) {
      errors_.ReportMessage(e.what());
      return;
    }
    s.origin = where;
    last_gps_time_ = *t;
    samples_.push_back(std::move(s));
  }

  template <typename Value>
  void Att(const Roles& r, const Value& value, long long place) {
    const std::optional<double> t = Time(r, value, place, "ATT");
    if (!t) return;
    if (!att_.empty() && std::abs(*t - att_.back().time_s) < kMinSeriesStepS) return;
    const std::optional<double> roll = value(r.roll), pitch = value(r.pitch), yaw = value(r.yaw);
    for (const auto& [v, name] : {std::pair{&roll, "Roll"}, {&pitch, "Pitch"}, {&yaw, "Yaw"}}) {
      if (!*v || !(std::abs(**v) <= 360.0)) {
        Malformed(place, fmt::format("ATT {} is not an angle in degrees", name));
        return;
      }
    }
    att_.push_back(SeriesPoint{*t, {*roll, *pitch, *yaw}});
  }

  template <typename Value>
  void Pos(const Roles& r, const Value& value, long long place) {
    const std::optional<double> t = Time(r, value, place, "POS");
    if (!t) return;
    if (!pos_.empty() && std::abs(*t - pos_.back().time_s) < kMinSeriesStepS) return;
    const std::optional<double> rel = value(r.rel_home_alt);
    if (!rel || !(std::abs(*rel) <= 1e5)) {
      Malformed(place, "POS RelHomeAlt is not a height in metres");
      return;
    }
    pos_.push_back(SeriesPoint{*t, {*rel, 0.0, 0.0}});
  }

  // One CAM or TRIG message of the first camera (instance 0) into `out`: the aircraft's
  // position, heights and attitude when the photo was taken, as AP_Camera_Backend.cpp
  // Write_CameraInfo logs them (the AHRS position, which it logs even without one: latitude =
  // longitude = 0 is a photo without a fix).
  template <typename Value>
  void Camera(const Roles& r, const Value& value, long long place,
              std::vector<TelemetrySample>& out) {
    const char* name = &out == &cam_ ? "CAM" : "TRIG";
    if (r.instance >= 0) {
      const std::optional<double> instance = value(r.instance);
      if (instance && *instance != 0.0) return;
    }
    const std::optional<double> t = Time(r, value, place, name);
    if (!t) return;
    if (!out.empty() && *t < out.back().time_s) {
      Malformed(place, fmt::format("{} time {:.6f} s is earlier than the previous {} message's "
                                   "{:.6f} s (messages out of order)",
                                   name, *t, name, out.back().time_s));
      return;
    }
    TelemetrySample s;
    s.time_s = *t;
    const std::optional<double> lat = value(r.lat), lon = value(r.lng);
    s.has_fix = lat && lon && !(*lat == 0.0 && *lon == 0.0);
    if (s.has_fix) {
      s.lat_deg = *lat;
      s.lon_deg = *lon;
    }
    const auto opt = [&](int i) { return i >= 0 ? value(i) : std::optional<double>(); };
    s.abs_alt_m = opt(r.alt);
    s.rel_alt_m = opt(r.rel_home_alt);
    s.roll_deg = opt(r.roll);
    s.pitch_deg = opt(r.pitch);
    s.yaw_deg = opt(r.yaw);
    s.unix_time_s = UnixTimeOf(r, value);
    const std::string where = Where(place);
    try {
      ValidateSample(s, where + ": " + name);
    } catch (const InputError& e) {
      errors_.ReportMessage(e.what());
      return;
    }
    const std::optional<double> image = opt(r.image);
    s.origin = image ? fmt::format("{}: {} {}", where, name, *image) : where + ": " + name;
    out.push_back(std::move(s));
  }

  RecordErrors& errors_;
  bool binary_;
  std::vector<TelemetrySample> samples_;
  std::vector<TelemetrySample> cam_, trig_;
  std::vector<SeriesPoint> att_, pos_;
  std::optional<double> last_gps_time_;
  int gps_messages_ = 0;
  int no_fix_ = 0;
  std::string missing_;
  long long unreadable_ = 0, total_ = 0;
};

// ------------------------------------------------------------------------------ binary form

struct BinaryFormat {
  bool defined = false;
  int length = 0;  // whole message, header included; >= 3
  std::string name;
  std::string format;
  std::vector<int> offsets;  // of each field, from the message's first byte
  Roles roles;
};

// Warnings are kept up to options.max_warnings in all (with those of skipped records), leaving
// room for the count of gaps not listed.
void ParseBinary(std::istream& in, const TelemetryReadOptions& options, RecordErrors& errors,
                 Collector& out) {
  ByteWindow w(in);
  std::array<BinaryFormat, 256> formats;
  formats[kFmtType].defined = true;
  formats[kFmtType].length = kFmtLength;
  formats[kFmtType].name = "FMT";
  // A message starts at q (`avail` bytes available from q): a header, a type the log defines,
  // and after its length the next header or the end of the file. The last check catches bytes
  // inserted into or lost from a message (its length would run into the next message): the
  // message is then damaged, not read with shifted fields.
  const auto starts_message = [&](const unsigned char* q, std::size_t avail) {
    if (avail < 3 || q[0] != kHead1 || q[1] != kHead2 || !formats[q[2]].defined) return false;
    const std::size_t len = static_cast<std::size_t>(formats[q[2]].length);
    if (avail <= len + 1) return true;  // the file ends within 1 byte of it (or cuts it short)
    return q[len] == kHead1 && q[len + 1] == kHead2;
  };
  const auto room = [&](int spare) {
    return static_cast<int>(errors.warnings().size()) + spare < options.max_warnings;
  };
  const auto warn = [&](std::string message) {
    if (room(0)) errors.warnings().push_back(std::move(message));
  };
  int gaps = 0, listed = 0;
  long long gap_bytes = 0;
  const auto gap = [&](long long at, long long bytes, const char* why) {
    ++gaps;
    gap_bytes += bytes;
    if (listed < kMaxListedGaps && room(1)) {
      ++listed;
      errors.warnings().push_back(
          fmt::format("{} at byte {}: {} byte(s) skipped: {}", errors.source(), at, bytes, why));
    }
  };
  while (true) {
    std::size_t avail = w.Fill(kMaxMessageLength + 2);
    if (avail == 0) break;
    const unsigned char* p = w.data();
    if (!starts_message(p, avail)) {
      // Not a message: bytes written over (power loss) or a cut tail. Resynchronise on the next
      // header followed by a type the log defines.
      const long long at = w.offset();
      long long skipped = 0;
      do {
        w.Skip(1);
        ++skipped;
        avail = w.Fill(kMaxMessageLength + 2);
      } while (avail >= 3 && !starts_message(w.data(), avail));
      if (avail < 3) {
        skipped += static_cast<long long>(avail);
        w.Skip(avail);
        gap(at, skipped, "no DataFlash message up to the end of the file (a cut or damaged log)");
        break;
      }
      gap(at, skipped,
          "not a DataFlash message, or a message whose length runs into the next one (a damaged "
          "log); read on at the next message");
      continue;
    }
    const int type = p[2];
    const BinaryFormat& f = formats[type];
    if (avail < static_cast<std::size_t>(f.length)) {
      gap(w.offset(), static_cast<long long>(avail),
          fmt::format("the last message ({}, {} bytes) is cut short (a log whose writing stopped)",
                      Printable(f.name), f.length)
              .c_str());
      w.Skip(avail);  // read: the file's size is the offset after it
      break;
    }
    const long long at = w.offset();
    if (type == kFmtType) {
      const int def_type = p[3];
      const int length = p[4];
      BinaryFormat d;
      d.name = FixedString(p + 5, 4);
      d.format = FixedString(p + 9, 16);
      const std::vector<std::string> columns = SplitTrimmed(FixedString(p + 25, 64), ',');
      if (def_type == kFmtType) {
        if (length != kFmtLength || d.format != "BBnNZ") {
          throw InputError(fmt::format(
              "{} at byte {}: the FMT message describes itself with length {} and format '{}' "
              "(ArduPilot's: 89, 'BBnNZ'): not a DataFlash log aerovo can read",
              errors.source(), at, length, Printable(d.format)));
        }
      } else if (length < 3) {
        warn(fmt::format(
            "{} at byte {}: FMT of type {} ('{}') with length {} < 3: its messages cannot be "
            "read",
            errors.source(), at, def_type, Printable(d.name), length));
        formats[def_type] = BinaryFormat{};
      } else {
        d.defined = true;
        d.length = length;
        int offset = 3;
        bool decodable = true;
        for (char c : d.format) {
          const int size = FieldSize(c);
          if (size == 0) decodable = false;
          d.offsets.push_back(offset);
          offset += size;
        }
        decodable = decodable && offset == length && columns.size() == d.format.size();
        std::string missing;
        if (decodable) {
          d.roles = RolesOf(d.name, columns, &missing);
        } else if (d.name == "GPS" || d.name == "ATT" || d.name == "POS" || d.name == "CAM" ||
                   d.name == "TRIG") {
          missing = fmt::format(
              "the FMT of {} at byte {} is inconsistent (format '{}' of {} bytes, {} columns, "
              "length {})",
              d.name, at, Printable(d.format), offset, columns.size(), length);
          warn(fmt::format("{}: {}: its messages are not read", errors.source(), missing));
        }
        if (!missing.empty() && d.name == "GPS") out.NoteMissing(missing);
        formats[def_type] = std::move(d);
      }
    } else if (f.roles.kind != Kind::kOther) {
      const auto value = [&](int i) -> std::optional<double> {
        if (i < 0) return std::nullopt;
        const std::optional<double> v = DecodeField(p + f.offsets[i], f.format[i]);
        if (v && !std::isfinite(*v)) return std::nullopt;
        return v;
      };
      out.Message(f.roles, value, at);
    }
    w.Skip(static_cast<std::size_t>(f.length));
  }
  out.NoteUnreadable(gap_bytes, w.offset());
  if (gaps > listed) {
    warn(fmt::format("{}: {} gaps of unreadable bytes in all ({} bytes), {} of them listed",
                     errors.source(), gaps, gap_bytes, listed));
  }
}

// ------------------------------------------------------------------------------ text form

struct TextFormat {
  std::size_t columns = 0;
  Roles roles;
};

void ParseText(std::istream& in, RecordErrors& errors, Collector& out) {
  io_detail::TextLines lines(in, errors.source());
  std::map<std::string, TextFormat, std::less<>> formats;
  std::string line;
  bool first = true;
  while (lines.Next(line)) {
    const std::string_view t = TrimSpace(line);
    if (t.empty()) continue;
    const std::size_t comma = t.find(',');
    const std::string_view name = TrimSpace(t.substr(0, comma));
    if (first) {
      if (name != "FMT") {
        throw InputError(fmt::format(
            "{}:{}: not an ArduPilot DataFlash log: a text log (Mission Planner's .log) starts "
            "with 'FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns', this file with "
            "'{}'",
            errors.source(), lines.line(), Printable(t)));
      }
      first = false;
    }
    if (name == "FMT") {
      // "FMT, type, length, name, format, columns": the columns are the rest of the line.
      const std::vector<std::string> f = SplitTrimmed(t, ',');
      if (f.size() < 6) {
        out.Malformed(lines.line(), "FMT line with fewer than 5 values");
        continue;
      }
      const std::vector<std::string> columns(f.begin() + 5, f.end());
      std::string missing;
      TextFormat d;
      d.columns = columns.size();
      d.roles = RolesOf(f[3], columns, &missing);
      if (!missing.empty() && f[3] == "GPS") out.NoteMissing(missing);
      formats[f[3]] = d;
      continue;
    }
    const auto it = formats.find(name);
    if (it == formats.end() || it->second.roles.kind == Kind::kOther) continue;
    const std::vector<std::string> values = SplitTrimmed(t.substr(comma + 1), ',');
    if (comma == std::string_view::npos || values.size() != it->second.columns) {
      out.Malformed(
          lines.line(),
          fmt::format("{} line with {} values, its FMT names {} columns", std::string(name),
                      comma == std::string_view::npos ? 0 : values.size(), it->second.columns));
      continue;
    }
    const auto value = [&](int i) -> std::optional<double> {
      if (i < 0) return std::nullopt;
      return ParseDecimal(values[static_cast<std::size_t>(i)]);
    };
    out.Message(it->second.roles, value, lines.line());
  }
  if (first) {
    throw InputError(
        fmt::format("{}: an empty file, not an ArduPilot DataFlash log", errors.source()));
  }
}

}  // namespace

TelemetryReadResult ParseDataFlash(std::istream& in, const std::string& source_name,
                                   const TelemetryReadOptions& options) {
  Validate(options);
  RecordErrors errors(options, source_name);
  // The first bytes: enough to tell the two forms apart (another file is named by HintFor).
  unsigned char head[16] = {};
  const std::streampos start = in.tellg();
  in.read(reinterpret_cast<char*>(head), sizeof head);
  const std::size_t n = static_cast<std::size_t>(in.gcount());
  in.clear();
  in.seekg(start);
  if (!in) throw InputError(fmt::format("{}: cannot read the file from its start", source_name));
  if (n >= 3 && head[0] == kHead1 && head[1] == kHead2) {
    if (head[2] != kFmtType) {
      throw InputError(fmt::format(
          "{}: a DataFlash log starts with an FMT message (type 128), this one with a message "
          "of type {}: not a whole log",
          source_name, head[2]));
    }
    Collector out(errors, true);
    ParseBinary(in, options, errors, out);
    return out.Finish();
  }
  // Text: the first line must be an FMT line (ParseText says so); bytes that are not text make
  // TextLines stop at the first NUL. Say what a binary file is before that.
  const bool text = n == 0 || std::all_of(head, head + n, [](unsigned char c) {
                      return c == '\t' || c == '\r' || c == '\n' || (c >= 0x20 && c < 0x7F);
                    });
  if (!text) {
    std::string bytes;
    for (std::size_t k = 0; k < std::min<std::size_t>(n, 8); ++k) {
      bytes += fmt::format("{}{:02X}", k ? " " : "", head[k]);
    }
    throw InputError(fmt::format(
        "{}: not an ArduPilot DataFlash log: a .bin log starts with the bytes A3 95 80 (an FMT "
        "message), this file with {}{}",
        source_name, bytes, io_detail::HintFor(in)));
  }
  Collector out(errors, false);
  ParseText(in, errors, out);
  return out.Finish();
}

TelemetryReadResult ReadDataFlash(const std::filesystem::path& path,
                                  const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  return ParseDataFlash(in, path.string(), options);
}

}  // namespace aerovo
