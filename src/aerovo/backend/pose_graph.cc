#include "aerovo/backend/pose_graph.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "aerovo/core/error.h"

namespace aerovo::backend {

const char* ToString(RobustKernel kernel) {
  switch (kernel) {
    case RobustKernel::kNone:
      return "none";
    case RobustKernel::kHuber:
      return "huber";
    case RobustKernel::kCauchy:
      return "cauchy";
  }
  return "?";
}

RobustKernel ParseRobustKernel(const char* name) {
  if (const auto k = options::ParseEnum<RobustKernel>(name ? name : "")) return *k;
  throw InvalidArgument(std::string("robust kernel must be one of ") +
                        options::EnumChoices<RobustKernel>() + ", got \"" + (name ? name : "") +
                        "\"");
}

const char* ToString(Termination termination) {
  switch (termination) {
    case Termination::kConverged:
      return "converged";
    case Termination::kMaxIterations:
      return "max-iterations";
    case Termination::kNoProgress:
      return "no-progress";
  }
  return "?";
}

void Validate(const PoseGraphOptions& options) { options::CheckRanges(options, "backend"); }

namespace {

constexpr int kDim = 4;  // Parameters per pose and residual components per factor.
using Mat4 = Eigen::Matrix4d;
using Vec4 = Eigen::Vector4d;

// The upper-triangular U with U'U = the information of the measured components (rows of the
// components not measured are zero), or an error text.
bool SqrtInformation(const Mat4& information, const std::array<bool, 4>& measured, Mat4* sqrt_info,
                     std::string* problem) {
  int idx[4], n = 0;
  for (int k = 0; k < kDim; ++k) {
    if (measured[static_cast<std::size_t>(k)]) idx[n++] = k;
  }
  Eigen::MatrixXd sub(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) sub(r, c) = information(idx[r], idx[c]);
  }
  if (!sub.allFinite()) {
    *problem = "information matrix is not finite";
    return false;
  }
  const double max_abs = sub.cwiseAbs().maxCoeff();
  if (!((sub - sub.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * max_abs)) {
    *problem = "information matrix is not symmetric";
    return false;
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(sub);
  const Eigen::VectorXd d = llt.matrixLLT().diagonal();
  if (llt.info() != Eigen::Success || !(d.minCoeff() > 0.0) ||
      !(d.minCoeff() * d.minCoeff() > 1e-12 * sub.diagonal().maxCoeff())) {
    *problem = "information matrix is not positive definite";
    return false;
  }
  const Eigen::MatrixXd u = llt.matrixU();
  sqrt_info->setZero();
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) (*sqrt_info)(idx[r], idx[c]) = u(r, c);
  }
  return true;
}

std::string RelativeName(int k, const RelativeFactor& f) {
  return "relative factor " + std::to_string(k) + " (poses " + std::to_string(f.prev) + " -> " +
         std::to_string(f.curr) + ")";
}

std::string AbsoluteName(int k, const AbsoluteFactor& f) {
  return "absolute factor " + std::to_string(k) + " (pose " + std::to_string(f.pose) + ")";
}

void CheckEstimate(int pose, const Similarity2& p) {
  if (!p.AllFinite()) {
    throw InvalidArgument("pose graph: the estimate of pose " + std::to_string(pose) +
                          " is not finite");
  }
}

}  // namespace

int PoseGraph::AddPose(const Similarity2& local_from_frame) {
  CheckEstimate(num_poses(), local_from_frame);
  poses_.push_back(local_from_frame);
  held_.push_back(0);
  relative_of_pose_.emplace_back();
  absolute_of_pose_.emplace_back();
  return num_poses() - 1;
}

int PoseGraph::AddRelative(const RelativeFactor& f) {
  const int k = static_cast<int>(relative_.size());
  const std::string name = RelativeName(k, f);
  auto fail = [&](const std::string& what) {
    throw InvalidArgument("pose graph: " + name + ": " + what);
  };
  for (const int pose : {f.prev, f.curr}) {
    if (pose < 0 || pose >= num_poses()) {
      fail("pose " + std::to_string(pose) + " is not in the graph (" + std::to_string(num_poses()) +
           " poses)");
    }
  }
  if (f.prev == f.curr) fail("a pose to itself");
  if (!f.prev_from_curr.AllFinite()) fail("the measurement is not finite");
  Mat4 sqrt_info;
  std::string problem;
  if (!SqrtInformation(f.information, {true, true, true, true}, &sqrt_info, &problem)) {
    fail(problem);
  }
  relative_.push_back(f);
  relative_sqrt_info_.push_back(sqrt_info);
  relative_of_pose_[static_cast<std::size_t>(f.prev)].push_back(k);
  relative_of_pose_[static_cast<std::size_t>(f.curr)].push_back(k);
  return k;
}

int PoseGraph::AddAbsolute(const AbsoluteFactor& f) {
  const int k = static_cast<int>(absolute_.size());
  const std::string name = AbsoluteName(k, f);
  auto fail = [&](const std::string& what) {
    throw InvalidArgument("pose graph: " + name + ": " + what);
  };
  if (f.pose < 0 || f.pose >= num_poses()) {
    fail("pose " + std::to_string(f.pose) + " is not in the graph (" + std::to_string(num_poses()) +
         " poses)");
  }
  const Similarity2& z = f.local_from_frame;
  if (!z.translation_m.allFinite() || (f.has_heading && !std::isfinite(z.heading_rad)) ||
      (f.has_log_scale && !std::isfinite(z.log_scale))) {
    fail("the measurement is not finite");
  }
  Mat4 sqrt_info;
  std::string problem;
  if (!SqrtInformation(f.information, {true, true, f.has_heading, f.has_log_scale}, &sqrt_info,
                       &problem)) {
    fail(problem);
  }
  absolute_.push_back(f);
  absolute_sqrt_info_.push_back(sqrt_info);
  absolute_of_pose_[static_cast<std::size_t>(f.pose)].push_back(k);
  return k;
}

int PoseGraph::AddPrior(int pose, const Similarity2& local_from_frame,
                        const Eigen::Matrix4d& information) {
  AbsoluteFactor f;
  f.pose = pose;
  f.local_from_frame = local_from_frame;
  f.has_heading = true;
  f.has_log_scale = true;
  f.information = information;
  return AddAbsolute(f);
}

void PoseGraph::SetHeld(int pose, bool held) {
  if (pose < 0 || pose >= num_poses()) {
    throw InvalidArgument("SetHeld: pose " + std::to_string(pose) + " is not in the graph (" +
                          std::to_string(num_poses()) + " poses)");
  }
  held_[static_cast<std::size_t>(pose)] = held ? 1 : 0;
}

void PoseGraph::SetEstimates(const std::vector<Similarity2>& local_from_frame) {
  if (local_from_frame.size() != poses_.size()) {
    throw InvalidArgument("SetEstimates: " + std::to_string(local_from_frame.size()) +
                          " poses given for a graph of " + std::to_string(num_poses()));
  }
  for (std::size_t p = 0; p < local_from_frame.size(); ++p) {
    CheckEstimate(static_cast<int>(p), local_from_frame[p]);
  }
  poses_ = local_from_frame;
}

void PoseGraph::SetEstimate(int pose, const Similarity2& local_from_frame) {
  if (pose < 0 || pose >= num_poses()) {
    throw InvalidArgument("SetEstimate: pose " + std::to_string(pose) + " is not in the graph (" +
                          std::to_string(num_poses()) + " poses)");
  }
  CheckEstimate(pose, local_from_frame);
  poses_[static_cast<std::size_t>(pose)] = local_from_frame;
}

void Validate(const PoseGraph& graph) {
  const int n = graph.num_poses();
  if (n == 0) throw InvalidArgument("pose graph: no poses");
  if (graph.relative_factors().empty() && graph.absolute_factors().empty()) {
    throw InvalidArgument("pose graph: " + std::to_string(n) + (n == 1 ? " pose" : " poses") +
                          " and no factors: nothing to optimise");
  }
}

Eigen::Vector4d RelativeResidual(const Similarity2& local_from_prev,
                                 const Similarity2& local_from_curr,
                                 const Similarity2& prev_from_curr, Eigen::Matrix4d* d_prev,
                                 Eigen::Matrix4d* d_curr) {
  const Similarity2& a = local_from_prev;
  const Similarity2& b = local_from_curr;
  const Similarity2& z = prev_from_curr;
  const double inv_s = std::exp(-a.log_scale);
  const double c = std::cos(a.heading_rad), s = std::sin(a.heading_rad);
  const Eigen::Vector2d d = b.translation_m - a.translation_m;
  // u = exp(-s_a) R(a)' d: the other pose's position in frame a's coordinates.
  const Eigen::Vector2d u(inv_s * (c * d.x() + s * d.y()), inv_s * (-s * d.x() + c * d.y()));
  Eigen::Vector4d r;
  r.head<2>() = u - z.translation_m;
  r(2) = WrapAngleRad(b.heading_rad - a.heading_rad - z.heading_rad);
  r(3) = b.log_scale - a.log_scale - z.log_scale;
  Eigen::Matrix2d rt;  // exp(-s_a) R(a)'
  rt << inv_s * c, inv_s * s, -inv_s * s, inv_s * c;
  if (d_prev) {
    d_prev->setZero();
    d_prev->topLeftCorner<2, 2>() = -rt;
    // d/da [R(a)' d] = R(a)' J' d with J the 90 degree rotation: (u_y, -u_x) after scaling.
    (*d_prev)(0, 2) = u.y();
    (*d_prev)(1, 2) = -u.x();
    (*d_prev)(0, 3) = -u.x();
    (*d_prev)(1, 3) = -u.y();
    (*d_prev)(2, 2) = -1.0;
    (*d_prev)(3, 3) = -1.0;
  }
  if (d_curr) {
    d_curr->setZero();
    d_curr->topLeftCorner<2, 2>() = rt;
    (*d_curr)(2, 2) = 1.0;
    (*d_curr)(3, 3) = 1.0;
  }
  return r;
}

namespace {

// One factor of a solve, in the solver's terms.
struct SolveFactor {
  int pose_a = -1, pose_b = -1;  // Graph pose indices (b = -1: absolute).
  int var_a = -1, var_b = -1;    // Free-variable indices (-1: held).
  const Similarity2* z = nullptr;
  const Mat4* sqrt_info = nullptr;
  int graph_index = 0;
  bool relative = true;
  // Offsets into the normal matrix's values of the 4x4 blocks (a,a), (b,b), (a,b), (b,a):
  // per block, the offset of each of its 4 columns' first (top) entry.
  std::array<std::array<int, 4>, 4> block_offsets{};
};

// rho(e^2) and rho'(e^2) of the kernel with scale c.
struct KernelValue {
  double rho = 0.0, weight = 1.0;
};
KernelValue Kernel(RobustKernel kernel, double c, double e2) {
  switch (kernel) {
    case RobustKernel::kNone:
      return {e2, 1.0};
    case RobustKernel::kHuber: {
      if (e2 <= c * c) return {e2, 1.0};
      const double e = std::sqrt(e2);
      return {2.0 * c * e - c * c, c / e};
    }
    case RobustKernel::kCauchy: {
      const double c2 = c * c;
      return {c2 * std::log1p(e2 / c2), 1.0 / (1.0 + e2 / c2)};
    }
  }
  return {e2, 1.0};
}

// One solve over the free poses of a window. Memory and time are those of the window's poses
// and factors (found through the graph's per-pose factor lists), plus one copy of the estimates
// for the result.
class Solver {
 public:
  Solver(const PoseGraph& graph, int first, int last, const PoseGraphOptions& options)
      : graph_(graph), options_(options), first_(first), last_(last) {
    Setup();
  }

  PoseGraphResult Run() {
    PoseGraphResult result;
    result.free_poses = num_vars_;
    result.gauge_pose = gauge_pose_;
    const RobustKernel kernel = options_.robust_kernel;
    result.initial_cost = Cost(free_, kernel);
    result.termination = Minimise(kernel, &result.iterations);
    result.final_cost = Cost(free_, kernel);
    if (options_.covariance) Covariances(kernel, &result.covariance);
    result.relative.resize(graph_.relative_factors().size());
    result.absolute.resize(graph_.absolute_factors().size());
    for (const SolveFactor& f : factors_) {
      const Vec4 e = *f.sqrt_info * Residual(f, free_, nullptr, nullptr);
      FactorResidual& out = f.relative ? result.relative[static_cast<std::size_t>(f.graph_index)]
                                       : result.absolute[static_cast<std::size_t>(f.graph_index)];
      out.whitened_norm = e.norm();
      out.weight = Kernel(kernel, options_.robust_scale, e.squaredNorm()).weight;
      out.outlier = out.whitened_norm > options_.outlier_sigmas;
      out.in_solve = true;
    }
    result.local_from_frame = graph_.estimates();
    for (int p = first_; p <= last_; ++p) {
      const int v = VarOf(p);
      if (v < 0) continue;
      Similarity2 pose = free_[static_cast<std::size_t>(v)];
      pose.heading_rad = WrapAngleRad(pose.heading_rad);
      result.local_from_frame[static_cast<std::size_t>(p)] = pose;
    }
    return result;
  }

 private:
  int VarOf(int pose) const {
    return pose < first_ || pose > last_ ? -1
                                         : var_in_window_[static_cast<std::size_t>(pose - first_)];
  }
  const Similarity2& PoseOf(int pose, int var, const std::vector<Similarity2>& free) const {
    return var >= 0 ? free[static_cast<std::size_t>(var)]
                    : graph_.estimates()[static_cast<std::size_t>(pose)];
  }

  // Residual (x, y, heading, log-scale) of f at the free poses `free` (and the Jacobians with
  // respect to pose a and pose b when asked).
  Vec4 Residual(const SolveFactor& f, const std::vector<Similarity2>& free, Mat4* jac_a,
                Mat4* jac_b) const {
    const Similarity2& a = PoseOf(f.pose_a, f.var_a, free);
    if (f.relative) {
      return RelativeResidual(a, PoseOf(f.pose_b, f.var_b, free), *f.z, jac_a, jac_b);
    }
    Vec4 r;
    r.head<2>() = a.translation_m - f.z->translation_m;
    r(2) = WrapAngleRad(a.heading_rad - f.z->heading_rad);
    r(3) = a.log_scale - f.z->log_scale;
    if (jac_a) jac_a->setIdentity();
    return r;
  }

  void Setup() {
    const int width = last_ - first_ + 1;
    auto is_free = [&](int p) {
      return p >= first_ && p <= last_ && !graph_.held()[static_cast<std::size_t>(p)];
    };
    // The factors that touch a free pose of the window, in the graph's order.
    std::vector<int> rel_ids, abs_ids;
    for (int p = first_; p <= last_; ++p) {
      if (!is_free(p)) continue;
      const auto& r = graph_.relative_factors_of(p);
      rel_ids.insert(rel_ids.end(), r.begin(), r.end());
      const auto& a = graph_.absolute_factors_of(p);
      abs_ids.insert(abs_ids.end(), a.begin(), a.end());
    }
    std::sort(rel_ids.begin(), rel_ids.end());
    rel_ids.erase(std::unique(rel_ids.begin(), rel_ids.end()), rel_ids.end());
    std::sort(abs_ids.begin(), abs_ids.end());
    if (rel_ids.empty() && abs_ids.empty()) {
      throw InvalidArgument("pose graph: no factor touches a free pose of poses " +
                            std::to_string(first_) + ".." + std::to_string(last_) +
                            ": nothing to optimise");
    }
    std::vector<char> touched(static_cast<std::size_t>(width), 0);
    bool anchored = !abs_ids.empty();  // An absolute factor or a held pose fixes the gauge.
    for (const int k : rel_ids) {
      const RelativeFactor& g = graph_.relative_factors()[static_cast<std::size_t>(k)];
      SolveFactor f;
      f.pose_a = g.prev;
      f.pose_b = g.curr;
      f.z = &g.prev_from_curr;
      f.sqrt_info = &graph_.relative_sqrt_information(k);
      f.graph_index = k;
      f.relative = true;
      for (const int p : {g.prev, g.curr}) {
        if (is_free(p)) {
          touched[static_cast<std::size_t>(p - first_)] = 1;
        } else {
          anchored = true;
        }
      }
      factors_.push_back(f);
    }
    for (const int k : abs_ids) {
      const AbsoluteFactor& g = graph_.absolute_factors()[static_cast<std::size_t>(k)];
      SolveFactor f;
      f.pose_a = g.pose;
      f.z = &g.local_from_frame;
      f.sqrt_info = &graph_.absolute_sqrt_information(k);
      f.graph_index = k;
      f.relative = false;
      touched[static_cast<std::size_t>(g.pose - first_)] = 1;
      factors_.push_back(f);
    }
    var_in_window_.assign(static_cast<std::size_t>(width), -1);
    for (int p = first_; p <= last_; ++p) {
      if (!touched[static_cast<std::size_t>(p - first_)]) continue;
      if (!anchored && gauge_pose_ < 0) {
        gauge_pose_ = p;  // Held: fixes placement, heading and scale.
        continue;
      }
      var_in_window_[static_cast<std::size_t>(p - first_)] = num_vars_++;
      free_.push_back(graph_.estimates()[static_cast<std::size_t>(p)]);
    }
    for (SolveFactor& f : factors_) {
      f.var_a = VarOf(f.pose_a);
      f.var_b = f.relative ? VarOf(f.pose_b) : -1;
    }
    BuildPattern();
  }

  void BuildPattern() {
    const int dim = kDim * num_vars_;
    std::vector<Eigen::Triplet<double>> triplets;
    auto add_block = [&](int r, int c) {
      for (int j = 0; j < kDim; ++j) {
        for (int i = 0; i < kDim; ++i) triplets.emplace_back(kDim * r + i, kDim * c + j, 0.0);
      }
    };
    for (int v = 0; v < num_vars_; ++v) add_block(v, v);
    for (const SolveFactor& f : factors_) {
      if (f.var_a >= 0 && f.var_b >= 0) {
        add_block(f.var_a, f.var_b);
        add_block(f.var_b, f.var_a);
      }
    }
    h_.resize(dim, dim);
    h_.setFromTriplets(triplets.begin(), triplets.end(), [](double a, double) { return a; });
    h_.makeCompressed();
    auto offsets = [&](int r, int c) {
      std::array<int, 4> out{};
      for (int j = 0; j < kDim; ++j) {
        const int col = kDim * c + j;
        const int* begin = h_.innerIndexPtr() + h_.outerIndexPtr()[col];
        const int* end = h_.innerIndexPtr() + h_.outerIndexPtr()[col + 1];
        out[static_cast<std::size_t>(j)] =
            static_cast<int>(std::lower_bound(begin, end, kDim * r) - h_.innerIndexPtr());
      }
      return out;
    };
    for (SolveFactor& f : factors_) {
      if (f.var_a >= 0) f.block_offsets[0] = offsets(f.var_a, f.var_a);
      if (f.var_b >= 0) f.block_offsets[1] = offsets(f.var_b, f.var_b);
      if (f.var_a >= 0 && f.var_b >= 0) {
        f.block_offsets[2] = offsets(f.var_a, f.var_b);
        f.block_offsets[3] = offsets(f.var_b, f.var_a);
      }
    }
    diag_offsets_.resize(static_cast<std::size_t>(dim));
    for (int k = 0; k < dim; ++k) {
      const int* begin = h_.innerIndexPtr() + h_.outerIndexPtr()[k];
      const int* end = h_.innerIndexPtr() + h_.outerIndexPtr()[k + 1];
      diag_offsets_[static_cast<std::size_t>(k)] =
          static_cast<int>(std::lower_bound(begin, end, k) - h_.innerIndexPtr());
    }
    if (dim > 0) ldlt_.analyzePattern(h_);
  }

  double Cost(const std::vector<Similarity2>& free, RobustKernel kernel) const {
    double cost = 0.0;
    for (const SolveFactor& f : factors_) {
      const Vec4 e = *f.sqrt_info * Residual(f, free, nullptr, nullptr);
      cost += Kernel(kernel, options_.robust_scale, e.squaredNorm()).rho;
    }
    return 0.5 * cost;
  }

  void AddBlock(const std::array<int, 4>& offsets, const Mat4& block) {
    double* values = h_.valuePtr();
    for (int j = 0; j < kDim; ++j) {
      double* col = values + offsets[static_cast<std::size_t>(j)];
      for (int i = 0; i < kDim; ++i) col[i] += block(i, j);
    }
  }

  // The re-weighted normal equations H = sum w J'J, g = sum w J'e at free_ (whitened).
  void Linearise(RobustKernel kernel) {
    std::fill(h_.valuePtr(), h_.valuePtr() + h_.nonZeros(), 0.0);
    g_.setZero(kDim * num_vars_);
    Mat4 ja, jb;
    for (const SolveFactor& f : factors_) {
      if (f.var_a < 0 && f.var_b < 0) continue;  // Between held poses (the gauge pose).
      const Vec4 r = Residual(f, free_, &ja, &jb);
      const Vec4 e = *f.sqrt_info * r;
      const double w = Kernel(kernel, options_.robust_scale, e.squaredNorm()).weight;
      const Mat4 wa = *f.sqrt_info * ja;
      if (f.var_a >= 0) {
        AddBlock(f.block_offsets[0], w * wa.transpose() * wa);
        g_.segment<kDim>(kDim * f.var_a) += w * wa.transpose() * e;
      }
      if (!f.relative) continue;
      const Mat4 wb = *f.sqrt_info * jb;
      if (f.var_b >= 0) {
        AddBlock(f.block_offsets[1], w * wb.transpose() * wb);
        g_.segment<kDim>(kDim * f.var_b) += w * wb.transpose() * e;
      }
      if (f.var_a >= 0 && f.var_b >= 0) {
        const Mat4 ab = w * wa.transpose() * wb;
        AddBlock(f.block_offsets[2], ab);
        AddBlock(f.block_offsets[3], ab.transpose());
      }
    }
  }

  // The 4x4 diagonal blocks of H^-1 at free_, per pose (zero for poses not free); empty when H
  // is singular.
  void Covariances(RobustKernel kernel, std::vector<Mat4>* out) {
    out->clear();
    if (num_vars_ == 0) return;
    Linearise(kernel);
    ldlt_.factorize(h_);
    if (ldlt_.info() != Eigen::Success) return;
    const int dim = kDim * num_vars_;
    std::vector<Mat4> blocks(static_cast<std::size_t>(num_vars_));
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(dim), column(dim);
    for (int v = 0; v < num_vars_; ++v) {
      for (int k = 0; k < kDim; ++k) {
        unit(kDim * v + k) = 1.0;
        column = ldlt_.solve(unit);
        unit(kDim * v + k) = 0.0;
        blocks[static_cast<std::size_t>(v)].col(k) = column.segment<kDim>(kDim * v);
      }
      const Mat4& b = blocks[static_cast<std::size_t>(v)];
      // A singular H may factorise with zero or negative pivots: no covariance then.
      if (!b.allFinite() || !(b.diagonal().minCoeff() > 0.0)) return;
    }
    out->assign(graph_.estimates().size(), Mat4::Zero());
    for (int p = first_; p <= last_; ++p) {
      const int v = VarOf(p);
      if (v >= 0) {
        const Mat4& b = blocks[static_cast<std::size_t>(v)];
        (*out)[static_cast<std::size_t>(p)] = 0.5 * (b + b.transpose());
      }
    }
  }

  static void Apply(const Eigen::VectorXd& step, std::vector<Similarity2>* free) {
    for (std::size_t v = 0; v < free->size(); ++v) {
      Similarity2& pose = (*free)[v];
      const int i = kDim * static_cast<int>(v);
      pose.translation_m += step.segment<2>(i);
      pose.heading_rad += step(i + 2);
      pose.log_scale += step(i + 3);
    }
  }

  Termination Minimise(RobustKernel kernel, int* iterations) {
    if (num_vars_ == 0) return Termination::kConverged;
    const int dim = kDim * num_vars_;
    double cost = Cost(free_, kernel);
    double lambda = options_.initial_damping;
    double nu = 2.0;
    Eigen::SparseMatrix<double> damped = h_;  // Same pattern; values set per trial.
    Eigen::VectorXd diag(dim), step(dim);
    std::vector<Similarity2> candidate;
    bool relinearise = true;
    for (int it = 0; it < options_.max_iterations; ++it) {
      ++*iterations;
      if (relinearise) {
        Linearise(kernel);
        for (int k = 0; k < dim; ++k) {
          diag(k) = std::max(h_.valuePtr()[diag_offsets_[static_cast<std::size_t>(k)]], 1e-12);
        }
        relinearise = false;
      }
      // Steps with growing damping until one lowers the cost (Madsen et al., algorithm 3.16).
      for (;;) {
        std::copy(h_.valuePtr(), h_.valuePtr() + h_.nonZeros(), damped.valuePtr());
        for (int k = 0; k < dim; ++k) {
          damped.valuePtr()[diag_offsets_[static_cast<std::size_t>(k)]] += lambda * diag(k);
        }
        ldlt_.factorize(damped);
        bool ok = ldlt_.info() == Eigen::Success;
        if (ok) {
          step = ldlt_.solve(-g_);
          ok = step.allFinite();
        }
        if (ok) {
          if (step.cwiseAbs().maxCoeff() < options_.step_tolerance) {
            return Termination::kConverged;
          }
          candidate = free_;
          Apply(step, &candidate);
          const double new_cost = Cost(candidate, kernel);
          // Decrease predicted by the damped quadratic model: 1/2 h'(lambda D h - g).
          const double predicted = 0.5 * step.dot(lambda * diag.cwiseProduct(step) - g_);
          const double gain = predicted > 0.0 ? (cost - new_cost) / predicted : -1.0;
          if (new_cost < cost && gain > 0.0) {
            const double decrease = cost - new_cost;
            free_.swap(candidate);
            cost = new_cost;
            lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain - 1.0, 3));
            nu = 2.0;
            relinearise = true;
            if (decrease <= options_.function_tolerance * cost) return Termination::kConverged;
            break;
          }
        }
        lambda *= nu;
        nu *= 2.0;
        if (!(lambda < 1e16)) return Termination::kNoProgress;
      }
    }
    return Termination::kMaxIterations;
  }

  const PoseGraph& graph_;
  const PoseGraphOptions& options_;
  const int first_, last_;
  std::vector<int> var_in_window_;  // Per pose of the window: its variable, -1 when held.
  std::vector<Similarity2> free_;   // The free poses' estimates, by variable.
  int num_vars_ = 0;
  int gauge_pose_ = -1;
  std::vector<SolveFactor> factors_;
  Eigen::SparseMatrix<double> h_;  // Column-major, both triangles.
  Eigen::VectorXd g_;
  std::vector<int> diag_offsets_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
};

}  // namespace

PoseGraphResult OptimizeAll(const PoseGraph& graph, const PoseGraphOptions& options) {
  Validate(options);
  Validate(graph);
  return OptimizeWindow(graph, 0, graph.num_poses() - 1, options);
}

PoseGraphResult OptimizeWindow(const PoseGraph& graph, int first_pose, int last_pose,
                               const PoseGraphOptions& options) {
  Validate(options);
  Validate(graph);
  if (first_pose < 0 || last_pose >= graph.num_poses() || first_pose > last_pose) {
    throw InvalidArgument("pose graph: window " + std::to_string(first_pose) + ".." +
                          std::to_string(last_pose) + " is empty or outside poses 0.." +
                          std::to_string(graph.num_poses() - 1));
  }
  Solver solver(graph, first_pose, last_pose, options);
  return solver.Run();
}

}  // namespace aerovo::backend
