#include "aerovo/matching/matcher.h"
#include "aerovo/core/cancel.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/parallel.h"
#include "aerovo/core/timer.h"
#include "aerovo/matching/distance_kernels.h"
#include "aerovo/matching/kd_forest.h"

namespace aerovo {

using matching_detail::Best2;
using matching_detail::kCandStep;
using matching_detail::Kernels;
using matching_detail::kPanelWidth;
using matching_detail::kQueryTile;
using matching_detail::kStreamRows;
using matching_detail::LaneTop2;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Largest SSD between two unit vectors (antipodal): the base of MatchThreshold's percentage.
constexpr double kMaxSsd = 4.0;
// Laplacian groups: points are compared only within a group (sign -1, 0, +1). With
// check_laplacian off everything goes to group 1.
constexpr int kNumGroups = 3;
// Query tiles per parallel work item (64 queries): small enough to balance 2..16 threads,
// large enough that each item streams a candidate block from L2 many times.
constexpr int kTilesPerItem = 16;
// Bytes of candidate descriptors per cache block; the block is re-read by every query tile of a
// work item, so it should stay in L2 (1-2 MB per core on current x86) with room to spare.
constexpr int kBlockBytes = 256 * 1024;
// Below these amounts of work a parallel region costs more than it saves (fork/join and, on a
// loaded machine, waiting for a descheduled thread); BENCHMARKS.md, "Matcher thresholds".
constexpr std::int64_t kMinPairsForThreads = 1 << 20;
constexpr int kMinGuidedQueriesForThreads = 4096;
// Exhaustive searches with at most this many queries (and at most half as many as candidates)
// pack the queries and stream the candidates in place (SearchStreaming).
constexpr int kMaxStreamingQueries = 4096;
// Guided search: queries ahead whose rows (query and up to kGuidedPrefetchRows candidates) are
// fetched while the current one is compared; tuned on real SURF with ~1 and ~20 candidates per
// query (bench_matching BM_Guided*, bench_correspondence).
constexpr int kGuidedPrefetchDistance = 4;
constexpr int kGuidedPrefetchRows = 8;
// Guided search: expected candidates per query (same Laplacian group, in the disc) from which
// queries are visited in spatial order (see SearchGuided).
constexpr double kGuidedSortMinCandidates = 4.0;
// Upper bound on guided-grid cells per Laplacian group (memory bound for tiny radii).
constexpr std::int64_t kMaxGridCells = 1 << 18;
// k-d forest search: queries from which a parallel region pays (BENCHMARKS.md, "Matcher
// thresholds").
constexpr int kMinKdQueriesForThreads = 1024;
// Largest MatchOptions::kd_trees accepted (memory: one index array per tree and group).
constexpr int kMaxKdTrees = 64;

// The k-d forest searches only when asked for and when its budget does not already cover the
// candidates (then the exhaustive search is the exact answer at no extra cost).
bool UseKdForest(const MatchOptions& o, std::size_t num_candidates) {
  return o.algorithm == MatchAlgorithm::kKdForest && o.kd_max_checks > 0 &&
         static_cast<std::size_t>(o.kd_max_checks) < num_candidates;
}

int GroupOf(std::int8_t laplacian, bool check_laplacian) {
  if (!check_laplacian) return 1;
  return laplacian < 0 ? 0 : (laplacian == 0 ? 1 : 2);
}

// Squared L2 norm (the kernels' NormFn; every variant gives the same value): the fastest the CPU
// has, also for a Matcher that forces the SSE kernels.
float SquaredNorm(const float* d, int dim) {
  static const matching_detail::NormFn norm = matching_detail::SelectKernels(true).norm;
  return norm(d, dim);
}

// True if any of v[0..n) is Inf or NaN (exponent bits all ones); integer ops vectorise.
bool AnyNonFinite(const float* v, std::size_t n) {
  std::uint32_t bad = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t bits;
    std::memcpy(&bits, v + i, sizeof(bits));
    bad |= static_cast<std::uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
  }
  return bad != 0;
}

// Best and second-best candidate of a query with their SSDs recomputed exactly (the kernels'
// ExactFn), re-sorted on the exact values (s1 <= s2, ties: lower index); j = original index, -1 =
// none.
struct ExactTop2 {
  int j1 = -1;
  int j2 = -1;
  double s1 = std::numeric_limits<double>::infinity();
  double s2 = std::numeric_limits<double>::infinity();
};

// exact: the kernels' ExactFn (SSD in double from the stored floats: the value the thresholds
// are applied to, independent of the float32 ranking score, so boundary decisions do not depend
// on the kernel used).
ExactTop2 MakeExact(matching_detail::ExactFn exact, const float* q, int dim, int j1,
                    const float* row1, int j2, const float* row2) {
  ExactTop2 e;
  if (j1 < 0) return e;
  e.j1 = j1;
  e.s1 = exact(q, row1, dim);
  if (j2 >= 0) {
    e.j2 = j2;
    e.s2 = exact(q, row2, dim);
    if (e.s2 < e.s1 || (e.s2 == e.s1 && e.j2 < e.j1)) {
      std::swap(e.s1, e.s2);
      std::swap(e.j1, e.j2);
    }
  }
  return e;
}

void CheckFeatureSet(const FeatureSet& f, const char* which) {
  if (f.descriptor_size <= 0) {
    throw InvalidArgument(std::string("Matcher::Match: ") + which + ".descriptor_size is " +
                          std::to_string(f.descriptor_size) + ", must be > 0");
  }
  const std::size_t expected = f.keypoints.size() * static_cast<std::size_t>(f.descriptor_size);
  if (f.descriptors.size() != expected) {
    throw InvalidArgument(std::string("Matcher::Match: ") + which + " has " +
                          std::to_string(f.keypoints.size()) + " keypoints of descriptor_size " +
                          std::to_string(f.descriptor_size) + " but " +
                          std::to_string(f.descriptors.size()) + " descriptor values (expected " +
                          std::to_string(expected) + ")");
  }
}

[[noreturn]] void ThrowNonFinite(const char* which, int index, const char* what) {
  throw InvalidArgument(std::string("Matcher::Match: ") + which + " point " +
                        std::to_string(index) + " has a non-finite " + what);
}

}  // namespace

MatchAlgorithm ParseMatchAlgorithm(const std::string& name) {
  if (name == "exhaustive") return MatchAlgorithm::kExhaustive;
  if (name == "kdtree") return MatchAlgorithm::kKdForest;
  throw InvalidArgument("unknown matcher '" + name + "' (expected exhaustive or kdtree)");
}

const char* ToString(MatchAlgorithm algorithm) {
  return algorithm == MatchAlgorithm::kKdForest ? "kdtree" : "exhaustive";
}

void Validate(const MatchOptions& o) {
  static_assert(kMaxKdTrees == 64, "the range of kd_trees in VisitFields(MatchOptions) says 64");
  options::CheckRanges(o, "match");
}

struct MatchCandidates::Grid {
  float x0 = 0.f, y0 = 0.f, inv_cell = 1.f;
  int nx = 0, ny = 0;
  std::vector<int> cell_start;  // kNumGroups * nx * ny + 1
  std::vector<int> cursor, key;
  std::vector<float> x, y;          // slot -> position
  std::vector<std::int32_t> index;  // slot -> original index
  std::vector<float> px, py;        // MatchCandidates: positions by index (FillGrid input)
  std::vector<std::uint8_t> group;  // MatchCandidates: Laplacian group by index
  double extent[4] = {0, 0, 0, 0};  // MatchCandidates: x0, y0, x1, y1 of px, py
};
using Grid = MatchCandidates::Grid;

namespace {

// Buckets points k = 0..count-1 (position px[k], py[k]; Laplacian group group_of(k); original
// index id_of(k)) by cell of side >= min_cell, per group; points at non-finite positions (a
// prior that overflowed) can be in no disc and are left out. Queries visit the cells their
// disc overlaps, whatever the cell side, so the side is chosen for speed only.
// `extent` (x0, y0, x1, y1), when given, is the bounding box of the positions, all finite
// (MatchCandidates computes it while it checks them): it saves a pass.
template <class GroupOf, class IdOf>
void FillGrid(std::size_t count, const float* px, const float* py, GroupOf group_of, IdOf id_of,
              double min_cell, Grid* g, const double* extent = nullptr) {
  const auto usable = [&](std::size_t k) { return std::isfinite(px[k]) && std::isfinite(py[k]); };
  std::size_t n = 0;
  double x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
  if (extent != nullptr) {
    n = count;
    x0 = extent[0];
    y0 = extent[1];
    x1 = extent[2];
    y1 = extent[3];
  } else {
    for (std::size_t k = 0; k < count; ++k) {
      if (!usable(k)) continue;
      ++n;
      x0 = std::min(x0, static_cast<double>(px[k]));
      x1 = std::max(x1, static_cast<double>(px[k]));
      y0 = std::min(y0, static_cast<double>(py[k]));
      y1 = std::max(y1, static_cast<double>(py[k]));
    }
  }
  if (n == 0) x0 = y0 = x1 = y1 = 0.0;
  // Cells of side ~ the mean spacing of the points hold ~1 point each: smaller ones would be
  // mostly empty, and clearing and scanning them would cost more than the comparisons (a 6 px
  // radius over 740 points of 800 x 600 would make 40k cells). Extents in double: the span of
  // float positions cannot overflow there.
  const double spacing =
      n > 0 ? std::sqrt(std::max(1.0, (x1 - x0) * (y1 - y0)) / static_cast<double>(n)) : 0.0;
  double cell = std::max({min_cell, spacing, 1e-3});
  const auto cells_for = [&](double c) {
    return (std::floor((x1 - x0) / c) + 1.0) * (std::floor((y1 - y0) / c) + 1.0);
  };
  while (cells_for(cell) > static_cast<double>(kMaxGridCells)) cell *= 2.0;
  g->x0 = static_cast<float>(x0);
  g->y0 = static_cast<float>(y0);
  g->inv_cell = static_cast<float>(1.0 / cell);
  g->nx = static_cast<int>((x1 - x0) / cell) + 1;
  g->ny = static_cast<int>((y1 - y0) / cell) + 1;
  const int cells = g->nx * g->ny;
  g->cell_start.assign(static_cast<std::size_t>(kNumGroups) * cells + 1, 0);
  // Same float expression as the queries' cell ranges (SearchGuided), clamped before the
  // conversion, so that a point within a disc always lies in a visited cell.
  g->key.resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    if (!usable(k)) continue;
    const float fx = std::clamp((px[k] - g->x0) * g->inv_cell, 0.f, static_cast<float>(g->nx - 1));
    const float fy = std::clamp((py[k] - g->y0) * g->inv_cell, 0.f, static_cast<float>(g->ny - 1));
    g->key[k] = group_of(k) * cells + static_cast<int>(fy) * g->nx + static_cast<int>(fx);
    ++g->cell_start[g->key[k] + 1];
  }
  for (std::size_t c = 1; c < g->cell_start.size(); ++c) {
    g->cell_start[c] += g->cell_start[c - 1];
  }
  g->cursor.assign(g->cell_start.begin(), g->cell_start.end() - 1);
  g->x.resize(n);
  g->y.resize(n);
  g->index.resize(n);
  for (std::size_t k = 0; k < count; ++k) {
    if (!usable(k)) continue;
    const int s = g->cursor[g->key[k]]++;
    g->x[s] = px[k];
    g->y[s] = py[k];
    g->index[s] = id_of(k);
  }
}

}  // namespace

struct Matcher::Impl {
  MatchOptions options;
  const Kernels* kernels = nullptr;

  // --- Search inputs (indices into the query / candidate FeatureSets) and outputs. -----------
  std::vector<int> fwd_ids;         // forward query set: prev indices, sorted, unique
  std::vector<int> rev_ids;         // reverse query set (unique): matched curr indices, sorted
  std::vector<ExactTop2> fwd_best;  // per fwd_ids entry; j = original curr index
  std::vector<ExactTop2> rev_best;  // per rev_ids entry; j = original prev index
  std::vector<float> qx, qy;        // query positions (guided)
  std::vector<float> cx, cy;        // candidate positions (guided), indexed like the candidate ids
  MatchCandidates own_candidates;   // Match(prev, FeatureSet curr): curr prepared per call
  std::vector<float> prev_norms;    // reverse guided pass: squared norm per prev index
  std::vector<std::int32_t> iota;   // iota[i] = i: tie keys of candidates listed by index
  std::vector<char> mark;           // per curr index (unique)
  std::vector<int> rev_slot;        // per curr index: position in rev_ids

  // --- Exhaustive: packed queries (row-major) and candidates (panels). -----------------------
  int q_begin[kNumGroups] = {}, q_end[kNumGroups] = {}, q_count[kNumGroups] = {};
  int c_begin[kNumGroups] = {}, c_end[kNumGroups] = {}, c_count[kNumGroups] = {};
  std::vector<float> q_rows;
  std::vector<int> q_slot_of;  // per query id position -> query slot
  std::vector<float> c_panels;
  std::vector<float> c_norms;
  std::vector<int> c_index;    // candidate slot -> original index (-1 = padding)
  std::vector<int> c_slot_of;  // per id position -> slot
  // Streaming mode (few queries): candidates read in place, per group in increasing id order,
  // padded to a multiple of kStreamRows with a zero row of norm +inf.
  std::vector<const float*> s_rows;
  std::vector<float> s_norms;
  std::vector<std::int32_t> s_ids;
  std::vector<float> zero_row;
  int s_begin[kNumGroups] = {}, s_end[kNumGroups] = {}, s_count[kNumGroups] = {};
  std::vector<LaneTop2> lanes;
  std::vector<Best2> slot_best;
  struct WorkItem {
    int group, q_begin, q_end;
  };
  std::vector<WorkItem> work;

  // --- Guided: candidates bucketed in a uniform grid per Laplacian group. ------------------
  Grid own_grid;                // built per call when the candidates' prepared grid cannot serve
  std::vector<int> cand_start;  // guided: candidates of the o-th visited query are
  std::vector<std::int32_t> cand_ids;         // cand_ids[cand_start[o] .. cand_start[o + 1])
  std::vector<int> q_order, q_key, q_bucket;  // guided queries in cell order

  // --- k-d forest: per-thread search state; the queries' forest (unique's reverse pass). -----
  std::vector<matching_detail::KdScratch> kd_scratch;
  matching_detail::KdForest rev_forest;
  std::vector<std::uint8_t> rev_group;  // per prev index: group, kNumGroups = not a query

  void PackQueries(const FeatureSet& f, const std::vector<int>& ids);
  // with_norms = false leaves c_norms of real slots unset (packing queries for streaming).
  void PackCandidates(const FeatureSet& f, const std::vector<int>& ids, const float* norms_by_id,
                      int pad_to = kCandStep, bool with_norms = true);
  std::int64_t SearchStreaming(const FeatureSet& fq, const std::vector<int>& qids,
                               const FeatureSet& fc, const std::vector<int>& cids,
                               const float* cand_norms, std::vector<ExactTop2>* out);
  // cand_norms: squared norms of fc's descriptors by index, or nullptr (computed here).
  std::int64_t SearchExhaustive(const FeatureSet& fq, const std::vector<int>& qids,
                                const FeatureSet& fc, const std::vector<int>& cids,
                                const float* cand_norms, std::vector<ExactTop2>* out);
  // own_grid over candidates `ids` of f at positions cx/cy (indexed like ids).
  void BuildGrid(const FeatureSet& f, const std::vector<int>& ids, float radius);
  // Candidates: the points of fc bucketed in `grid`; cand_norms: squared norms of fc's
  // descriptors by index. check_queries names the query set ("prev") when the query
  // descriptors have not been checked finite yet: the search checks each row while it has it
  // in cache, and throws for the lowest bad index.
  std::int64_t SearchGuided(const FeatureSet& fq, const std::vector<int>& qids,
                            const FeatureSet& fc, const Grid& grid, float radius,
                            const float* cand_norms, std::vector<ExactTop2>* out,
                            const char* check_queries = nullptr);
  // Approximate top-2 of each query among the points of fc in its group (the forest's).
  std::int64_t SearchKdForest(const FeatureSet& fq, const std::vector<int>& qids,
                              const FeatureSet& fc, const matching_detail::KdForest& forest,
                              const float* cand_norms, std::vector<ExactTop2>* out);
  void CheckFinite(const FeatureSet& f, const std::vector<int>& ids, const char* which) const;
  // iota[i] = i for i < n at least.
  void EnsureIota(std::size_t n) {
    const std::size_t old_size = iota.size();
    if (old_size >= n) return;
    iota.resize(n);
    for (std::size_t i = old_size; i < n; ++i) iota[i] = static_cast<std::int32_t>(i);
  }
  // prev_norms[id] = squared norm of prev's descriptor id, for the ids of the forward queries.
  void FillPrevNorms(const FeatureSet& prev) {
    prev_norms.resize(prev.size());
    for (int id : fwd_ids) prev_norms[id] = SquaredNorm(prev.descriptor(id), prev.descriptor_size);
  }
};

void Matcher::Impl::CheckFinite(const FeatureSet& f, const std::vector<int>& ids,
                                const char* which) const {
  const std::size_t dim = f.descriptor_size;
  // Fast path: one pass over the whole array when every point is used.
  if (ids.size() == f.size() && !AnyNonFinite(f.descriptors.data(), f.descriptors.size())) return;
  for (int id : ids) {
    if (AnyNonFinite(f.descriptor(id), dim)) ThrowNonFinite(which, id, "descriptor");
  }
}

void Matcher::Impl::PackQueries(const FeatureSet& f, const std::vector<int>& ids) {
  const int dim = f.descriptor_size;
  const bool lap = options.check_laplacian;
  std::fill(std::begin(q_count), std::end(q_count), 0);
  for (int id : ids) ++q_count[GroupOf(f.keypoints[id].laplacian, lap)];
  int slot = 0;
  for (int g = 0; g < kNumGroups; ++g) {
    q_begin[g] = slot;
    slot += (q_count[g] + kQueryTile - 1) / kQueryTile * kQueryTile;
    q_end[g] = slot;
  }
  q_rows.resize(static_cast<std::size_t>(slot) * dim);
  q_slot_of.resize(ids.size());
  int cursor[kNumGroups];
  std::copy(std::begin(q_begin), std::end(q_begin), cursor);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const int s = cursor[GroupOf(f.keypoints[ids[k]].laplacian, lap)]++;
    q_slot_of[k] = s;
    std::memcpy(q_rows.data() + static_cast<std::size_t>(s) * dim, f.descriptor(ids[k]),
                sizeof(float) * dim);
  }
  for (int g = 0; g < kNumGroups; ++g) {
    for (int s = cursor[g]; s < q_end[g]; ++s) {
      std::fill_n(q_rows.data() + static_cast<std::size_t>(s) * dim, dim, 0.f);
    }
  }
}

void Matcher::Impl::PackCandidates(const FeatureSet& f, const std::vector<int>& ids,
                                   const float* norms_by_id, int pad_to, bool with_norms) {
  const int dim = f.descriptor_size;
  const bool lap = options.check_laplacian;
  std::fill(std::begin(c_count), std::end(c_count), 0);
  for (int id : ids) ++c_count[GroupOf(f.keypoints[id].laplacian, lap)];
  int slot = 0;
  for (int g = 0; g < kNumGroups; ++g) {
    c_begin[g] = slot;
    slot += (c_count[g] + pad_to - 1) / pad_to * pad_to;
    c_end[g] = slot;
  }
  c_panels.resize(static_cast<std::size_t>(slot) * dim);
  c_norms.resize(slot);
  c_index.resize(slot);
  int cursor[kNumGroups];
  std::copy(std::begin(c_begin), std::end(c_begin), cursor);
  const auto panel_ptr = [&](int s) {
    return c_panels.data() + static_cast<std::size_t>(s / kPanelWidth) * dim * kPanelWidth +
           s % kPanelWidth;
  };
  c_slot_of.resize(ids.size());
  std::size_t pos = 0;
  for (int id : ids) {
    const int s = cursor[GroupOf(f.keypoints[id].laplacian, lap)]++;
    const float* d = f.descriptor(id);
    float* p = panel_ptr(s);
    for (int k = 0; k < dim; ++k) p[k * kPanelWidth] = d[k];
    if (with_norms) c_norms[s] = norms_by_id != nullptr ? norms_by_id[id] : SquaredNorm(d, dim);
    c_index[s] = id;
    c_slot_of[pos++] = s;
  }
  for (int g = 0; g < kNumGroups; ++g) {
    for (int s = cursor[g]; s < c_end[g]; ++s) {
      float* p = panel_ptr(s);
      for (int k = 0; k < dim; ++k) p[k * kPanelWidth] = 0.f;
      c_norms[s] = kInf;  // never better than a real candidate
      c_index[s] = -1;
    }
  }
}

std::int64_t Matcher::Impl::SearchExhaustive(const FeatureSet& fq, const std::vector<int>& qids,
                                             const FeatureSet& fc, const std::vector<int>& cids,
                                             const float* cand_norms, std::vector<ExactTop2>* out) {
  // Pack the smaller side: with few queries (a cell of clustered RANSAC) transposing every
  // candidate would cost more than the distances themselves.
  if (qids.size() <= static_cast<std::size_t>(kMaxStreamingQueries) &&
      qids.size() * 2 <= cids.size()) {
    return SearchStreaming(fq, qids, fc, cids, cand_norms, out);
  }
  const int dim = fq.descriptor_size;
  PackQueries(fq, qids);
  PackCandidates(fc, cids, cand_norms);
  const int q_slots = q_end[kNumGroups - 1];
  lanes.resize(q_slots);
  slot_best.resize(q_slots);
  work.clear();
  std::int64_t comparisons = 0;
  for (int g = 0; g < kNumGroups; ++g) {
    if (q_count[g] == 0) continue;
    if (c_count[g] == 0) {
      for (int s = q_begin[g]; s < q_end[g]; ++s) slot_best[s] = Best2{kInf, kInf, -1, -1};
      continue;
    }
    comparisons += static_cast<std::int64_t>(q_count[g]) * c_count[g];
    for (int s = q_begin[g]; s < q_end[g]; s += kTilesPerItem * kQueryTile) {
      work.push_back({g, s, std::min(q_end[g], s + kTilesPerItem * kQueryTile)});
    }
  }
  const int block = std::max(
      kCandStep, kBlockBytes / (dim * static_cast<int>(sizeof(float))) / kCandStep * kCandStep);
  const int num_threads =
      comparisons >= kMinPairsForThreads ? ResolveThreadCount(options.num_threads) : 1;
  const int num_items = static_cast<int>(work.size());
  const matching_detail::TileFn tile = kernels->tile;
  ParallelFor(num_threads, num_items, 1, [&](long item_begin, long item_end, int /*worker*/) {
    for (int w = static_cast<int>(item_begin); w < item_end; ++w) {
      const WorkItem item = work[w];
      for (int s = item.q_begin; s < item.q_end; ++s) matching_detail::ResetLanes(&lanes[s]);
      for (int cb = c_begin[item.group]; cb < c_end[item.group]; cb += block) {
        if (CancelRequested()) break;  // core/cancel.h; thrown after the loop
        const int n = std::min(block, c_end[item.group] - cb);
        const float* panels = c_panels.data() + static_cast<std::size_t>(cb) * dim;
        for (int s = item.q_begin; s < item.q_end; s += kQueryTile) {
          tile(q_rows.data() + static_cast<std::size_t>(s) * dim, dim, panels, c_norms.data() + cb,
               cb, n, &lanes[s]);
        }
      }
      for (int s = item.q_begin; s < item.q_end; ++s) {
        slot_best[s] = matching_detail::ReduceLanes(lanes[s]);
      }
    }
  });
  ThrowIfCancelled("descriptor matching");
  out->resize(qids.size());
  for (std::size_t k = 0; k < qids.size(); ++k) {
    const Best2& b = slot_best[q_slot_of[k]];
    const int j1 = b.j1 >= 0 ? c_index[b.j1] : -1;
    const int j2 = b.j2 >= 0 ? c_index[b.j2] : -1;
    (*out)[k] =
        MakeExact(kernels->exact, fq.descriptor(qids[k]), dim, j1,
                  j1 >= 0 ? fc.descriptor(j1) : nullptr, j2, j2 >= 0 ? fc.descriptor(j2) : nullptr);
  }
  return comparisons;
}

std::int64_t Matcher::Impl::SearchStreaming(const FeatureSet& fq, const std::vector<int>& qids,
                                            const FeatureSet& fc, const std::vector<int>& cids,
                                            const float* cand_norms, std::vector<ExactTop2>* out) {
  const int dim = fq.descriptor_size;
  const bool lap = options.check_laplacian;
  // Queries in panels (the candidate packing, reused): c_* now describe the queries, whose
  // norms the streaming kernel does not use.
  PackCandidates(fq, qids, nullptr, kPanelWidth, /*with_norms=*/false);
  // Candidate streams per group.
  std::fill(std::begin(s_count), std::end(s_count), 0);
  for (int id : cids) ++s_count[GroupOf(fc.keypoints[id].laplacian, lap)];
  int n = 0;
  for (int g = 0; g < kNumGroups; ++g) {
    s_begin[g] = n;
    n += (s_count[g] + kStreamRows - 1) / kStreamRows * kStreamRows;
    s_end[g] = n;
  }
  zero_row.assign(dim, 0.f);
  s_rows.resize(n);
  s_norms.resize(n);
  s_ids.resize(n);
  int cursor[kNumGroups];
  std::copy(std::begin(s_begin), std::end(s_begin), cursor);
  for (int id : cids) {
    const int k = cursor[GroupOf(fc.keypoints[id].laplacian, lap)]++;
    s_rows[k] = fc.descriptor(id);
    s_norms[k] = cand_norms != nullptr ? cand_norms[id] : SquaredNorm(s_rows[k], dim);
    s_ids[k] = id;
  }
  for (int g = 0; g < kNumGroups; ++g) {
    for (int k = cursor[g]; k < s_end[g]; ++k) {
      s_rows[k] = zero_row.data();
      s_norms[k] = kInf;
      s_ids[k] = -1;
    }
  }
  // Work items: panel ranges of one group.
  const int num_panels = c_end[kNumGroups - 1] / kPanelWidth;
  lanes.resize(num_panels);
  work.clear();
  std::int64_t comparisons = 0;
  constexpr int kPanelsPerItem = 16;  // 128 queries: 32 KB of 64-d panels, L1/L2 resident
  for (int g = 0; g < kNumGroups; ++g) {
    const int p0 = c_begin[g] / kPanelWidth, p1 = c_end[g] / kPanelWidth;
    for (int p = p0; p < p1; ++p) matching_detail::ResetLanes(&lanes[p]);
    if (c_count[g] == 0 || s_count[g] == 0) continue;
    comparisons += static_cast<std::int64_t>(c_count[g]) * s_count[g];
    for (int p = p0; p < p1; p += kPanelsPerItem) {
      work.push_back({g, p, std::min(p1, p + kPanelsPerItem)});
    }
  }
  const int num_threads =
      comparisons >= kMinPairsForThreads ? ResolveThreadCount(options.num_threads) : 1;
  const int num_items = static_cast<int>(work.size());
  const matching_detail::StreamFn stream = kernels->stream;
  ParallelFor(num_threads, num_items, 1, [&](long item_begin, long item_end, int /*worker*/) {
    for (int w = static_cast<int>(item_begin); w < item_end; ++w) {
      const WorkItem item = work[w];
      const float* panels =
          c_panels.data() + static_cast<std::size_t>(item.q_begin) * dim * kPanelWidth;
      for (int k = s_begin[item.group]; k < s_end[item.group]; k += kStreamRows) {
        if (CancelRequested()) break;  // core/cancel.h; thrown after the loop
        stream(&s_rows[k], &s_norms[k], &s_ids[k], dim, panels, item.q_end - item.q_begin,
               &lanes[item.q_begin]);
      }
    }
  });
  ThrowIfCancelled("descriptor matching");
  out->resize(qids.size());
  for (std::size_t k = 0; k < qids.size(); ++k) {
    const int slot = c_slot_of[k];
    const LaneTop2& st = lanes[slot / kPanelWidth];
    const int lane = slot % kPanelWidth;
    const int j1 = st.i1[lane], j2 = st.i2[lane];
    (*out)[k] =
        MakeExact(kernels->exact, fq.descriptor(qids[k]), dim, j1,
                  j1 >= 0 ? fc.descriptor(j1) : nullptr, j2, j2 >= 0 ? fc.descriptor(j2) : nullptr);
  }
  return comparisons;
}

void Matcher::Impl::BuildGrid(const FeatureSet& f, const std::vector<int>& ids, float radius) {
  const bool lap = options.check_laplacian;
  FillGrid(
      ids.size(), cx.data(), cy.data(),
      [&](std::size_t k) { return GroupOf(f.keypoints[ids[k]].laplacian, lap); },
      [&](std::size_t k) { return ids[k]; }, radius, &own_grid);
}

// Query positions are taken from qx/qy (indexed like `qids`), candidate positions from cx/cy.
std::int64_t Matcher::Impl::SearchGuided(const FeatureSet& fq, const std::vector<int>& qids,
                                         const FeatureSet& fc, const Grid& grid, float radius,
                                         const float* cand_norms, std::vector<ExactTop2>* out,
                                         const char* check_queries) {
  const int dim = fq.descriptor_size;
  const bool lap = options.check_laplacian;
  const float g_x0 = grid.x0, g_y0 = grid.y0, g_inv_cell = grid.inv_cell;
  const int g_nx = grid.nx, g_ny = grid.ny;
  // Candidates are listed by index and their rows read in place: each is compared with the
  // few queries whose discs hold it, so copying the rows into grid order would cost more than
  // the comparisons it speeds up.
  EnsureIota(fc.size());
  const int num_threads = static_cast<int>(qids.size()) >= kMinGuidedQueriesForThreads
                              ? ResolveThreadCount(options.num_threads)
                              : 1;
  out->resize(qids.size());
  const int nq = static_cast<int>(qids.size());
  const int cells = g_nx * g_ny;
  const float r2 = radius * radius;
  const matching_detail::ListFn list = kernels->list;
  // Visit order. With many candidates per query (a wide disc over dense points) each candidate
  // row is read by many queries: visiting the queries in grid-cell order of their predicted
  // positions makes consecutive queries read the same rows while they are in cache. With few
  // (a tight final pass: ~1 per query) there is no reuse to gain, and the given order reads the
  // query rows sequentially instead of at random.
  q_order.resize(nq);
  q_key.resize(nq);
  const double cell_area = 1.0 / (static_cast<double>(g_inv_cell) * g_inv_cell);
  const double per_cell =
      static_cast<double>(grid.x.size()) / (static_cast<double>(kNumGroups) * std::max(cells, 1));
  const bool spatial_order = per_cell * kPi * r2 / cell_area >= kGuidedSortMinCandidates;
  if (spatial_order) q_bucket.assign(static_cast<std::size_t>(kNumGroups) * cells + 1, 0);
  for (int k = 0; k < nq; ++k) {
    const float fx = std::clamp((qx[k] - g_x0) * g_inv_cell, 0.f, static_cast<float>(g_nx - 1));
    const float fy = std::clamp((qy[k] - g_y0) * g_inv_cell, 0.f, static_cast<float>(g_ny - 1));
    q_key[k] = GroupOf(fq.keypoints[qids[k]].laplacian, lap) * cells + static_cast<int>(fy) * g_nx +
               static_cast<int>(fx);
    if (spatial_order) ++q_bucket[q_key[k] + 1];
  }
  if (spatial_order) {
    for (std::size_t c = 1; c < q_bucket.size(); ++c) q_bucket[c] += q_bucket[c - 1];
    for (int k = 0; k < nq; ++k) q_order[q_bucket[q_key[k]]++] = k;
  } else {
    for (int k = 0; k < nq; ++k) q_order[k] = k;
  }
  // Pass 1, positions only: the candidates of every query, in visiting order. Knowing them in
  // advance lets pass 2 fetch the descriptor rows of later queries while it compares the
  // current one; the rows are scattered over arrays larger than L2, so without that each
  // comparison would wait for memory (BENCHMARKS.md, "Matcher thresholds").
  cand_start.resize(static_cast<std::size_t>(nq) + 1);
  // Branch-free append: every scanned slot is written and the count advances only for those in
  // the disc (whether a slot is in the disc is a coin flip for the branch predictor). The buffer
  // grows, before each row of cells, to hold the row's slots.
  std::size_t count = 0;
  const float* gx = grid.x.data();
  const float* gy = grid.y.data();
  const std::int32_t* gi = grid.index.data();
  for (int o = 0; o < nq; ++o) {
    cand_start[o] = static_cast<int>(count);
    const int k = q_order[o];
    const float x = qx[k], y = qy[k];
    const float fx0 = (x - radius - g_x0) * g_inv_cell, fx1 = (x + radius - g_x0) * g_inv_cell;
    const float fy0 = (y - radius - g_y0) * g_inv_cell, fy1 = (y + radius - g_y0) * g_inv_cell;
    if (!(fx1 >= 0.f && fy1 >= 0.f && fx0 < static_cast<float>(g_nx) &&
          fy0 < static_cast<float>(g_ny))) {
      continue;
    }
    // Clamp in float before converting: predictions may lie far outside the grid.
    const int ix0 = static_cast<int>(std::max(fx0, 0.f));
    const int ix1 = static_cast<int>(std::min(fx1, static_cast<float>(g_nx - 1)));
    const int iy0 = static_cast<int>(std::max(fy0, 0.f));
    const int iy1 = static_cast<int>(std::min(fy1, static_cast<float>(g_ny - 1)));
    const int* row_start = grid.cell_start.data() + q_key[k] / cells * cells + ix0;
    for (int iy = iy0; iy <= iy1; ++iy) {
      // Cells ix0..ix1 of one row are consecutive slots.
      const int s0 = row_start[iy * g_nx];
      const int s1 = row_start[iy * g_nx + ix1 - ix0 + 1];
      if (count + static_cast<std::size_t>(s1 - s0) > cand_ids.size()) {
        cand_ids.resize(std::max(2 * cand_ids.size(), count + (s1 - s0) + 1024));
      }
      std::int32_t* out_ids = cand_ids.data();
      for (int s = s0; s < s1; ++s) {
        const float dx = gx[s] - x, dy = gy[s] - y;
        out_ids[count] = gi[s];
        count += dx * dx + dy * dy <= r2 ? 1 : 0;
      }
    }
  }
  cand_start[nq] = static_cast<int>(count);
  const std::int64_t comparisons = static_cast<std::int64_t>(count);
  const std::size_t row_bytes = static_cast<std::size_t>(dim) * sizeof(float);
  const auto prefetch_row = [row_bytes](const float* row) {
    const char* p = reinterpret_cast<const char*>(row);
    for (std::size_t b = 0; b < row_bytes; b += 64) __builtin_prefetch(p + b);
  };
  // Rows of non-finite values only make the SSDs NaN until the throw below.
  const bool check = check_queries != nullptr;
  std::atomic<bool> any_bad{false};
  ParallelFor(num_threads, nq, 64, [&](long o_begin, long o_end, int /*worker*/) {
    for (int o = static_cast<int>(o_begin); o < o_end; ++o) {
      if (CancelRequested()) return;  // core/cancel.h; thrown after the loop
      if (o + kGuidedPrefetchDistance < nq) {
        const int ahead = o + kGuidedPrefetchDistance;
        prefetch_row(fq.descriptor(qids[q_order[ahead]]));
        const int c1 = std::min(cand_start[ahead + 1], cand_start[ahead] + kGuidedPrefetchRows);
        for (int c = cand_start[ahead]; c < c1; ++c) prefetch_row(fc.descriptor(cand_ids[c]));
      }
      const int k = q_order[o];
      const int c0 = cand_start[o], num = cand_start[o + 1] - c0;
      Best2 b{kInf, kInf, -1, -1};
      const float* q = fq.descriptor(qids[k]);
      if (check && AnyNonFinite(q, static_cast<std::size_t>(dim))) {
        any_bad.store(true, std::memory_order_relaxed);
      }
      if (num > 2) {
        list(q, dim, fc.descriptors.data(), cand_norms, cand_ids.data() + c0, num, iota.data(), &b);
      } else if (num > 0) {
        // The top two of at most two candidates are the candidates themselves, and MakeExact
        // orders them by the exact SSD: the float ranking would change nothing.
        b.j1 = cand_ids[c0];
        b.j2 = num == 2 ? cand_ids[c0 + 1] : -1;
      }
      // Exact SSDs now, while the query and candidate rows are in cache.
      (*out)[k] = MakeExact(kernels->exact, q, dim, b.j1, b.j1 >= 0 ? fc.descriptor(b.j1) : nullptr,
                            b.j2, b.j2 >= 0 ? fc.descriptor(b.j2) : nullptr);
    }
  });
  ThrowIfCancelled("guided matching");
  if (any_bad.load()) CheckFinite(fq, qids, check_queries);  // throws for the lowest bad index
  return comparisons;
}

std::int64_t Matcher::Impl::SearchKdForest(const FeatureSet& fq, const std::vector<int>& qids,
                                           const FeatureSet& fc,
                                           const matching_detail::KdForest& forest,
                                           const float* cand_norms, std::vector<ExactTop2>* out) {
  const int dim = fq.descriptor_size;
  const bool lap = options.check_laplacian;
  EnsureIota(fc.size());
  const int nq = static_cast<int>(qids.size());
  const int num_threads =
      nq >= kMinKdQueriesForThreads ? ResolveThreadCount(options.num_threads) : 1;
  if (kd_scratch.size() < static_cast<std::size_t>(num_threads)) kd_scratch.resize(num_threads);
  out->resize(qids.size());
  const matching_detail::ListFn list = kernels->list;
  const int max_checks = options.kd_max_checks;
  std::atomic<std::int64_t> comparisons{0};
  // Each query's search depends only on the query and the forest, so the result does not
  // depend on the thread count or schedule.
  ParallelFor(num_threads, nq, 64, [&](long k_begin, long k_end, int worker) {
    std::int64_t chunk_comparisons = 0;
    for (int k = static_cast<int>(k_begin); k < k_end; ++k) {
      if (CancelRequested()) break;  // core/cancel.h; thrown after the loop
      const float* q = fq.descriptor(qids[k]);
      const int g = GroupOf(fq.keypoints[qids[k]].laplacian, lap);
      if (forest.group_size(g) == 0) {
        (*out)[k] = ExactTop2{};
        continue;
      }
      Best2 b;
      chunk_comparisons += forest.Search(g, q, fc.descriptors.data(), cand_norms, iota.data(), list,
                                         max_checks, &kd_scratch[worker], &b);
      (*out)[k] = MakeExact(kernels->exact, q, dim, b.j1, b.j1 >= 0 ? fc.descriptor(b.j1) : nullptr,
                            b.j2, b.j2 >= 0 ? fc.descriptor(b.j2) : nullptr);
    }
    comparisons.fetch_add(chunk_comparisons, std::memory_order_relaxed);
  });
  ThrowIfCancelled("k-d forest matching");
  return comparisons.load();
}

Matcher::Matcher(const MatchOptions& options) : impl_(nullptr) {
  Validate(options);
  impl_ = new Impl;
  impl_->options = options;
  impl_->kernels = &matching_detail::SelectKernels(options.use_avx2);
}

Matcher::~Matcher() { delete impl_; }

Matcher::Matcher(Matcher&& other) noexcept : impl_(other.impl_) { other.impl_ = nullptr; }

Matcher& Matcher::operator=(Matcher&& other) noexcept {
  if (this != &other) {
    delete impl_;
    impl_ = other.impl_;
    other.impl_ = nullptr;
  }
  return *this;
}

const MatchOptions& Matcher::options() const { return impl_->options; }

MatchCandidates::MatchCandidates() : grid_(std::make_unique<Grid>()) {}
MatchCandidates::MatchCandidates(const FeatureSet& features) : MatchCandidates() {
  Reset(features);
}
MatchCandidates::~MatchCandidates() = default;
// Moves leave the source without a grid; Reset gives it a new one.
MatchCandidates::MatchCandidates(MatchCandidates&&) noexcept = default;
MatchCandidates& MatchCandidates::operator=(MatchCandidates&&) noexcept = default;

void MatchCandidates::Reset(const FeatureSet& f) {
  CheckFeatureSet(f, "curr");
  features_ = nullptr;  // not ready until every check has passed
  if (!grid_) grid_ = std::make_unique<Grid>();
  const int n = static_cast<int>(f.size());
  norms_.resize(static_cast<std::size_t>(n));
  grid_built_ = false;
  if (forest_) forest_->Clear();
  // A non-finite norm is exactly a non-finite value (or one whose square overflows), so this is
  // also the check of the descriptors.
  for (int i = 0; i < n; ++i) {
    norms_[i] = SquaredNorm(f.descriptor(i), f.descriptor_size);
    if (!std::isfinite(norms_[i])) {
      ThrowNonFinite("curr", i, "descriptor (or values whose squares overflow)");
    }
    const Keypoint& kp = f.keypoints[static_cast<std::size_t>(i)];
    if (!std::isfinite(kp.x) || !std::isfinite(kp.y)) ThrowNonFinite("curr", i, "position");
  }
  features_ = &f;
}

const MatchCandidates::Grid& MatchCandidates::grid() const {
  if (!grid_built_) {
    Grid& g = *grid_;
    // Positions, groups and extent in one pass over the keypoints (Reset checked them finite).
    const FeatureSet& f = *features_;
    const std::size_t n = f.size();
    g.px.resize(n);
    g.py.resize(n);
    g.group.resize(n);
    float x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
    for (std::size_t i = 0; i < n; ++i) {
      const Keypoint& kp = f.keypoints[i];
      g.px[i] = kp.x;
      g.py[i] = kp.y;
      g.group[i] = static_cast<std::uint8_t>(GroupOf(kp.laplacian, true));
      x0 = std::min(x0, kp.x);
      x1 = std::max(x1, kp.x);
      y0 = std::min(y0, kp.y);
      y1 = std::max(y1, kp.y);
    }
    g.extent[0] = x0;
    g.extent[1] = y0;
    g.extent[2] = x1;
    g.extent[3] = y1;
    const std::uint8_t* group = g.group.data();
    FillGrid(
        g.px.size(), g.px.data(), g.py.data(), [group](std::size_t k) { return int{group[k]}; },
        [](std::size_t k) { return static_cast<std::int32_t>(k); }, 0.0, &g, g.extent);
    grid_built_ = true;
  }
  return *grid_;
}

const matching_detail::KdForest& MatchCandidates::kd_forest(int trees, std::uint64_t seed,
                                                            bool check_laplacian) const {
  if (!forest_) forest_ = std::make_unique<matching_detail::KdForest>();
  matching_detail::KdForest& forest = *forest_;
  if (!forest.built() || forest.trees_per_group() != trees || forest.seed() != seed ||
      forest_laplacian_ != check_laplacian) {
    const FeatureSet& f = *features_;
    const int n = static_cast<int>(f.size());
    std::vector<std::uint8_t> group(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      group[i] = static_cast<std::uint8_t>(GroupOf(f.keypoints[i].laplacian, check_laplacian));
    }
    forest.Build(f.descriptors.data(), f.descriptor_size, group.data(), n, kNumGroups, trees, seed);
    forest_laplacian_ = check_laplacian;
  }
  return forest;
}

MatchResult Matcher::Match(const FeatureSet& prev, const FeatureSet& curr,
                           const std::vector<int>& prev_subset,
                           const std::optional<Eigen::Matrix<double, 2, 3>>& curr_from_prev_prior) {
  const Stopwatch watch;
  CheckFeatureSet(prev, "prev");
  impl_->own_candidates.Reset(curr);
  MatchResult r = Match(prev, impl_->own_candidates, prev_subset, curr_from_prev_prior);
  r.time_ms = watch.elapsed_ms();
  return r;
}

MatchResult Matcher::Match(const FeatureSet& prev, const MatchCandidates& candidates,
                           const std::vector<int>& prev_subset,
                           const std::optional<Eigen::Matrix<double, 2, 3>>& curr_from_prev_prior) {
  const Stopwatch watch;
  Impl& m = *impl_;
  const MatchOptions& o = m.options;
  if (!candidates.ready()) {
    throw InvalidArgument("Matcher::Match: MatchCandidates used before Reset");
  }
  const FeatureSet& curr = candidates.features();
  CheckFeatureSet(prev, "prev");
  if (prev.descriptor_size != curr.descriptor_size) {
    throw InvalidArgument("Matcher::Match: descriptor sizes differ (prev " +
                          std::to_string(prev.descriptor_size) + ", curr " +
                          std::to_string(curr.descriptor_size) + ")");
  }
  const int n_prev = static_cast<int>(prev.size());
  const int n_curr = static_cast<int>(curr.size());

  // Forward query set: the subset (sorted, duplicates dropped) or every prev point.
  m.fwd_ids.clear();
  if (prev_subset.empty()) {
    m.fwd_ids.resize(n_prev);
    for (int i = 0; i < n_prev; ++i) m.fwd_ids[i] = i;
  } else {
    for (int id : prev_subset) {
      if (id < 0 || id >= n_prev) {
        throw InvalidArgument("Matcher::Match: prev_subset index " + std::to_string(id) +
                              " out of range [0, " + std::to_string(n_prev) + ")");
      }
    }
    m.fwd_ids.assign(prev_subset.begin(), prev_subset.end());
    std::sort(m.fwd_ids.begin(), m.fwd_ids.end());
    m.fwd_ids.erase(std::unique(m.fwd_ids.begin(), m.fwd_ids.end()), m.fwd_ids.end());
  }
  if (curr_from_prev_prior && !curr_from_prev_prior->allFinite()) {
    throw InvalidArgument("Matcher::Match: curr_from_prev_prior has non-finite entries");
  }

  MatchResult result;
  if (m.fwd_ids.empty() || n_curr == 0) {
    result.time_ms = watch.elapsed_ms();
    return result;
  }
  const bool guided = curr_from_prev_prior.has_value();
  // The guided search checks the query rows itself, as it reads them (one pass over them
  // instead of two: the final pass of clustered RANSAC queries every prev point).
  if (!guided) m.CheckFinite(prev, m.fwd_ids, "prev");
  // All curr points are candidates; m.rev_ids doubles as the "all curr" id list here.
  m.rev_ids.resize(n_curr);
  for (int i = 0; i < n_curr; ++i) m.rev_ids[i] = i;
  const float* curr_norms = candidates.squared_norms().data();

  const float radius = o.guided_radius_px;
  Eigen::Matrix<double, 2, 3> A = Eigen::Matrix<double, 2, 3>::Zero();
  if (guided) {
    A = *curr_from_prev_prior;
    const std::size_t nq = m.fwd_ids.size();
    m.qx.resize(nq);
    m.qy.resize(nq);
    for (std::size_t k = 0; k < nq; ++k) {
      const Keypoint& kp = prev.keypoints[m.fwd_ids[k]];
      if (!std::isfinite(kp.x) || !std::isfinite(kp.y))
        ThrowNonFinite("prev", m.fwd_ids[k], "position");
      m.qx[k] = static_cast<float>(A(0, 0) * kp.x + A(0, 1) * kp.y + A(0, 2));
      m.qy[k] = static_cast<float>(A(1, 0) * kp.x + A(1, 1) * kp.y + A(1, 2));
      // An extreme prior can overflow (inf, or inf - inf = NaN): such a point has no candidate.
      if (!std::isfinite(m.qx[k]) || !std::isfinite(m.qy[k])) m.qx[k] = m.qy[k] = kInf;
    }
    // The prepared grid groups by Laplacian sign; without the sign check all candidates form
    // one group, so the grid is built here.
    const Grid* grid = &candidates.grid();
    if (!o.check_laplacian) {
      m.cx.resize(n_curr);
      m.cy.resize(n_curr);
      for (int i = 0; i < n_curr; ++i) {
        m.cx[i] = curr.keypoints[i].x;
        m.cy[i] = curr.keypoints[i].y;
      }
      m.BuildGrid(curr, m.rev_ids, radius);
      grid = &m.own_grid;
    }
    result.num_comparisons +=
        m.SearchGuided(prev, m.fwd_ids, curr, *grid, radius, curr_norms, &m.fwd_best, "prev");
  } else if (UseKdForest(o, static_cast<std::size_t>(n_curr))) {
    const matching_detail::KdForest& forest =
        candidates.kd_forest(o.kd_trees, o.kd_seed, o.check_laplacian);
    result.num_comparisons +=
        m.SearchKdForest(prev, m.fwd_ids, curr, forest, curr_norms, &m.fwd_best);
  } else {
    result.num_comparisons +=
        m.SearchExhaustive(prev, m.fwd_ids, curr, m.rev_ids, curr_norms, &m.fwd_best);
  }

  // Decisions on exact SSDs (double, from the stored floats) of the two best candidates.
  const double threshold = static_cast<double>(o.match_threshold_percent) / 100.0 * kMaxSsd;
  const double ratio = o.max_ratio;
  std::vector<aerovo::Match>& out = result.matches;
  for (std::size_t k = 0; k < m.fwd_ids.size(); ++k) {
    const ExactTop2& b = m.fwd_best[k];
    if (b.j1 < 0) continue;
    const double s1 = b.s1, s2 = b.s2;
    const int j1 = b.j1, j2 = b.j2;
    if (!(s1 <= threshold)) continue;
    if (j2 >= 0) {
      // second == 0 means two identical best candidates: ambiguous, rejected (as MATLAB's
      // 0/0 ratio, which fails its <= test).
      if (!(s2 > 0.0 && s1 <= ratio * s2)) continue;
    } else if (!o.accept_single_candidate) {
      continue;
    }
    out.push_back({m.fwd_ids[k], j1, static_cast<float>(s1)});
  }

  if (o.unique && !out.empty()) {
    // Reverse pass: each matched curr point against the same query set (same Laplacian group,
    // same guided disc), keeping the pair only if the prev point is its best.
    m.mark.assign(n_curr, 0);
    for (const aerovo::Match& mt : out) m.mark[mt.curr_index] = 1;
    m.rev_ids.clear();
    m.rev_slot.resize(n_curr);
    for (int i = 0; i < n_curr; ++i) {
      if (m.mark[i]) {
        m.rev_slot[i] = static_cast<int>(m.rev_ids.size());
        m.rev_ids.push_back(i);
      }
    }
    if (guided) {
      const std::size_t nq = m.fwd_ids.size();
      m.cx.resize(nq);
      m.cy.resize(nq);
      std::copy(m.qx.begin(), m.qx.begin() + nq, m.cx.begin());
      std::copy(m.qy.begin(), m.qy.begin() + nq, m.cy.begin());
      m.qx.resize(m.rev_ids.size());
      m.qy.resize(m.rev_ids.size());
      for (std::size_t k = 0; k < m.rev_ids.size(); ++k) {
        m.qx[k] = curr.keypoints[m.rev_ids[k]].x;
        m.qy[k] = curr.keypoints[m.rev_ids[k]].y;
      }
      m.FillPrevNorms(prev);
      m.BuildGrid(prev, m.fwd_ids, radius);
      result.num_comparisons += m.SearchGuided(curr, m.rev_ids, prev, m.own_grid, radius,
                                               m.prev_norms.data(), &m.rev_best);
    } else if (UseKdForest(o, m.fwd_ids.size())) {
      // A forest over the queries, built per call (the query set is the call's).
      m.FillPrevNorms(prev);
      m.rev_group.assign(prev.size(), static_cast<std::uint8_t>(kNumGroups));
      for (int id : m.fwd_ids) {
        m.rev_group[id] =
            static_cast<std::uint8_t>(GroupOf(prev.keypoints[id].laplacian, o.check_laplacian));
      }
      m.rev_forest.Build(prev.descriptors.data(), prev.descriptor_size, m.rev_group.data(), n_prev,
                         kNumGroups, o.kd_trees, o.kd_seed);
      result.num_comparisons +=
          m.SearchKdForest(curr, m.rev_ids, prev, m.rev_forest, m.prev_norms.data(), &m.rev_best);
    } else {
      result.num_comparisons +=
          m.SearchExhaustive(curr, m.rev_ids, prev, m.fwd_ids, nullptr, &m.rev_best);
    }
    std::size_t kept = 0;
    for (const aerovo::Match& mt : out) {
      // p must be the exact best of the reverse top-2 (the exact SSD is symmetric in its operands,
      // so p's value here equals the forward one).
      const ExactTop2& b = m.rev_best[m.rev_slot[mt.curr_index]];
      const bool best = b.j1 == mt.prev_index;
      if (best) out[kept++] = mt;
    }
    out.resize(kept);
  }
  result.time_ms = watch.elapsed_ms();
  return result;
}

}  // namespace aerovo
