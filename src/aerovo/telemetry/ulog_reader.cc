// PX4 ULog flight logs (.ulg): the binary log PX4 writes to its SD card. A GPS topic becomes the
// samples; vehicle_attitude and the height above home (vehicle_local_position, home_position)
// are interpolated onto them; camera_capture becomes the camera triggers (the photos taken). See
// telemetry_readers.h (ParseULog) and docs/inputs.md "PX4 ULog flight logs".
//
// The format, as PX4 defines it (PX4 User Guide, "ULog File Format",
// docs.px4.io/main/en/dev_log/ulog_file_format.html; PX4-Autopilot
// docs/en/dev_log/ulog_file_format.md):
//  - a 16-byte header: the magic 'U' 'L' 'o' 'g' 0x01 0x12 0x35, a version byte, a uint64
//    timestamp (microseconds); then messages, each a uint16 msg_size (the payload's bytes, the
//    3-byte header excluded), a uint8 msg_type and the payload. Little-endian, unaligned;
//  - definitions: 'B' flag bits (compat_flags[8], incompat_flags[8], appended_offsets[3]: a
//    parser must refuse a log with an incompatible bit it does not know; bit 0 of
//    incompat_flags[0], DATA_APPENDED, says data was appended at the non-zero offsets, the
//    message cut there being discarded), 'F' format ("name:type field;type field;...", types
//    int8_t..uint64_t, float, double, bool, char, fixed arrays "type[n]", or the name of another
//    format; fields named _padding... are skipped, and a trailing one may not be logged), 'I'
//    info, 'M' multi info, 'P' parameter, 'Q' default parameter;
//  - data: 'A' subscription (uint8 multi_id, uint16 msg_id, char[] message_name), 'D' data
//    (uint16 msg_id, then the topic's fields as its format packs them; every subscribed format
//    has a uint64_t timestamp in microseconds), 'L' and 'C' logged strings, 'S' sync (magic
//    2F 73 13 20 25 0C BB 12, "so that a reader can recover from a corrupt message"), 'O'
//    dropout (uint16 duration, ms), 'R' unsubscription (uint16 msg_id);
//  - unknown message types are ignored; a log that ends in the middle of a message is read up
//    to it.
// The topics (PX4-Autopilot msg/*.msg; the field names and layouts are read from the log's own
// 'F' formats, never assumed):
//  - vehicle_gps_position: before v1.14 (msg/vehicle_gps_position.msg) int32 lat, lon (1e-7
//    degrees), int32 alt (mm above MSL); from v1.14 the selected receiver with the layout of
//    sensor_gps (msg/SensorGps.msg: "# TOPICS sensor_gps vehicle_gps_position"): double
//    latitude_deg, longitude_deg, altitude_msl_m (m). Both: uint8 fix_type (0-1 no fix, 2 2D,
//    3 3D, 4 and up better), uint64 time_utc_usec (UTC microseconds, 0 until the receiver has
//    it), int32 timestamp_time_relative ("timestamp + timestamp_time_relative = time of the UTC
//    timestamp since system start");
//  - sensor_gps (v1.14 on, one instance per receiver): the same fields;
//  - vehicle_global_position (msg/VehicleGlobalPosition.msg): double lat, lon (degrees), float
//    alt (m AMSL), bool lat_lon_valid (recent versions);
//  - vehicle_attitude (msg/VehicleAttitude.msg): float[4] q, "Hamilton convention, order
//    (w, x, y, z)", "rotation from the FRD body frame to the NED earth frame";
//  - vehicle_local_position (msg/VehicleLocalPosition.msg): float z ("Down position (negative
//    altitude) in NED earth-fixed frame", m, from the position where EKF2 started, not home),
//    bool z_valid; home_position (msg/HomePosition.msg): float z (home in the same local
//    frame), bool valid_alt. The height above home is home.z - z, as PX4 computes
//    GLOBAL_POSITION_INT.relative_alt (src/modules/mavlink/streams/GLOBAL_POSITION_INT.hpp).
//  - camera_capture (msg/CameraCapture.msg): a photo the camera took (Collector::Camera):
//    uint64 timestamp (us since boot), uint64 timestamp_utc (us, UTC), uint32 seq, double lat,
//    lon (degrees), float alt (m AMSL), float[4] q (as vehicle_attitude's, or the gimbal's
//    attitude when the camera is on one: not read), int8 result (1 success, 0 failure, -1 no
//    feedback).
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/telemetry/binary_log_util.h"
#include "aerovo/telemetry/file_kind.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
// Named (not only anonymous): the module may be built as one unity source with the other readers.
namespace ulog_reader {
namespace {

// Roll, pitch, yaw in degrees of the rotation quaternion q = (w, x, y, z) (Hamilton convention,
// from the FRD body frame to the NED earth frame: PX4-Autopilot msg/VehicleAttitude.msg) with
// norm `norm` > 0 (q is normalised here): the "3-2-1 intrinsic Tait-Bryan rotation sequence"
// (yaw about down, pitch about the new right axis, roll about the new forward axis) as PX4
// itself turns q into Euler angles (PX4-Autopilot src/lib/matrix/matrix/Euler.hpp,
// Euler(const Dcm&)). Yaw 0 = north, 90 = east, in [0, 360); pitch up and roll right positive.
std::array<double, 3> RollPitchYawDeg(const double q[4], double norm) {
  const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
  const double roll = std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
  const double pitch = std::asin(std::clamp(2.0 * (w * y - x * z), -1.0, 1.0));
  double yaw = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)) * kRadToDeg;
  if (yaw < 0.0) yaw += 360.0;
  if (yaw >= 360.0) yaw -= 360.0;
  return {roll * kRadToDeg, pitch * kRadToDeg, yaw};
}

using io_detail::ByteWindow;
using io_detail::LoadLe;
using io_detail::RecordErrors;
using io_detail::SeriesPoint;

constexpr unsigned char kMagic[7] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35};
constexpr std::size_t kFileHeaderSize = 16;
constexpr std::size_t kMessageHeaderSize = 3;
// msg_size is a uint16: no payload is longer.
constexpr std::size_t kMaxPayload = 65535;
constexpr unsigned char kSyncMagic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};
// The read window holds a whole message and the next message's header.
constexpr std::size_t kWindowBytes = std::size_t{1} << 17;
constexpr std::size_t kLookahead = kMessageHeaderSize + kMaxPayload + kMessageHeaderSize;

// Bounds on what a file can make the reader keep (a real log has a few hundred formats of a few
// hundred bytes each): formats beyond them are ignored with a warning.
constexpr std::size_t kMaxFormats = 8192;
constexpr std::size_t kMaxFormatBytes = std::size_t{8} << 20;
// Nesting depth of formats (a format that contains itself never ends: refused at this depth).
constexpr int kMaxNesting = 16;

// sensor_gps fix_type (msg/SensorGps.msg FIX_TYPE_3D): a sample needs a 3D fix.
constexpr double kFix3d = 3.0;
using io_detail::kMaxInterpolationGapS;
using io_detail::kMaxListedGaps;
using io_detail::kMinSeriesStepS;

// ------------------------------------------------------------------------------ formats

enum class Basic { kNone, kI8, kU8, kI16, kU16, kI32, kU32, kI64, kU64, kF32, kF64, kBool, kChar };

struct BasicInfo {
  std::string_view name;
  Basic type;
  int size;
};
constexpr BasicInfo kBasics[] = {
    {"int8_t", Basic::kI8, 1},    {"uint8_t", Basic::kU8, 1},   {"int16_t", Basic::kI16, 2},
    {"uint16_t", Basic::kU16, 2}, {"int32_t", Basic::kI32, 4},  {"uint32_t", Basic::kU32, 4},
    {"int64_t", Basic::kI64, 8},  {"uint64_t", Basic::kU64, 8}, {"float", Basic::kF32, 4},
    {"double", Basic::kF64, 8},   {"bool", Basic::kBool, 1},    {"char", Basic::kChar, 1},
};

const BasicInfo* FindBasic(std::string_view name) {
  for (const BasicInfo& b : kBasics) {
    if (b.name == name) return &b;
  }
  return nullptr;
}

int BasicSize(Basic t) {
  for (const BasicInfo& b : kBasics) {
    if (b.type == t) return b.size;
  }
  return 0;
}

bool IsInteger(Basic t) { return t != Basic::kF32 && t != Basic::kF64 && t != Basic::kNone; }

double DecodeBasic(Basic t, const unsigned char* p) {
  switch (t) {
    case Basic::kI8:
      return static_cast<std::int8_t>(p[0]);
    case Basic::kU8:
    case Basic::kBool:
    case Basic::kChar:
      return p[0];
    case Basic::kI16:
      return static_cast<std::int16_t>(LoadLe(p, 2));
    case Basic::kU16:
      return static_cast<double>(LoadLe(p, 2));
    case Basic::kI32:
      return static_cast<std::int32_t>(LoadLe(p, 4));
    case Basic::kU32:
      return static_cast<double>(LoadLe(p, 4));
    case Basic::kI64:
      return static_cast<double>(static_cast<std::int64_t>(LoadLe(p, 8)));
    case Basic::kU64:
      return static_cast<double>(LoadLe(p, 8));
    case Basic::kF32:
      return io_detail::LoadFloatLe(p);
    case Basic::kF64:
      return io_detail::LoadDoubleLe(p);
    case Basic::kNone:
      break;
  }
  return std::nan("");
}

struct Field {
  std::string type;  // a basic type or another format's name
  long long count = 1;
  std::string name;
};

struct Format {
  std::string name;
  std::vector<Field> fields;
};

// "name:type field;type[n] field;..." -> the format; nullopt with `why` when malformed.
std::optional<Format> ParseFormat(std::string_view text, std::string* why) {
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos || colon == 0) {
    *why = "no 'name:' before the fields";
    return std::nullopt;
  }
  Format f;
  f.name = std::string(text.substr(0, colon));
  std::string_view rest = text.substr(colon + 1);
  while (!rest.empty()) {
    const std::size_t semi = rest.find(';');
    const std::string_view item = TrimSpace(rest.substr(0, semi));
    rest = semi == std::string_view::npos ? std::string_view() : rest.substr(semi + 1);
    if (item.empty()) continue;
    const std::size_t space = item.rfind(' ');
    if (space == std::string_view::npos || space == 0 || space + 1 == item.size()) {
      *why = fmt::format("field '{}' is not 'type name'", Printable(item, 40));
      return std::nullopt;
    }
    Field field;
    field.name = std::string(item.substr(space + 1));
    std::string_view type = TrimSpace(item.substr(0, space));
    const std::size_t bracket = type.find('[');
    if (bracket != std::string_view::npos) {
      if (type.back() != ']') {
        *why = fmt::format("field '{}': an array is written 'type[n]'", Printable(item, 40));
        return std::nullopt;
      }
      const auto n = io_detail::ParseInt(type.substr(bracket + 1, type.size() - bracket - 2));
      if (!n || *n < 0 || *n > static_cast<long long>(kMaxPayload)) {
        *why = fmt::format("field '{}': array length not in [0, 65535]", Printable(item, 40));
        return std::nullopt;
      }
      field.count = *n;
      type = type.substr(0, bracket);
    }
    if (type.empty()) {
      *why = fmt::format("field '{}' has no type", Printable(item, 40));
      return std::nullopt;
    }
    field.type = std::string(type);
    f.fields.push_back(std::move(field));
  }
  if (f.fields.empty()) {
    *why = "no field";
    return std::nullopt;
  }
  return f;
}

// A top-level field of a topic, where it is in a 'D' message's data.
struct FieldRef {
  int offset = -1;  // -1: the topic has no such field (of a basic type)
  Basic type = Basic::kNone;
  int count = 0;
};

class Formats {
 public:
  // Adds a format; false (and `why`) when it is malformed or over the bounds.
  bool Add(std::string_view text, std::string* why) {
    if (formats_.size() >= kMaxFormats || bytes_ + text.size() > kMaxFormatBytes) {
      *why = fmt::format("more formats than aerovo keeps ({} formats, {} bytes)", kMaxFormats,
                         kMaxFormatBytes);
      return false;
    }
    std::optional<Format> f = ParseFormat(text, why);
    if (!f) return false;
    // A name is defined once (ulog_file_format.md); a second definition is ignored, so that the
    // sizes computed from the first stay right.
    if (index_.count(f->name) != 0) {
      *why = "defined twice";
      return false;
    }
    bytes_ += text.size();
    index_.emplace(f->name, static_cast<int>(formats_.size()));
    formats_.push_back(std::move(*f));
    return true;
  }
  int Find(std::string_view name) const {
    const auto it = index_.find(name);
    return it == index_.end() ? -1 : it->second;
  }
  const Format& at(int i) const { return formats_[static_cast<std::size_t>(i)]; }

  // Size in bytes of format i with its nested formats; -1 when a type is unknown, the nesting
  // is deeper than kMaxNesting (a format that contains itself) or it exceeds any message.
  long long Size(int i, int depth = 0) {
    if (depth > kMaxNesting) return -1;
    const auto cached = sizes_.find(i);
    if (cached != sizes_.end()) return cached->second;
    long long total = 0;
    for (const Field& f : at(i).fields) {
      long long size;
      if (const BasicInfo* b = FindBasic(f.type)) {
        size = b->size;
      } else {
        const int nested = Find(f.type);
        size = nested < 0 ? -1 : Size(nested, depth + 1);
      }
      if (size < 0) {
        total = -1;
        break;
      }
      total += size * f.count;
      if (total > static_cast<long long>(kMaxPayload)) {
        total = -1;
        break;
      }
    }
    // A failure at the depth bound is not cached from within the recursion: only the outermost
    // call says whether the format has a size.
    if (total >= 0 || depth == 0) sizes_[i] = total;
    return total;
  }

  // Offsets of the top-level fields of basic types of format i (Size(i) >= 0); nested fields
  // only move the offsets.
  std::map<std::string, FieldRef, std::less<>> TopLevel(int i) {
    std::map<std::string, FieldRef, std::less<>> out;
    long long offset = 0;
    for (const Field& f : at(i).fields) {
      long long size;
      const BasicInfo* b = FindBasic(f.type);
      if (b != nullptr) {
        size = b->size;
        out[f.name] = FieldRef{static_cast<int>(offset), b->type, static_cast<int>(f.count)};
      } else {
        size = Size(Find(f.type), 1);
      }
      offset += size * f.count;
    }
    return out;
  }

 private:
  std::vector<Format> formats_;
  std::map<std::string, int, std::less<>> index_;
  std::map<int, long long> sizes_;
  std::size_t bytes_ = 0;
};

// ------------------------------------------------------------------------------ topics

enum class Kind { kOther, kVehicleGps, kSensorGps, kGlobal, kAttitude, kLocal, kHome, kCamera };
constexpr int kGpsTopics = 3;  // kVehicleGps, kSensorGps, kGlobal: in this order of preference

const char* KindName(Kind k) {
  switch (k) {
    case Kind::kVehicleGps:
      return "vehicle_gps_position";
    case Kind::kSensorGps:
      return "sensor_gps";
    case Kind::kGlobal:
      return "vehicle_global_position";
    case Kind::kAttitude:
      return "vehicle_attitude";
    case Kind::kLocal:
      return "vehicle_local_position";
    case Kind::kHome:
      return "home_position";
    case Kind::kCamera:
      return "camera_capture";
    case Kind::kOther:
      break;
  }
  return "";
}

Kind KindOf(std::string_view topic) {
  for (Kind k : {Kind::kVehicleGps, Kind::kSensorGps, Kind::kGlobal, Kind::kAttitude, Kind::kLocal,
                 Kind::kHome, Kind::kCamera}) {
    if (topic == KindName(k)) return k;
  }
  return Kind::kOther;
}

// The fields read from a topic, and the factors to degrees and metres.
struct Roles {
  Kind kind = Kind::kOther;
  FieldRef time, lat, lon, alt, fix, utc, utc_relative, lat_lon_valid, q, z, z_valid, valid_alt;
  FieldRef seq, result;  // camera_capture
  double lat_factor = 1.0, alt_factor = 1.0;
};

// A subscription ('A'): its format, the data size its 'D' messages have, and what is read.
struct Subscription {
  bool active = false;
  int format = -1;
  long long size = -1;      // -1: unknown (a nested type the log does not define)
  long long min_size = -1;  // size without a trailing _padding field (which may not be logged)
  Roles roles;
};

// The roles of topic `kind` from its top-level fields; kOther with `missing` set when a field it
// needs is not there.
Roles RolesOf(Kind kind, const std::map<std::string, FieldRef, std::less<>>& fields,
              std::string* missing) {
  Roles r;
  const auto get = [&](std::string_view name) {
    const auto it = fields.find(name);
    return it == fields.end() ? FieldRef{} : it->second;
  };
  std::vector<const char*> absent;
  const auto need = [&](const FieldRef& f, const char* name) {
    if (f.offset < 0 || f.count != 1) absent.push_back(name);
  };
  r.time = get("timestamp");
  need(r.time, "timestamp");
  switch (kind) {
    case Kind::kVehicleGps:
    case Kind::kSensorGps:
      r.fix = get("fix_type");
      need(r.fix, "fix_type");
      r.utc = get("time_utc_usec");
      r.utc_relative = get("timestamp_time_relative");
      if (get("latitude_deg").offset >= 0) {  // v1.14 on: degrees and metres
        r.lat = get("latitude_deg");
        r.lon = get("longitude_deg");
        r.alt = get("altitude_msl_m");
        need(r.lat, "latitude_deg");
        need(r.lon, "longitude_deg");
      } else {  // before v1.14: int32 1e-7 degrees and millimetres
        r.lat = get("lat");
        r.lon = get("lon");
        r.alt = get("alt");
        need(r.lat, "lat");
        need(r.lon, "lon");
        if (IsInteger(r.lat.type)) r.lat_factor = 1e-7;
        if (IsInteger(r.alt.type)) r.alt_factor = 1e-3;
      }
      break;
    case Kind::kGlobal:
      r.lat = get("lat");
      r.lon = get("lon");
      r.alt = get("alt");
      r.lat_lon_valid = get("lat_lon_valid");
      need(r.lat, "lat");
      need(r.lon, "lon");
      break;
    case Kind::kAttitude:
      r.q = get("q");
      if (r.q.offset < 0 || r.q.count != 4 || r.q.type != Basic::kF32)
        absent.push_back("float[4] q");
      break;
    case Kind::kLocal:
      r.z = get("z");
      r.z_valid = get("z_valid");
      need(r.z, "z");
      break;
    case Kind::kHome:
      r.z = get("z");
      r.valid_alt = get("valid_alt");
      need(r.z, "z");
      break;
    case Kind::kCamera:
      // Only the timestamp is needed: a field the format lacks (an old log without `result`)
      // is not read.
      r.lat = get("lat");
      r.lon = get("lon");
      r.alt = get("alt");
      r.utc = get("timestamp_utc");
      r.seq = get("seq");
      r.result = get("result");
      for (FieldRef* f : {&r.lat, &r.lon, &r.alt, &r.utc, &r.seq, &r.result}) {
        if (f->count != 1) *f = FieldRef{};
      }
      break;
    case Kind::kOther:
      break;
  }
  if (!absent.empty()) {
    std::string list;
    for (const char* a : absent) list += fmt::format("{}'{}'", list.empty() ? "" : ", ", a);
    *missing = fmt::format("its format has no field {}", list);
    return Roles{};
  }
  r.kind = kind;
  return r;
}

// The value of element `index` of field f in a 'D' message's data (`len` bytes); nullopt when
// the topic has no such field or the message is too short for it; NaN stays NaN.
std::optional<double> ValueOf(const FieldRef& f, const unsigned char* data, std::size_t len,
                              int index = 0) {
  if (f.offset < 0 || index >= f.count) return std::nullopt;
  const int size = BasicSize(f.type);
  const std::size_t at =
      static_cast<std::size_t>(f.offset) + static_cast<std::size_t>(index * size);
  if (at + static_cast<std::size_t>(size) > len) return std::nullopt;
  return DecodeBasic(f.type, data + at);
}

// ------------------------------------------------------------------------------ samples

// Collects what the topics say and builds the samples.
class Collector {
 public:
  explicit Collector(RecordErrors& errors) : errors_(errors) {}

  std::string Where(long long offset) const {
    return fmt::format("{} at byte {}", errors_.source(), offset);
  }
  void Malformed(long long offset, const std::string& message) {
    errors_.ReportMessage(fmt::format("{}: {}", Where(offset), message));
  }
  // A topic aerovo reads whose format lacks a field: said when no GPS sample is read.
  void NoteMissing(const std::string& m) {
    if (missing_.empty()) missing_ = m;
  }
  void NoteUnreadable(long long skipped, long long total) {
    unreadable_ = skipped;
    total_ = total;
  }

  // One 'D' message of a topic read (`data`, `len` bytes) at byte `offset`.
  void Data(const Roles& r, const unsigned char* data, std::size_t len, long long offset) {
    const auto value = [&](const FieldRef& f, int index = 0) {
      std::optional<double> v = ValueOf(f, data, len, index);
      if (v && !std::isfinite(*v)) v.reset();
      return v;
    };
    const std::optional<double> us = value(r.time);
    if (!us || *us < 0.0) {
      Malformed(offset, fmt::format("{} message without a valid timestamp", KindName(r.kind)));
      return;
    }
    const double t = *us / 1e6;
    switch (r.kind) {
      case Kind::kVehicleGps:
      case Kind::kSensorGps:
      case Kind::kGlobal:
        Gps(r, value, t, offset);
        break;
      case Kind::kAttitude:
        Attitude(r, value, t, offset);
        break;
      case Kind::kCamera:
        Camera(r, data, len, t, offset);
        break;
      case Kind::kLocal: {
        if (!local_.empty() && std::abs(t - local_.back().time_s) < kMinSeriesStepS) return;
        const std::optional<double> valid = value(r.z_valid), z = value(r.z);
        if (valid && *valid == 0.0) return;
        if (!z || !(std::abs(*z) <= 1e5)) {
          Malformed(offset, "vehicle_local_position z is not a height in metres");
          return;
        }
        local_.push_back(SeriesPoint{t, {*z, 0.0, 0.0}});
        break;
      }
      case Kind::kHome: {
        const std::optional<double> valid = value(r.valid_alt), z = value(r.z);
        if (valid && *valid == 0.0) return;
        if (!z || !(std::abs(*z) <= 1e5)) {
          Malformed(offset, "home_position z is not a height in metres");
          return;
        }
        // Home is set at arming and seldom changes: a few messages, kept as often as the rest.
        if (!home_.empty() && std::abs(t - home_.back().time_s) < kMinSeriesStepS) return;
        home_.push_back(SeriesPoint{t, {*z, 0.0, 0.0}});
        break;
      }
      case Kind::kOther:
        break;
    }
  }

  TelemetryReadResult Finish() {
    int chosen = -1;
    for (int k = 0; k < kGpsTopics && chosen < 0; ++k) {
      if (!gps_[k].samples.empty()) chosen = k;
    }
    int messages = 0, no_fix = 0;
    for (const GpsTopic& g : gps_) {
      messages += g.messages;
      no_fix += g.no_fix;
    }
    if (chosen < 0) {
      if (messages == 0 && !missing_.empty()) {
        throw InputError(
            fmt::format("{}: no GPS position in this ULog: {}", errors_.source(), missing_));
      }
      if (messages == 0 && errors_.skipped() == 0) {
        throw InputError(fmt::format(
            "{}: no GPS message in this ULog (no vehicle_gps_position, sensor_gps or "
            "vehicle_global_position data{})",
            errors_.source(),
            unreadable_ > 0 ? fmt::format("; {} of its {} bytes are no ULog message: a damaged "
                                          "log",
                                          unreadable_, total_)
                            : std::string(": a log without a GPS receiver, or its logging "
                                          "profile leaves them out (SDLOG_PROFILE)")));
      }
      if (no_fix > 0 && errors_.skipped() == 0) {
        throw InputError(fmt::format(
            "{}: no GPS message with a 3D fix in this ULog ({} messages without one: fix_type "
            "< 3, lat_lon_valid false, or at latitude = longitude = 0)",
            errors_.source(), no_fix));
      }
      return io_detail::Finish({}, errors_, no_fix, "ULog");
    }
    std::vector<TelemetrySample> samples = std::move(gps_[chosen].samples);
    std::stable_sort(att_.begin(), att_.end(), io_detail::SeriesByTime);
    std::stable_sort(local_.begin(), local_.end(), io_detail::SeriesByTime);
    std::stable_sort(home_.begin(), home_.end(), io_detail::SeriesByTime);
    for (TelemetrySample& s : samples) {
      if (const auto a =
              io_detail::InterpolateSeries(att_, s.time_s, true, kMaxInterpolationGapS)) {
        s.roll_deg = a->v[0];
        s.pitch_deg = a->v[1];
        s.yaw_deg = a->v[2];
      }
      // The home in force at the sample's time: the last home_position at or before it.
      const auto home =
          std::upper_bound(home_.begin(), home_.end(), s.time_s,
                           [](double t, const SeriesPoint& p) { return t < p.time_s; });
      if (home == home_.begin()) continue;
      if (const auto z =
              io_detail::InterpolateSeries(local_, s.time_s, false, kMaxInterpolationGapS)) {
        s.rel_alt_m = (home - 1)->v[0] - z->v[0];
      }
    }
    TelemetryReadResult result =
        io_detail::Finish(std::move(samples), errors_, gps_[chosen].no_fix, "ULog");
    result.camera_triggers = std::move(triggers_);
    return result;
  }

 private:
  struct GpsTopic {
    std::vector<TelemetrySample> samples;
    std::optional<double> last_time;
    int messages = 0;
    int no_fix = 0;
  };

  template <typename Value>
  void Gps(const Roles& r, const Value& value, double t, long long offset) {
    GpsTopic& g = gps_[static_cast<int>(r.kind) - static_cast<int>(Kind::kVehicleGps)];
    ++g.messages;
    if (r.fix.offset >= 0) {
      const std::optional<double> fix = value(r.fix);
      if (!fix || *fix < kFix3d) {
        ++g.no_fix;
        return;
      }
    }
    if (r.lat_lon_valid.offset >= 0) {
      const std::optional<double> valid = value(r.lat_lon_valid);
      if (!valid || *valid == 0.0) {
        ++g.no_fix;
        return;
      }
    }
    const std::optional<double> lat = value(r.lat), lon = value(r.lon);
    if (!lat || !lon) {
      Malformed(offset, fmt::format("{} message whose latitude or longitude is not a number",
                                    KindName(r.kind)));
      return;
    }
    if (*lat == 0.0 && *lon == 0.0) {
      ++g.no_fix;
      return;
    }
    if (g.last_time && t < *g.last_time) {
      Malformed(offset, fmt::format("{} time {:.6f} s is earlier than the previous message's "
                                    "{:.6f} s (messages out of order)",
                                    KindName(r.kind), t, *g.last_time));
      return;
    }
    TelemetrySample s;
    s.time_s = t;
    s.lat_deg = *lat * r.lat_factor;
    s.lon_deg = *lon * r.lat_factor;
    if (const std::optional<double> alt = value(r.alt)) s.abs_alt_m = *alt * r.alt_factor;
    if (const std::optional<double> utc = value(r.utc); utc && *utc > 0.0) {
      // time_utc_usec is the receiver's time of the fix, timestamp + timestamp_time_relative on
      // the boot clock: the UTC time at `timestamp` is time_utc_usec - timestamp_time_relative.
      const std::optional<double> rel = value(r.utc_relative);
      const double rel_us = rel && std::abs(*rel) <= 1e7 ? *rel : 0.0;
      s.unix_time_s = (*utc - rel_us) / 1e6;
    }
    const std::string where = Where(offset);
    try {
      ValidateSample(s, where);
    } catch (const InputError& e) {
      errors_.ReportMessage(e.what());
      return;
    }
    s.origin = where;
    g.last_time = t;
    g.samples.push_back(std::move(s));
  }

  // vehicle_attitude q (w, x, y, z; body FRD to NED) -> roll, pitch, yaw in degrees
  // (RollPitchYawDeg: 3-2-1 Tait-Bryan angles as PX4 computes them, yaw in [0, 360)).
  template <typename Value>
  void Attitude(const Roles& r, const Value& value, double t, long long offset) {
    if (!att_.empty() && std::abs(t - att_.back().time_s) < kMinSeriesStepS) return;
    double q[4];
    for (int k = 0; k < 4; ++k) {
      const std::optional<double> v = value(r.q, k);
      if (!v) {
        Malformed(offset, "vehicle_attitude q is not a number");
        return;
      }
      q[k] = *v;
    }
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (norm == 0.0) return;  // not set yet
    if (std::abs(norm - 1.0) > 0.1) {
      Malformed(offset, fmt::format("vehicle_attitude q has norm {:.3f}, not a rotation", norm));
      return;
    }
    const std::array<double, 3> a = RollPitchYawDeg(q, norm);
    att_.push_back(SeriesPoint{t, {a[0], a[1], a[2]}});
  }

  // camera_capture (PX4-Autopilot msg/CameraCapture.msg): one photo the camera took, at
  // `timestamp` (t, seconds since boot: the clock of the GPS samples' time_s). result 0 is a
  // capture that failed (not a photo: dropped); 1 success and -1 "camera does not provide
  // feedback" are kept, and so is every message of a log whose format has no `result`. lat, lon
  // (degrees) NaN, or both 0, is a photo without a position (has_fix false); alt (m AMSL) ->
  // abs_alt_m when finite; timestamp_utc (UTC microseconds, 0 = unknown) -> unix_time_s. Not
  // read: q ("Attitude of the camera relative to NED earth-fixed frame when using a gimbal,
  // otherwise vehicle attitude": which of the two a log holds is not written, and a nadir
  // gimbal's would read as an aircraft pitched 90 degrees) and ground_distance (m above the
  // ground below, not above home).
  void Camera(const Roles& r, const unsigned char* data, std::size_t len, double t,
              long long offset) {
    // Raw values: NaN says "no position", not damage.
    const auto raw = [&](const FieldRef& f, int index = 0) { return ValueOf(f, data, len, index); };
    if (const std::optional<double> result = raw(r.result); result && *result == 0.0) return;
    const std::optional<double> seq = raw(r.seq);
    TelemetrySample s;
    s.time_s = t;
    // seq is a uint32 in PX4's format; another type of the file's own is printed, never cast.
    s.origin =
        fmt::format("{}: camera_capture{}", Where(offset),
                    seq && std::isfinite(*seq) ? fmt::format(" {:.0f}", *seq) : std::string());
    const std::optional<double> lat = raw(r.lat), lon = raw(r.lon);
    s.has_fix =
        lat && lon && !std::isnan(*lat) && !std::isnan(*lon) && !(*lat == 0.0 && *lon == 0.0);
    if (s.has_fix) {
      s.lat_deg = *lat;  // an infinite or out-of-range value fails ValidateSample below
      s.lon_deg = *lon;
    }
    if (const std::optional<double> alt = raw(r.alt); alt && std::isfinite(*alt)) {
      s.abs_alt_m = *alt;
    }
    if (const std::optional<double> utc = raw(r.utc); utc && std::isfinite(*utc) && *utc > 0.0) {
      s.unix_time_s = *utc / 1e6;
    }
    try {
      ValidateSample(s, s.origin);
    } catch (const InputError& e) {
      errors_.ReportMessage(e.what());
      return;
    }
    triggers_.push_back(std::move(s));
  }

  RecordErrors& errors_;
  GpsTopic gps_[kGpsTopics];
  std::vector<SeriesPoint> att_, local_, home_;
  std::vector<TelemetrySample> triggers_;  // camera_capture, in the log's order
  std::string missing_;
  long long unreadable_ = 0, total_ = 0;
};

// ------------------------------------------------------------------------------ messages

bool IsKnownType(unsigned char type) {
  switch (type) {
    case 'A':
    case 'B':
    case 'C':
    case 'D':
    case 'F':
    case 'I':
    case 'L':
    case 'M':
    case 'O':
    case 'P':
    case 'Q':
    case 'R':
    case 'S':
      return true;
    default:
      return false;
  }
}

// Whether a header of a known type with this payload size can be a message of that type (the
// fixed parts of each message, ulog_file_format.md).
bool PlausibleHeader(unsigned char type, std::size_t size) {
  switch (type) {
    case 'D':  // msg_id + data
    case 'R':  // msg_id
    case 'O':  // duration
      return size >= 2 && (type == 'D' || size == 2);
    case 'A':  // multi_id, msg_id, a name
      return size >= 4;
    case 'S':
      return size == sizeof kSyncMagic;
    case 'L':  // log_level, timestamp
      return size >= 9;
    case 'C':  // log_level, tag, timestamp
      return size >= 11;
    case 'F':  // "n:t f"
      return size >= 5;
    case 'I':
    case 'P':  // key_len, key
      return size >= 2;
    case 'M':
    case 'Q':  // is_continued / default_types, key_len, key
      return size >= 3;
    case 'B':  // compat_flags, incompat_flags, appended_offsets (more may follow)
      return size >= 40;
    default:
      return false;
  }
}

class Parser {
 public:
  Parser(std::istream& in, const TelemetryReadOptions& options, RecordErrors& errors,
         Collector& out)
      : w_(in, kWindowBytes), options_(options), errors_(errors), out_(out) {}

  void Run() {
    // The header, checked by ParseULog.
    if (w_.Fill(kFileHeaderSize) < kFileHeaderSize) return;
    w_.Skip(kFileHeaderSize);
    while (true) {
      std::size_t avail = w_.Fill(kLookahead);
      if (avail == 0) break;
      // Data appended at a known offset (DATA_APPENDED): the message cut there is discarded.
      std::size_t limit = avail;
      while (!appended_.empty() && appended_.front() <= w_.offset()) {
        appended_.erase(appended_.begin());
      }
      if (!appended_.empty() && appended_.front() - w_.offset() < static_cast<long long>(avail)) {
        limit = static_cast<std::size_t>(appended_.front() - w_.offset());
      }
      const Check c = Plausible(w_.data(), limit, /*resync=*/false);
      if (c == Check::kOk || c == Check::kUnknown) {
        Message(w_.data(), c == Check::kUnknown);
        continue;
      }
      if (limit < avail) {  // cut by the appended data: read on there
        w_.Skip(limit);
        continue;
      }
      if (c == Check::kCut) {
        Gap(w_.offset(), static_cast<long long>(avail),
            avail < kMessageHeaderSize
                ? "the log ends within a message header (a log whose writing stopped)"
                : fmt::format("the last message ('{}', {} bytes) is cut short (a log whose "
                              "writing stopped)",
                              TypeName(w_.data()[2]), LoadLe(w_.data(), 2)));
        w_.Skip(avail);
        break;
      }
      Resync();
    }
    out_.NoteUnreadable(gap_bytes_, w_.offset());
    if (gaps_ > listed_) {
      Warn(fmt::format("{}: {} gaps of unreadable bytes in all ({} bytes), {} of them listed",
                       errors_.source(), gaps_, gap_bytes_, listed_));
    }
    if (unknown_ > 0) {
      Warn(
          fmt::format("{}: {} messages of a type aerovo does not know (first '{}' at byte {}) "
                      "ignored",
                      errors_.source(), unknown_, first_unknown_type_, first_unknown_at_));
    }
    if (dropouts_ > 0) {
      Warn(
          fmt::format("{}: the logger lost messages {} times ({} ms in all, 'O' dropout "
                      "messages): the telemetry has gaps there",
                      errors_.source(), dropouts_, dropout_ms_));
    }
  }

 private:
  enum class Check { kOk, kUnknown, kBad, kCut };

  static std::string TypeName(unsigned char t) {
    return t >= 0x20 && t < 0x7F ? std::string(1, static_cast<char>(t))
                                 : fmt::format("\\x{:02X}", t);
  }

  // Whether a message starts at p = w_.data() (`avail` bytes from p): a plausible header, the whole
  // message in the file, a consistent payload, and after it the end of the file or another
  // plausible header (bytes inserted into a message or lost from it make it fail: a damaged message
  // is dropped, not read with shifted fields). kUnknown: a message of an unknown type followed by
  // a known message (ignored, as the format requires); never while resynchronising.
  Check Plausible(const unsigned char* p, std::size_t avail, bool resync) const {
    if (avail < kMessageHeaderSize) return Check::kCut;
    const std::size_t size = static_cast<std::size_t>(LoadLe(p, 2));
    const unsigned char type = p[2];
    const bool known = IsKnownType(type);
    if (known && !PlausibleHeader(type, size)) return Check::kBad;
    // 'B' is "the first message right after the header section" (and only there).
    if (type == 'B' && w_.offset() != static_cast<long long>(kFileHeaderSize)) return Check::kBad;
    if (!known && resync) return Check::kBad;
    if (avail < kMessageHeaderSize + size) return Check::kCut;
    if (known && !PlausiblePayload(type, p + kMessageHeaderSize, size)) return Check::kBad;
    const std::size_t next = kMessageHeaderSize + size;
    if (avail >= next + kMessageHeaderSize) {
      const unsigned char next_type = p[next + 2];
      const std::size_t next_size = static_cast<std::size_t>(LoadLe(p + next, 2));
      // After a known message, a message of an unknown type (a letter, as every type is) is
      // accepted when reading on, not when resynchronising.
      const bool next_ok = IsKnownType(next_type)
                               ? next_type != 'B' && PlausibleHeader(next_type, next_size)
                               : known && !resync && std::isalpha(next_type) != 0;
      if (!next_ok) return Check::kBad;
    }
    return known ? Check::kOk : Check::kUnknown;
  }

  bool PlausiblePayload(unsigned char type, const unsigned char* q, std::size_t size) const {
    switch (type) {
      case 'S':
        return std::memcmp(q, kSyncMagic, sizeof kSyncMagic) == 0;
      case 'D': {
        const Subscription* s = Find(static_cast<int>(LoadLe(q, 2)));
        if (s == nullptr) return false;
        if (s->size < 0) return true;
        const long long len = static_cast<long long>(size) - 2;
        return len <= s->size && len >= s->min_size;
      }
      case 'F':
        return std::memchr(q, ':', size) != nullptr;
      case 'I':
      case 'P':
        return q[0] > 0 && q[0] <= size - 1;
      case 'M':
      case 'Q':
        return q[1] > 0 && q[1] <= size - 2;
      default:
        return true;
    }
  }

  const Subscription* Find(int msg_id) const {
    const auto it = subscriptions_.find(msg_id);
    return it == subscriptions_.end() ? nullptr : &it->second;
  }

  // Skips bytes up to the next place where a message starts (the next 'S' sync message among
  // them) or where appended data starts, counting them in a gap warning.
  void Resync() {
    const long long at = w_.offset();
    long long skipped = 0;
    std::size_t avail;
    bool appended = false;
    do {
      w_.Skip(1);
      ++skipped;
      avail = w_.Fill(kLookahead);
      appended = !appended_.empty() && appended_.front() == w_.offset();
    } while (!appended && avail >= kMessageHeaderSize &&
             Plausible(w_.data(), avail, /*resync=*/true) != Check::kOk);
    if (!appended && avail < kMessageHeaderSize) {
      skipped += static_cast<long long>(avail);
      w_.Skip(avail);
      Gap(at, skipped, "no ULog message up to the end of the file (a cut or damaged log)");
      return;
    }
    Gap(at, skipped,
        "not a ULog message, or a message whose size runs into the next one (a damaged log); "
        "read on at the next message");
  }

  void Message(const unsigned char* p, bool unknown) {
    const std::size_t size = static_cast<std::size_t>(LoadLe(p, 2));
    const unsigned char type = p[2];
    const unsigned char* q = p + kMessageHeaderSize;
    const long long at = w_.offset();
    if (unknown) {
      if (unknown_++ == 0) {
        first_unknown_type_ = TypeName(type);
        first_unknown_at_ = at;
      }
    }
    switch (unknown ? 0 : type) {
      case 'B':
        FlagBits(q, at);
        break;
      case 'F': {
        std::string why;
        const std::string_view text(reinterpret_cast<const char*>(q), size);
        if (!formats_.Add(text, &why)) {
          const std::string name(text.substr(0, std::min(text.find(':'), text.size())));
          if (KindOf(name) != Kind::kOther || formats_full_warned_ == false) {
            if (KindOf(name) == Kind::kOther) formats_full_warned_ = true;
            Warn(fmt::format("{} at byte {}: format '{}' not read: {}", errors_.source(), at,
                             Printable(name, 60), why));
          }
        }
        break;
      }
      case 'A':
        Subscribe(q[0], static_cast<int>(LoadLe(q + 1, 2)),
                  std::string_view(reinterpret_cast<const char*>(q + 3), size - 3), at);
        break;
      case 'R':
        subscriptions_.erase(static_cast<int>(LoadLe(q, 2)));
        break;
      case 'D': {
        const Subscription* s = Find(static_cast<int>(LoadLe(q, 2)));
        if (s != nullptr && s->roles.kind != Kind::kOther) {
          out_.Data(s->roles, q + 2, size - 2, at);
        }
        break;
      }
      case 'O':
        ++dropouts_;
        dropout_ms_ += static_cast<long long>(LoadLe(q, 2));
        break;
      default:  // I, M, P, Q, L, C, S: nothing aerovo reads
        break;
    }
    w_.Skip(kMessageHeaderSize + size);
  }

  // 'B': refuses unknown incompatible flags (ulog_file_format.md, "Must refuse to parse a log
  // which contains unknown incompatibility bits set"); notes the appended-data offsets.
  void FlagBits(const unsigned char* q, long long at) {
    const unsigned char* incompat = q + 8;
    bool unknown = (incompat[0] & ~1u) != 0;
    for (int k = 1; k < 8; ++k) unknown = unknown || incompat[k] != 0;
    if (unknown) {
      std::string bits;
      for (int k = 0; k < 8; ++k) bits += fmt::format("{}{:02X}", k ? " " : "", incompat[k]);
      throw InputError(fmt::format(
          "{} at byte {}: this ULog sets incompatible flag bits aerovo does not know "
          "(incompat_flags {}; aerovo knows bit 0, DATA_APPENDED): a log of a newer ULog "
          "version, which the format says a reader must refuse",
          errors_.source(), at, bits));
    }
    if ((incompat[0] & 1u) != 0) {
      for (int k = 0; k < 3; ++k) {
        const long long offset = static_cast<long long>(LoadLe(q + 16 + 8 * k, 8));
        if (offset > at) appended_.push_back(offset);
      }
      std::sort(appended_.begin(), appended_.end());
    }
  }

  void Subscribe(int multi_id, int msg_id, std::string_view name, long long at) {
    const int format = formats_.Find(name);
    const Kind kind = KindOf(name);
    if (format < 0) {
      // camera_capture is not why a log has no GPS position: not named then.
      if (kind != Kind::kOther && kind != Kind::kCamera && multi_id == 0) {
        out_.NoteMissing(
            fmt::format("the log subscribes to {} without its format", KindName(kind)));
      }
      subscriptions_.erase(msg_id);  // its data cannot be told from damage
      return;
    }
    Subscription s;
    s.active = true;
    s.format = format;
    s.size = formats_.Size(format);
    s.min_size = s.size;
    const Format& f = formats_.at(format);
    if (s.size >= 0 && f.fields.back().name.rfind("_padding", 0) == 0) {
      const BasicInfo* b = FindBasic(f.fields.back().type);
      if (b != nullptr) s.min_size = s.size - b->size * f.fields.back().count;
    }
    // Several instances of a topic (several receivers): the first one, multi_id 0, as
    // dataflash_reader.cc reads its first receiver.
    if (kind != Kind::kOther && multi_id == 0) {
      if (s.size < 0) {
        const std::string m = fmt::format(
            "the format of {} has a type the log does not define, nests itself or is larger "
            "than any message",
            KindName(kind));
        Warn(fmt::format("{} at byte {}: {}: its messages are not read", errors_.source(), at, m));
        out_.NoteMissing(m);
      } else {
        std::string missing;
        s.roles = RolesOf(kind, formats_.TopLevel(format), &missing);
        if (!missing.empty()) {
          const std::string m = fmt::format("{}: {}", KindName(kind), missing);
          Warn(
              fmt::format("{} at byte {}: {}: its messages are not read", errors_.source(), at, m));
          out_.NoteMissing(m);
        }
      }
    }
    subscriptions_[msg_id] = std::move(s);
  }

  bool Room(int spare) const {
    return static_cast<int>(errors_.warnings().size()) + spare < options_.max_warnings;
  }
  void Warn(std::string message) {
    if (Room(0)) errors_.warnings().push_back(std::move(message));
  }
  void Gap(long long at, long long bytes, const std::string& why) {
    ++gaps_;
    gap_bytes_ += bytes;
    if (listed_ < kMaxListedGaps && Room(1)) {
      ++listed_;
      errors_.warnings().push_back(
          fmt::format("{} at byte {}: {} byte(s) skipped: {}", errors_.source(), at, bytes, why));
    }
  }

  ByteWindow w_;
  const TelemetryReadOptions& options_;
  RecordErrors& errors_;
  Collector& out_;
  Formats formats_;
  std::map<int, Subscription> subscriptions_;
  std::vector<long long> appended_;
  int gaps_ = 0, listed_ = 0;
  long long gap_bytes_ = 0;
  int unknown_ = 0;
  std::string first_unknown_type_;
  long long first_unknown_at_ = 0;
  bool formats_full_warned_ = false;
  int dropouts_ = 0;
  long long dropout_ms_ = 0;
};

}  // namespace
}  // namespace ulog_reader

TelemetryReadResult ParseULog(std::istream& in, const std::string& source_name,
                              const TelemetryReadOptions& options) {
  namespace u = ulog_reader;
  Validate(options);
  io_detail::RecordErrors errors(options, source_name);
  unsigned char head[u::kFileHeaderSize] = {};
  const std::streampos start = in.tellg();
  in.read(reinterpret_cast<char*>(head), u::kFileHeaderSize);
  const std::size_t n = static_cast<std::size_t>(in.gcount());
  in.clear();
  in.seekg(start);
  if (!in) throw InputError(fmt::format("{}: cannot read the file from its start", source_name));
  if (n < sizeof u::kMagic || std::memcmp(head, u::kMagic, sizeof u::kMagic) != 0) {
    std::string bytes;
    for (std::size_t k = 0; k < std::min<std::size_t>(n, sizeof u::kMagic); ++k) {
      bytes += fmt::format("{}{:02X}", k ? " " : "", head[k]);
    }
    throw InputError(fmt::format(
        "{}: not a PX4 ULog: a .ulg log starts with the bytes 55 4C 6F 67 01 12 35 ('ULog' "
        "01 12 35), this file with {}{}",
        source_name, n == 0 ? std::string("nothing (empty)") : bytes, io_detail::HintFor(in)));
  }
  if (n < u::kFileHeaderSize) {
    throw InputError(fmt::format("{}: a PX4 ULog cut short within its 16-byte header ({} bytes)",
                                 source_name, n));
  }
  u::Collector out(errors);
  u::Parser parser(in, options, errors, out);
  parser.Run();
  return out.Finish();
}

TelemetryReadResult ReadULog(const std::filesystem::path& path,
                             const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  return ParseULog(in, path.string(), options);
}

}  // namespace aerovo
