// Geo-referencing of the visual-odometry trajectory: local VO frame (metres, see pose_chain.h)
// -> East-North-Up (GeographicLib LocalCartesian, origin at the first GPS fix observed, see
// enu()) -> WGS84.
// No I/O: the caller feeds frame positions with whatever telemetry it has.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"

namespace aerovo {

/// Where the rotation between the local VO frame and East-North comes from.
enum class HeadingSource {
  /// Default: the first frame's camera yaw if telemetry gives one, else the GPS segment.
  kAuto,
  /// The first frame's camera (gimbal, else aircraft) yaw, compass degrees: the local +y axis
  /// (the first image's up) points along that bearing. Needs yaw on the first frame.
  kTelemetryYaw,
  /// Least-squares 2-D rotation aligning the first VO positions with the first GPS fixes,
  /// once both tracks have moved `min_segment_m` from their start.
  kGpsSegment,
};

const char* ToString(HeadingSource source);
/// Parses "auto" / "yaw" / "gps"; throws InvalidArgument otherwise.
HeadingSource ParseHeadingSource(const std::string& text);

struct GeoRefOptions {
  HeadingSource heading_source = HeadingSource::kAuto;
  /// kGpsSegment: both the GPS track and the VO track must have moved this far (metres) from
  /// their first position before the rotation is fixed. 30 m is ~10x typical consumer GPS
  /// noise (1-3 m), i.e. a heading error of a few degrees at most; also the bound on how many
  /// frames a streaming caller must buffer before it can write geographic positions.
  double min_segment_m = 30.0;
  /// Robust segment fit (kGpsSegment): after the least-squares fit, the fixes whose residual
  /// exceeds max(outlier_m, 5 x the residuals' robust sigma, 1.4826 x their median) are dropped
  /// and the fit repeated on the others. 0 = plain least squares over every fix. The run sets it
  /// to GpsCheckOptions::tolerance_m (gps_check.h): a fix that passed the plausibility check but
  /// still disagrees with the segment by more than GPS noise cannot steer the heading.
  double outlier_m = 0.0;
  /// kTelemetryYaw: the translation is that of the first fix when the first `yaw_fixes` fixes
  /// agree with it within outlier_m, else their component-wise median, so that one bad fix among
  /// them cannot shift the track (1 = the first fix alone, ready at once). The run sets it to
  /// GpsCheckOptions::min_chain (3).
  int yaw_fixes = 1;
};

/// Throws InvalidArgument naming the bad field.
void Validate(const GeoRefOptions& options);

/// Streaming estimator of enu_from_local (a 2-D rotation + translation, no scale: the VO
/// trajectory is metric) and its use. Frames are fed in order with Observe().
class GeoReferencer {
 public:
  /// `fix_altitudes_above_sea_level`: the GPS fixes' altitudes (GeoPoint::alt_m) are above sea
  /// level; false when the telemetry gives none (heights above the take-off point only, or no
  /// height: pipeline/run_steps.h GpsOf then puts those, or 0, in alt_m), so that the ENU
  /// origin's altitude, and every altitude derived from it, is not known (altitude_known()).
  explicit GeoReferencer(const GeoRefOptions& options = {},
                         bool fix_altitudes_above_sea_level = true);

  /// Feeds one frame: its camera position in the local VO frame (metres), its GPS fix if any,
  /// its camera yaw (compass degrees) if any. Returns ready().
  bool Observe(const Eigen::Vector2d& local_m, const std::optional<GeoPoint>& gps,
               std::optional<double> camera_yaw_deg);

  /// End of the flight before ready() (a GPS segment shorter than min_segment_m): fixes the
  /// rotation from whatever segment was observed (at least 2 fixes with some spread in both
  /// tracks). Returns ready().
  bool FixWithAvailable();

  /// Fixes enu_from_local from one absolute fix of a frame when GPS did not (a fix against a
  /// reference map, pipeline/map_fixer.h): `local_m` and `local_heading_rad` are the frame's
  /// local position (metres) and heading (angle of its image x axis counter-clockwise from local
  /// x), `at` the frame's WGS84 position and `enu_heading_rad` the same axis' angle
  /// counter-clockwise from east. The rotation is their difference, the translation puts
  /// `local_m` at `at`; the ENU origin stays the first GPS fix observed (if any), else `at`,
  /// whose altitude is then not known (altitude_known(): a map gives no height).
  /// heading_source_used() is "map". Precondition: !ready() (InvalidArgument otherwise).
  void SeedFromFix(const Eigen::Vector2d& local_m, double local_heading_rad, const GeoPoint& at,
                   double enu_heading_rad);

  /// Forgets the fixes observed so far (they were found to be outliers, gps_check.h) and the ENU
  /// origin they set: the following Observe() calls start a new segment, whose first fix is the
  /// new origin (a rejected fix is never the origin of the run's ENU frame). Precondition:
  /// !ready().
  void Restart();

  /// Fixes dropped by the robust segment fit (GeoRefOptions::outlier_m).
  int outliers() const { return outliers_; }
  /// As constructed.
  const GeoRefOptions& options() const { return options_; }
  bool fix_altitudes_above_sea_level() const { return fix_altitudes_above_sea_level_; }

  /// True once enu_from_local is known.
  bool ready() const { return ready_; }
  /// The ENU frame: origin = the first GPS fix observed since construction or the last
  /// Restart() (the run feeds only accepted fixes: the first accepted fix that was not
  /// superseded). Fixed once ready(). Precondition: has_enu().
  const LocalEnu& enu() const;
  bool has_enu() const { return enu_.has_value(); }
  /// True when the ENU origin is a GPS fix with an altitude above sea level, which the origin
  /// (and Wgs84FromLocal's alt_m) carries; false without an origin, when the fixes have no such
  /// altitude (fix_altitudes_above_sea_level()), or when SeedFromFix set it (a position from a
  /// map: its alt_m is 0, no altitude).
  bool altitude_known() const { return altitude_known_; }

  /// Rotation angle of enu_from_local, radians counter-clockwise (east towards north).
  double rotation_rad() const { return rotation_rad_; }
  /// "telemetry-yaw", "gps-segment" or "map" (SeedFromFix); empty until ready.
  const std::string& heading_source_used() const { return source_used_; }

  /// enu_from_local applied to a local VO position (metres). Precondition: ready().
  Eigen::Vector2d EnuFromLocal(const Eigen::Vector2d& local_m) const;
  /// The WGS84 position of a local VO position, at the ENU origin's height (0 when
  /// !altitude_known()). Precondition: ready().
  GeoPoint Wgs84FromLocal(const Eigen::Vector2d& local_m) const;
  /// Wgs84FromLocal as the run's tracks write it: alt_m NaN (not known, outputs/track_writers.h
  /// GeoTrackPoint) when !altitude_known(). Precondition: ready().
  GeoPoint TrackWgs84FromLocal(const Eigen::Vector2d& local_m) const;

 private:
  void FixFromSegment();
  void FixFromYaw();

  GeoRefOptions options_;
  bool fix_altitudes_above_sea_level_ = true;
  std::optional<LocalEnu> enu_;
  bool altitude_known_ = false;  // enu_ from a GPS fix (altitude_known())
  bool ready_ = false;
  bool first_frame_seen_ = false;
  std::optional<double> first_yaw_deg_;
  double rotation_rad_ = 0.0;
  Eigen::Vector2d translation_m_ = Eigen::Vector2d::Zero();
  std::string source_used_;
  // First frame with a fix: its local and ENU position; running sums for the segment fit.
  Eigen::Vector2d local0_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d enu0_ = Eigen::Vector2d::Zero();
  double sum_dot_ = 0.0, sum_cross_ = 0.0;
  Eigen::Vector2d sum_local_ = Eigen::Vector2d::Zero(), sum_enu_ = Eigen::Vector2d::Zero();
  int num_pairs_ = 0;
  bool have_pair0_ = false;
  // The segment's pairs (local, ENU), kept until ready for the robust fit.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> pairs_;
  int outliers_ = 0;
};

}  // namespace aerovo
