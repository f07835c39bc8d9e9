// The MAVLink messages aerovo sends (ODOMETRY, VISION_POSITION_ESTIMATE, VISION_POSITION_DELTA,
// GPS_INPUT, HEARTBEAT, TIMESYNC) and reads (DISTANCE_SENSOR, GLOBAL_POSITION_INT, ATTITUDE,
// TIMESYNC, HEARTBEAT). Field lists, units, CRC_EXTRA and ids from the official definitions
// (mavlink/mavlink message_definitions/v1.0: common.xml, minimal.xml for HEARTBEAT, standard.xml
// for GLOBAL_POSITION_INT in recent trees, ardupilotmega.xml for VISION_POSITION_DELTA and
// CAMERA_FEEDBACK).
// On the wire the fields of MAVLink 1 are sorted by the size of their type, largest first
// (stable: XML order among equal sizes; an array counts by its element type), and the extension
// fields follow in XML order; each struct's Write/Read below is in that wire order, little
// endian. Encode() frames a message (protocol.h), Decode() reads a received packet.
// Telemetry logs (.tlog, telemetry/tlog_reader.cc) are also read for GPS_RAW_INT, SYSTEM_TIME,
// CAMERA_FEEDBACK (ardupilotmega.xml) and CAMERA_IMAGE_CAPTURED.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include "aerovo/mavlink/protocol.h"

namespace aerovo::mavlink {

// Enum values used (common.xml / minimal.xml).
constexpr uint8_t kMavFrameLocalNed = 1;             ///< MAV_FRAME_LOCAL_NED
constexpr uint8_t kMavFrameBodyFrd = 12;             ///< MAV_FRAME_BODY_FRD
constexpr uint8_t kMavFrameLocalFrd = 20;            ///< MAV_FRAME_LOCAL_FRD
constexpr uint8_t kMavEstimatorTypeVision = 2;       ///< MAV_ESTIMATOR_TYPE_VISION
constexpr uint8_t kMavTypeOnboardController = 18;    ///< MAV_TYPE_ONBOARD_CONTROLLER
constexpr uint8_t kMavAutopilotInvalid = 8;          ///< MAV_AUTOPILOT_INVALID
constexpr uint8_t kMavCompIdAutopilot1 = 1;          ///< MAV_COMP_ID_AUTOPILOT1
constexpr uint8_t kMavStateActive = 4;               ///< MAV_STATE_ACTIVE
constexpr uint8_t kMavCompIdVisualInertialOdometry = 197;  ///< MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
constexpr uint8_t kMavSensorRotationPitch270 = 25;   ///< MAV_SENSOR_ROTATION_PITCH_270 (down)
constexpr uint8_t kMavlinkVersion = 3;               ///< HEARTBEAT.mavlink_version (minimal.xml)

constexpr bool kHostLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

/// Little-endian writer into a payload buffer of the message's full length.
class PayloadWriter {
 public:
  explicit PayloadWriter(uint8_t* out) : out_(out) {}
  template <class T>
  void Put(T v) {
    static_assert(std::numeric_limits<T>::is_specialized, "scalar fields only");
    uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T); ++i) out_[pos_ + i] = b[IndexLe(i, sizeof(T))];
    pos_ += sizeof(T);
  }
  template <class T, std::size_t N>
  void Put(const std::array<T, N>& a) {
    for (const T& v : a) Put(v);
  }
  std::size_t size() const { return pos_; }

 private:
  static constexpr std::size_t IndexLe(std::size_t i, std::size_t n) {
    return kHostLittleEndian ? i : n - 1 - i;
  }
  uint8_t* out_;
  std::size_t pos_ = 0;
};

/// Little-endian reader of a (zero-padded) payload.
class PayloadReader {
 public:
  explicit PayloadReader(const uint8_t* in) : in_(in) {}
  template <class T>
  void Get(T& v) {
    uint8_t b[sizeof(T)];
    for (std::size_t i = 0; i < sizeof(T); ++i) b[IndexLe(i, sizeof(T))] = in_[pos_ + i];
    std::memcpy(&v, b, sizeof(T));
    pos_ += sizeof(T);
  }
  template <class T, std::size_t N>
  void Get(std::array<T, N>& a) {
    for (T& v : a) Get(v);
  }

 private:
  static constexpr std::size_t IndexLe(std::size_t i, std::size_t n) {
    return kHostLittleEndian ? i : n - 1 - i;
  }
  const uint8_t* in_;
  std::size_t pos_ = 0;
};

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// HEARTBEAT (#0, minimal.xml).
struct Heartbeat {
  static constexpr uint32_t kId = 0;
  static constexpr uint8_t kCrcExtra = 50;
  static constexpr uint8_t kMinLength = 9, kLength = 9;
  uint32_t custom_mode = 0;
  uint8_t type = kMavTypeOnboardController;
  uint8_t autopilot = kMavAutopilotInvalid;
  uint8_t base_mode = 0;
  uint8_t system_status = kMavStateActive;
  uint8_t mavlink_version = kMavlinkVersion;
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.custom_mode), io(m.type), io(m.autopilot), io(m.base_mode), io(m.system_status),
        io(m.mavlink_version);
  }
};

/// ATTITUDE (#30): Euler angles of the vehicle in NED, radians.
struct Attitude {
  static constexpr uint32_t kId = 30;
  static constexpr uint8_t kCrcExtra = 39;
  static constexpr uint8_t kMinLength = 28, kLength = 28;
  uint32_t time_boot_ms = 0;
  float roll = 0, pitch = 0, yaw = 0;                  ///< rad
  float rollspeed = 0, pitchspeed = 0, yawspeed = 0;   ///< rad/s
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_boot_ms), io(m.roll), io(m.pitch), io(m.yaw), io(m.rollspeed), io(m.pitchspeed),
        io(m.yawspeed);
  }
};

/// SYSTEM_TIME (#2, common.xml): the sender's clock, Unix time (0 = unknown) and time since boot.
struct SystemTime {
  static constexpr uint32_t kId = 2;
  static constexpr uint8_t kCrcExtra = 137;
  static constexpr uint8_t kMinLength = 12, kLength = 12;
  uint64_t time_unix_usec = 0;  ///< us since 1970-01-01 UTC, 0 when the sender does not know it
  uint32_t time_boot_ms = 0;    ///< ms since the sender booted
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_unix_usec), io(m.time_boot_ms);
  }
};

/// GPS_RAW_INT (#24, common.xml): the first GPS receiver's own fix (not the estimator's
/// position), with its extensions (alt_ellipsoid .. yaw).
struct GpsRawInt {
  static constexpr uint32_t kId = 24;
  static constexpr uint8_t kCrcExtra = 24;
  static constexpr uint8_t kMinLength = 30, kLength = 52;
  uint64_t time_usec = 0;     ///< us, Unix time or since boot (the magnitude tells)
  int32_t lat = 0, lon = 0;   ///< degE7
  int32_t alt = 0;            ///< mm, MSL
  uint16_t eph = UINT16_MAX;  ///< HDOP * 100, UINT16_MAX = unknown
  uint16_t epv = UINT16_MAX;  ///< VDOP * 100, UINT16_MAX = unknown
  uint16_t vel = UINT16_MAX;  ///< cm/s ground speed, UINT16_MAX = unknown
  uint16_t cog = UINT16_MAX;  ///< cdeg course over ground, UINT16_MAX = unknown
  uint8_t fix_type = 0;       ///< GPS_FIX_TYPE: 0 no GPS, 1 no fix, 2 2D, 3 3D, 4-8 better
  uint8_t satellites_visible = UINT8_MAX;
  int32_t alt_ellipsoid = 0;      ///< mm above the WGS84 ellipsoid
  uint32_t h_acc = 0, v_acc = 0;  ///< mm
  uint32_t vel_acc = 0;           ///< mm/s
  uint32_t hdg_acc = 0;           ///< degE5
  uint16_t yaw = 0;               ///< cdeg, 0 = unknown, 36000 = north
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_usec), io(m.lat), io(m.lon), io(m.alt), io(m.eph), io(m.epv), io(m.vel), io(m.cog),
        io(m.fix_type), io(m.satellites_visible);
    io(m.alt_ellipsoid), io(m.h_acc), io(m.v_acc), io(m.vel_acc), io(m.hdg_acc), io(m.yaw);
  }
};

/// GLOBAL_POSITION_INT (#33).
struct GlobalPositionInt {
  static constexpr uint32_t kId = 33;
  static constexpr uint8_t kCrcExtra = 104;
  static constexpr uint8_t kMinLength = 28, kLength = 28;
  uint32_t time_boot_ms = 0;
  int32_t lat = 0, lon = 0;   ///< degE7
  int32_t alt = 0;            ///< mm, MSL
  int32_t relative_alt = 0;   ///< mm above home
  int16_t vx = 0, vy = 0, vz = 0;  ///< cm/s, NED
  uint16_t hdg = 0xFFFF;      ///< cdeg, UINT16_MAX = unknown
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_boot_ms), io(m.lat), io(m.lon), io(m.alt), io(m.relative_alt), io(m.vx), io(m.vy),
        io(m.vz), io(m.hdg);
  }
};

/// VISION_POSITION_ESTIMATE (#102), with its extensions covariance and reset_counter.
struct VisionPositionEstimate {
  static constexpr uint32_t kId = 102;
  static constexpr uint8_t kCrcExtra = 158;
  static constexpr uint8_t kMinLength = 32, kLength = 117;
  uint64_t usec = 0;
  float x = 0, y = 0, z = 0;           ///< m
  float roll = 0, pitch = 0, yaw = 0;  ///< rad
  std::array<float, 21> covariance{};  ///< upper-right triangle of the 6x6 pose covariance
  uint8_t reset_counter = 0;
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.usec), io(m.x), io(m.y), io(m.z), io(m.roll), io(m.pitch), io(m.yaw);
    io(m.covariance), io(m.reset_counter);  // extensions
  }
};

/// TIMESYNC (#111), with its extensions target_system and target_component.
struct Timesync {
  static constexpr uint32_t kId = 111;
  static constexpr uint8_t kCrcExtra = 34;
  static constexpr uint8_t kMinLength = 16, kLength = 18;
  int64_t tc1 = 0;  ///< ns; 0 in a request, the responder's time in the answer
  int64_t ts1 = 0;  ///< ns; the requester's time, mirrored in the answer
  uint8_t target_system = 0, target_component = 0;
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.tc1), io(m.ts1);
    io(m.target_system), io(m.target_component);  // extensions
  }
};

/// DISTANCE_SENSOR (#132), with its extensions.
struct DistanceSensor {
  static constexpr uint32_t kId = 132;
  static constexpr uint8_t kCrcExtra = 85;
  static constexpr uint8_t kMinLength = 14, kLength = 39;
  uint32_t time_boot_ms = 0;
  uint16_t min_distance = 0, max_distance = 0, current_distance = 0;  ///< cm
  uint8_t type = 0, id = 0, orientation = 0;
  uint8_t covariance = 255;  ///< cm^2, 255 = unknown
  float horizontal_fov = 0, vertical_fov = 0;  ///< rad
  std::array<float, 4> quaternion{};
  uint8_t signal_quality = 0;  ///< %, 0 = unknown
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_boot_ms), io(m.min_distance), io(m.max_distance), io(m.current_distance),
        io(m.type), io(m.id), io(m.orientation), io(m.covariance);
    io(m.horizontal_fov), io(m.vertical_fov), io(m.quaternion), io(m.signal_quality);
  }
};

/// GPS_INPUT_IGNORE_FLAGS (common.xml): a set bit tells the receiver to ignore the field(s).
enum GpsInputIgnoreFlag : uint16_t {
  kGpsInputIgnoreAlt = 1,
  kGpsInputIgnoreHdop = 2,
  kGpsInputIgnoreVdop = 4,
  kGpsInputIgnoreVelHoriz = 8,             ///< vn and ve
  kGpsInputIgnoreVelVert = 16,             ///< vd
  kGpsInputIgnoreSpeedAccuracy = 32,
  kGpsInputIgnoreHorizontalAccuracy = 64,
  kGpsInputIgnoreVerticalAccuracy = 128,
};
/// GPS_FIX_TYPE (common.xml) values used.
constexpr uint8_t kGpsFixTypeNoFix = 1;  ///< GPS_FIX_TYPE_NO_FIX
constexpr uint8_t kGpsFixType3d = 3;     ///< GPS_FIX_TYPE_3D_FIX

/// GPS_INPUT (#232, common.xml): a position to be used as a GPS receiver's, with its extension
/// yaw. Wire order: the 8-byte field, the 4-byte ones, the 2-byte ones, the 1-byte ones, each
/// group in XML order, then yaw.
struct GpsInput {
  static constexpr uint32_t kId = 232;
  static constexpr uint8_t kCrcExtra = 151;
  static constexpr uint8_t kMinLength = 63, kLength = 65;
  uint64_t time_usec = 0;     ///< us, Unix epoch or since boot (not read by ArduPilot)
  uint32_t time_week_ms = 0;  ///< ms since the start of the GPS week (GPS time)
  int32_t lat = 0, lon = 0;   ///< degE7, WGS84
  float alt = 0;              ///< m, above mean sea level
  float hdop = 0, vdop = 0;   ///< dilution of precision, no unit
  float vn = 0, ve = 0, vd = 0;  ///< m/s, NED
  float speed_accuracy = 0;   ///< m/s
  float horiz_accuracy = 0;   ///< m
  float vert_accuracy = 0;    ///< m
  uint16_t ignore_flags = 0;  ///< GpsInputIgnoreFlag bits
  uint16_t time_week = 0;     ///< GPS week number
  uint8_t gps_id = 0;         ///< the receiving GPS instance (0 = the first)
  uint8_t fix_type = 0;       ///< GPS_FIX_TYPE: 0-1 no fix, 2 2D, 3 3D
  uint8_t satellites_visible = 0;
  uint16_t yaw = 0;           ///< cdeg from north, clockwise; 0 = unknown, 36000 = north
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_usec), io(m.time_week_ms), io(m.lat), io(m.lon), io(m.alt), io(m.hdop),
        io(m.vdop), io(m.vn), io(m.ve), io(m.vd), io(m.speed_accuracy), io(m.horiz_accuracy),
        io(m.vert_accuracy), io(m.ignore_flags), io(m.time_week), io(m.gps_id), io(m.fix_type),
        io(m.satellites_visible);
    io(m.yaw);  // extension
  }
};

/// ODOMETRY (#331), with its extensions reset_counter, estimator_type and quality.
struct Odometry {
  static constexpr uint32_t kId = 331;
  static constexpr uint8_t kCrcExtra = 91;
  static constexpr uint8_t kMinLength = 230, kLength = 233;
  uint64_t time_usec = 0;
  float x = 0, y = 0, z = 0;                 ///< m, in frame_id
  std::array<float, 4> q{1, 0, 0, 0};        ///< w, x, y, z: frame_id from body
  float vx = 0, vy = 0, vz = 0;              ///< m/s, in child_frame_id
  float rollspeed = 0, pitchspeed = 0, yawspeed = 0;  ///< rad/s
  std::array<float, 21> pose_covariance{};      ///< x y z roll pitch yaw, upper-right triangle
  std::array<float, 21> velocity_covariance{};  ///< vx vy vz rollspeed pitchspeed yawspeed
  uint8_t frame_id = kMavFrameLocalFrd;
  uint8_t child_frame_id = kMavFrameBodyFrd;
  uint8_t reset_counter = 0;
  uint8_t estimator_type = kMavEstimatorTypeVision;
  int8_t quality = 0;  ///< %: -1 failed, 0 unknown, 1 worst .. 100 best
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_usec), io(m.x), io(m.y), io(m.z), io(m.q), io(m.vx), io(m.vy), io(m.vz),
        io(m.rollspeed), io(m.pitchspeed), io(m.yawspeed), io(m.pose_covariance),
        io(m.velocity_covariance), io(m.frame_id), io(m.child_frame_id);
    io(m.reset_counter), io(m.estimator_type), io(m.quality);  // extensions
  }
};

/// VISION_POSITION_DELTA (#11011, ardupilotmega.xml): the motion since the previous report.
struct VisionPositionDelta {
  static constexpr uint32_t kId = 11011;
  static constexpr uint8_t kCrcExtra = 106;
  static constexpr uint8_t kMinLength = 44, kLength = 44;
  uint64_t time_usec = 0;
  uint64_t time_delta_usec = 0;
  std::array<float, 3> angle_delta{};     ///< rad, roll pitch yaw from the previous BODY_FRD
  std::array<float, 3> position_delta{};  ///< m, in the previous BODY_FRD
  float confidence = 0;                   ///< 0 .. 100
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_usec), io(m.time_delta_usec), io(m.angle_delta), io(m.position_delta),
        io(m.confidence);
  }
};

/// CAMERA_FEEDBACK (#180, ardupilotmega.xml): a photo ArduPilot's camera library took (read in
/// telemetry logs). Wire order: the 8-byte field, the 4-byte ones, img_idx, the 1-byte ones
/// (each group in XML order), then the extension completed_captures.
struct CameraFeedback {
  static constexpr uint32_t kId = 180;
  static constexpr uint8_t kCrcExtra = 52;
  static constexpr uint8_t kMinLength = 45, kLength = 47;
  uint64_t time_usec = 0;     ///< us since 1970-01-01 UTC ("Image timestamp (since UNIX epoch)")
  int32_t lat = 0, lng = 0;   ///< degE7
  float alt_msl = 0;          ///< m, above mean sea level
  float alt_rel = 0;          ///< m, above home
  float roll = 0, pitch = 0;  ///< deg, earth frame, +-180
  float yaw = 0;              ///< deg, earth frame, 0-360, from true north
  float foc_len = 0;          ///< mm
  uint16_t img_idx = 0;       ///< image index
  uint8_t target_system = 0;
  uint8_t cam_idx = 0;  ///< camera id
  uint8_t flags = 0;    ///< CAMERA_FEEDBACK_FLAGS
  uint16_t completed_captures = 0;
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_usec), io(m.lat), io(m.lng), io(m.alt_msl), io(m.alt_rel), io(m.roll), io(m.pitch),
        io(m.yaw), io(m.foc_len), io(m.img_idx), io(m.target_system), io(m.cam_idx), io(m.flags);
    io(m.completed_captures);  // extension
  }
};

/// CAMERA_IMAGE_CAPTURED (#263, common.xml): a photo a camera took, as PX4 and MAVLink cameras
/// report it (read in telemetry logs). Wire order: time_utc, the 4-byte fields (q as floats),
/// then the 1-byte ones (file_url as char) in XML order. No extension.
struct CameraImageCaptured {
  static constexpr uint32_t kId = 263;
  static constexpr uint8_t kCrcExtra = 133;
  static constexpr uint8_t kMinLength = 255, kLength = 255;
  uint64_t time_utc = 0;      ///< us since 1970-01-01 UTC, 0 = unknown
  uint32_t time_boot_ms = 0;  ///< ms since the sender booted
  int32_t lat = 0, lon = 0;   ///< degE7
  int32_t alt = 0;            ///< mm, above mean sea level
  int32_t relative_alt = 0;   ///< mm, "above ground" (PX4: camera_capture.ground_distance)
  std::array<float, 4> q{};   ///< w, x, y, z, the camera's orientation (PX4: camera_capture.q)
  int32_t image_index = 0;    ///< 0-based
  uint8_t camera_id = 0;      ///< "Camera ID (1 for first, 2 for second, etc.)"
  int8_t capture_result = 0;  ///< 1 success, 0 failure (PX4 also -1: no feedback)
  std::array<char, 205> file_url{};
  template <class IO, class M>
  static void Fields(IO& io, M& m) {
    io(m.time_utc), io(m.time_boot_ms), io(m.lat), io(m.lon), io(m.alt), io(m.relative_alt),
        io(m.q), io(m.image_index), io(m.camera_id), io(m.capture_result), io(m.file_url);
  }
};

template <class M>
constexpr MessageInfo Info() {
  return {M::kId, M::kCrcExtra, M::kMinLength, M::kLength};
}

/// The full-length payload of `m` (wire order, little endian, not truncated).
template <class M>
std::array<uint8_t, M::kLength> Payload(const M& m) {
  std::array<uint8_t, M::kLength> out{};
  PayloadWriter w(out.data());
  auto put = [&w](const auto& v) { w.Put(v); };
  M::Fields(put, m);
  return out;
}

/// `m` framed as a MAVLink 2 packet from `sysid`/`compid` with sequence number `seq`.
template <class M>
std::vector<uint8_t> Encode(const M& m, uint8_t seq, uint8_t sysid, uint8_t compid) {
  const auto payload = Payload(m);
  PacketHeader h;
  h.seq = seq;
  h.sysid = sysid;
  h.compid = compid;
  h.msgid = M::kId;
  return EncodePacket(h, M::kCrcExtra, payload.data(), payload.size());
}

/// The message in `packet` when it is an M (by message id), else nullopt.
template <class M>
std::optional<M> Decode(const Packet& packet) {
  if (packet.header.msgid != M::kId || packet.payload.size() < M::kLength) return std::nullopt;
  M m;
  PayloadReader r(packet.payload.data());
  auto get = [&r](auto& v) { r.Get(v); };
  M::Fields(get, m);
  return m;
}

}  // namespace aerovo::mavlink
