// Internal SIMD kernels of the matcher: best and second-best candidate of a query descriptor by
// the score  s = |c|^2 - 2 q.c  (= SSD(q, c) - |q|^2, so it ranks candidates of one query
// exactly as the SSD does). Not part of the public API; used by matcher.cc and the benchmark.
#pragma once

#include <cstdint>

namespace aerovo::matching_detail {

/// Candidates are packed in panels of kPanelWidth descriptors stored dimension-major
/// (panel[d * kPanelWidth + j] = component d of candidate j), so that one SIMD load gives one
/// component of 8 candidates. A slot is a candidate's position in the packed array.
inline constexpr int kPanelWidth = 8;
/// Queries processed together by the tile kernel (their rows are contiguous).
inline constexpr int kQueryTile = 4;
/// Candidate slots consumed per tile-kernel step; packed candidate groups are padded to it.
inline constexpr int kCandStep = 16;

/// Top-2 state of one query, per SIMD lane (lane j sees slots = j mod 8). Slots -1 = none.
struct LaneTop2 {
  float b1[kPanelWidth];
  float b2[kPanelWidth];
  std::int32_t i1[kPanelWidth];
  std::int32_t i2[kPanelWidth];
};

/// Best and second-best (score, slot) of one query; slot -1 = none.
struct Best2 {
  float s1;
  float s2;
  std::int32_t j1;
  std::int32_t j2;
};

/// Updates the LaneTop2 state of kQueryTile queries (rows at `queries`, stride `dim`) with the
/// `num_slots` (multiple of kCandStep) candidates starting at `panels` (the first panel of the
/// range), whose squared norms are `norms[0..num_slots)`; slot numbers reported are
/// slot_base + k. Padding slots must have norm +inf.
using TileFn = void (*)(const float* queries, int dim, const float* panels, const float* norms,
                        int slot_base, int num_slots, LaneTop2* state);

/// Best2 of one query over an explicit list of candidate slots (rows stored row-major with
/// stride dim, squared norms `norms`); ties go to the smaller tie_key[slot].
using ListFn = void (*)(const float* query, int dim, const float* rows, const float* norms,
                        const std::int32_t* slots, int num_slots, const std::int32_t* tie_key,
                        Best2* out);

/// Candidate rows consumed per call of the streaming kernel.
inline constexpr int kStreamRows = 8;

/// Streaming variant for few queries against many candidates (queries packed, candidates read
/// in place): updates the LaneTop2 state of `num_panels` query panels (lane j of panel p
/// = query slot 8p + j) with kStreamRows candidate rows `rows[k]` (pointers to `dim` floats),
/// squared norms `norms[k]` (+inf for padding) and indices `ids[k]`, which are reported as the
/// slots. Candidates must arrive in increasing id order for ties to go to the
/// lower id.
using StreamFn = void (*)(const float* const* rows, const float* norms, const std::int32_t* ids,
                          int dim, const float* panels, int num_panels, LaneTop2* state);

/// SSD in double of two float vectors of length dim: the value the match decisions are taken
/// on. Every variant computes it bit-identically (8 partial sums s[k] over d = k mod 8, tail into
/// s[0], combined as ((s0 + s4) + (s1 + s5)) + ((s2 + s6) + (s3 + s7)), no fused multiply-add),
/// so decisions do not depend on the kernel chosen.
using ExactFn = double (*)(const float* a, const float* b, int dim);

/// Squared L2 norm in float of a vector of length dim, bit-identical in every variant (8 partial
/// sums acc[l] over d = l mod 8, tail into acc[0], combined as ((a0 + a1) + (a2 + a3)) +
/// ((a4 + a5) + (a6 + a7)), no fused multiply-add).
using NormFn = float (*)(const float* d, int dim);

struct Kernels {
  TileFn tile;
  ListFn list;
  StreamFn stream;
  ExactFn exact;
  NormFn norm;
  const char* name;  ///< "avx2" or "sse4" (x86), "portable" (other targets)
};

/// The fastest kernels the CPU supports (AVX2+FMA if present and allowed, else SSE4.2).
const Kernels& SelectKernels(bool allow_avx2);

/// Inserts candidate j with score s into a running top-2 (ties: lower j; j < 0 is ignored).
inline void InsertTop2(float s, std::int32_t j, Best2* b) {
  if (j < 0) return;
  if (b->j1 < 0 || s < b->s1 || (s == b->s1 && j < b->j1)) {
    b->s2 = b->s1;
    b->j2 = b->j1;
    b->s1 = s;
    b->j1 = j;
  } else if (b->j2 < 0 || s < b->s2 || (s == b->s2 && j < b->j2)) {
    b->s2 = s;
    b->j2 = j;
  }
}

/// Reduces the 8 lanes of a LaneTop2 to the overall best and second best (ties: lower slot).
Best2 ReduceLanes(const LaneTop2& state);

/// Resets a LaneTop2 to "no candidate".
void ResetLanes(LaneTop2* state);

}  // namespace aerovo::matching_detail
