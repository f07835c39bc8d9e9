// MAVLink telemetry logs (.tlog): what Mission Planner, QGroundControl and MAVProxy record of
// their link to a MAVLink autopilot (ArduPilot or PX4). The autopilot's GLOBAL_POSITION_INT
// messages become the samples; ATTITUDE is interpolated onto them; CAMERA_FEEDBACK or
// CAMERA_IMAGE_CAPTURED become the camera triggers. See telemetry_readers.h
// (ParseTlog) and docs/inputs.md "MAVLink telemetry logs (.tlog)".
//
// The file (QGroundControl Developer Guide, "MAVLink Log Format"
// https://docs.qgroundcontrol.com/master/en/qgc-dev-guide/file_formats/mavlink.html; ardupilot.org
// "Telemetry Logs" https://ardupilot.org/planner/docs/mission-planner-telemetry-logs.html) is a
// sequence of records, with no file header:
//  - an unsigned 64-bit timestamp, microseconds since 1970-01-01 UTC, big-endian: the ground
//    station's clock when it received (or sent) the packet (QGroundControl writes it with
//    qToBigEndian, in whole milliseconds: src/comm/MAVLinkProtocol.cc; pymavlink's mavlogfile
//    reads it as '>Q'), so it carries the link's latency;
//  - one MAVLink packet, as on the wire: MAVLink 2 (0xFD, possibly signed) or MAVLink 1 (0xFE),
//    mavlink.io "Packet Serialization" https://mavlink.io/en/guide/serialization.html. Its framing
//    and checksum are those of aerovo's own MAVLink code (mavlink/protocol.h, CheckFrame).
// Packets of every message are in the log; the messages read (common.xml, with their CRC_EXTRA
// in mavlink/messages.h): HEARTBEAT (autopilot type), GLOBAL_POSITION_INT, ATTITUDE,
// GPS_RAW_INT (fix_type), SYSTEM_TIME, and the photos taken: ArduPilot's CAMERA_FEEDBACK
// (ardupilotmega.xml), else CAMERA_IMAGE_CAPTURED (PX4) -> camera_triggers
// (Collector::Triggers says how their times are placed). The others are skipped by their
// length.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <istream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "aerovo/core/angles.h"
#include "aerovo/mavlink/messages.h"
#include "aerovo/mavlink/protocol.h"
#include "aerovo/telemetry/binary_log_util.h"
#include "aerovo/telemetry/file_kind.h"
#include "aerovo/telemetry/parse_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo {
namespace {
// Its own namespace: the module is compiled as one unity source with dataflash_reader.cc.
namespace tlog {

using io_detail::ByteWindow;
using io_detail::RecordErrors;
using io_detail::SeriesPoint;
namespace mav = aerovo::mavlink;

constexpr std::size_t kTimestampBytes = io_detail::kTlogTimestampBytes;
// The longest packet: a signed MAVLink 2 packet with a 255-byte payload (280 bytes).
constexpr std::size_t kMaxPacketBytes =
    mav::kHeaderBytes + mav::kMaxPayloadBytes + mav::kChecksumBytes + mav::kSignatureBytes;
// Bytes looked at from a record's start: the longest record, then the next record's timestamp
// and magic byte (to check that a record of an unknown message ends where the next begins).
constexpr std::size_t kLookahead = 2 * kTimestampBytes + kMaxPacketBytes + 1;

// Record timestamps after 2100-01-01 are not a ground station's clock (file_kind.h). Before
// 2000-01-01 the ground station's clock was not set (QGroundControl's guide allows "close to
// zero"): the records are read, their time is not used as a date.
constexpr std::uint64_t kMaxTimestampUs = io_detail::kMaxTlogTimestampUs;
constexpr double kMinDateUs = 946684800e6;
// When looking for the next record after damaged bytes, a candidate's timestamp must be within
// this of the last good record's (a false start in the damaged bytes rarely is).
constexpr double kResyncWindowUs = 86400e6;

// HEARTBEAT.autopilot (MAV_AUTOPILOT, minimal.xml) of a ground station or of any component that
// is not a flight controller.
constexpr std::uint8_t kAutopilotInvalid = mav::kMavAutopilotInvalid;
// GPS_FIX_TYPE (common.xml): 0 no GPS, 1 no fix, 2 2D, 3 3D, 4 DGPS, 5 RTK float, 6 RTK fixed,
// 7 static, 8 PPP. A position needs a 3D fix.
constexpr std::uint8_t kFix3d = mav::kGpsFixType3d;
// GLOBAL_POSITION_INT.hdg: UINT16_MAX = unknown.
constexpr std::uint16_t kHeadingUnknown = 0xFFFF;

// time_boot_ms going back by more than this may be the autopilot rebooting (GLOBAL_POSITION_INT's
// time can lag ATTITUDE's by a GPS period). Links reorder and delay packets too (a radio's
// buffer, or a router merging two links: node-mavlink's examples/vtol.tlog has
// GLOBAL_POSITION_INT arriving 1.2 s of the autopilot's time after later ones), so a drop is a
// reboot only when the ground station's clock says so: a packet of the same boot that arrived
// late was received `late` seconds after the boot's earliest-received timing, while a new boot's
// first packet arrives at least the old boot's uptime after it. A drop is a reboot when `late`
// is more than this fraction of the old boot's latest time since boot.
constexpr double kRebootDropS = 2.0;
constexpr double kRebootLateFraction = 0.5;
// ATTITUDE kept at most every kMinSeriesStepS, not interpolated across kMaxInterpolationGapS;
// gaps of unreadable bytes and bad checksums listed up to kMaxListedGaps (binary_log_util.h).
using io_detail::kMaxInterpolationGapS;
using io_detail::kMaxListedGaps;
using io_detail::kMinSeriesStepS;

std::uint64_t LoadBe64(const unsigned char* p) {
  std::uint64_t v = 0;
  for (int k = 0; k < 8; ++k) v = (v << 8) | p[k];
  return v;
}

// A position report of one system, before attitude and dates are added.
struct Pending {
  TelemetrySample sample;
  int segment = 0;              // boot of the autopilot (0 = the first in the log)
  std::uint64_t record_us = 0;  // the record's timestamp (ground station clock)
  std::optional<double> heading_deg;
};

// A photo the autopilot reported (CAMERA_FEEDBACK or CAMERA_IMAGE_CAPTURED), before its time
// is known (Collector::Triggers).
struct PendingTrigger {
  TelemetrySample sample;
  bool boot_time = false;       // sample.time_s set from time_boot_ms (CAMERA_IMAGE_CAPTURED)
  std::uint64_t utc_us = 0;     // the message's own UTC time (us since 1970), 0 = unknown
  int segment = 0;              // boot of the autopilot when it arrived
  std::uint64_t record_us = 0;  // the record's timestamp (ground station clock)
};

// The photos of one camera reported by one message type.
struct TriggerList {
  std::vector<PendingTrigger> pending;
  int messages = 0;             // of every camera
  std::optional<int> camera;    // cam_idx / camera_id of the first message
  int other_camera = 0;         // messages of another camera, not read
  std::optional<int> other_id;  // the first other camera
  // (image index, the message's own time) of those read: a photo reported twice (logged from
  // two links, or sent again on request) is read once.
  std::set<std::pair<long long, std::uint64_t>> seen;
};

// What one system (one sysid, its component 1: MAV_COMP_ID_AUTOPILOT1) sent.
struct System {
  int heartbeat_rank = -1;  // order of its first HEARTBEAT with an autopilot type; -1 = none
  int positions = 0;        // GLOBAL_POSITION_INT messages
  int no_fix = 0;
  std::optional<std::uint8_t> fix_type;  // of its latest GPS_RAW_INT
  std::vector<Pending> samples;
  std::vector<SeriesPoint> attitude;
  // Deferred malformed messages (reported only when this system is the vehicle): the first ones
  // verbatim, the count of the others.
  std::vector<std::string> malformed;
  int malformed_more = 0;
  // Time: time_s = time_boot_ms / 1000 + offset_s of the boot segment.
  int segment = 0;
  double offset_s = 0.0;
  std::optional<double> max_boot_s;  // latest time since boot of this segment
  // Earliest (record time - time since boot) of this segment, seconds: the boot's moment by the
  // ground station's clock plus the link's smallest latency.
  std::optional<double> boot_epoch_s;
  double last_time_s = 0.0;
  std::uint64_t last_record_us = 0;
  std::map<int, double> unix_minus_time;  // per segment: Unix time - time_s (SYSTEM_TIME)
  // Per segment (index): its boot_epoch_s and offset_s as they ended, to place a record's time.
  std::vector<double> segment_epoch_s, segment_offset_s;
  TriggerList feedback, captured;         // CAMERA_FEEDBACK, CAMERA_IMAGE_CAPTURED
  std::vector<long long> reboots;         // byte offsets of the first message after each
  std::optional<double> last_position_s;
  // GLOBAL_POSITION_INT received after one with a later time (a link that reorders packets):
  // how many, and the most autopilot time one lagged by (s).
  int late_positions = 0;
  double max_lag_s = 0.0;
};

std::string Hex(const unsigned char* p, std::size_t n) {
  std::string s;
  for (std::size_t k = 0; k < n; ++k) s += fmt::format("{}{:02X}", k ? " " : "", p[k]);
  return s;
}

class Collector {
 public:
  Collector(RecordErrors& errors, const TelemetryReadOptions& options)
      : errors_(errors), options_(options) {}

  std::string Where(long long offset) const {
    return fmt::format("{} at byte {}", errors_.source(), offset);
  }

  void Packet(const mav::Packet& packet, std::uint64_t record_us, long long offset) {
    ++packets_;
    if (packet.header.msgid == mav::Heartbeat::kId) ++heartbeats_;
    // Only the flight controller's own messages: component 1 (MAV_COMP_ID_AUTOPILOT1). A ground
    // station's packets (sysid 255 by convention, autopilot MAV_AUTOPILOT_INVALID) and those of
    // cameras, gimbals or companion computers are not the vehicle's position.
    if (packet.header.compid != mav::kMavCompIdAutopilot1) return;
    System& s = systems_[packet.header.sysid];
    if (const auto h = mav::Decode<mav::Heartbeat>(packet)) {
      if (h->autopilot != kAutopilotInvalid && s.heartbeat_rank < 0) {
        s.heartbeat_rank = next_rank_++;
      }
    } else if (const auto g = mav::Decode<mav::GlobalPositionInt>(packet)) {
      Position(s, *g, record_us, offset);
    } else if (const auto a = mav::Decode<mav::Attitude>(packet)) {
      Attitude(s, *a, record_us, offset);
    } else if (const auto r = mav::Decode<mav::GpsRawInt>(packet)) {
      s.fix_type = r->fix_type;
    } else if (const auto f = mav::Decode<mav::CameraFeedback>(packet)) {
      Feedback(s, *f, record_us, offset);
    } else if (const auto c = mav::Decode<mav::CameraImageCaptured>(packet)) {
      Captured(s, *c, record_us, offset);
    } else if (const auto t = mav::Decode<mav::SystemTime>(packet)) {
      const double time_s = Time(s, t->time_boot_ms, record_us, offset);
      // 0 = the autopilot does not know the date (no GPS time yet).
      if (t->time_unix_usec >= kMinDateUs && t->time_unix_usec <= kMaxTimestampUs &&
          s.unix_minus_time.count(s.segment) == 0) {
        s.unix_minus_time[s.segment] = static_cast<double>(t->time_unix_usec) / 1e6 - time_s;
      }
    }
  }

  // `unreadable` of the file's `total` bytes were no record: said when nothing is read.
  TelemetryReadResult Finish(long long bad_checksums, long long unreadable, long long total) {
    const std::string damaged =
        unreadable > 0 ? fmt::format(" ({} of its {} bytes are no tlog record: a damaged log)",
                                     unreadable, total)
                       : std::string();
    const System* vehicle = nullptr;
    int vehicle_id = -1;
    for (const auto& [id, s] : systems_) {
      if (s.heartbeat_rank >= 0 && (!vehicle || s.heartbeat_rank < vehicle->heartbeat_rank)) {
        vehicle = &s;
        vehicle_id = id;
      }
    }
    if (vehicle == nullptr) {
      throw InputError(fmt::format(
          "{}: no HEARTBEAT of an autopilot in this MAVLink telemetry log ({} packets read, {} "
          "HEARTBEATs, none from component 1 with an autopilot type other than "
          "MAV_AUTOPILOT_INVALID): a log of the ground station alone, recorded before the "
          "vehicle was connected?{}{}",
          errors_.source(), packets_, heartbeats_,
          bad_checksums > 0 ? fmt::format(" ({} packets with a wrong checksum)", bad_checksums)
                            : std::string(),
          damaged));
    }
    for (const std::string& m : vehicle->malformed) errors_.ReportMessage(m);
    for (int k = 0; k < vehicle->malformed_more; ++k) {
      errors_.ReportMessage(fmt::format("{}: a malformed message of system {} (not listed)",
                                        errors_.source(), vehicle_id));
    }
    const auto warn = [&](std::string message) {
      if (static_cast<int>(errors_.warnings().size()) < options_.max_warnings) {
        errors_.warnings().push_back(std::move(message));
      }
    };
    for (const auto& [id, s] : systems_) {
      if (&s != vehicle && s.positions > 0) {
        warn(fmt::format(
            "{}: {} GLOBAL_POSITION_INT messages of system {} ignored: the vehicle read is system "
            "{}, the first whose autopilot sent a HEARTBEAT",
            errors_.source(), s.positions, id, vehicle_id));
      }
    }
    if (vehicle->late_positions > 0) {
      warn(fmt::format(
          "{}: {} GLOBAL_POSITION_INT message(s) of the autopilot (system {}) arrived after later "
          "ones (by up to {:.3f} s of its time since boot: a link that reorders packets); read in "
          "the autopilot's time order",
          errors_.source(), vehicle->late_positions, vehicle_id, vehicle->max_lag_s));
    }
    for (const long long at : vehicle->reboots) {
      warn(fmt::format(
          "{}: the autopilot (system {}) rebooted: its time since boot starts again; time_s goes "
          "on from the ground station's clock (the gap between the records)",
          Where(at), vehicle_id));
    }
    if (vehicle->samples.empty()) {
      if (vehicle->positions == 0) {
        throw InputError(fmt::format(
            "{}: no GLOBAL_POSITION_INT from the autopilot (system {}, component 1) in this "
            "MAVLink telemetry log: its position stream was off (ArduPilot SRn_POSITION, PX4 "
            "MAV_n_MODE/rate) or the log ends before it started{}",
            errors_.source(), vehicle_id, damaged));
      }
      if (vehicle->no_fix > 0 && errors_.skipped() == 0) {
        throw InputError(fmt::format(
            "{}: no GLOBAL_POSITION_INT with a GPS fix in this MAVLink telemetry log ({} "
            "without one: latitude = longitude = 0, or GPS_RAW_INT fix_type below 3D)",
            errors_.source(), vehicle->no_fix));
      }
    }
    std::vector<SeriesPoint> attitude = vehicle->attitude;
    std::stable_sort(attitude.begin(), attitude.end(), io_detail::SeriesByTime);
    // In the autopilot's time order (time_s follows its reboots); a report received twice
    // (logged from two links, or resent) is read once.
    std::vector<const Pending*> order;
    order.reserve(vehicle->samples.size());
    for (const Pending& p : vehicle->samples) order.push_back(&p);
    std::stable_sort(order.begin(), order.end(), [](const Pending* a, const Pending* b) {
      return a->sample.time_s < b->sample.time_s;
    });
    order.erase(std::unique(order.begin(), order.end(),
                            [](const Pending* a, const Pending* b) {
                              return a->sample.time_s == b->sample.time_s;
                            }),
                order.end());
    std::vector<TelemetrySample> samples;
    samples.reserve(order.size());
    for (const Pending* pending : order) {
      const Pending& p = *pending;
      TelemetrySample s = p.sample;
      if (const auto a =
              io_detail::InterpolateSeries(attitude, s.time_s, true, kMaxInterpolationGapS)) {
        s.roll_deg = a->v[0];
        s.pitch_deg = a->v[1];
        s.yaw_deg = a->v[2];
      } else if (p.heading_deg) {
        s.yaw_deg = *p.heading_deg;
      }
      const auto unix = vehicle->unix_minus_time.find(p.segment);
      if (unix != vehicle->unix_minus_time.end()) {
        s.unix_time_s = s.time_s + unix->second;
      } else if (p.record_us >= kMinDateUs) {
        s.unix_time_s = static_cast<double>(p.record_us) / 1e6;
      }
      samples.push_back(std::move(s));
    }
    std::vector<TelemetrySample> triggers = Triggers(*vehicle, warn);
    TelemetryReadResult result =
        io_detail::Finish(std::move(samples), errors_, vehicle->no_fix, "MAVLink telemetry log");
    result.camera_triggers = std::move(triggers);
    return result;
  }

 private:
  // time_s of a message with `time_boot_ms`, following the autopilot's reboots.
  double Time(System& s, std::uint32_t time_boot_ms, std::uint64_t record_us, long long offset) {
    const double boot_s = time_boot_ms / 1000.0;
    const double record_s = static_cast<double>(record_us) / 1e6;
    const double late_s = s.boot_epoch_s ? record_s - boot_s - *s.boot_epoch_s : 0.0;
    if (s.max_boot_s && boot_s < *s.max_boot_s - kRebootDropS &&
        late_s > kRebootLateFraction * *s.max_boot_s) {
      // A reboot: the new boot's time goes on from the last message's by the ground station's
      // clock (the records' timestamps), so that time_s keeps increasing.
      const double gap_s = record_us > s.last_record_us
                               ? static_cast<double>(record_us - s.last_record_us) / 1e6
                               : 0.0;
      s.offset_s = s.last_time_s + gap_s - boot_s;
      ++s.segment;
      s.max_boot_s.reset();
      s.boot_epoch_s.reset();
      s.last_position_s.reset();
      if (s.reboots.size() < 100) s.reboots.push_back(offset);
    }
    s.max_boot_s = std::max(s.max_boot_s.value_or(boot_s), boot_s);
    s.boot_epoch_s = std::min(s.boot_epoch_s.value_or(record_s - boot_s), record_s - boot_s);
    const std::size_t segment = static_cast<std::size_t>(s.segment);
    if (s.segment_epoch_s.size() <= segment) {
      s.segment_epoch_s.resize(segment + 1, std::nan(""));
      s.segment_offset_s.resize(segment + 1, 0.0);
    }
    s.segment_epoch_s[segment] = *s.boot_epoch_s;
    s.segment_offset_s[segment] = s.offset_s;
    const double t = boot_s + s.offset_s;
    s.last_time_s = std::max(s.last_time_s, t);
    s.last_record_us = record_us;
    return t;
  }

  // The camera triggers of the vehicle: its CAMERA_FEEDBACK (ArduPilot) when it sent any, else
  // its CAMERA_IMAGE_CAPTURED (PX4), in the log's order, with time_s on the samples' clock:
  //  - CAMERA_IMAGE_CAPTURED: time_boot_ms through Time(), as every message of the autopilot;
  //  - CAMERA_FEEDBACK has no time since boot, only time_usec, the UTC time of the photo by the
  //    autopilot's own clock. With the segment's SYSTEM_TIME relation (time_unix_usec and
  //    time_boot_ms sampled together by the autopilot) time_s = time_usec / 1e6 - (Unix time -
  //    time_s): exact to the milliseconds of SYSTEM_TIME. Without it (no SYSTEM_TIME in that
  //    boot, or time_usec 0: the autopilot had no GPS time), the record's timestamp is mapped as
  //    Time() maps a message's: time_s = record time - boot_epoch_s + offset_s of its segment.
  //    That is when the ground station received the report, less the link's smallest latency:
  //    late by the time the autopilot took to send it and by any latency above the smallest.
  template <typename Warn>
  std::vector<TelemetrySample> Triggers(const System& vehicle, const Warn& warn) {
    const bool feedback = vehicle.feedback.messages > 0;
    const TriggerList& list = feedback ? vehicle.feedback : vehicle.captured;
    const char* name = feedback ? "CAMERA_FEEDBACK" : "CAMERA_IMAGE_CAPTURED";
    if (list.other_camera > 0) {
      warn(
          fmt::format("{}: {} {} message(s) of camera {} ignored: the camera triggers read are "
                      "those of camera {}, the first in the log",
                      errors_.source(), list.other_camera, name, *list.other_id, *list.camera));
    }
    std::vector<TelemetrySample> out;
    int unplaced = 0;
    for (const PendingTrigger& p : list.pending) {
      TelemetrySample s = p.sample;
      const auto unix = vehicle.unix_minus_time.find(p.segment);
      const bool utc = p.utc_us >= kMinDateUs && p.utc_us <= kMaxTimestampUs;
      const std::size_t segment = static_cast<std::size_t>(p.segment);
      if (!p.boot_time) {
        if (utc && unix != vehicle.unix_minus_time.end()) {
          s.time_s = static_cast<double>(p.utc_us) / 1e6 - unix->second;
        } else if (segment < vehicle.segment_epoch_s.size() &&
                   !std::isnan(vehicle.segment_epoch_s[segment])) {
          s.time_s = static_cast<double>(p.record_us) / 1e6 - vehicle.segment_epoch_s[segment] +
                     vehicle.segment_offset_s[segment];
        } else {
          ++unplaced;  // no message with a time since boot in its boot: nothing places it
          continue;
        }
      }
      if (utc) {
        s.unix_time_s = static_cast<double>(p.utc_us) / 1e6;
      } else if (unix != vehicle.unix_minus_time.end()) {
        s.unix_time_s = s.time_s + unix->second;
      } else if (p.record_us >= kMinDateUs) {
        s.unix_time_s = static_cast<double>(p.record_us) / 1e6;
      }
      out.push_back(std::move(s));
    }
    if (unplaced > 0) {
      warn(
          fmt::format("{}: {} {} message(s) not read: no message with the autopilot's time since "
                      "boot in the same boot places them in time",
                      errors_.source(), unplaced, name));
    }
    return out;
  }

  // Which camera a photo report is of: the first camera's are read, the others counted.
  static bool FirstCamera(TriggerList& list, int camera) {
    ++list.messages;
    if (!list.camera) list.camera = camera;
    if (camera == *list.camera) return true;
    if (list.other_camera++ == 0) list.other_id = camera;
    return false;
  }

  // CAMERA_FEEDBACK (ardupilotmega.xml): lat, lng (degE7; both 0 = no position: ArduPilot sends
  // 0 for every position field then), alt_msl -> abs_alt_m and alt_rel -> rel_alt_m (m, with a
  // position only), roll, pitch, yaw (degrees: the aircraft's attitude at the photo), foc_len
  // (mm, 0 = unknown) -> focal_length_mm. Its time is placed in Triggers().
  void Feedback(System& s, const mav::CameraFeedback& f, std::uint64_t record_us,
                long long offset) {
    if (!FirstCamera(s.feedback, f.cam_idx)) return;
    if (!s.feedback.seen.emplace(f.img_idx, f.time_usec).second) return;
    PendingTrigger p;
    p.sample.origin = fmt::format("{}: CAMERA_FEEDBACK {}", Where(offset), f.img_idx);
    p.sample.has_fix = !(f.lat == 0 && f.lng == 0);
    if (p.sample.has_fix) {
      p.sample.lat_deg = f.lat / 1e7;
      p.sample.lon_deg = f.lng / 1e7;
      p.sample.abs_alt_m = f.alt_msl;
      p.sample.rel_alt_m = f.alt_rel;
    }
    p.sample.roll_deg = f.roll;
    p.sample.pitch_deg = f.pitch;
    p.sample.yaw_deg = f.yaw;
    if (f.foc_len > 0.0f) p.sample.focal_length_mm = f.foc_len;
    try {
      ValidateSample(p.sample, p.sample.origin);
    } catch (const InputError& e) {
      Malformed(s, e.what());
      return;
    }
    p.utc_us = f.time_usec;
    p.segment = s.segment;
    p.record_us = record_us;
    s.feedback.pending.push_back(std::move(p));
  }

  // CAMERA_IMAGE_CAPTURED (common.xml): capture_result 0 (failure) is no photo (1 success and
  // PX4's -1, "no feedback", are); lat, lon (degE7, both 0 = no position), alt (mm AMSL, with a
  // position only); relative_alt is "above ground" (PX4 sends camera_capture.ground_distance),
  // not above home: not read; q is not read either (below); time_utc (us, 0 = unknown) ->
  // unix_time_s. Only the autopilot's (component 1): a MAVLink camera component's time_boot_ms
  // is its own clock.
  void Captured(System& s, const mav::CameraImageCaptured& c, std::uint64_t record_us,
                long long offset) {
    if (!FirstCamera(s.captured, c.camera_id) || c.capture_result == 0) return;
    if (!s.captured.seen.emplace(c.image_index, c.time_boot_ms).second) return;
    PendingTrigger p;
    const double boot_s = c.time_boot_ms / 1000.0;
    if (s.max_boot_s && boot_s < *s.max_boot_s - kRebootDropS) {
      // Older than the latest time of this boot: a photo reported again (on request), which
      // says nothing of a reboot; placed in the current boot.
      p.sample.time_s = boot_s + s.offset_s;
    } else {
      p.sample.time_s = Time(s, c.time_boot_ms, record_us, offset);
    }
    p.boot_time = true;
    p.sample.origin = fmt::format("{}: CAMERA_IMAGE_CAPTURED {}", Where(offset), c.image_index);
    p.sample.has_fix = !(c.lat == 0 && c.lon == 0);
    if (p.sample.has_fix) {
      p.sample.lat_deg = c.lat / 1e7;
      p.sample.lon_deg = c.lon / 1e7;
      p.sample.abs_alt_m = c.alt / 1000.0;
    }
    // q is not read: "Quaternion of camera orientation" (common.xml), the gimbal's on a gimbal
    // (PX4 fills it from camera_capture), which would read as an aircraft pitched 90 degrees
    // under a nadir camera.
    try {
      ValidateSample(p.sample, p.sample.origin);
    } catch (const InputError& e) {
      Malformed(s, e.what());
      return;
    }
    p.utc_us = c.time_utc;
    p.segment = s.segment;
    p.record_us = record_us;
    s.captured.pending.push_back(std::move(p));
  }

  // `message` names its place.
  void Malformed(System& s, std::string message) {
    if (static_cast<int>(s.malformed.size()) <= options_.max_warnings) {
      s.malformed.push_back(std::move(message));
    } else {
      ++s.malformed_more;
    }
  }

  void Position(System& s, const mav::GlobalPositionInt& g, std::uint64_t record_us,
                long long offset) {
    ++s.positions;
    const double t = Time(s, g.time_boot_ms, record_us, offset);
    // ArduPilot sends GLOBAL_POSITION_INT whether or not it has a position (0, 0 before its
    // first one; a dead-reckoned estimate after the fix is lost); GPS_RAW_INT's fix_type says
    // whether the receiver has a fix.
    if ((g.lat == 0 && g.lon == 0) || (s.fix_type && *s.fix_type < kFix3d)) {
      ++s.no_fix;
      return;
    }
    if (s.last_position_s && t < *s.last_position_s) {
      // Sent before the last one read: put in its place when the samples are sorted.
      ++s.late_positions;
      s.max_lag_s = std::max(s.max_lag_s, *s.last_position_s - t);
    }
    Pending p;
    p.sample.time_s = t;
    p.sample.lat_deg = g.lat / 1e7;
    p.sample.lon_deg = g.lon / 1e7;
    p.sample.abs_alt_m = g.alt / 1000.0;
    p.sample.rel_alt_m = g.relative_alt / 1000.0;
    p.sample.origin = Where(offset);
    try {
      ValidateSample(p.sample, p.sample.origin);
    } catch (const InputError& e) {
      Malformed(s, e.what());
      return;
    }
    if (g.hdg != kHeadingUnknown && g.hdg < 36000) p.heading_deg = g.hdg / 100.0;
    p.segment = s.segment;
    p.record_us = record_us;
    s.last_position_s = std::max(s.last_position_s.value_or(t), t);
    s.samples.push_back(std::move(p));
  }

  void Attitude(System& s, const mav::Attitude& a, std::uint64_t record_us, long long offset) {
    const double t = Time(s, a.time_boot_ms, record_us, offset);
    if (!std::isfinite(a.roll) || !std::isfinite(a.pitch) || !std::isfinite(a.yaw) ||
        std::abs(a.roll) > 7.0f || std::abs(a.pitch) > 7.0f || std::abs(a.yaw) > 7.0f) {
      Malformed(s, fmt::format("{}: ATTITUDE angles are not angles in radians", Where(offset)));
      return;
    }
    if (!s.attitude.empty() && std::abs(t - s.attitude.back().time_s) < kMinSeriesStepS) return;
    s.attitude.push_back(
        SeriesPoint{t, {a.roll * kRadToDeg, a.pitch * kRadToDeg, a.yaw * kRadToDeg}});
  }

  RecordErrors& errors_;
  const TelemetryReadOptions& options_;
  std::map<int, System> systems_;
  int next_rank_ = 0;
  long long packets_ = 0, heartbeats_ = 0;
};

using io_detail::StartsTlogRecord;

TelemetryReadResult Parse(std::istream& in, const TelemetryReadOptions& options,
                          RecordErrors& errors) {
  ByteWindow w(in);
  std::size_t avail = w.Fill(kLookahead);
  if (avail == 0) {
    throw InputError(
        fmt::format("{}: an empty file, not a MAVLink telemetry log", errors.source()));
  }
  if (!StartsTlogRecord(w.data(), avail)) {
    throw InputError(fmt::format(
        "{}: not a MAVLink telemetry log: a .tlog starts with an 8-byte timestamp (big-endian "
        "microseconds since 1970) then a MAVLink packet (byte 8 = FD or FE), this file with "
        "{}{}",
        errors.source(), Hex(w.data(), std::min<std::size_t>(avail, 9)),
        io_detail::KindHint(
            io_detail::RecognizeFile(w.data(), w.Fill(io_detail::kRecognizeBytes)))));
  }
  Collector out(errors, options);
  mav::Packet packet;
  std::optional<std::uint64_t> last_us;  // timestamp of the last good record
  int listed = 0;
  long long gaps = 0, gap_bytes = 0, bad_checksums = 0;
  const auto room = [&](int spare) {
    return static_cast<int>(errors.warnings().size()) + spare < options.max_warnings;
  };
  const auto damage = [&](std::string message) {
    if (listed < kMaxListedGaps && room(1)) {
      ++listed;
      errors.warnings().push_back(std::move(message));
    }
  };
  // The record at q, if one is there: the size of its packet when it is a known message with
  // the right checksum, or an unknown message followed by the next record (or the file's end).
  const auto record_at = [&](const unsigned char* q, std::size_t n, mav::FrameCheck* check) {
    *check = mav::CheckFrame(q + kTimestampBytes, n - kTimestampBytes, &packet);
    if (check->status == mav::FrameStatus::kOk) return true;
    if (check->status != mav::FrameStatus::kUnknownMessage) return false;
    const std::size_t next = kTimestampBytes + check->size;
    return n == next || (n > next && n < next + kTimestampBytes + 1) ||
           StartsTlogRecord(q + next, n - next);
  };
  while (true) {
    avail = w.Fill(kLookahead);
    if (avail == 0) break;
    const unsigned char* p = w.data();
    const long long at = w.offset();
    mav::FrameCheck check;
    if (StartsTlogRecord(p, avail)) {
      const bool good = record_at(p, avail, &check);
      const std::uint64_t us = LoadBe64(p);
      if (check.status == mav::FrameStatus::kNeedMore) {
        // Fewer bytes than the packet's header announces: the file ends inside the record.
        ++gaps;
        gap_bytes += static_cast<long long>(avail);
        damage(
            fmt::format("{} at byte {}: {} byte(s) skipped: the last record is cut short (a "
                        "log whose writing stopped)",
                        errors.source(), at, avail));
        w.Skip(avail);
        break;
      }
      if (good) {
        if (check.status == mav::FrameStatus::kOk) out.Packet(packet, us, at);
        last_us = us;
        w.Skip(kTimestampBytes + check.size);
        continue;
      }
      const std::size_t next = kTimestampBytes + check.size;
      if (check.status == mav::FrameStatus::kBadChecksum &&
          (avail == next || StartsTlogRecord(p + next, avail - next))) {
        // A damaged packet (bytes flipped on the link or in the file) between two records:
        // skipped, counted. When no record follows it, its length is damaged too: a gap below.
        ++bad_checksums;
        damage(fmt::format(
            "{} at byte {}: MAVLink packet of message {} with a wrong checksum: "
            "skipped",
            errors.source(), at + static_cast<long long>(kTimestampBytes), check.msgid));
        w.Skip(next);
        continue;
      }
    }
    // Not a record: bytes written over, or a record whose length runs into the next one.
    // Resynchronise on the next plausible record.
    long long skipped = 0;
    do {
      w.Skip(1);
      ++skipped;
      avail = w.Fill(kLookahead);
    } while (
        avail > kTimestampBytes &&
        !(StartsTlogRecord(w.data(), avail) &&
          (!last_us || std::abs(static_cast<double>(LoadBe64(w.data())) -
                                static_cast<double>(*last_us)) <= kResyncWindowUs) &&
          (record_at(w.data(), avail, &check) || check.status == mav::FrameStatus::kNeedMore)));
    const bool to_end = avail <= kTimestampBytes;
    if (to_end) {
      skipped += static_cast<long long>(avail);
      w.Skip(avail);
    }
    ++gaps;
    gap_bytes += skipped;
    damage(fmt::format("{} at byte {}: {} byte(s) skipped: {}", errors.source(), at, skipped,
                       to_end ? "no tlog record up to the end of the file (a cut or damaged log)"
                              : "not a tlog record (a damaged log); read on at the next record"));
    if (to_end) break;
  }
  if (gaps + bad_checksums > listed && room(0)) {
    errors.warnings().push_back(fmt::format(
        "{}: {} gap(s) of unreadable bytes ({} bytes) and {} packet(s) with a wrong checksum in "
        "all, {} of them listed",
        errors.source(), gaps, gap_bytes, bad_checksums, listed));
  }
  return out.Finish(bad_checksums, gap_bytes, w.offset());
}

}  // namespace tlog
}  // namespace

TelemetryReadResult ParseTlog(std::istream& in, const std::string& source_name,
                              const TelemetryReadOptions& options) {
  Validate(options);
  io_detail::RecordErrors errors(options, source_name);
  return tlog::Parse(in, options, errors);
}

TelemetryReadResult ReadTlog(const std::filesystem::path& path,
                             const TelemetryReadOptions& options) {
  std::ifstream in = io_detail::OpenInput(path);
  return ParseTlog(in, path.string(), options);
}

}  // namespace aerovo
