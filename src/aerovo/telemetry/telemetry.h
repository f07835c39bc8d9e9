// Telemetry of a flight (GPS position, altitudes, attitude, focal length) as a time series,
// whatever file it came from (DJI .SRT, GPX, CSV, EXIF/XMP of photos), and its association
// with frames by time or by frame index.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace aerovo {

/// One telemetry fix. Angles in degrees, lengths in metres, times in seconds.
struct TelemetrySample {
  /// Seconds from the start of the source: the video time for DJI SRT (subtitle start), the
  /// time since the first point for GPX, CSV dates and photos, the value as written for CSV
  /// times given in seconds.
  double time_s = 0.0;
  /// Absolute time (seconds since 1970-01-01T00:00:00Z) when the source gives a date. DJI SRT
  /// dates and EXIF dates are the drone's local clock with no zone; they are stored as if UTC.
  std::optional<double> unix_time_s;
  /// 0-based index of the video frame / photo this fix belongs to, when the source says so
  /// (DJI SRT: FrameCnt - 1 or subtitle number - 1; CSV: the frame column; photos: their rank).
  std::optional<int> frame_index;
  /// false: the record gives no position (DJI writes "N/A" or latitude = longitude = 0 until
  /// the receiver has a fix); lat_deg and lon_deg are then 0 and mean nothing, while the
  /// heights, angles and focal lengths of the record are kept.
  bool has_fix = true;
  double lat_deg = 0.0;             ///< WGS84 latitude, [-90, 90] (0 without a fix).
  double lon_deg = 0.0;             ///< WGS84 longitude, [-180, 180] (0 without a fix).
  std::optional<double> abs_alt_m;  ///< Altitude above sea level / ellipsoid as the source says.
  std::optional<double> rel_alt_m;  ///< Height above the take-off point (DJI relative altitude).
  /// Aircraft heading, degrees clockwise from north (DJI FlightYawDegree, CSV yaw/heading).
  std::optional<double> yaw_deg;
  std::optional<double> pitch_deg;  ///< Aircraft pitch (DJI FlightPitchDegree).
  std::optional<double> roll_deg;   ///< Aircraft roll (DJI FlightRollDegree).
  /// Gimbal (camera) yaw, degrees clockwise from north (DJI GimbalYawDegree, SRT gb_yaw).
  std::optional<double> gimbal_yaw_deg;
  std::optional<double> gimbal_pitch_deg;  ///< -90 = nadir (DJI GimbalPitchDegree, gb_pitch).
  std::optional<double> gimbal_roll_deg;
  std::optional<double> focal_length_mm;       ///< Real focal length (EXIF FocalLength).
  std::optional<double> focal_length_35mm_mm;  ///< 35 mm equivalent (EXIF, SRT focal_len).
  /// Where the sample was read, for messages: "<file>:<line>" of its record (SRT, GPX, CSV) or
  /// the photo's path; "between A and B" when interpolated; empty when unknown.
  std::string origin;

  /// The heading of the camera: gimbal yaw when known, else aircraft yaw.
  std::optional<double> CameraYawDeg() const { return gimbal_yaw_deg ? gimbal_yaw_deg : yaw_deg; }
};

/// Throws InputError (prefix `where`) when a value is out of range or not finite: latitude
/// outside [-90, 90], longitude outside [-180, 180], a time or altitude that is NaN/inf,
/// |altitude| > 100 km, angles outside [-360, 360], focal lengths <= 0 or > 10 m.
void ValidateSample(const TelemetrySample& sample, const std::string& where);

/// A time-ordered telemetry series. Samples are sorted by time_s (stable: equal times keep
/// their file order). Lookups never extrapolate: outside the covered time span (beyond a
/// tolerance) they return nothing, so "fewer fixes than frames" shows up as missing fixes and
/// never as invented positions.
class Telemetry {
 public:
  Telemetry() = default;
  /// Sorts the samples by time. `source` names where they came from (used in messages).
  explicit Telemetry(std::vector<TelemetrySample> samples, std::string source = {});

  const std::vector<TelemetrySample>& samples() const { return samples_; }
  const std::string& source() const { return source_; }
  std::size_t size() const { return samples_.size(); }
  bool empty() const { return samples_.empty(); }
  const TelemetrySample& operator[](std::size_t i) const { return samples_[i]; }
  double start_time_s() const;  ///< time_s of the first sample (0 when empty).
  double end_time_s() const;    ///< time_s of the last sample (0 when empty).

  /// The fix at `time_s`: linear interpolation between the two samples around it (latitude,
  /// longitude, altitudes, focal lengths linear; angles along the shorter arc; longitude
  /// unwrapped across +-180). Optional fields are interpolated when both neighbours have
  /// them, else taken from the nearer neighbour. frame_index is kept only on an exact hit.
  /// Between a sample with a fix and one without (has_fix), the result has no fix; `origin`
  /// is "between A and B".
  /// Outside [start - tolerance_s, end + tolerance_s] -> nullopt; inside the tolerance band the
  /// end sample is returned unchanged (time_s set to the query).
  std::optional<TelemetrySample> Lookup(double time_s, double tolerance_s = 0.0) const;

  /// The fix of frame `frame_index`: the sample carrying that index if there is one, else
  /// interpolation between the nearest samples with smaller and larger indices (by index).
  /// nullopt when the index is outside the indexed range or no sample has a frame index.
  std::optional<TelemetrySample> AtFrame(int frame_index) const;

  /// True when at least one sample carries a frame index.
  bool HasFrameIndices() const;

  /// The fix at an absolute time (seconds since 1970), for matching photos or a video of known
  /// start to a GPX/CSV track: Lookup(unix_time_s - (u0 - t0)) where (u0, t0) are the unix and
  /// source times of the first sample that has a unix time. nullopt when no sample has one.
  /// Precondition: the samples' unix times and time_s differ by a constant (true for GPX, CSV
  /// dates and photos; for DJI SRT the date lines follow the video time to within the drone
  /// clock's jitter).
  std::optional<TelemetrySample> LookupUnix(double unix_time_s, double tolerance_s = 0.0) const;

  /// The fix of a delivered frame. kAuto: by frame index when the telemetry has frame indices
  /// (DJI SRT with FrameCnt, CSV with a frame column, photo metadata), else by time. By time,
  /// the telemetry time looked up is frame_time_s + time_offset_s (time_offset_s = telemetry
  /// time at the frame time 0, e.g. when a GPX track starts before the video).
  enum class Match { kAuto, kByFrameIndex, kByTime };
  std::optional<TelemetrySample> ForFrame(int frame_index, double frame_time_s,
                                          Match how = Match::kAuto, double time_offset_s = 0.0,
                                          double tolerance_s = 0.0) const;

 private:
  std::vector<TelemetrySample> samples_;
  std::string source_;
  std::vector<std::pair<int, std::size_t>> by_frame_;  ///< (frame_index, sample), sorted.
};

/// Interpolates between a (weight 1 - w) and b (weight w), w in [0, 1]; see Telemetry::Lookup.
TelemetrySample InterpolateSamples(const TelemetrySample& a, const TelemetrySample& b, double w);

/// A run of records that share one time: a clock coarser than the records (a date with whole
/// seconds on a 10 Hz log, photos taken within a second without EXIF SubSecTimeOriginal).
struct RepeatedTimeRun {
  std::size_t first = 0;  ///< Index of the run's first record.
  std::size_t count = 0;  ///< Records in the run (>= 2).
  double time_s = 0.0;    ///< The time they share.
  /// The interval the run is spread over, seconds: the gap to the next distinct time, at most
  /// the clock's step (the median gap between consecutive distinct times), that step for the
  /// last run. 0 when every record has the same time (no step is known).
  double step_s = 0.0;
};

/// The runs of equal consecutive times in `times_s` (seconds; meant for non-decreasing times:
/// a time that goes back counts for no step).
std::vector<RepeatedTimeRun> RepeatedTimeRuns(const std::vector<double>& times_s);

/// The time of record k of a run (0 <= k < count) spread evenly over the run's interval:
/// time_s + k * step_s / count. The records of a truncating clock lie anywhere in
/// [time_s, time_s + step): evenly spread, each is at most one record interval from its true
/// time (a constant record rate assumed) instead of up to a whole step, and time still never
/// goes back.
inline double SpreadTime(const RepeatedTimeRun& run, std::size_t k) {
  return run.time_s + static_cast<double>(k) * run.step_s / static_cast<double>(run.count);
}

}  // namespace aerovo
