// One row of a run's per-frame log: where the camera was and what each pipeline stage did.
// Filled by the odometry pipeline, written by outputs/track_writers.h (frames.csv, TUM, GeoJSON,
// KML, GPX).
#pragma once

#include <limits>
#include <optional>
#include <string>

#include "aerovo/geo/geo_point.h"

namespace aerovo {

/// FrameRecord::gps_flag of a fix withheld from the run by GPS denial (RunConfig::
/// gps_denied_after_s): a GPS position for the comparison, in the gps.* tracks, used for nothing else.
inline constexpr const char* kGpsFlagWithheld = "withheld";

/// Per-frame record. Positions are the camera centre in the run's local East-North-Up frame
/// (metres; x = east, y = north, z = up), and in WGS84 when the track is geo-referenced.
struct FrameRecord {
  int frame = 0;        ///< 0-based index of the frame in the source (video frame / photo).
  double time_s = 0.0;  ///< Seconds from the start of the source.
  double x_m = 0.0;     ///< East, metres.
  double y_m = 0.0;     ///< North, metres.
  double z_m = 0.0;     ///< Up, metres (TUM tz; not a CSV column).
  /// Heading of the image x axis in ENU, radians counter-clockwise from east (TUM
  /// orientation, a rotation about z; not a CSV column).
  double yaw_rad = 0.0;
  /// WGS84 position (CSV lat_deg, lon_deg, alt_m; empty cells when absent). Absent when the
  /// track is not geo-referenced; GeoJSON/KML/GPX VO tracks only contain frames that have it.
  /// alt_m NaN: the altitude is not known (an empty alt_m cell; track_writers.h GeoTrackPoint).
  std::optional<GeoPoint> geo;
  int n_surf = 0;              ///< SURF keypoints detected in this frame.
  int n_matched = 0;           ///< Putative matches with the previous frame.
  int n_inliers = 0;           ///< RANSAC inliers of the accepted transform.
  int cluster = -1;            ///< Cluster used by clustered RANSAC; -1 = none / standard RANSAC.
  double detect_ms = 0.0;      ///< Keypoint detection time, ms.
  double describe_ms = 0.0;    ///< Descriptor time, ms.
  double correspond_ms = 0.0;  ///< Matching time, ms.
  double estimate_ms = 0.0;    ///< Transform estimation (RANSAC) time, ms.
  double total_ms = 0.0;       ///< Whole frame, ms.
  /// Capture-to-send latency, ms: from the moment the source delivered the frame
  /// (Frame::received_s) to the moment its local pose was sent (the pose stream written, the
  /// frame handed to the outputs); includes the wait in the decode queue. NaN = not measured
  /// (empty CSV cell; column latency_ms, the last).
  double latency_ms = std::numeric_limits<double>::quiet_NaN();
  /// Outcome of the frame, e.g. "ok", "bridged", "dark" (free text written as is; quoted in
  /// the CSV when it contains a comma, quote or newline).
  std::string status = "ok";
  /// The frame's GPS fix (gps_* CSV cells) failed the plausibility check and is used neither for
  /// the geo-referencing nor for the comparison with GPS: "rejected:speed", "rejected:altitude",
  /// "rejected:vo" (a jump the visual odometry does not show) or "rejected:superseded" (outvoted
  /// by the later fixes); "withheld" (kGpsFlagWithheld): GPS denial (pipeline/run_config.h
  /// gps_denied_after_s), the fix is kept only for the comparison with GPS; "" when the fix is
  /// used or there is none (odometry/gps_check.h).
  std::string gps_flag;
  /// Height above ground used for the frame, metres (CSV height_m; 0 when not known).
  double height_m = 0.0;
  /// Where that height came from (CSV height_source): pipeline/run_types.h FrameHeightSource
  /// ("altitude_flag", "telemetry", "first_record", "last_known", "mavlink_distance_sensor",
  /// ...; docs/attitude.md); "" when unknown.
  std::string height_source;
  /// The autopilot's attitude at the frame (MAVLink ATTITUDE), degrees (CSV roll_deg,
  /// pitch_deg; empty cells when absent).
  std::optional<double> roll_deg, pitch_deg;
  /// The camera attitude the odometry applied to the frame's keypoints (the virtual nadir
  /// camera, odometry/attitude.h CameraAttitude: aerospace Z-Y-X roll and pitch of the camera's
  /// FRD axes from level, yaw dropped), degrees (CSV camera_roll_deg, camera_pitch_deg; empty
  /// cells when none was applied). What a later reader of the run folder (the mosaic, `aerovo
  /// map build`) needs to draw the frame as the odometry saw it.
  std::optional<double> camera_roll_deg, camera_pitch_deg;
};

/// Throws InvalidArgument naming the frame when a number is not finite, frame < 0, or geo is
/// set but invalid (latitude outside [-90, 90]).
void Validate(const FrameRecord& record);

}  // namespace aerovo
