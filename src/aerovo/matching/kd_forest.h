// Internal: randomized k-d forest over descriptor rows for approximate best / second-best search
// (MatchAlgorithm::kKdForest). Not part of the public API; used by matcher.cc and its tests.
//
// Method: several k-d trees over the same points, each split on a dimension drawn at random
// among the few of highest variance, searched together best-bin-first with one priority queue
// shared by all trees and a budget of examined points (Silpa-Anan & Hartley, "Optimised KD-trees
// for fast image descriptor matching", CVPR 2008; Muja & Lowe, "Fast approximate nearest
// neighbors with automatic algorithm configuration", VISAPP 2009, and TPAMI 2014). Written for
// aerovo from those descriptions.
#pragma once

#include <cstdint>
#include <vector>

#include "aerovo/matching/distance_kernels.h"

namespace aerovo::matching_detail {

/// Per-thread search state, reused between queries (no allocation per query in steady state).
struct KdScratch {
  struct Branch {
    float key;  ///< Lower-bound estimate of the SSD to the branch's points (queue order).
    std::int32_t tree;
    std::int32_t node;
  };
  std::vector<std::uint32_t> seen;  ///< Per point index: query stamp when last examined.
  std::uint32_t stamp = 0;
  std::vector<Branch> queue;
  std::vector<std::int32_t> slots;  ///< Unexamined points of the current leaf.
};

/// The trees of every point group (Laplacian sign) of one point set.
class KdForest {
 public:
  /// Builds `trees` trees per group over the n rows (row i = rows[i * dim ..]); group_of[i] in
  /// [0, num_groups) is point i's group (points are searched only within their group; a value
  /// >= num_groups leaves the point out). Same seed, same trees. Preconditions: trees >= 1,
  /// finite rows.
  void Build(const float* rows, int dim, const std::uint8_t* group_of, int n, int num_groups,
             int trees, std::uint64_t seed);
  /// Forgets the trees (built() becomes false).
  void Clear() { built_ = false; }
  bool built() const { return built_; }
  /// Parameters of the last Build (valid when built()).
  int trees_per_group() const { return trees_per_group_; }
  std::uint64_t seed() const { return seed_; }
  int num_groups() const { return num_groups_; }
  /// Points of group g.
  int group_size(int g) const { return group_size_[static_cast<std::size_t>(g)]; }
  /// Points the forest was built over.
  int num_points() const { return num_points_; }

  /// Approximate best and second-best of query q among the points of
  /// group g, examining at least max_checks distinct points when the group has them (every
  /// tree's first leaf is always examined, and the current leaf is finished). Scores and
  /// indices as the list kernel reports them (s = |c|^2 - 2 q.c, j = point index, ties to the
  /// lower index); rows and norms are the build's rows and their squared norms; iota[i] = i.
  /// Returns the number of points examined. Deterministic.
  int Search(int g, const float* q, const float* rows, const float* norms, const std::int32_t* iota,
             ListFn list, int max_checks, KdScratch* scratch, Best2* out) const;

 private:
  /// dim >= 0: split node; points with x[dim] < split are under `a`, the others under `b`.
  /// dim < 0: leaf holding ids[a .. b).
  struct Node {
    std::int32_t dim;
    float split;
    std::int32_t a;
    std::int32_t b;
  };
  struct Tree {
    std::vector<Node> nodes;  // nodes[0] = root
    std::vector<std::int32_t> ids;
  };
  void BuildTree(const float* rows, int dim, std::uint64_t rng_state, Tree* tree);

  std::vector<Tree> trees_;  // group g, tree t at g * trees_per_group_ + t
  std::vector<int> group_size_;
  std::vector<double> mean_, var_;  // build scratch
  std::vector<int> order_;          // build scratch: dimensions by variance
  int dim_ = 0;
  int trees_per_group_ = 0;
  int num_groups_ = 0;
  int num_points_ = 0;
  std::uint64_t seed_ = 0;
  bool built_ = false;
};

}  // namespace aerovo::matching_detail
