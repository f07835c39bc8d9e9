// PX4 ULog flight logs (ulog_reader.cc): logs written here byte for byte as the PX4 User Guide
// "ULog File Format" describes them, with the topics' fields of PX4-Autopilot msg/*.msg in the
// order PX4's generated formats have them (largest types first, then a _padding field up to a
// multiple of 8 bytes).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"
#include "aerovo/telemetry/telemetry_readers.h"

namespace aerovo::ulog_test {
namespace {

using io_test::ExpectInputError;
using ::testing::HasSubstr;

// sensor_gps of PX4-Autopilot msg/SensorGps.msg (also the layout of vehicle_gps_position from
// v1.14: "# TOPICS sensor_gps vehicle_gps_position"); 151 bytes of fields + 1 of padding.
constexpr char kSensorGps[] =
    "sensor_gps:uint64_t timestamp;uint64_t timestamp_sample;double latitude_deg;double "
    "longitude_deg;double altitude_msl_m;double altitude_ellipsoid_m;uint64_t time_utc_usec;"
    "uint32_t device_id;float s_variance_m_s;float c_variance_rad;float eph;float epv;float hdop;"
    "float vdop;int32_t noise_per_ms;int32_t jamming_indicator;float vel_m_s;float vel_n_m_s;"
    "float vel_e_m_s;float vel_d_m_s;float cog_rad;int32_t timestamp_time_relative;uint32_t "
    "system_error;float heading;float heading_offset;float heading_accuracy;float "
    "rtcm_injection_rate;uint16_t automatic_gain_control;uint8_t fix_type;uint8_t jamming_state;"
    "uint8_t spoofing_state;uint8_t authentication_state;bool vel_ned_valid;uint8_t "
    "satellites_used;uint8_t selected_rtcm_instance;bool rtcm_crc_failed;uint8_t rtcm_msg_used;"
    "uint8_t quality_corrections;uint8_t quality_receiver;uint8_t quality_gnss_signals;uint8_t "
    "quality_post_processing;uint8_t[1] _padding0;";

// vehicle_gps_position before v1.14 (msg/vehicle_gps_position.msg): lat/lon int32 1e-7 degrees,
// alt int32 mm; 125 bytes of fields + 3 of padding.
constexpr char kVehicleGpsOld[] =
    "vehicle_gps_position:uint64_t timestamp;uint64_t timestamp_sample;uint64_t time_utc_usec;"
    "uint32_t device_id;int32_t lat;int32_t lon;int32_t alt;int32_t alt_ellipsoid;float "
    "s_variance_m_s;float c_variance_rad;float eph;float epv;float hdop;float vdop;int32_t "
    "noise_per_ms;int32_t jamming_indicator;float vel_m_s;float vel_n_m_s;float vel_e_m_s;float "
    "vel_d_m_s;float cog_rad;int32_t timestamp_time_relative;float heading;float heading_offset;"
    "float[3] position_offset;uint8_t fix_type;uint8_t jamming_state;bool vel_ned_valid;uint8_t "
    "satellites_used;uint8_t selected;uint8_t[3] _padding0;";

// msg/VehicleAttitude.msg.
constexpr char kAttitude[] =
    "vehicle_attitude:uint64_t timestamp;uint64_t timestamp_sample;float[4] q;float[4] "
    "delta_q_reset;uint8_t quat_reset_counter;uint8_t[7] _padding0;";

// msg/VehicleGlobalPosition.msg.
constexpr char kGlobal[] =
    "vehicle_global_position:uint64_t timestamp;uint64_t timestamp_sample;double lat;double lon;"
    "float alt;float alt_ellipsoid;float delta_alt;float delta_terrain;float eph;float epv;float "
    "terrain_alt;bool lat_lon_valid;bool alt_valid;bool alt_ellipsoid_valid;uint8_t "
    "lat_lon_reset_counter;uint8_t alt_reset_counter;uint8_t terrain_reset_counter;bool "
    "terrain_alt_valid;bool dead_reckoning;uint8_t[4] _padding0;";

// msg/VehicleLocalPosition.msg, its position fields (a real log has the velocity, acceleration
// and limit fields too).
constexpr char kLocal[] =
    "vehicle_local_position:uint64_t timestamp;uint64_t timestamp_sample;uint64_t ref_timestamp;"
    "double ref_lat;double ref_lon;float x;float y;float z;float ref_alt;float eph;float epv;bool "
    "xy_valid;bool z_valid;bool xy_global;bool z_global;uint8_t[4] _padding0;";

// msg/HomePosition.msg.
constexpr char kHome[] =
    "home_position:uint64_t timestamp;double lat;double lon;float alt;float x;float y;float z;"
    "float yaw;uint32_t update_count;bool valid_alt;bool valid_hpos;bool valid_lpos;bool "
    "manual_home;uint8_t[4] _padding0;";

// msg/CameraCapture.msg as PX4 generates its format (8-byte fields, then the 4-byte ones in the
// .msg's order, then result); 61 bytes of fields + 3 of padding.
constexpr char kCamera[] =
    "camera_capture:uint64_t timestamp;uint64_t timestamp_utc;double lat;double lon;uint32_t seq;"
    "float alt;float ground_distance;float[4] q;int8_t result;uint8_t[3] _padding0;";

struct FieldDef {
  std::string type;
  int count;
  std::string name;
};

int TypeSize(const std::string& t) {
  if (t == "int8_t" || t == "uint8_t" || t == "bool" || t == "char") return 1;
  if (t == "int16_t" || t == "uint16_t") return 2;
  if (t == "int32_t" || t == "uint32_t" || t == "float") return 4;
  return 8;  // int64_t, uint64_t, double
}

std::vector<FieldDef> FieldsOf(const std::string& format) {
  std::vector<FieldDef> out;
  std::stringstream ss(format.substr(format.find(':') + 1));
  std::string item;
  while (std::getline(ss, item, ';')) {
    if (item.empty()) continue;
    const std::size_t space = item.rfind(' ');
    FieldDef f{item.substr(0, space), 1, item.substr(space + 1)};
    const std::size_t bracket = f.type.find('[');
    if (bracket != std::string::npos) {
      f.count = std::stoi(f.type.substr(bracket + 1));
      f.type = f.type.substr(0, bracket);
    }
    out.push_back(f);
  }
  return out;
}

// v in n little-endian bytes; bytes beyond v's 8 are 0 (a shift by 64 or more is undefined).
void Le(std::string& out, std::uint64_t v, int n) {
  for (int k = 0; k < n; ++k) out += static_cast<char>(k < 8 ? (v >> (8 * k)) & 0xFF : 0);
}

// The data of a topic of `format` with the given values (integers as stored, e.g. lat
// 435367000 for 43.5367 degrees; arrays as "q[0]"...); other fields 0. `with_last_padding`:
// a trailing _padding field written (PX4 leaves it out).
std::string Pack(const std::string& format, const std::map<std::string, double>& values,
                 bool with_last_padding = false) {
  std::string out;
  const std::vector<FieldDef> fields = FieldsOf(format);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const FieldDef& f = fields[i];
    if (i + 1 == fields.size() && f.name.rfind("_padding", 0) == 0 && !with_last_padding) break;
    for (int k = 0; k < f.count; ++k) {
      const std::string key =
          f.count > 1 || f.name == "q" ? fmt::format("{}[{}]", f.name, k) : f.name;
      const auto it = values.find(key);
      const double v = it == values.end() ? 0.0 : it->second;
      if (f.type == "float") {
        const float x = static_cast<float>(v);
        std::uint32_t bits;
        std::memcpy(&bits, &x, 4);
        Le(out, bits, 4);
      } else if (f.type == "double") {
        std::uint64_t bits;
        std::memcpy(&bits, &v, 8);
        Le(out, bits, 8);
      } else {
        Le(out, static_cast<std::uint64_t>(std::llround(v)), TypeSize(f.type));
      }
    }
  }
  return out;
}

// Writes a ULog: the 16-byte header, then messages.
class ULogWriter {
 public:
  explicit ULogWriter(int version = 1) {
    bytes_ = std::string("ULog\x01\x12\x35", 7);
    bytes_ += static_cast<char>(version);
    Le(bytes_, 1234567, 8);
  }
  void Message(char type, const std::string& payload) {
    Le(bytes_, payload.size(), 2);
    bytes_ += type;
    bytes_ += payload;
  }
  void FlagBits(int incompat0, std::uint64_t appended = 0, int incompat1 = 0) {
    std::string p(8, '\0');
    p += static_cast<char>(incompat0);
    p += static_cast<char>(incompat1);
    p += std::string(6, '\0');
    Le(p, appended, 8);
    Le(p, 0, 16);
    Message('B', p);
  }
  void Format(const std::string& text) { Message('F', text); }
  void Info(const std::string& key, const std::string& value) {
    Message('I', std::string(1, static_cast<char>(key.size())) + key + value);
  }
  void Parameter(const std::string& key, std::int32_t value) {
    std::string p(1, static_cast<char>(key.size()));
    p += key;
    Le(p, static_cast<std::uint32_t>(value), 4);
    Message('P', p);
  }
  void Subscribe(int multi_id, int msg_id, const std::string& name) {
    std::string p(1, static_cast<char>(multi_id));
    Le(p, static_cast<std::uint64_t>(msg_id), 2);
    Message('A', p + name);
  }
  void Data(int msg_id, const std::string& data) {
    std::string p;
    Le(p, static_cast<std::uint64_t>(msg_id), 2);
    Message('D', p + data);
  }
  void Logged(const std::string& text) {
    std::string p(1, '6');
    Le(p, 1000, 8);
    Message('L', p + text);
  }
  void Sync() { Message('S', std::string("\x2F\x73\x13\x20\x25\x0C\xBB\x12", 8)); }
  void Dropout(int ms) {
    std::string p;
    Le(p, static_cast<std::uint64_t>(ms), 2);
    Message('O', p);
  }
  void Raw(const std::string& b) { bytes_ += b; }
  const std::string& bytes() const { return bytes_; }
  std::size_t size() const { return bytes_.size(); }

 private:
  std::string bytes_;
};

TelemetryReadResult Parse(const std::string& bytes, bool lenient = false) {
  std::istringstream in(bytes);
  TelemetryReadOptions o;
  o.lenient = lenient;
  return ParseULog(in, "log.ulg", o);
}

// A quaternion (w, x, y, z) of the 3-2-1 rotation yaw, pitch, roll (degrees).
std::map<std::string, double> Quaternion(double yaw_deg, double pitch_deg, double roll_deg) {
  const double d = M_PI / 360.0;  // half angle, radians per degree
  const double cy = std::cos(yaw_deg * d), sy = std::sin(yaw_deg * d);
  const double cp = std::cos(pitch_deg * d), sp = std::sin(pitch_deg * d);
  const double cr = std::cos(roll_deg * d), sr = std::sin(roll_deg * d);
  return {{"q[0]", cr * cp * cy + sr * sp * sy},
          {"q[1]", sr * cp * cy - cr * sp * sy},
          {"q[2]", cr * sp * cy + sr * cp * sy},
          {"q[3]", cr * cp * sy - sr * sp * cy}};
}

std::map<std::string, double> With(std::map<std::string, double> a,
                                   const std::map<std::string, double>& b) {
  a.insert(b.begin(), b.end());
  return a;
}

// 2024-05-03T10:20:00Z.
constexpr double kUtc0 = 1714731600.0;

// A v1.14-style log: vehicle_gps_position with sensor_gps's fields, attitude, local position,
// home; the definitions and data messages a real log has around them.
ULogWriter FlightLog() {
  ULogWriter w;
  w.FlagBits(0);
  w.Format("vehicle_gps_position" + std::string(kSensorGps).substr(std::strlen("sensor_gps")));
  w.Format(kAttitude);
  w.Format(kLocal);
  w.Format(kHome);
  w.Info("char[3] sys_name", "PX4");
  w.Info("char[7] ver_sw", "1a2b3c4");
  w.Parameter("int32_t SDLOG_PROFILE", 1);
  w.Subscribe(0, 0, "vehicle_gps_position");
  w.Subscribe(0, 1, "vehicle_attitude");
  w.Subscribe(0, 2, "vehicle_local_position");
  w.Subscribe(0, 3, "home_position");
  w.Subscribe(1, 4, "vehicle_gps_position");  // a second instance: not read
  w.Logged("[logger] logging started");
  w.Data(3, Pack(kHome, {{"timestamp", 9e6}, {"z", -1.5}, {"valid_alt", 1}}));
  for (int i = 0; i < 5; ++i) {
    const double t = 10.0 + 0.2 * i;
    w.Data(1, Pack(kAttitude, With({{"timestamp", (t - 0.05) * 1e6}}, Quaternion(350, 2, -4))));
    w.Data(1, Pack(kAttitude, With({{"timestamp", (t + 0.05) * 1e6}}, Quaternion(10, 4, -2))));
    w.Data(2, Pack(kLocal, {{"timestamp", (t - 0.05) * 1e6}, {"z", -40.0}, {"z_valid", 1}}));
    w.Data(2, Pack(kLocal, {{"timestamp", (t + 0.05) * 1e6}, {"z", -42.0}, {"z_valid", 1}}));
    w.Data(0, Pack(kSensorGps, {{"timestamp", t * 1e6},
                                {"latitude_deg", 43.5367 + 1e-5 * i},
                                {"longitude_deg", 6.5567},
                                {"altitude_msl_m", 350.25},
                                {"fix_type", 3},
                                {"time_utc_usec", (kUtc0 + t) * 1e6 + 50000},
                                {"timestamp_time_relative", 50000}}));
    w.Data(4, Pack(kSensorGps, {{"timestamp", t * 1e6},
                                {"latitude_deg", 1.0},
                                {"longitude_deg", 1.0},
                                {"fix_type", 3}}));
    if (i == 2) {
      w.Sync();
      w.Dropout(35);
    }
  }
  return w;
}

TEST(ULog, ReadsGpsAttitudeAndHeightAboveHome) {
  const TelemetryReadResult r = Parse(FlightLog().bytes());
  ASSERT_EQ(r.records, 5);
  EXPECT_EQ(r.no_fix_records, 0);
  const TelemetrySample& s = r.telemetry.samples()[2];
  EXPECT_DOUBLE_EQ(s.time_s, 10.4);
  EXPECT_DOUBLE_EQ(s.lat_deg, 43.5367 + 2e-5);
  EXPECT_DOUBLE_EQ(s.lon_deg, 6.5567);
  ASSERT_TRUE(s.abs_alt_m);
  EXPECT_DOUBLE_EQ(*s.abs_alt_m, 350.25);
  // time_utc_usec - timestamp_time_relative: the UTC time at `timestamp`.
  ASSERT_TRUE(s.unix_time_s);
  EXPECT_NEAR(*s.unix_time_s, kUtc0 + 10.4, 1e-6);
  // Attitude halfway between yaw 350 and 10 (across north), pitch 2..4, roll -4..-2.
  ASSERT_TRUE(s.yaw_deg && s.pitch_deg && s.roll_deg);
  EXPECT_NEAR(std::remainder(*s.yaw_deg, 360.0), 0.0, 1e-3);
  EXPECT_NEAR(*s.pitch_deg, 3.0, 1e-3);
  EXPECT_NEAR(*s.roll_deg, -3.0, 1e-3);
  // Height above home: home z -1.5 m, vehicle z -41 m (NED, down) -> 39.5 m up.
  ASSERT_TRUE(s.rel_alt_m);
  EXPECT_NEAR(*s.rel_alt_m, 39.5, 1e-4);
  EXPECT_EQ(s.origin.rfind("log.ulg at byte ", 0), 0u) << s.origin;
  // The dropout is said; the sync message and the second receiver are no damage.
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("1 times (35 ms"));
}

TEST(ULog, EulerAnglesOfAQuaternionAwayFromZero) {
  ULogWriter w;
  w.Format(kSensorGps);
  w.Format(kAttitude);
  w.Subscribe(0, 0, "sensor_gps");
  w.Subscribe(0, 1, "vehicle_attitude");
  w.Data(1, Pack(kAttitude, With({{"timestamp", 1e6}}, Quaternion(-120, 25, 40))));
  w.Data(0, Pack(kSensorGps, {{"timestamp", 1e6},
                              {"latitude_deg", -33.9},
                              {"longitude_deg", 151.2},
                              {"fix_type", 6}}));
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 1);
  const TelemetrySample& s = r.telemetry.samples()[0];
  EXPECT_NEAR(*s.yaw_deg, 240.0, 1e-4);
  EXPECT_NEAR(*s.pitch_deg, 25.0, 1e-4);
  EXPECT_NEAR(*s.roll_deg, 40.0, 1e-4);
  EXPECT_FALSE(s.rel_alt_m);    // no home, no local position
  EXPECT_FALSE(s.unix_time_s);  // time_utc_usec 0: the receiver has no time yet
}

TEST(ULog, ReadsVehicleGpsPositionBeforeV114InIntegerUnits) {
  ULogWriter w;
  w.Format(kVehicleGpsOld);
  w.Subscribe(0, 7, "vehicle_gps_position");
  for (int i = 0; i < 3; ++i) {
    // The trailing padding written too (allowed: "may not be logged").
    w.Data(7, Pack(kVehicleGpsOld,
                   {{"timestamp", 5e6 + 2e5 * i},
                    {"lat", 435367000 + 100 * i},
                    {"lon", -65567000},
                    {"alt", 350123},
                    {"fix_type", i == 0 ? 2 : 3},
                    {"time_utc_usec", (kUtc0 + 5.0 + 0.2 * i) * 1e6}},
                   /*with_last_padding=*/true));
  }
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 2);
  EXPECT_EQ(r.no_fix_records, 1);  // fix_type 2
  const TelemetrySample& s = r.telemetry.samples()[1];
  EXPECT_DOUBLE_EQ(s.time_s, 5.4);
  EXPECT_NEAR(s.lat_deg, 43.5367200, 1e-9);
  EXPECT_NEAR(s.lon_deg, -6.5567, 1e-9);
  EXPECT_NEAR(*s.abs_alt_m, 350.123, 1e-9);
  EXPECT_NEAR(*s.unix_time_s, kUtc0 + 5.4, 1e-6);
  EXPECT_FALSE(s.yaw_deg);
}

TEST(ULog, PrefersVehicleGpsPositionThenSensorGpsThenGlobalPosition) {
  ULogWriter w;
  w.Format(kSensorGps);
  w.Format(kGlobal);
  w.Subscribe(0, 0, "vehicle_global_position");
  w.Subscribe(0, 1, "sensor_gps");
  w.Data(0, Pack(kGlobal, {{"timestamp", 1e6},
                           {"lat", 10.0},
                           {"lon", 20.0},
                           {"alt", 100.5},
                           {"lat_lon_valid", 1}}));
  w.Data(
      1,
      Pack(kSensorGps,
           {{"timestamp", 1e6}, {"latitude_deg", 11.0}, {"longitude_deg", 21.0}, {"fix_type", 3}}));
  TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 1);
  EXPECT_DOUBLE_EQ(r.telemetry.samples()[0].lat_deg, 11.0);

  // Without a GPS topic: the estimator's global position (lat_lon_valid false: no fix).
  ULogWriter g;
  g.Format(kGlobal);
  g.Subscribe(0, 0, "vehicle_global_position");
  g.Data(0, Pack(kGlobal, {{"timestamp", 1e6}, {"lat", 10.0}, {"lon", 20.0}}));
  g.Data(0, Pack(kGlobal, {{"timestamp", 2e6},
                           {"lat", 10.0},
                           {"lon", 20.0},
                           {"alt", 100.5},
                           {"lat_lon_valid", 1}}));
  r = Parse(g.bytes());
  ASSERT_EQ(r.records, 1);
  EXPECT_EQ(r.no_fix_records, 1);
  EXPECT_DOUBLE_EQ(r.telemetry.samples()[0].time_s, 2.0);
  EXPECT_DOUBLE_EQ(*r.telemetry.samples()[0].abs_alt_m, 100.5);
}

TEST(ULog, SkipsDamagedBytesWithAWarningNamingTheOffset) {
  ULogWriter w = FlightLog();
  const std::size_t at = w.size();
  w.Raw(std::string("\x07\x00\x44garbage-bytes\xFF\xFF", 18));
  w.Data(
      0,
      Pack(kSensorGps,
           {{"timestamp", 12e6}, {"latitude_deg", 43.6}, {"longitude_deg", 6.6}, {"fix_type", 3}}));
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 6);
  EXPECT_DOUBLE_EQ(r.telemetry.samples()[5].lat_deg, 43.6);
  bool named = false;
  for (const std::string& m : r.warnings) {
    named = named ||
            m.find(fmt::format("log.ulg at byte {}: 18 byte(s) skipped", at)) != std::string::npos;
  }
  EXPECT_TRUE(named) << ::testing::PrintToString(r.warnings);
}

TEST(ULog, ResyncsOnTheSyncMessageAfterAMessageWithAWrongSize) {
  ULogWriter w = FlightLog();
  // A GPS message whose size says 2 bytes more than its topic's: damaged, dropped with the
  // bytes up to the next message.
  std::string bad =
      Pack(kSensorGps,
           {{"timestamp", 11e6}, {"latitude_deg", 50.0}, {"longitude_deg", 6.6}, {"fix_type", 3}});
  w.Data(0, bad + "xx");
  w.Sync();
  w.Data(
      0,
      Pack(kSensorGps,
           {{"timestamp", 12e6}, {"latitude_deg", 43.6}, {"longitude_deg", 6.6}, {"fix_type", 3}}));
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.records, 6);
  for (const TelemetrySample& s : r.telemetry.samples()) EXPECT_NE(s.lat_deg, 50.0);
  EXPECT_THAT(::testing::PrintToString(r.warnings), HasSubstr("byte(s) skipped"));
}

TEST(ULog, ACutLastMessageIsDroppedWithAWarning) {
  const std::string whole = FlightLog().bytes();
  // The last message (the second receiver's, 3 + 2 + 151 bytes) gone, and the end of the
  // first receiver's last one.
  const std::string cut = whole.substr(0, whole.size() - 156 - 20);
  const TelemetryReadResult r = Parse(cut);
  EXPECT_EQ(r.records, 4);
  EXPECT_THAT(::testing::PrintToString(r.warnings), HasSubstr("is cut short"));
}

TEST(ULog, MessagesOfUnknownTypesAreIgnored) {
  // "Must ignore unknown messages" (a later version of the format may add types).
  ULogWriter w;
  w.Format(kSensorGps);
  w.Subscribe(0, 0, "sensor_gps");
  for (int i = 0; i < 3; ++i) {
    w.Data(0, Pack(kSensorGps, {{"timestamp", 1e6 * (i + 1)},
                                {"latitude_deg", 43.0},
                                {"longitude_deg", 6.0 + 0.001 * i},
                                {"fix_type", 3}}));
    w.Message('X', "future");
  }
  const TelemetryReadResult r = Parse(w.bytes());
  EXPECT_EQ(r.records, 3);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_THAT(r.warnings[0], HasSubstr("3 messages of a type aerovo does not know (first 'X'"));
}

TEST(ULog, NoFixIsAnInputError) {
  ULogWriter w;
  w.Format(kSensorGps);
  w.Subscribe(0, 0, "sensor_gps");
  for (int i = 0; i < 3; ++i) {
    w.Data(0, Pack(kSensorGps, {{"timestamp", 1e6 * (i + 1)}, {"fix_type", 1}}));
  }
  ExpectInputError([&] { Parse(w.bytes()); },
                   {"log.ulg", "no GPS message with a 3D fix", "3 messages without one"});
}

TEST(ULog, NoGpsTopicIsAnInputError) {
  ULogWriter w;
  w.Format(kAttitude);
  w.Subscribe(0, 0, "vehicle_attitude");
  w.Data(0, Pack(kAttitude, With({{"timestamp", 1e6}}, Quaternion(0, 0, 0))));
  ExpectInputError([&] { Parse(w.bytes()); }, {"log.ulg", "no GPS message in this ULog"});
}

TEST(ULog, AGpsFormatWithoutItsFieldsSaysWhich) {
  ULogWriter w;
  w.Format("sensor_gps:uint64_t timestamp;double lat_x;uint8_t fix_type;");
  w.Subscribe(0, 0, "sensor_gps");
  ExpectInputError([&] { Parse(w.bytes()); }, {"no GPS position", "'lat'"});
}

TEST(ULog, NotAULogSaysSo) {
  ExpectInputError([] { Parse(std::string("\xFF\xD8\xFF\xE0\x00\x10JFIF\x00", 11)); },
                   {"log.ulg", "not a PX4 ULog", "FF D8 FF", "JPEG"});
  ExpectInputError([] { Parse(std::string("\xA3\x95\x80\x80\x59", 5)); },
                   {"not a PX4 ULog", "DataFlash"});
  ExpectInputError([] { Parse(""); }, {"not a PX4 ULog", "empty"});
  ExpectInputError([] { Parse(std::string("ULog\x01\x12\x35\x01", 8)); }, {"16-byte header"});
}

TEST(ULog, RefusesUnknownIncompatibleFlags) {
  ULogWriter w;
  w.FlagBits(0, 0, /*incompat1=*/0x04);
  w.Format(kSensorGps);
  ExpectInputError([&] { Parse(w.bytes()); },
                   {"log.ulg at byte 16", "incompatible flag bits", "00 04 00"});
}

TEST(ULog, ReadsDataAppendedAfterACutMessage) {
  ULogWriter w;
  w.FlagBits(1, 0);  // DATA_APPENDED; offset patched below
  w.Format(kSensorGps);
  w.Subscribe(0, 0, "sensor_gps");
  const std::string fix =
      Pack(kSensorGps,
           {{"timestamp", 1e6}, {"latitude_deg", 43.0}, {"longitude_deg", 6.0}, {"fix_type", 3}});
  w.Data(0, fix);
  // A message cut by the end of the log (power loss), then the appended data.
  ULogWriter cut;
  cut.Data(0, fix);
  w.Raw(cut.bytes().substr(16, 40));
  const std::uint64_t appended = w.size();
  w.Data(
      0,
      Pack(kSensorGps,
           {{"timestamp", 2e6}, {"latitude_deg", 44.0}, {"longitude_deg", 6.0}, {"fix_type", 3}}));
  std::string bytes = w.bytes();
  std::string offset;
  Le(offset, appended, 8);
  bytes.replace(16 + 3 + 16, 8, offset);  // appended_offsets[0]
  const TelemetryReadResult r = Parse(bytes);
  ASSERT_EQ(r.records, 2);
  EXPECT_DOUBLE_EQ(r.telemetry.samples()[1].lat_deg, 44.0);
  EXPECT_TRUE(r.warnings.empty()) << ::testing::PrintToString(r.warnings);
}

TEST(ULog, MalformedRecordsStrictOrLenient) {
  ULogWriter w;
  w.Format(kSensorGps);
  w.Subscribe(0, 0, "sensor_gps");
  for (double t : {2.0, 1.0, 3.0}) {  // the second out of order
    w.Data(0, Pack(kSensorGps, {{"timestamp", t * 1e6},
                                {"latitude_deg", 43.0},
                                {"longitude_deg", 6.0},
                                {"fix_type", 3}}));
  }
  EXPECT_THROW(Parse(w.bytes()), MalformedRecordError);
  const TelemetryReadResult r = Parse(w.bytes(), /*lenient=*/true);
  EXPECT_EQ(r.records, 2);
  EXPECT_EQ(r.skipped_records, 1);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_THAT(r.warnings[0], HasSubstr("out of order"));
}

TEST(ULog, HostileFormatsAndSizesNeitherCrashNorHang) {
  // A format nesting itself, one nesting an undefined type, a huge array: their subscriptions
  // are refused; zero-size messages of unknown types; then garbage.
  ULogWriter w;
  w.Format("sensor_gps:uint64_t timestamp;sensor_gps[2] inner;");
  w.Format("vehicle_attitude:uint64_t timestamp;nowhere[3] x;");
  w.Format("vehicle_local_position:uint64_t timestamp;double[65535] z;");
  w.Subscribe(0, 0, "sensor_gps");
  w.Subscribe(0, 1, "vehicle_attitude");
  w.Subscribe(0, 2, "vehicle_local_position");
  for (int i = 0; i < 100; ++i) w.Message('\0', "");
  w.Raw(std::string(5000, '\0'));
  ExpectInputError([&] { Parse(w.bytes()); }, {"log.ulg", "no GPS position", "nests itself"});
  // A megabyte of bytes that are no message after the header.
  std::string noise = ULogWriter().bytes();
  std::uint32_t x = 12345;
  for (int i = 0; i < (1 << 20); ++i) {
    x = x * 1664525u + 1013904223u;
    noise += static_cast<char>(x >> 24);
  }
  ExpectInputError([&] { Parse(noise, /*lenient=*/true); }, {"log.ulg", "no GPS"});
}

// FlightLog() (GPS at 10.0 .. 10.8 s) with camera_capture messages: the two instances of the
// topic, and at `offsets` the byte offset of each message of instance 0.
ULogWriter FlightLogWithPhotos(std::vector<std::size_t>* offsets) {
  ULogWriter w = FlightLog();
  w.Format(kCamera);
  w.Subscribe(0, 5, "camera_capture");
  w.Subscribe(1, 6, "camera_capture");  // a second camera: not read
  const auto photo = [&](std::map<std::string, double> values) {
    offsets->push_back(w.size());
    w.Data(5, Pack(kCamera, values));
  };
  // seq 0: a photo with a position, an attitude and a date.
  photo(With({{"timestamp", 10.1e6},
              {"timestamp_utc", (kUtc0 + 10.1) * 1e6},
              {"seq", 0},
              {"lat", 43.53671},
              {"lon", 6.55672},
              {"alt", 352.5},
              {"ground_distance", 98.0},
              {"result", 1}},
             Quaternion(-120, 25, 40)));
  // seq 1: a capture that failed.
  photo({{"timestamp", 10.3e6}, {"seq", 1}, {"lat", 43.5}, {"lon", 6.5}, {"result", 0}});
  // seq 2: no feedback from the camera (-1), no position (NaN), no attitude (q zero).
  photo({{"timestamp", 10.5e6},
         {"seq", 2},
         {"lat", std::nan("")},
         {"lon", std::nan("")},
         {"alt", std::nan("")},
         {"result", -1}});
  // seq 3: the position 0, 0 of a vehicle without a fix.
  photo(With({{"timestamp", 10.7e6}, {"seq", 3}, {"alt", 351.0}, {"result", 1}},
             Quaternion(0, 0, 0)));
  w.Data(6, Pack(kCamera,
                 {{"timestamp", 10.2e6}, {"seq", 0}, {"lat", 1.0}, {"lon", 1.0}, {"result", 1}}));
  return w;
}

TEST(ULog, ReadsCameraCaptureAsCameraTriggers) {
  std::vector<std::size_t> at;
  const TelemetryReadResult r = Parse(FlightLogWithPhotos(&at).bytes());
  ASSERT_EQ(r.records, 5);  // the GPS samples as before
  EXPECT_DOUBLE_EQ(r.telemetry.samples()[0].time_s, 10.0);
  EXPECT_EQ(r.skipped_records, 0);
  const std::vector<TelemetrySample>& c = r.camera_triggers;
  ASSERT_EQ(c.size(), 3u);  // seq 1 failed, instance 1 not read
  // timestamp / 1e6: the clock of the GPS samples (10.0 .. 10.8 s).
  EXPECT_DOUBLE_EQ(c[0].time_s, 10.1);
  EXPECT_DOUBLE_EQ(c[1].time_s, 10.5);
  EXPECT_DOUBLE_EQ(c[2].time_s, 10.7);
  EXPECT_EQ(c[0].origin, fmt::format("log.ulg at byte {}: camera_capture 0", at[0]));
  EXPECT_EQ(c[1].origin, fmt::format("log.ulg at byte {}: camera_capture 2", at[2]));
  EXPECT_EQ(c[2].origin, fmt::format("log.ulg at byte {}: camera_capture 3", at[3]));
  EXPECT_TRUE(c[0].has_fix);
  EXPECT_DOUBLE_EQ(c[0].lat_deg, 43.53671);
  EXPECT_DOUBLE_EQ(c[0].lon_deg, 6.55672);
  ASSERT_TRUE(c[0].abs_alt_m);
  EXPECT_DOUBLE_EQ(*c[0].abs_alt_m, 352.5);
  EXPECT_FALSE(c[0].rel_alt_m);  // ground_distance is not the height above home
  // q is the camera's attitude on a gimbal (CameraCapture.msg): not read as the aircraft's.
  EXPECT_FALSE(c[0].yaw_deg || c[0].pitch_deg || c[0].roll_deg);
  ASSERT_TRUE(c[0].unix_time_s);
  EXPECT_NEAR(*c[0].unix_time_s, kUtc0 + 10.1, 1e-6);
  EXPECT_FALSE(c[0].frame_index);
  // NaN position and altitude, zero q, no date.
  EXPECT_FALSE(c[1].has_fix);
  EXPECT_FALSE(c[1].abs_alt_m);
  EXPECT_FALSE(c[1].yaw_deg);
  EXPECT_FALSE(c[1].unix_time_s);
  // 0, 0: no fix, the altitude kept.
  EXPECT_FALSE(c[2].has_fix);
  ASSERT_TRUE(c[2].abs_alt_m);
  EXPECT_DOUBLE_EQ(*c[2].abs_alt_m, 351.0);
}

TEST(ULog, CameraCaptureOfAnOldFormatWithoutResultKeepsEveryMessage) {
  ULogWriter w = FlightLog();
  w.Format("camera_capture:uint64_t timestamp;double lat;double lon;uint32_t seq;float alt;");
  w.Subscribe(0, 5, "camera_capture");
  for (int k = 0; k < 2; ++k) {
    w.Data(5,
           Pack("camera_capture:uint64_t timestamp;double lat;double lon;uint32_t seq;float alt;",
                {{"timestamp", (10.2 + 0.4 * k) * 1e6},
                 {"lat", 43.5368},
                 {"lon", 6.5568 + 1e-4 * k},
                 {"seq", 7 + k},
                 {"alt", 300.0}}));
  }
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.camera_triggers.size(), 2u);
  EXPECT_DOUBLE_EQ(r.camera_triggers[1].time_s, 10.6);
  EXPECT_DOUBLE_EQ(r.camera_triggers[1].lon_deg, 6.5569);
  EXPECT_THAT(r.camera_triggers[1].origin, HasSubstr(": camera_capture 8"));
  EXPECT_FALSE(r.camera_triggers[1].unix_time_s);  // no timestamp_utc
}

TEST(ULog, CameraCaptureWithABadValueIsAMalformedRecord) {
  for (const bool bad_alt : {false, true}) {
    SCOPED_TRACE(bad_alt ? "altitude 1e6 m" : "latitude 123");
    ULogWriter w = FlightLog();
    w.Format(kCamera);
    w.Subscribe(0, 5, "camera_capture");
    std::map<std::string, double> good = {
        {"timestamp", 10.1e6}, {"seq", 0}, {"lat", 43.5}, {"lon", 6.5}, {"result", 1}};
    w.Data(5, Pack(kCamera, good));
    const std::size_t at = w.size();
    std::map<std::string, double> bad = {{"timestamp", 10.3e6},
                                         {"seq", 1},
                                         {"lat", bad_alt ? 43.5 : 123.0},
                                         {"lon", 6.5},
                                         {"result", 1}};
    if (bad_alt) bad["alt"] = 1e6;
    w.Data(5, Pack(kCamera, bad));
    ExpectInputError([&] { Parse(w.bytes()); },
                     {fmt::format("log.ulg at byte {}: camera_capture", at).c_str(),
                      bad_alt ? "absolute altitude" : "latitude"});
    EXPECT_THROW(Parse(w.bytes()), MalformedRecordError);
    const TelemetryReadResult r = Parse(w.bytes(), /*lenient=*/true);
    EXPECT_EQ(r.records, 5);
    EXPECT_EQ(r.skipped_records, 1);
    ASSERT_EQ(r.camera_triggers.size(), 1u);
    EXPECT_DOUBLE_EQ(r.camera_triggers[0].time_s, 10.1);
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_THAT(r.warnings[0], HasSubstr(fmt::format("at byte {}", at)));
  }
}

TEST(ULog, CameraCaptureWithASeqOfAnotherTypeIsNamedWithoutIt) {
  // A format of the file's own with a double seq: NaN is not a number to print (nor to cast).
  const std::string format = "camera_capture:uint64_t timestamp;double seq;double lat;double lon;";
  ULogWriter w = FlightLog();
  w.Format(format);
  w.Subscribe(0, 5, "camera_capture");
  const std::size_t at = w.size();
  w.Data(5,
         Pack(format, {{"timestamp", 10.2e6}, {"seq", std::nan("")}, {"lat", 43.5}, {"lon", 6.5}}));
  w.Data(5, Pack(format, {{"timestamp", 10.4e6}, {"seq", 1e30}, {"lat", 43.5}, {"lon", 6.5}}));
  const TelemetryReadResult r = Parse(w.bytes());
  ASSERT_EQ(r.camera_triggers.size(), 2u);
  EXPECT_EQ(r.camera_triggers[0].origin, fmt::format("log.ulg at byte {}: camera_capture", at));
  EXPECT_THAT(r.camera_triggers[1].origin,
              HasSubstr(": camera_capture 1000000000000000019884624838656"));
}

TEST(ULog, ALogWithoutCameraCaptureHasNoCameraTriggers) {
  const TelemetryReadResult r = Parse(FlightLog().bytes());
  EXPECT_EQ(r.records, 5);
  EXPECT_TRUE(r.camera_triggers.empty());
}

TEST(ULog, ReadTelemetryFilePicksTheULogReaderByExtension) {
  io_test::TempDir dir("ulog");
  const auto path = dir / "log_12_2024-5-3-10-20-00.ULG";
  {
    std::ofstream out(path, std::ios::binary);
    out << FlightLog().bytes();
  }
  const TelemetryReadResult r = ReadTelemetryFile(path);
  EXPECT_EQ(r.records, 5);
}

}  // namespace
}  // namespace aerovo::ulog_test
