// Plausibility of GPS fixes, frame by frame: a fix that implies an impossible speed or jump
// against the last accepted fix (horizontally or vertically), or a jump the camera's own motion
// (the visual odometry) does not show, is rejected, so that it never reaches the
// geo-referencing (georef.h) nor the comparison with GPS. No I/O: the caller reports.
//
// Which fixes are "the good ones" is decided by their mutual consistency: fixes are compared
// with the last accepted fix (the anchor chain); rejected fixes that agree with one another form
// a challenger chain, which replaces the anchor chain when it has become longer than it and
// at least `min_chain` fixes long (a bad FIRST fix, or a position that was wrong from the start
// and then jumped to the truth). A spike, a run of bad fixes shorter than what came before, a
// step (a jump that stays) after the first fixes: rejected, the anchor chain wins.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "aerovo/core/options.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"

namespace aerovo {

struct GpsCheckOptions {
  /// Off: every fix is accepted (the behaviour before these checks existed).
  bool enabled = true;
  /// Largest plausible horizontal ground speed, m/s. 40 m/s = 144 km/h: above the top speed of
  /// consumer multirotors (DJI spec sheets: Mavic 3 21 m/s, Phantom 4 20 m/s).
  double max_speed_mps = 40.0;
  /// Largest plausible vertical speed, m/s (DJI spec sheets: 6-8 m/s climb, 6 m/s descent).
  double max_vertical_speed_mps = 15.0;
  /// Jump always allowed on top of the speed limits, metres: consumer GPS noise is 1-3 m (the
  /// figure georef.h's min_segment_m rests on), so 10 m is 3-10 sigma of it.
  double tolerance_m = 10.0;
  /// Against the visual odometry: the horizontal jump between two fixes may be at most
  /// vo_ratio x the camera's motion between them (plus tolerance_m). 3 allows a VO scale error
  /// of 3x (a height 3x off) before a sound fix is rejected. 0 = no check against the VO.
  double vo_ratio = 3.0;
  /// Rejected fixes that agree with one another replace the accepted ones once they are this
  /// many and more numerous than them.
  int min_chain = 3;
};

/// Throws InvalidArgument naming the bad field.
void Validate(const GpsCheckOptions& options);

// clang-format off
template <class V>
void VisitFields(GpsCheckOptions& o, V& v) {
  using namespace options;
  v.Field(o.enabled, "enabled", "Reject GPS fixes that imply an impossible speed or jump (against their neighbours and the VO motion)", Any());
  v.Field(o.max_speed_mps, "max_speed_mps", "Largest plausible horizontal speed, m/s", GreaterThan(0).Finite());
  v.Field(o.max_vertical_speed_mps, "max_vertical_speed_mps", "Largest plausible vertical speed, m/s", GreaterThan(0).Finite());
  v.Field(o.tolerance_m, "tolerance_m", "Jump always allowed on top of the speed limits (GPS noise), m", AtLeast(0).Finite());
  v.Field(o.vo_ratio, "vo_ratio", "A fix may jump at most this times the camera's VO motion (+ tolerance_m); 0 = no VO check", AtLeast(0).Finite());
  v.Field(o.min_chain, "min_chain", "Consistent rejected fixes that replace the accepted ones when more numerous", Interval(1, 1000000));
}
// clang-format on

/// The verdict on one fix.
struct GpsFixVerdict {
  bool accepted = true;
  /// "speed", "altitude" or "vo" (a jump the camera's motion does not show) when rejected; ""
  /// when accepted.
  std::string kind;
  /// What is wrong, e.g. "jumps 1112.0 m in 1.00 s (1112 m/s; limit 40 m/s)".
  std::string reason;
  /// The challenger chain replaced the anchor chain with this fix: the fixes of `superseded`
  /// (accepted before) are now rejected, those of `reinstated` (rejected before, the earlier
  /// fixes of the challenger chain, in order) are now accepted.
  bool switched = false;
  std::vector<int> superseded;  ///< Frame indices.
  struct Reinstated {
    int frame = 0;
    double time_s = 0.0;
    GeoPoint gps;
    Eigen::Vector2d local_m = Eigen::Vector2d::Zero();
  };
  std::vector<Reinstated> reinstated;
};

/// Streaming checker: one Check() per frame with a fix, in frame order. Per fix: a few
/// comparisons, no allocation except the growth of the chains' frame lists.
class GpsFixChecker {
 public:
  explicit GpsFixChecker(const GpsCheckOptions& options = {});

  /// The fix `gps` (alt_m: its altitude, metres) and relative altitude `rel_alt_m` (if any) of
  /// frame `frame_index` at `time_s` (seconds, the frames' clock); `local_m`: the camera
  /// position in the local VO frame (metres); `unmeasured_frames`: how many frames since the
  /// start had no measured VO step (bridged): between two fixes with different counts the VO
  /// motion is not trusted and only the speed limits apply.
  GpsFixVerdict Check(int frame_index, double time_s, const GeoPoint& gps,
                      std::optional<double> rel_alt_m, const Eigen::Vector2d& local_m,
                      int unmeasured_frames);

  /// The relative altitude (metres) to take for the height above ground of the frame at
  /// `time_s` (seconds, the frames' clock) whose telemetry gives `rel_alt_m`: `rel_alt_m`, or
  /// `last_height_m` (the height used for the frame before, metres) when the check is enabled
  /// and the change since the last plausible relative altitude exceeds tolerance_m +
  /// max_vertical_speed_mps x the time since it (at least 1 ms): such a jump would scale the
  /// visual odometry's step (the fix itself is judged by Check). A plausible positive
  /// `rel_alt_m` becomes the last plausible one. One call per frame with a relative altitude, in
  /// frame order.
  double PlausibleRelAlt(double time_s, double rel_alt_m, std::optional<double> last_height_m);

  const GpsCheckOptions& options() const { return options_; }

 private:
  struct Fix {
    int frame = 0;
    double time_s = 0.0;
    GeoPoint gps;
    Eigen::Vector3d enu = Eigen::Vector3d::Zero();
    std::optional<double> rel_alt_m;
    Eigen::Vector2d local = Eigen::Vector2d::Zero();
    int unmeasured = 0;
  };
  // "" when `b` is plausible after `a`; else the kind, with the reason in *reason.
  std::string Compare(const Fix& a, const Fix& b, std::string* reason) const;

  GpsCheckOptions options_;
  // Centred on the first fix, then on the first fix of the chain that replaced the anchor chain.
  std::optional<LocalEnu> enu_;
  std::optional<Fix> anchor_;
  std::vector<int> anchor_chain_;  // frames of the accepted chain (since the last switch)
  std::vector<Fix> challenger_;    // consecutive mutually consistent rejected fixes
  std::optional<double> last_rel_alt_time_s_;  // frame time of the last plausible rel. altitude
};

}  // namespace aerovo
