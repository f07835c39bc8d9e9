// Writing DJI-style SRT telemetry (the subtitle track of DJI videos), as the simulator does and
// as the SRT reader (telemetry_readers.h) reads it back.
#pragma once

#include <optional>
#include <string>

#include "aerovo/geo/geo_point.h"

namespace aerovo {

/// One subtitle entry, in the current bracketed format of DJI Mini/Air/Mavic 3 videos:
///   1
///   00:00:00,000 --> 00:00:00,033
///   <font size="28">FrameCnt: 1, DiffTime: 33ms
///   2026-05-01 10:00:00.000
///   [iso: 100] [shutter: 1/1000.0] [fnum: 2.8] [ev: 0] [color_md: default] [focal_len: 25.16]
///   [latitude: 43.539340] [longitude: 6.551628] [rel_alt: 100.000 abs_alt: 400.000] [ct: 5500]
///   </font>
/// (the bracketed fields on one line), then a blank line. The exposure fields are fixed values.
struct DjiSrtEntry {
  int index = 1;         ///< 1-based entry number (= FrameCnt).
  double start_s = 0.0;  ///< Subtitle interval, seconds from the video start (ms precision).
  double end_s = 0.0;
  int diff_ms = 0;        ///< DiffTime: milliseconds between frames.
  std::string date_time;  ///< "YYYY-MM-DD HH:MM:SS.mmm" as DJI writes it (local clock).
  /// focal_len: 35 mm-equivalent focal length (EXIF diagonal convention, camera/pinhole.h),
  /// written with 2 decimals.
  double focal_35mm_mm = 0.0;
  GeoPoint position;       ///< latitude, longitude (6 decimals) and abs_alt (m above MSL).
  double rel_alt_m = 0.0;  ///< rel_alt: height above the take-off point (m).
  /// Gimbal pitch and roll (degrees, -90 = nadir; pipeline/run_steps.h CameraAttitudeOf reads
  /// them): when set, "[gb_pitch: -75.0 gb_roll: 3.2] " follows the altitudes (1 decimal, as DJI
  /// writes them). Unset: no gimbal field (a nadir flight's entries as before).
  std::optional<double> gimbal_pitch_deg, gimbal_roll_deg;
};

/// The text of `entry` (see DjiSrtEntry), ending with the blank line that separates entries.
std::string FormatDjiSrtEntry(const DjiSrtEntry& entry);

/// SRT time stamp "HH:MM:SS,mmm" of `t_s` seconds (rounded to the millisecond).
std::string SrtTimestamp(double t_s);

}  // namespace aerovo
