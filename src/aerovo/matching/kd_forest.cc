#include "aerovo/matching/kd_forest.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace aerovo::matching_detail {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Points per leaf at most. Muja & Lowe's randomized trees go down to single points; here the
// traversal (node reads, queue operations) costs more than the distances, so leaves of up to
// 16 points (4 steps of the 4-wide list kernel) are faster at equal recall than 8 and halve the
// build time (BENCHMARKS.md, "k-d forest leaf size").
constexpr int kLeafSize = 16;
// Points whose mean and variance choose a node's split: the first ones of the node's range
// (the ids are shuffled once per tree, and partitions keep them in an order unrelated to the
// split dimension). 100 as in Muja & Lowe's FLANN (SAMPLE_MEAN).
constexpr int kSampleSize = 100;
// The split dimension is drawn among this many dimensions of highest variance (Silpa-Anan &
// Hartley 2008); 5 is the fixed value Muja & Lowe (2009) use (FLANN's RAND_DIM).
constexpr int kRandomDims = 5;

// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", OOPSLA
// 2014): a tiny generator with fixed output on every platform, unlike std distributions.
std::uint64_t NextRandom(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Uniform in [0, n) (n small: the modulo bias is below 2^-50).
int RandomBelow(std::uint64_t* state, int n) {
  return static_cast<int>(NextRandom(state) % static_cast<std::uint64_t>(n));
}

// Priority-queue order: smallest key first; equal keys by (tree, node), a total order, so that
// the visiting order, hence the result, does not depend on where a branch sits in the queue.
struct Later {
  bool operator()(const KdScratch::Branch& x, const KdScratch::Branch& y) const {
    if (x.key != y.key) return x.key > y.key;
    if (x.tree != y.tree) return x.tree > y.tree;
    return x.node > y.node;
  }
};

}  // namespace

void KdForest::Build(const float* rows, int dim, const std::uint8_t* group_of, int n,
                     int num_groups, int trees, std::uint64_t seed) {
  dim_ = dim;
  trees_per_group_ = trees;
  num_groups_ = num_groups;
  num_points_ = n;
  seed_ = seed;
  group_size_.assign(static_cast<std::size_t>(num_groups), 0);
  for (int i = 0; i < n; ++i) {
    if (group_of[i] < num_groups) ++group_size_[group_of[i]];
  }
  trees_.resize(static_cast<std::size_t>(num_groups) * trees);
  for (int g = 0; g < num_groups; ++g) {
    for (int t = 0; t < trees; ++t) {
      Tree& tree = trees_[static_cast<std::size_t>(g) * trees + t];
      tree.ids.clear();
      for (int i = 0; i < n; ++i) {
        if (group_of[i] == g) tree.ids.push_back(i);
      }
      // One stream per (seed, group, tree); the multipliers only decorrelate the streams.
      std::uint64_t state = seed * 0xd1342543de82ef95ull + static_cast<std::uint64_t>(g) * 1009u +
                            static_cast<std::uint64_t>(t) * 7919u;
      BuildTree(rows, dim, NextRandom(&state), &tree);
    }
  }
  built_ = true;
}

void KdForest::BuildTree(const float* rows, int dim, std::uint64_t rng_state, Tree* tree) {
  std::vector<std::int32_t>& ids = tree->ids;
  const int n = static_cast<int>(ids.size());
  // Fisher-Yates: every node's range then starts with an unbiased sample of its points.
  for (int i = n - 1; i > 0; --i) std::swap(ids[i], ids[RandomBelow(&rng_state, i + 1)]);
  std::vector<Node>& nodes = tree->nodes;
  nodes.clear();
  nodes.push_back({-1, 0.f, 0, n});
  struct Pending {
    int node, begin, end;
  };
  std::vector<Pending> stack{{0, 0, n}};
  std::vector<float> sum(static_cast<std::size_t>(dim)), sum2(static_cast<std::size_t>(dim));
  mean_.resize(static_cast<std::size_t>(dim));
  var_.resize(static_cast<std::size_t>(dim));
  order_.resize(static_cast<std::size_t>(dim));
  const auto value = [&](std::int32_t id, int d) {
    return rows[static_cast<std::size_t>(id) * dim + d];
  };
  while (!stack.empty()) {
    const Pending p = stack.back();
    stack.pop_back();
    const int count = p.end - p.begin;
    if (count <= kLeafSize) {
      nodes[p.node] = {-1, 0.f, p.begin, p.end};
      continue;
    }
    // Mean and variance per dimension over the sample (float sums over <= 100 unit-range
    // values: ample precision to rank dimensions, and they vectorise).
    const int m = std::min(count, kSampleSize);
    std::fill(sum.begin(), sum.end(), 0.f);
    std::fill(sum2.begin(), sum2.end(), 0.f);
    for (int k = 0; k < m; ++k) {
      const float* x = rows + static_cast<std::size_t>(ids[p.begin + k]) * dim;
      for (int d = 0; d < dim; ++d) {
        sum[d] += x[d];
        sum2[d] += x[d] * x[d];
      }
    }
    for (int d = 0; d < dim; ++d) {
      mean_[d] = static_cast<double>(sum[d]) / m;
      var_[d] = static_cast<double>(sum2[d]) / m - mean_[d] * mean_[d];
    }
    const int top = std::min(kRandomDims, dim);
    std::iota(order_.begin(), order_.end(), 0);
    std::partial_sort(order_.begin(), order_.begin() + top, order_.end(), [&](int a, int b) {
      return var_[a] > var_[b] || (var_[a] == var_[b] && a < b);
    });
    const int d = order_[RandomBelow(&rng_state, top)];
    float split = static_cast<float>(mean_[d]);
    std::int32_t* first = ids.data() + p.begin;
    std::int32_t* last = ids.data() + p.end;
    std::int32_t* mid =
        std::partition(first, last, [&](std::int32_t id) { return value(id, d) < split; });
    if (mid == first || mid == last) {
      // Everything on one side of the mean (a sample unlike the rest, or equal values): split
      // at the median position instead, so that every split shrinks both sides.
      mid = first + count / 2;
      std::nth_element(first, mid, last, [&](std::int32_t a, std::int32_t b) {
        const float va = value(a, d), vb = value(b, d);
        return va < vb || (va == vb && a < b);
      });
      split = value(*mid, d);
    }
    const int a = static_cast<int>(nodes.size());
    nodes.push_back({-1, 0.f, 0, 0});
    nodes.push_back({-1, 0.f, 0, 0});
    nodes[p.node] = {d, split, a, a + 1};
    const int split_at = static_cast<int>(mid - ids.data());
    stack.push_back({a, p.begin, split_at});
    stack.push_back({a + 1, split_at, p.end});
  }
}

int KdForest::Search(int g, const float* q, const float* rows, const float* norms,
                     const std::int32_t* iota, ListFn list, int max_checks, KdScratch* sc,
                     Best2* out) const {
  if (sc->seen.size() < static_cast<std::size_t>(num_points_)) {
    sc->seen.resize(static_cast<std::size_t>(num_points_), 0u);
  }
  if (sc->slots.size() < static_cast<std::size_t>(kLeafSize)) sc->slots.resize(kLeafSize);
  if (++sc->stamp == 0) {
    std::fill(sc->seen.begin(), sc->seen.end(), 0u);
    sc->stamp = 1;
  }
  const std::uint32_t stamp = sc->stamp;
  std::uint32_t* seen = sc->seen.data();
  std::int32_t* slots = sc->slots.data();
  std::vector<KdScratch::Branch>& queue = sc->queue;
  queue.clear();
  Best2 best{kInf, kInf, -1, -1};
  int checks = 0;
  const Tree* group_trees = trees_.data() + static_cast<std::size_t>(g) * trees_per_group_;
  // Down to the leaf nearest the query, queueing every branch not taken with the key of its
  // cell: the parent's key plus the squared distance to the splitting plane (Muja & Lowe's
  // incremental estimate, summed over the planes crossed).
  const auto descend = [&](int t, int node, float key) {
    const Tree& tree = group_trees[t];
    const Node* nodes = tree.nodes.data();
    while (nodes[node].dim >= 0) {
      const Node& nd = nodes[node];
      const float diff = q[nd.dim] - nd.split;
      const bool left = diff < 0.f;
      queue.push_back({key + diff * diff, t, left ? nd.b : nd.a});
      node = left ? nd.a : nd.b;
    }
    const Node& leaf = nodes[node];
    int k = 0;
    for (int i = leaf.a; i < leaf.b; ++i) {
      const std::int32_t id = tree.ids[i];
      if (seen[id] != stamp) {
        seen[id] = stamp;
        slots[k++] = id;
      }
    }
    if (k > 0) {
      Best2 b;
      list(q, dim_, rows, norms, slots, k, iota, &b);
      InsertTop2(b.s1, b.j1, &best);
      InsertTop2(b.s2, b.j2, &best);
      checks += k;
    }
  };
  for (int t = 0; t < trees_per_group_; ++t) descend(t, 0, 0.f);
  while (checks < max_checks && !queue.empty()) {
    // Unsorted queue: pushes (~10 per descent) are appends and the few pops scan it. A binary
    // heap spent more on sifting the pushes than this spends on the scans (a query pops only
    // a few branches at the default budget): faster searches (BENCHMARKS.md, "Approximate
    // matching: randomized k-d forest"), the same branches popped in the same order (same
    // results).
    std::size_t best_k = 0;
    for (std::size_t k = 1; k < queue.size(); ++k) {
      if (Later{}(queue[best_k], queue[k])) best_k = k;
    }
    const KdScratch::Branch br = queue[best_k];
    queue[best_k] = queue.back();
    queue.pop_back();
    descend(br.tree, br.node, br.key);
  }
  *out = best;
  return checks;
}

}  // namespace aerovo::matching_detail
