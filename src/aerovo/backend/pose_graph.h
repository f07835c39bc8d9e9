// The estimation back-end: a graph of frame poses on the ground plane, each a 2D similarity
// `local_from_frame` (similarity2.h: position in metres in the local metric/ENU frame, heading,
// log-scale), tied by
// - relative factors: a frame pair's fitted transform `prev_from_curr` (the pose of frame
//   `curr` in frame `prev`'s coordinates) with the 4x4 information matrix of the fit;
// - absolute factors: a fix of one frame's position (a GPS fix the run trusts, a fix against a
//   geo-referenced map), optionally its heading and log-scale, with its information matrix; a
//   prior is an absolute factor of all four components;
// and solved for the poses that minimise the robust sum of squared Mahalanobis residuals.
// No I/O: the graph and the options come in, a plain result goes out by value.
//
// Residuals, in the order (x, y, heading, log-scale), for poses T_i = local_from_i:
//   relative i -> j, measurement z = prev_from_curr:
//     r = (exp(-s_i) R(-a_i) (t_j - t_i) - t_z,  wrap(a_j - a_i - a_z),  s_j - s_i - s_z)
//     (the translation error in frame i's coordinates, as g2o's SE(2) edge does: R. Kuemmerle
//     et al., "g2o: A General Framework for Graph Optimization", ICRA 2011; with the scale added);
//   absolute on i, measurement z = local_from_frame:
//     r = (t_i - t_z,  wrap(a_i - a_z),  s_i - s_z), the components not measured left out.
// Cost: 1/2 sum_k rho(r_k' Omega_k r_k), rho the robust kernel of the options (Huber: P. J.
// Huber, "Robust estimation of a location parameter", Ann. Math. Statist. 35(1), 1964; Cauchy,
// or Lorentzian: the table of M-estimators in Z. Zhang, "Parameter estimation techniques: a
// tutorial with application to conic fitting", Image and Vision Computing 15(1), 1997), applied
// to the whitened residual norm e = sqrt(r' Omega r) with the scale in standard deviations.
//
// Solver: Levenberg-Marquardt (K. Madsen, H. B. Nielsen, O. Tingleff, "Methods for non-linear
// least squares problems", IMM DTU 2004, sec. 3.2: Marquardt's diagonal scaling, Nielsen's
// damping update) on the iteratively re-weighted normal equations (the kernel's weight
// rho'(e^2) per factor), with analytic Jacobians, the sparse normal matrix (4x4 blocks) and
// Eigen's SimplicialLDLT (sparse LDL' with an AMD fill-reducing ordering computed once per
// problem). Why Eigen and not Ceres Solver or g2o: Eigen is already the core's one linear-algebra
// dependency and is all the aarch64 cross build needs (AEROVO_CORE_ONLY, scripts/test-aarch64.sh);
// the problem has one fixed structure (4 parameters per pose, residuals of 4, Jacobians written
// out), so a general solver's automatic differentiation and parameter blocks of any size are not
// needed. What Ceres would add here is a supernodal sparse Cholesky (SuiteSparse's CHOLMOD),
// which would pay on the largest graphs, where Eigen's simplicial factorisation is most of the
// time (BENCHMARKS.md, "Pose-graph back-end", has the solve times); Ceres is not installed and
// would be a new dependency of every build, the cross build's included.
//
// Incremental use: OptimizeWindow solves for the poses of an index range only; every other pose
// a factor of the window touches is held at its current estimate (a fixed prior: the old poses
// are conditioned on, not marginalised with their covariance, so the window does not feed back
// the information of factors outside it; the poses out of the window are final for the live
// stream). OptimizeAll solves for every pose (the offline whole-flight optimisation).
//
// Gauge: relative factors alone leave the graph's placement, heading and scale free. When the
// factors of a solve touch no held pose (PoseGraph::SetHeld, or a pose outside the window) and
// include no absolute factor, the first free pose is held at its estimate (reported as
// gauge_pose). A graph that is otherwise under-determined (one absolute position fix and no
// heading) keeps the undetermined directions near their initial estimate through the damping.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "aerovo/backend/similarity2.h"
#include "aerovo/core/options.h"

namespace aerovo::backend {

/// The robust kernel applied to each factor's whitened residual norm e.
enum class RobustKernel {
  kNone,    ///< Least squares: rho(e^2) = e^2.
  kHuber,   ///< Quadratic up to the scale c, linear beyond: weight min(1, c / e).
  kCauchy,  ///< rho(e^2) = c^2 log(1 + e^2 / c^2): weight 1 / (1 + e^2 / c^2), redescending.
};
/// "none", "huber", "cauchy".
const char* ToString(RobustKernel kernel);
/// Inverse of ToString; throws InvalidArgument naming the accepted values.
RobustKernel ParseRobustKernel(const char* name);

/// Options of a solve. Plain aggregate; check with Validate().
struct PoseGraphOptions {
  /// Default kCauchy: a redescending kernel gives a false loop closure (perceptual aliasing: a
  /// match between two places that look alike) a weight near 0, whereas Huber's bounded but
  /// constant pull still bends the track by metres; started from the chained odometry, Cauchy
  /// also keeps the true closures of a drifting survey (pose_graph_test.cc, FalseClosure* and
  /// LoopClosures*; BENCHMARKS.md, "Pose-graph back-end").
  RobustKernel robust_kernel = RobustKernel::kCauchy;
  /// Kernel scale c, in standard deviations of the whitened residual norm. Default 4: a 4-D
  /// residual of a correct factor exceeds 4 sigma with probability 0.003 (chi-square, 4 degrees
  /// of freedom), so correct factors keep nearly full weight.
  double robust_scale = 4.0;
  /// Levenberg-Marquardt iterations at most. Default 100.
  int max_iterations = 100;
  /// Stop when the cost decreases by less than this fraction of itself in an accepted step.
  /// Default 1e-10.
  double function_tolerance = 1e-10;
  /// Stop when the step's largest component is below this (metres, radians, log-scale units).
  /// Default 1e-9.
  double step_tolerance = 1e-9;
  /// Initial Levenberg-Marquardt damping, relative to the normal matrix's diagonal (Marquardt's
  /// scaling). Default 1e-4: the chained initial estimate is close, Gauss-Newton steps are good.
  double initial_damping = 1e-4;
  /// A factor whose final whitened residual norm exceeds outlier_sigmas is reported as
  /// down-weighted (FactorResidual::outlier). Default 4 (as robust_scale).
  double outlier_sigmas = 4.0;
  /// Also compute each free pose's marginal covariance (PoseGraphResult::covariance): 4 solves
  /// with the factorised normal matrix per free pose, so off by default for whole flights.
  bool covariance = false;
};

/// Throws InvalidArgument naming the field ("backend.robust_scale must be ...").
void Validate(const PoseGraphOptions& options);

// clang-format off
template <class V>
void VisitFields(PoseGraphOptions& o, V& v) {
  using namespace options;
  v.Field(o.robust_kernel, "robust_kernel", "Robust kernel of the factors' residuals", Any());
  v.Field(o.robust_scale, "robust_scale", "Kernel scale, standard deviations of the whitened residual", GreaterThan(0).Finite());
  v.Field(o.max_iterations, "max_iterations", "Levenberg-Marquardt iterations at most", Interval(1, 10000));
  v.Field(o.function_tolerance, "function_tolerance", "Stop when the cost decreases by less than this fraction", AtLeast(0).Finite());
  v.Field(o.step_tolerance, "step_tolerance", "Stop when the largest step component is below this", AtLeast(0).Finite());
  v.Field(o.initial_damping, "initial_damping", "Initial damping, relative to the normal matrix's diagonal", GreaterThan(0).Finite());
  v.Field(o.outlier_sigmas, "outlier_sigmas", "A factor with a larger final whitened residual is reported as an outlier", GreaterThan(0).Finite());
  v.Field(o.covariance, "covariance", "Compute each free pose's marginal covariance", Any());
}
// clang-format on

/// A frame pair's fitted transform: the pose of frame `curr` in frame `prev`'s coordinates.
struct RelativeFactor {
  int prev = 0;  ///< Pose index (PoseGraph::AddPose's).
  int curr = 0;  ///< Pose index.
  Similarity2 prev_from_curr;
  /// Inverse covariance of (x, y [frame prev's metres], heading [rad], log-scale); symmetric
  /// positive definite.
  Eigen::Matrix4d information = Eigen::Matrix4d::Identity();
};

/// A fix of one frame's pose in the local frame: its position, and its heading and log-scale
/// when measured.
struct AbsoluteFactor {
  int pose = 0;  ///< Pose index.
  /// translation_m always; heading_rad when has_heading; log_scale when has_log_scale.
  Similarity2 local_from_frame;
  bool has_heading = false;
  bool has_log_scale = false;
  /// Inverse covariance of (x, y [m], heading [rad], log-scale); only the rows and columns of
  /// the measured components are read, and that block must be symmetric positive definite.
  Eigen::Matrix4d information = Eigen::Matrix4d::Identity();
};

/// The graph: poses (their current estimates) and factors. Poses are numbered 0, 1, ... in the
/// order added; a factor names poses already added. Every addition is checked as it is made, so
/// that a graph is always solvable and a solve costs nothing per factor outside its window:
/// InvalidArgument names the factor and what is wrong ("pose graph: relative factor 3 (poses
/// 2 -> 7): pose 7 is not in the graph (5 poses)"): a pose not in the graph, a relative factor
/// from a pose to itself, a measurement that is not finite, an information matrix (of the measured
/// components) that is not finite, not symmetric or not positive definite; and a pose estimate
/// that is not finite ("pose graph: the estimate of pose 4 is not finite").
class PoseGraph {
 public:
  /// Adds a pose with its initial estimate; returns its index.
  int AddPose(const Similarity2& local_from_frame);
  /// Adds a factor; returns its index among the factors of its kind.
  int AddRelative(const RelativeFactor& factor);
  int AddAbsolute(const AbsoluteFactor& factor);
  /// A prior: an absolute factor on all four components.
  int AddPrior(int pose, const Similarity2& local_from_frame, const Eigen::Matrix4d& information);

  /// Held poses are never changed by a solve (their factors still constrain the free poses).
  void SetHeld(int pose, bool held);
  /// Replaces the estimates (e.g. with a solve's result); size must equal num_poses().
  void SetEstimates(const std::vector<Similarity2>& local_from_frame);
  void SetEstimate(int pose, const Similarity2& local_from_frame);

  int num_poses() const { return static_cast<int>(poses_.size()); }
  const std::vector<Similarity2>& estimates() const { return poses_; }
  const std::vector<char>& held() const { return held_; }
  const std::vector<RelativeFactor>& relative_factors() const { return relative_; }
  const std::vector<AbsoluteFactor>& absolute_factors() const { return absolute_; }
  /// The upper-triangular U with U'U = the factor's information (of the measured components;
  /// the rows of the others are zero): the whitened residual is U r.
  const Eigen::Matrix4d& relative_sqrt_information(int k) const {
    return relative_sqrt_info_[static_cast<std::size_t>(k)];
  }
  const Eigen::Matrix4d& absolute_sqrt_information(int k) const {
    return absolute_sqrt_info_[static_cast<std::size_t>(k)];
  }
  /// The indices of the factors that name `pose`, in the order added.
  const std::vector<int>& relative_factors_of(int pose) const {
    return relative_of_pose_[static_cast<std::size_t>(pose)];
  }
  const std::vector<int>& absolute_factors_of(int pose) const {
    return absolute_of_pose_[static_cast<std::size_t>(pose)];
  }

 private:
  std::vector<Similarity2> poses_;
  std::vector<char> held_;
  std::vector<RelativeFactor> relative_;
  std::vector<AbsoluteFactor> absolute_;
  std::vector<Eigen::Matrix4d> relative_sqrt_info_, absolute_sqrt_info_;
  std::vector<std::vector<int>> relative_of_pose_, absolute_of_pose_;
};

/// Throws InvalidArgument for a graph that cannot be solved: no poses ("pose graph: no poses");
/// no factors ("pose graph: 1 pose and no factors: nothing to optimise").
void Validate(const PoseGraph& graph);

/// The residual (x, y, heading, log-scale) of a relative factor with measurement
/// `prev_from_curr` at the poses local_from_prev and local_from_curr (the formula of the file
/// comment), and when asked its Jacobians with respect to each pose's (x, y, heading_rad,
/// log_scale). The solver's own; public for tests and for other solvers of the same factors.
Eigen::Vector4d RelativeResidual(const Similarity2& local_from_prev,
                                 const Similarity2& local_from_curr,
                                 const Similarity2& prev_from_curr,
                                 Eigen::Matrix4d* d_prev = nullptr,
                                 Eigen::Matrix4d* d_curr = nullptr);

/// A factor after the solve.
struct FactorResidual {
  double whitened_norm = 0.0;  ///< e = sqrt(r' Omega r) at the solution, standard deviations.
  double weight = 1.0;         ///< The final kernel's weight rho'(e^2), in (0, 1].
  bool outlier = false;        ///< e > PoseGraphOptions::outlier_sigmas (down-weighted).
  /// The factor touched a free pose of the solve; when false the other members are defaults.
  bool in_solve = false;
};

/// Why the solve stopped.
enum class Termination {
  kConverged,      ///< function_tolerance or step_tolerance reached.
  kMaxIterations,  ///< max_iterations reached.
  kNoProgress,     ///< The damping grew without finding a step that lowers the cost.
};
/// "converged", "max-iterations", "no-progress".
const char* ToString(Termination termination);

struct PoseGraphResult {
  /// Every pose of the graph (the held and out-of-window ones as they were), heading wrapped to
  /// (-pi, pi].
  std::vector<Similarity2> local_from_frame;
  /// With PoseGraphOptions::covariance: per pose, the marginal covariance of (x [m], y [m],
  /// heading [rad], log-scale) of a free pose (zero for the poses not solved for): its 4x4 block
  /// of the inverse of the re-weighted normal matrix at the solution (first order; with a robust
  /// kernel each factor counts with its final weight). Empty when not asked, or when that matrix
  /// is singular (an under-determined graph, e.g. one position fix and no heading).
  std::vector<Eigen::Matrix4d> covariance;
  std::vector<FactorResidual> relative;  ///< One per relative factor, in the graph's order.
  std::vector<FactorResidual> absolute;  ///< One per absolute factor.
  int free_poses = 0;                    ///< Poses solved for.
  int gauge_pose = -1;                   ///< The pose held to fix the gauge (-1: none needed).
  int iterations = 0;                    ///< Levenberg-Marquardt iterations.
  double initial_cost = 0.0;             ///< 1/2 sum rho(e^2) at the start.
  double final_cost = 0.0;               ///< The same at the solution.
  Termination termination = Termination::kConverged;
};

/// Solves for every pose not held (the offline whole-flight optimisation). Throws
/// InvalidArgument (Validate of the graph and the options).
PoseGraphResult OptimizeAll(const PoseGraph& graph, const PoseGraphOptions& options = {});

/// Solves for the poses first_pose..last_pose (inclusive) not held, with the factors that touch
/// them; every other pose stays at its estimate (see the file comment). Free poses that no
/// factor touches keep their estimate. Throws InvalidArgument as OptimizeAll, and when the range
/// is empty or outside the graph, or no factor touches a pose of the window.
PoseGraphResult OptimizeWindow(const PoseGraph& graph, int first_pose, int last_pose,
                               const PoseGraphOptions& options = {});

}  // namespace aerovo::backend

template <>
struct aerovo::options::EnumTraits<aerovo::backend::RobustKernel>
    : aerovo::options::EnumList<aerovo::backend::RobustKernel, aerovo::backend::ToString,
                                aerovo::backend::RobustKernel::kNone,
                                aerovo::backend::RobustKernel::kHuber,
                                aerovo::backend::RobustKernel::kCauchy> {};
