// Trajectory evaluation in the horizontal plane: 2-D Umeyama alignment (SE(2) / Sim(2)),
// absolute trajectory error, end-point drift, relative error over fixed segment lengths, and
// association of reference fixes (GPS) with estimated poses (visual odometry) by time.
// Conventions: docs/method.md, "Trajectory evaluation". Everything here
// is pure math on plain structs (no file I/O). Units: seconds and metres; both trajectories
// are expected in the same local metric frame (ENU east = x, north = y, see geo/local_enu.h).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

namespace aerovo {

/// One timestamped horizontal position: t in seconds (any epoch, consistent within a run),
/// x and y in metres (x = east, y = north when the frame is ENU).
struct TrajectoryPoint2D {
  double t = 0.0;
  double x = 0.0;
  double y = 0.0;
};

/// A 2-D similarity transform p_to = scale * R(angle_rad) * p_from + translation_m, with
/// R(a) = [cos a, -sin a; sin a, cos a] (counter-clockwise, radians). scale = 1 is a rigid
/// SE(2) motion.
struct Similarity2D {
  double angle_rad = 0.0;
  double scale = 1.0;
  Eigen::Vector2d translation_m = Eigen::Vector2d::Zero();

  Eigen::Matrix2d Rotation() const;
  Eigen::Vector2d Apply(const Eigen::Vector2d& p) const;
  /// The 3x3 homogeneous matrix [sR t; 0 0 1].
  Eigen::Matrix3d Matrix() const;
};

/// Which transform group the alignment may use.
enum class AlignmentModel {
  kSE2,   ///< Rotation + translation; the estimate's scale is trusted (metric scale known from
          ///< altitude and camera focal length).
  kSim2,  ///< Rotation + translation + uniform scale.
};

/// Result of aligning an estimated trajectory (VO) to a reference (GPS in ENU).
struct AlignmentResult {
  AlignmentModel model = AlignmentModel::kSE2;
  /// Maps estimate coordinates into the reference frame: enu_p = enu_from_vo.Apply(vo_p).
  /// Least-squares optimal (Umeyama 1991, restricted to proper rotations); scale = 1 for SE(2).
  Similarity2D enu_from_vo;
  int num_points = 0;   ///< Number of point pairs used.
  double rmse_m = 0.0;  ///< RMS distance between aligned estimate and reference, metres.
};

/// Closed-form least-squares alignment of point pairs (estimate[i] <-> reference[i]; only x
/// and y are used, t is ignored): minimises sum |reference_i - T(estimate_i)|^2 over T in
/// SE(2) or Sim(2) (Umeyama, IEEE TPAMI 13(4), 1991; in 2-D the optimal angle is
/// atan2(sum x'_i cross y'_i, sum x'_i . y'_i) over centred points, and the Sim(2) scale is
/// the ratio of that correlation's magnitude to the estimate's spread).
/// Throws InvalidArgument when the sizes differ, fewer than 2 pairs are given, a coordinate is
/// not finite, or the configuration is degenerate (all estimate points coincide, or the
/// centred point sets are uncorrelated so no rotation is defined).
AlignmentResult AlignUmeyama2D(const std::vector<TrajectoryPoint2D>& estimate,
                               const std::vector<TrajectoryPoint2D>& reference,
                               AlignmentModel model);

/// Summary statistics of a set of non-negative errors (metres, or per cent for drift).
/// All zero when count == 0.
struct TrajectoryErrorStats {
  int count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;  ///< Mean of the two middle values when count is even.
  double max = 0.0;
};

/// Statistics of `errors` (taken by value: the median partially sorts a copy).
TrajectoryErrorStats SummarizeErrors(std::vector<double> errors);

/// Relative (drift) error over one segment length, in the style of KITTI's odometry metric but
/// in 2-D on positions only: for every start pose i, the end pose j is the first one at which
/// the reference path length from i reaches `length_m`; the error is
/// |(A e_j - A e_i) - (r_j - r_i)| with A the alignment of the evaluation (the global
/// rotation/scale; translation cancels), and the drift is that error over the reference path
/// length from i to j, in per cent.
struct SegmentErrors {
  double length_m = 0.0;         ///< Requested segment length (reference path length), metres.
  TrajectoryErrorStats error_m;  ///< Statistics of the segment end-point errors, metres.
  TrajectoryErrorStats drift_percent;  ///< Statistics of the error / segment path length * 100.
};

/// Options of EvaluateTrajectory. Defaults: SE(2) alignment (aerovo takes the metric scale from
/// altitude and focal length, docs/method.md "Trajectory evaluation"), segments of 10, 50 and
/// 100 m (the project's reference flights are 0.3 to 2 km long, so 100 m still gives many
/// segments).
struct TrajectoryEvalOptions {
  AlignmentModel model = AlignmentModel::kSE2;
  /// Segment lengths for the relative error, metres, each > 0. Lengths longer than the
  /// reference path give a SegmentErrors with count 0.
  std::vector<double> segment_lengths_m = {10.0, 50.0, 100.0};
};

/// Throws InvalidArgument naming the offending field.
void Validate(const TrajectoryEvalOptions& options);

/// All error figures of one estimated trajectory against its reference (plain, by value).
struct TrajectoryErrors {
  AlignmentResult alignment;
  /// Absolute trajectory error after alignment: distances |reference_i - T(estimate_i)|, m.
  TrajectoryErrorStats ate_m;
  std::vector<double> ate_per_point_m;  ///< Same order as the input pairs.
  /// Path length of the reference (sum of distances between consecutive reference points),
  /// metres: "the distance flown". GPS noise lengthens it slightly.
  double distance_flown_m = 0.0;
  /// Error at the last pair after alignment, metres, and as a percentage of distance_flown_m.
  double end_point_error_m = 0.0;
  double end_point_error_percent = 0.0;
  /// Error at the last pair with no alignment (the estimate as given, e.g. a VO track
  /// geo-referenced at the first fix with a telemetry heading), metres and per cent.
  double end_point_error_unaligned_m = 0.0;
  double end_point_error_unaligned_percent = 0.0;
  std::vector<SegmentErrors> segments;  ///< One per options.segment_lengths_m, same order.
};

/// Aligns `estimate` to `reference` (pairs by index, as produced by AssociateByTime) and
/// computes all errors. Throws InvalidArgument as AlignUmeyama2D does, or for invalid options.
/// Percentages are 0 when the reference path length is 0.
TrajectoryErrors EvaluateTrajectory(const std::vector<TrajectoryPoint2D>& estimate,
                                    const std::vector<TrajectoryPoint2D>& reference,
                                    const TrajectoryEvalOptions& options = {});

/// SE(2) and Sim(2) evaluations side by side (Sim(2) is always reported beside the primary
/// SE(2) figures: it shows what the track's shape is worth whatever its scale).
struct TrajectoryComparison {
  TrajectoryErrors se2;
  TrajectoryErrors sim2;
};

/// EvaluateTrajectory with options.model = kSE2 and with kSim2; `options.model` is ignored.
TrajectoryComparison CompareTrajectories(const std::vector<TrajectoryPoint2D>& estimate,
                                         const std::vector<TrajectoryPoint2D>& reference,
                                         const TrajectoryEvalOptions& options = {});

/// How reference fixes are matched to estimate timestamps.
enum class AssociationMethod {
  kNearest,      ///< The reference fix nearest in time, if within max_time_difference_s.
  kInterpolate,  ///< Linear interpolation between the two fixes bracketing the time, if they
                 ///< are at most max_gap_s apart; an exact time match is used as is.
};

/// Options of AssociateByTime. Defaults: interpolation (GPS at 1-10 Hz vs video at 25-30 fps,
/// so nearest-fix would add up to half a fix interval of motion, ~2.5 m at 10 m/s and 1 Hz),
/// tolerating fix gaps up to 2 s (DJI SRT/flight logs give 1-10 Hz; a longer gap is a dropout
/// that should not be bridged by a straight line); nearest-fix tolerance 0.1 s.
struct AssociationOptions {
  AssociationMethod method = AssociationMethod::kInterpolate;
  double max_time_difference_s = 0.1;  ///< kNearest: maximum |t_estimate - t_fix|, s, >= 0.
  double max_gap_s = 2.0;              ///< kInterpolate: maximum bracketing fix interval, s, > 0.
};

/// Throws InvalidArgument naming the offending field.
void Validate(const AssociationOptions& options);

/// Pairs of estimate and reference points matched by time, ready for EvaluateTrajectory.
struct AssociatedTrajectories {
  std::vector<TrajectoryPoint2D> estimate;   ///< Matched estimate points (input order).
  std::vector<TrajectoryPoint2D> reference;  ///< Reference at each estimate time (t = the
                                             ///< estimate's t when interpolated, the fix's t
                                             ///< for kNearest).
  std::vector<int> estimate_index;           ///< Index in the input estimate of each pair.
  std::vector<int> reference_index;          ///< kNearest: the fix used; kInterpolate: the earlier
                                             ///< bracketing fix.
  int num_unmatched = 0;                     ///< Estimate points left without a reference.
};

/// Matches every estimate point (any order) with the reference trajectory (sorted by
/// non-decreasing t; duplicate times keep the first fix) by time. Throws InvalidArgument when
/// the reference times decrease (naming the index), a time or coordinate is not finite, or
/// the options are invalid.
AssociatedTrajectories AssociateByTime(const std::vector<TrajectoryPoint2D>& estimate,
                                       const std::vector<TrajectoryPoint2D>& reference,
                                       const AssociationOptions& options = {});

/// Path length of a trajectory (sum of consecutive point distances), metres.
double PathLength(const std::vector<TrajectoryPoint2D>& trajectory);

/// Whether an estimate fits its reference as a mirror image: a Sim(2) alignment can rotate and
/// scale but never reflect, so an estimate mirrored against its reference (latitude and
/// longitude swapped in the telemetry, a mirrored camera image) leaves errors of the order of
/// the track itself, which the same alignment of the reflected estimate (x, -y) removes.
struct MirrorCheck {
  double rmse_m = 0.0;           ///< Sim(2) alignment RMSE of the estimate as given, metres.
  double mirrored_rmse_m = 0.0;  ///< The same for the reflected estimate, metres.
  /// RMS distance of the reference points from their centroid, metres: the track's size.
  double spread_m = 0.0;
  /// Square root of the ratio of the reference's smaller to larger principal variance: 0 for a
  /// straight line (which its reflection fits as well), 1 for a round or square track.
  double aspect = 0.0;
  /// mirrored_rmse_m < rmse_m / 2, rmse_m > spread_m / 10 (the track is wrong by a tenth of its
  /// size), and aspect >= 0.2 (a track wide enough for its reflection to differ).
  bool mirrored = false;
};

/// MirrorCheck of estimate/reference pairs (as AlignUmeyama2D); nullopt when either alignment
/// is undefined (degenerate point sets).
std::optional<MirrorCheck> CheckMirrored(const std::vector<TrajectoryPoint2D>& estimate,
                                         const std::vector<TrajectoryPoint2D>& reference);

}  // namespace aerovo
