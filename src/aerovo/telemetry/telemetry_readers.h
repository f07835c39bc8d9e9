// Readers of flight telemetry files: DJI .SRT subtitles, GPX tracks, CSV tables and ArduPilot
// DataFlash logs (.bin, and their text form .log).
// MAVLink telemetry logs (.tlog) of a ground station: ParseTlog below.
//
// Every reader is a pure parsing function over a std::istream (`source_name` is used only in
// messages) plus a wrapper that opens a file. Errors are InputError with the message
// "<source>:<line>: <problem>", e.g. "flight.srt:42: latitude 123.4 out of range [-90, 90]"
// ("<source> at byte <offset>: <problem>" in a binary DataFlash log).
//
// Malformed records (a line that cannot be parsed, a record missing latitude or longitude, a
// value out of range, a timestamp earlier than the previous record's):
//  - strict (default, TelemetryReadOptions::lenient = false): the first one throws InputError;
//  - lenient: the record is skipped, counted in TelemetryReadResult::skipped_records, and its
//    message kept in `warnings` (the first max_warnings of them).
// Facts about how a file as a whole was read (its dates not read, records on a coarse clock
// spread in time, a GPX document cut short, no time in any point) follow the record messages in
// `warnings` in both modes, whatever their number: at most kMaxReadNotes. ReadTelemetryFile puts
// one more line first when it recognised the format by content, not by extension.
// In both modes a file with no valid record at all throws InputError ("no telemetry samples").
// Records that say "no GPS fix" (DJI writes latitude 0 and longitude 0, or "N/A", before the fix)
// are not damage: in DJI SRT files they are samples with has_fix = false that keep their heights
// and angles, in GPX and CSV files they are dropped, and so are DataFlash GPS messages with a
// Status below 3D fix; both modes count them in no_fix_records.
// Every sample's `origin` is "<source>:<line>" of its record ("<source> at byte <offset>" in a
// binary DataFlash log).
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/telemetry.h"

namespace aerovo {

/// The InputError of a malformed record (unreadable number, missing field, value out of range)
/// in strict mode: exactly what TelemetryReadOptions::lenient would have skipped. Other input
/// errors (no such file, not a GPX file, bad CSV header, no record at all) are plain InputError.
class MalformedRecordError : public InputError {
 public:
  using InputError::InputError;
};

struct TelemetryReadOptions {
  /// false: the first malformed record throws MalformedRecordError; true: skip and count it.
  bool lenient = false;
  /// Messages of skipped records kept in TelemetryReadResult::warnings (the count is exact).
  int max_warnings = 20;
};

/// Notes about a file as a whole kept after the record messages in TelemetryReadResult::warnings
/// (see above): a parser's warnings hold at most max_warnings + kMaxReadNotes lines.
/// Two today: a CSV file's dates not read and its times spread; a GPX document cut short and
/// its times spread, or no time in any point.
inline constexpr int kMaxReadNotes = 2;

/// Throws InvalidArgument when max_warnings < 0.
void Validate(const TelemetryReadOptions& options);

struct TelemetryReadResult {
  Telemetry telemetry;      ///< Sorted by time; time_s = 0 at the first record.
  int records = 0;          ///< Records accepted (== telemetry.size()).
  int skipped_records = 0;  ///< Malformed records skipped (lenient mode only).
  int no_fix_records = 0;   ///< Records without a GPS fix (latitude = longitude = 0, "N/A").
  /// "<source>:<line>: <problem>" of skipped records and damaged bytes (at most max_warnings),
  /// then the notes about the file as a whole (at most kMaxReadNotes).
  std::vector<std::string> warnings;
  /// The photos the autopilot says its camera took, in the log's order (DataFlash CAM, else
  /// TRIG; ULog camera_capture; tlog CAMERA_FEEDBACK, else CAMERA_IMAGE_CAPTURED), of the first
  /// camera only: time_s on the clock of `telemetry`'s samples, the position, heights and
  /// aircraft attitude the autopilot logged with the photo (has_fix false when it logged none),
  /// frame_index unset, origin naming the message ("<source> at byte <offset>: CAM 12").
  /// Empty for the formats that have none. A photo folder is matched to them photo by photo
  /// (pipeline/run_steps.h RunTelemetry::Load).
  std::vector<TelemetrySample> camera_triggers;
};

/// DJI .SRT subtitles. Each subtitle block is: a number line, a timing line
/// "HH:MM:SS,mmm --> HH:MM:SS,mmm" and text lines (HTML tags such as <font> are removed first).
/// The families read (docs/inputs.md "DJI .SRT families" has an example line of each):
///  - bracketed fields (Mavic Air 2 / Mini / Mavic 3 style):
///    "[latitude: 43.5367] [longitude: 6.5567] [rel_alt: 100.000 abs_alt: 350.123]",
///    also "[longtitude : ...]" (Mavic Pro's misspelling), "[altitude: ...]" (= abs_alt),
///    "[focal_len : 240]" (35 mm equivalent: an integer >= 100 is in tenths of mm, 240 = 24 mm;
///    a value with decimals is in mm, 24.00 = 24 mm),
///    "[gb_yaw: .. gb_pitch: .. gb_roll: ..]" (gimbal angles), "[drone_yaw: .. drone_pitch: ..
///    drone_roll: ..]" and "[Drone: Yaw:.., Pitch:.., Roll:..]" (aircraft angles);
///  - the multi-line records of enterprise aircraft (M30/M300 with H20-class cameras): the same
///    fields over several lines, then a blank line, a line "0" and more lines of the same
///    subtitle;
///  - "FrameCnt: 12, DiffTime: 33ms" or "SrtCnt : 12, ..." (frame counter, 1-based);
///  - a date line "2023-05-01 12:00:00,123,456" / "2023-05-01 12:00:00.123";
///  - 1 Hz records: "GPS(6.5567,43.5367,19)" / "GPS (6.5567, 43.5367, 19)" / "RTK (...)" with
///    the order of latitude and longitude given by the third value: an integer (satellites) ->
///    longitude first (Phantom, Mavic 2, P4 RTK); an altitude with "M" -> latitude first
///    (M200/M300: "GPS(36.6146,-6.1120,0.0M)"); no marker: a value beyond +-90 is the longitude.
///    A file with two orders, or with a GPS(...) that no marker or value decides, throws
///    InputError "<source>:<line>: ..." naming both readings (in both modes: never a guess).
///    "BAROMETER:100.5" / "BAROMETER:0.3M" / "BAROMETER(91.2)" and "H 19.30m" (height above
///    take-off); "Hb:35.2m", else "Hs:34.8m" when there is neither; "HOME(lon,lat) date";
///    "F.PRY (p°, r°, y°)" / "G.PRY (...)" (pitch, roll, yaw of the aircraft / the gimbal).
///  - Autel's captions: "GPS(W: 111.903317, N: 40.760884, 1452.30m)", each value with its
///    hemisphere letter (N/S the latitude, E/W the longitude, S and W negative, either order; the
///    third value is not read), "HOME(W: .., N: ..) date".
///  - no fix: "GPS(N/A,N/A,n)", "[latitude: N/A]" or latitude = longitude = 0: a sample with
///    has_fix = false, keeping its heights and angles.
/// time_s = the block's start time (video time). frame_index = counter - 1 (0-based video
/// frame) when the block has FrameCnt/SrtCnt; unset otherwise (old formats write one subtitle
/// per second, not per frame: match those by time).
TelemetryReadResult ParseDjiSrt(std::istream& in, const std::string& source_name,
                                const TelemetryReadOptions& options = {});
TelemetryReadResult ReadDjiSrt(const std::filesystem::path& path,
                               const TelemetryReadOptions& options = {});

/// GPX 1.0/1.1 track points (<trkpt lat=".." lon=".."> with optional <ele> -> abs_alt_m and
/// <time> ISO 8601 -> unix_time_s). Route points (<rtept>) are read when there is no <trkpt>.
/// Every point needs a <time> (time_s = seconds since the first point) unless no point has
/// one, in which case time_s = the point's rank and a warning says so. Line numbers in errors
/// are those of the <trkpt> element. XML syntax errors throw in both modes.
TelemetryReadResult ParseGpx(std::istream& in, const std::string& source_name,
                             const TelemetryReadOptions& options = {});
TelemetryReadResult ReadGpx(const std::filesystem::path& path,
                            const TelemetryReadOptions& options = {});

/// CSV with a header row naming the columns, separated by ',' or ';' (whichever the header
/// has more of, or a first line "sep=," / "sep=;"; '"' quoting allowed). A header cell is an
/// optional group prefix ("OSD.", "GIMBAL.", "CUSTOM." of DJI flight records), a name and an
/// optional unit: "name(unit)", "name [unit]" or "name_unit"; case-insensitive, spaces trimmed.
/// Aliases (without a unit: metres, seconds, degrees):
///   latitude: lat, latitude, OSD.latitude    longitude: lon, lng, long, longitude, OSD.longitude
///   abs_alt_m: abs_alt, altitude_above_sealevel, altitude_msl, OSD.altitude; then alt,
///     altitude, ele, elevation; then alt_ellipsoid, altitude_ellipsoid
///   rel_alt_m: rel_alt, relative_altitude, height_above_takeoff, OSD.height; then height
///   time: time, t, OSD.flyTime; then timestamp  (a number, or an ISO 8601 date)
///   date: datetime, CUSTOM.updateTime  (-> unix_time_s; "(utc)", "(local)" = as if UTC)
///   frame: frame, frame_index, frame_idx
///   yaw: yaw, heading, flight_yaw, compass_heading, OSD.yaw; pitch, roll, OSD.pitch, OSD.roll
///   gimbal: gimbal_yaw, gimbal_heading, gimbal_pitch, gimbal_roll, GIMBAL.yaw/pitch/roll
///   focal_length_mm: focal_length, focal; focal_length_35mm_mm: focal_35mm, focal35
/// Units are converted (ft, mm -> m; ms, us -> s; rad -> deg; degE7 -> deg); an unknown unit on
/// a column that is read throws InputError "<source>:<line>: column '..' ... unit '..'".
/// Where a field has several columns the first group above is read; two columns of one group
/// throw InputError ("two columns mean ..."). Layouts recognised by their columns: Litchi logs
/// (an "ultrasonicHeight" column: "altitude" is the height above take-off) and PX4 ulog2csv
/// position topics (first column "timestamp" and an "eph" column: timestamp in microseconds,
/// angles in radians; with "fix_type", lat/lon in integer 1e-7 degrees and alt in mm). An
/// out-of-range integer latitude/longitude >= 1e4 elsewhere is a malformed record whose message
/// says how to name degE7 columns. docs/inputs.md "CSV exports of flight logs" lists the exports.
/// Latitude and longitude columns are required, and a time, a date or a frame column. The time
/// of a record is its time column, else its date (time_s from the first record), else its frame
/// index; with a time and a date column, unix_time_s = time_s + (date - time_s) of the first
/// record with both. Empty cells leave optional fields unset. Blank lines and lines starting
/// with '#' are ignored.
TelemetryReadResult ParseTelemetryCsv(std::istream& in, const std::string& source_name,
                                      const TelemetryReadOptions& options = {});
TelemetryReadResult ReadTelemetryCsv(const std::filesystem::path& path,
                                     const TelemetryReadOptions& options = {});

/// ArduPilot DataFlash logs: the binary log (.bin, written by the autopilot to its SD card,
/// starting with the bytes A3 95 80) or its text form (.log, Mission Planner's "convert .bin to
/// .log": lines "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns", "GPS, ..."), told
/// apart by their first bytes. Message layouts and column names are read from the log's own FMT
/// messages (format characters of ArduPilot's libraries/AP_Logger/LogStructure.h; the text form
/// has the values already scaled). Read:
///  - GPS (first receiver, column I = 0 when present): one sample per message with Status >= 3
///    (3D fix): Lat, Lng (degrees), Alt (metres above sea level -> abs_alt_m); time_s = TimeUS /
///    1e6 (seconds since the autopilot booted); unix_time_s from GWk and GMS (GPS week and
///    milliseconds: 315964800 + GWk * 604800 + GMS / 1000 - 18 leap seconds, right since
///    2017-01-01). Status < 3 (no fix) and Lat = Lng = 0 are counted in no_fix_records;
///  - ATT Roll, Pitch, Yaw (degrees, aircraft attitude) -> roll_deg, pitch_deg, yaw_deg, and POS
///    RelHomeAlt (metres above home) -> rel_alt_m, interpolated linearly onto each GPS time
///    (angles along the shorter arc; not across a gap of more than 1 s, never extrapolated).
/// Bytes that are not a message (a damaged or cut log) are skipped up to the next header with a
/// type the log defines and the next header at its length (so that bytes inserted into a
/// message drop it rather than shift its fields), with a warning naming the byte offset and the
/// count
/// (whatever the mode); a cut last message likewise. A file that is neither form throws
/// InputError "not an ArduPilot DataFlash log"; a log without a GPS message with a 3D fix
/// throws InputError. Memory is bounded by the samples kept (the file is read through a 64 KiB
/// window; ATT and POS are kept at most every 0.02 s).
TelemetryReadResult ParseDataFlash(std::istream& in, const std::string& source_name,
                                   const TelemetryReadOptions& options = {});
TelemetryReadResult ReadDataFlash(const std::filesystem::path& path,
                                  const TelemetryReadOptions& options = {});

/// MAVLink telemetry logs (.tlog) as Mission Planner, QGroundControl and MAVProxy record the
/// link to an ArduPilot or PX4 autopilot: records of an 8-byte big-endian timestamp (the ground
/// station's clock, microseconds since 1970) and one MAVLink 1 or 2 packet. Read from the
/// vehicle only: component 1 of the first system that sends a HEARTBEAT with an autopilot type
/// (not MAV_AUTOPILOT_INVALID, which ground stations send); other systems' positions are ignored
/// with a warning. Messages (common.xml):
///  - GLOBAL_POSITION_INT: one sample each: lat, lon (degE7 -> degrees), alt (mm MSL ->
///    abs_alt_m), relative_alt (mm above home -> rel_alt_m), hdg (cdeg -> yaw_deg, only when no
///    ATTITUDE is at hand); time_s = time_boot_ms / 1000 (seconds since the autopilot booted).
///    latitude = longitude = 0, or the latest GPS_RAW_INT saying fix_type < 3 (no 3D fix), is
///    counted in no_fix_records and gives no sample;
///  - ATTITUDE roll, pitch, yaw (radians -> degrees) interpolated onto each sample (along the
///    shorter arc; not across a gap of more than 1 s, never extrapolated; kept at most every
///    0.02 s);
///  - unix_time_s: from SYSTEM_TIME (time_unix_usec - time_boot_ms, the first non-zero one of
///    each boot) when the autopilot sends it, else the record's timestamp (the ground station's
///    clock, late by the link's latency);
///  - camera_triggers: CAMERA_FEEDBACK (ardupilotmega.xml, ArduPilot) when the autopilot sent
///    any, else CAMERA_IMAGE_CAPTURED with capture_result != 0 (PX4), of the first cam_idx /
///    camera_id, a photo reported twice read once: lat, lon (degE7; 0, 0 -> has_fix false),
///    altitudes, attitude (CAMERA_FEEDBACK roll/pitch/yaw in degrees; CAMERA_IMAGE_CAPTURED's q,
///    the camera's orientation, is not read), the photo's UTC time -> unix_time_s. time_s:
///    CAMERA_IMAGE_CAPTURED time_boot_ms as the samples'; CAMERA_FEEDBACK time_usec (UTC) minus the
///    SYSTEM_TIME relation of its boot, else the record's timestamp placed on the samples' clock
///    (when the ground station received it: late by the link). origin "<source> at byte <offset>:
///    CAMERA_FEEDBACK <img_idx>" / "CAMERA_IMAGE_CAPTURED <image_index>". A value out of range is
///    a malformed record (strict/lenient).
/// An autopilot reboot (time_boot_ms going back by more than 2 s) is not an error: time_s goes on
/// from the ground station's clock across the gap, with a warning naming the byte offset.
/// Damaged bytes are skipped up to the next plausible record, a packet with a wrong checksum is
/// skipped and counted, a cut last record is dropped, each with a warning naming the byte
/// offset (whatever the mode). A file that does not start with a record throws InputError
/// "not a MAVLink telemetry log"; a log without an autopilot HEARTBEAT (a ground station alone)
/// or without a GLOBAL_POSITION_INT with a fix throws InputError. Memory is bounded by the
/// samples kept (64 KiB read window).
TelemetryReadResult ParseTlog(std::istream& in, const std::string& source_name,
                              const TelemetryReadOptions& options = {});
TelemetryReadResult ReadTlog(const std::filesystem::path& path,
                             const TelemetryReadOptions& options = {});

/// PX4 ULog flight logs (.ulg, written by PX4 to its SD card; PX4 User Guide "ULog File
/// Format"). Layouts and field names are read from the log's own 'F' format messages. Read:
///  - the GPS: vehicle_gps_position (the receiver PX4 uses), else sensor_gps, else
///    vehicle_global_position (the estimator's position), instance multi_id 0: one sample per
///    message with fix_type >= 3 (3D fix; vehicle_global_position: lat_lon_valid when the log
///    has it): latitude and longitude in degrees (lat/lon int32 1e-7 degrees before v1.14,
///    latitude_deg/longitude_deg from v1.14), altitude above MSL in metres -> abs_alt_m (alt in
///    mm, altitude_msl_m; vehicle_global_position alt in m); time_s = timestamp / 1e6 (seconds
///    since PX4 booted); unix_time_s = (time_utc_usec - timestamp_time_relative) / 1e6 when
///    time_utc_usec is not 0. fix_type < 3 and latitude = longitude = 0 count in
///    no_fix_records;
///  - vehicle_attitude q (Hamilton w, x, y, z, body FRD to NED) as roll_deg, pitch_deg, yaw_deg
///    (3-2-1 Tait-Bryan angles, yaw in [0, 360) from north), and the height above home
///    home_position.z - vehicle_local_position.z (NED metres, as PX4's
///    GLOBAL_POSITION_INT.relative_alt) -> rel_alt_m when both are valid, interpolated onto
///    each GPS time as in ParseDataFlash;
///  - camera_capture (instance 0) -> camera_triggers: one per message whose result is not 0
///    (failed; a format without `result` keeps all): time_s = timestamp / 1e6 (the samples'
///    clock), lat/lon (has_fix false when NaN or both 0), alt -> abs_alt_m, timestamp_utc ->
///    unix_time_s (q, the gimbal's attitude on a gimbal, is not read); origin "<source> at byte
///    <offset>: camera_capture <seq>". A value out of range is a malformed record (strict/lenient).
/// Bytes that are not a message (a damaged log) are skipped up to the next message whose header
/// and payload are consistent and which is followed by another message (an 'S' sync message
/// among them), with a warning naming the byte offset and the count (whatever the mode); a cut
/// last message likewise. A file that does not start with the ULog magic throws InputError "not
/// a PX4 ULog"; a log with incompatible flag bits aerovo does not know throws InputError; a log
/// without a GPS message with a 3D fix throws InputError. Memory is bounded by the samples kept
/// (a 128 KiB read window; formats up to 8 MiB; attitude and height kept at most every 0.02 s).
TelemetryReadResult ParseULog(std::istream& in, const std::string& source_name,
                              const TelemetryReadOptions& options = {});
TelemetryReadResult ReadULog(const std::filesystem::path& path,
                             const TelemetryReadOptions& options = {});

/// Picks the reader by extension (case-insensitive): .srt, .gpx, .csv/.txt, .bin/.log
/// (DataFlash), .ulg (PX4 ULog), .tlog (MAVLink telemetry log). Another extension (or none): by
/// the content where it is unambiguous (a binary log's magic bytes, a .tlog record, a <gpx
/// element, SRT's counter and timing lines; never CSV), with a first warning saying so. Throws
/// InputError for a missing/unreadable file or a content of none of these formats.
TelemetryReadResult ReadTelemetryFile(const std::filesystem::path& path,
                                      const TelemetryReadOptions& options = {});

}  // namespace aerovo
