#include "aerovo/matching/distance_kernels.h"

#if defined(__x86_64__) || defined(__i386__)
#define AEROVO_X86_KERNELS 1
#include <immintrin.h>
#endif

#include <limits>

namespace aerovo::matching_detail {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

#if defined(AEROVO_X86_KERNELS)
// ---------------------------------------------------------------------------------------------
// SSE4.2 baseline (every x86-64-v2 CPU).

inline void UpdateSse(__m128 s, __m128i idx, __m128& b1, __m128& b2, __m128i& i1, __m128i& i2) {
  // Strict comparisons: among equal scores in one lane the earlier slot stays best.
  const __m128 lt1 = _mm_cmplt_ps(s, b1);
  const __m128 lt2 = _mm_cmplt_ps(s, b2);
  const __m128 fidx = _mm_castsi128_ps(idx);
  __m128 nb2 = _mm_blendv_ps(b2, s, lt2);
  __m128 ni2 = _mm_blendv_ps(_mm_castsi128_ps(i2), fidx, lt2);
  nb2 = _mm_blendv_ps(nb2, b1, lt1);
  ni2 = _mm_blendv_ps(ni2, _mm_castsi128_ps(i1), lt1);
  b1 = _mm_blendv_ps(b1, s, lt1);
  i1 = _mm_castps_si128(_mm_blendv_ps(_mm_castsi128_ps(i1), fidx, lt1));
  b2 = nb2;
  i2 = _mm_castps_si128(ni2);
}

void TileSse(const float* queries, int dim, const float* panels, const float* norms, int slot_base,
             int num_slots, LaneTop2* state) {
  __m128 b1[kQueryTile][2], b2[kQueryTile][2];
  __m128i i1[kQueryTile][2], i2[kQueryTile][2];
  for (int k = 0; k < kQueryTile; ++k) {
    for (int h = 0; h < 2; ++h) {
      b1[k][h] = _mm_loadu_ps(state[k].b1 + 4 * h);
      b2[k][h] = _mm_loadu_ps(state[k].b2 + 4 * h);
      i1[k][h] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(state[k].i1 + 4 * h));
      i2[k][h] = _mm_loadu_si128(reinterpret_cast<const __m128i*>(state[k].i2 + 4 * h));
    }
  }
  const __m128 two = _mm_set1_ps(2.f);
  const __m128i iota_lo = _mm_setr_epi32(0, 1, 2, 3);
  const __m128i iota_hi = _mm_setr_epi32(4, 5, 6, 7);
  for (int c = 0; c < num_slots; c += kPanelWidth) {
    const float* p = panels + static_cast<std::ptrdiff_t>(c) * dim;
    __m128 acc[kQueryTile][2];
    for (int k = 0; k < kQueryTile; ++k) acc[k][0] = acc[k][1] = _mm_setzero_ps();
    for (int d = 0; d < dim; ++d) {
      const __m128 lo = _mm_loadu_ps(p + d * kPanelWidth);
      const __m128 hi = _mm_loadu_ps(p + d * kPanelWidth + 4);
      for (int k = 0; k < kQueryTile; ++k) {
        const __m128 qd = _mm_set1_ps(queries[k * dim + d]);
        acc[k][0] = _mm_add_ps(acc[k][0], _mm_mul_ps(qd, lo));
        acc[k][1] = _mm_add_ps(acc[k][1], _mm_mul_ps(qd, hi));
      }
    }
    const __m128 n_lo = _mm_loadu_ps(norms + c);
    const __m128 n_hi = _mm_loadu_ps(norms + c + 4);
    const __m128i base = _mm_set1_epi32(slot_base + c);
    const __m128i idx_lo = _mm_add_epi32(base, iota_lo);
    const __m128i idx_hi = _mm_add_epi32(base, iota_hi);
    for (int k = 0; k < kQueryTile; ++k) {
      UpdateSse(_mm_sub_ps(n_lo, _mm_mul_ps(two, acc[k][0])), idx_lo, b1[k][0], b2[k][0], i1[k][0],
                i2[k][0]);
      UpdateSse(_mm_sub_ps(n_hi, _mm_mul_ps(two, acc[k][1])), idx_hi, b1[k][1], b2[k][1], i1[k][1],
                i2[k][1]);
    }
  }
  for (int k = 0; k < kQueryTile; ++k) {
    for (int h = 0; h < 2; ++h) {
      _mm_storeu_ps(state[k].b1 + 4 * h, b1[k][h]);
      _mm_storeu_ps(state[k].b2 + 4 * h, b2[k][h]);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(state[k].i1 + 4 * h), i1[k][h]);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(state[k].i2 + 4 * h), i2[k][h]);
    }
  }
}

void StreamSse(const float* const* rows, const float* norms, const std::int32_t* ids, int dim,
               const float* panels, int num_panels, LaneTop2* state) {
  const __m128 two = _mm_set1_ps(2.f);
  for (int p = 0; p < num_panels; ++p) {
    const float* pp = panels + static_cast<std::ptrdiff_t>(p) * dim * kPanelWidth;
    for (int r0 = 0; r0 < kStreamRows; r0 += 4) {
      __m128 acc[4][2];
      for (int r = 0; r < 4; ++r) acc[r][0] = acc[r][1] = _mm_setzero_ps();
      for (int d = 0; d < dim; ++d) {
        const __m128 lo = _mm_loadu_ps(pp + d * kPanelWidth);
        const __m128 hi = _mm_loadu_ps(pp + d * kPanelWidth + 4);
        for (int r = 0; r < 4; ++r) {
          const __m128 rd = _mm_set1_ps(rows[r0 + r][d]);
          acc[r][0] = _mm_add_ps(acc[r][0], _mm_mul_ps(rd, lo));
          acc[r][1] = _mm_add_ps(acc[r][1], _mm_mul_ps(rd, hi));
        }
      }
      LaneTop2& st = state[p];
      for (int h = 0; h < 2; ++h) {
        __m128 b1 = _mm_loadu_ps(st.b1 + 4 * h), b2 = _mm_loadu_ps(st.b2 + 4 * h);
        __m128i i1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(st.i1 + 4 * h));
        __m128i i2 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(st.i2 + 4 * h));
        for (int r = 0; r < 4; ++r) {
          const __m128 s = _mm_sub_ps(_mm_set1_ps(norms[r0 + r]), _mm_mul_ps(two, acc[r][h]));
          UpdateSse(s, _mm_set1_epi32(ids[r0 + r]), b1, b2, i1, i2);
        }
        _mm_storeu_ps(st.b1 + 4 * h, b1);
        _mm_storeu_ps(st.b2 + 4 * h, b2);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(st.i1 + 4 * h), i1);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(st.i2 + 4 * h), i2);
      }
    }
  }
}

inline float DotSse(const float* a, const float* b, int dim) {
  __m128 acc0 = _mm_setzero_ps(), acc1 = _mm_setzero_ps();
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
    acc0 = _mm_add_ps(acc0, _mm_mul_ps(_mm_loadu_ps(a + d), _mm_loadu_ps(b + d)));
    acc1 = _mm_add_ps(acc1, _mm_mul_ps(_mm_loadu_ps(a + d + 4), _mm_loadu_ps(b + d + 4)));
  }
  acc0 = _mm_add_ps(acc0, acc1);
  acc0 = _mm_hadd_ps(acc0, acc0);
  acc0 = _mm_hadd_ps(acc0, acc0);
  float sum = _mm_cvtss_f32(acc0);
  for (; d < dim; ++d) sum += a[d] * b[d];
  return sum;
}

inline void Push(float s, std::int32_t slot, const std::int32_t* tie_key, Best2* b) {
  const auto better = [&](float sa, std::int32_t ja, float sb, std::int32_t jb) {
    return jb < 0 || sa < sb || (sa == sb && tie_key[ja] < tie_key[jb]);
  };
  if (better(s, slot, b->s1, b->j1)) {
    b->s2 = b->s1;
    b->j2 = b->j1;
    b->s1 = s;
    b->j1 = slot;
  } else if (better(s, slot, b->s2, b->j2)) {
    b->s2 = s;
    b->j2 = slot;
  }
}

void ListSse(const float* query, int dim, const float* rows, const float* norms,
             const std::int32_t* slots, int num_slots, const std::int32_t* tie_key, Best2* out) {
  Best2 b{kInf, kInf, -1, -1};
  for (int k = 0; k < num_slots; ++k) {
    const std::int32_t j = slots[k];
    const float s =
        norms[j] - 2.f * DotSse(query, rows + static_cast<std::ptrdiff_t>(j) * dim, dim);
    Push(s, j, tie_key, &b);
  }
  *out = b;
}

// ---------------------------------------------------------------------------------------------
// AVX2 + FMA (selected at run time).

__attribute__((target("avx2,fma"))) inline void UpdateAvx2(__m256 s, __m256i idx, __m256& b1,
                                                           __m256& b2, __m256i& i1, __m256i& i2) {
  const __m256 lt1 = _mm256_cmp_ps(s, b1, _CMP_LT_OQ);
  const __m256 lt2 = _mm256_cmp_ps(s, b2, _CMP_LT_OQ);
  const __m256 fidx = _mm256_castsi256_ps(idx);
  __m256 nb2 = _mm256_blendv_ps(b2, s, lt2);
  __m256 ni2 = _mm256_blendv_ps(_mm256_castsi256_ps(i2), fidx, lt2);
  nb2 = _mm256_blendv_ps(nb2, b1, lt1);
  ni2 = _mm256_blendv_ps(ni2, _mm256_castsi256_ps(i1), lt1);
  b1 = _mm256_blendv_ps(b1, s, lt1);
  i1 = _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(i1), fidx, lt1));
  b2 = nb2;
  i2 = _mm256_castps_si256(ni2);
}

// kDim > 0: dimension known at compile time (64, 128: fully unrolled, no loop counter
// pressure); kDim == 0: run-time `dim`. The per-lane top-2 state lives in memory (L1) and is
// touched once per 16 candidates, so that the 8 accumulators, the 2 panel rows and the
// broadcast stay in registers through the dot-product loop.
template <int kDim>
__attribute__((target("avx2,fma"))) void TileAvx2(const float* queries, int dim_rt,
                                                  const float* panels, const float* norms,
                                                  int slot_base, int num_slots, LaneTop2* state) {
  const int dim = kDim > 0 ? kDim : dim_rt;
  const __m256 two = _mm256_set1_ps(2.f);
  const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i eight = _mm256_set1_epi32(kPanelWidth);
  for (int c = 0; c < num_slots; c += 2 * kPanelWidth) {
    const float* p0 = panels + static_cast<std::ptrdiff_t>(c) * dim;
    const float* p1 = p0 + static_cast<std::ptrdiff_t>(kPanelWidth) * dim;
    __m256 acc[kQueryTile][2];
    for (int k = 0; k < kQueryTile; ++k) acc[k][0] = acc[k][1] = _mm256_setzero_ps();
#pragma GCC unroll 8
    for (int d = 0; d < dim; ++d) {
      const __m256 v0 = _mm256_loadu_ps(p0 + d * kPanelWidth);
      const __m256 v1 = _mm256_loadu_ps(p1 + d * kPanelWidth);
      for (int k = 0; k < kQueryTile; ++k) {
        const __m256 qd = _mm256_broadcast_ss(queries + k * dim + d);
        acc[k][0] = _mm256_fmadd_ps(qd, v0, acc[k][0]);
        acc[k][1] = _mm256_fmadd_ps(qd, v1, acc[k][1]);
      }
    }
    const __m256 n0 = _mm256_loadu_ps(norms + c);
    const __m256 n1 = _mm256_loadu_ps(norms + c + kPanelWidth);
    const __m256i idx0 = _mm256_add_epi32(_mm256_set1_epi32(slot_base + c), iota);
    const __m256i idx1 = _mm256_add_epi32(idx0, eight);
    for (int k = 0; k < kQueryTile; ++k) {
      __m256 b1 = _mm256_loadu_ps(state[k].b1);
      __m256 b2 = _mm256_loadu_ps(state[k].b2);
      __m256i i1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(state[k].i1));
      __m256i i2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(state[k].i2));
      UpdateAvx2(_mm256_fnmadd_ps(two, acc[k][0], n0), idx0, b1, b2, i1, i2);
      UpdateAvx2(_mm256_fnmadd_ps(two, acc[k][1], n1), idx1, b1, b2, i1, i2);
      _mm256_storeu_ps(state[k].b1, b1);
      _mm256_storeu_ps(state[k].b2, b2);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(state[k].i1), i1);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(state[k].i2), i2);
    }
  }
}

void TileAvx2Any(const float* queries, int dim, const float* panels, const float* norms,
                 int slot_base, int num_slots, LaneTop2* state) {
  switch (dim) {
    case 64:
      return TileAvx2<64>(queries, dim, panels, norms, slot_base, num_slots, state);
    case 128:
      return TileAvx2<128>(queries, dim, panels, norms, slot_base, num_slots, state);
    default:
      return TileAvx2<0>(queries, dim, panels, norms, slot_base, num_slots, state);
  }
}

// R candidate rows x P query panels (R * P = 8 accumulators): the dot products, then the
// state updates in row (= id) order.
template <int kDim, int R, int P>
__attribute__((target("avx2,fma"), always_inline)) inline void StreamBlockAvx2(
    const float* const* rows, const float* norms, const std::int32_t* ids, int dim_rt,
    const float* panel0, LaneTop2* state) {
  const int dim = kDim > 0 ? kDim : dim_rt;
  __m256 acc[R][P];
  for (int r = 0; r < R; ++r) {
    for (int h = 0; h < P; ++h) acc[r][h] = _mm256_setzero_ps();
  }
#pragma GCC unroll 8
  for (int d = 0; d < dim; ++d) {
    __m256 v[P];
    for (int h = 0; h < P; ++h) {
      v[h] = _mm256_loadu_ps(panel0 + static_cast<std::ptrdiff_t>(h) * dim * kPanelWidth +
                             d * kPanelWidth);
    }
    for (int r = 0; r < R; ++r) {
      const __m256 a = _mm256_broadcast_ss(rows[r] + d);
      for (int h = 0; h < P; ++h) acc[r][h] = _mm256_fmadd_ps(a, v[h], acc[r][h]);
    }
  }
  const __m256 two = _mm256_set1_ps(2.f);
  for (int h = 0; h < P; ++h) {
    LaneTop2& st = state[h];
    __m256 b1 = _mm256_loadu_ps(st.b1);
    __m256 b2 = _mm256_loadu_ps(st.b2);
    __m256i i1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(st.i1));
    __m256i i2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(st.i2));
    for (int r = 0; r < R; ++r) {
      UpdateAvx2(_mm256_fnmadd_ps(two, acc[r][h], _mm256_set1_ps(norms[r])),
                 _mm256_set1_epi32(ids[r]), b1, b2, i1, i2);
    }
    _mm256_storeu_ps(st.b1, b1);
    _mm256_storeu_ps(st.b2, b2);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(st.i1), i1);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(st.i2), i2);
  }
}

template <int kDim>
__attribute__((target("avx2,fma"))) void StreamAvx2(const float* const* rows, const float* norms,
                                                    const std::int32_t* ids, int dim,
                                                    const float* panels, int num_panels,
                                                    LaneTop2* state) {
  const std::ptrdiff_t panel_floats = static_cast<std::ptrdiff_t>(dim) * kPanelWidth;
  int p = 0;
  for (; p + 2 <= num_panels; p += 2) {
    StreamBlockAvx2<kDim, 4, 2>(rows, norms, ids, dim, panels + p * panel_floats, state + p);
    StreamBlockAvx2<kDim, 4, 2>(rows + 4, norms + 4, ids + 4, dim, panels + p * panel_floats,
                                state + p);
  }
  if (p < num_panels) {
    StreamBlockAvx2<kDim, 8, 1>(rows, norms, ids, dim, panels + p * panel_floats, state + p);
  }
}

void StreamAvx2Any(const float* const* rows, const float* norms, const std::int32_t* ids, int dim,
                   const float* panels, int num_panels, LaneTop2* state) {
  switch (dim) {
    case 64:
      return StreamAvx2<64>(rows, norms, ids, dim, panels, num_panels, state);
    case 128:
      return StreamAvx2<128>(rows, norms, ids, dim, panels, num_panels, state);
    default:
      return StreamAvx2<0>(rows, norms, ids, dim, panels, num_panels, state);
  }
}

__attribute__((target("avx2,fma"))) inline float DotAvx2(const float* a, const float* b, int dim) {
  __m256 acc0 = _mm256_setzero_ps(), acc1 = _mm256_setzero_ps();
  int d = 0;
  for (; d + 16 <= dim; d += 16) {
    acc0 = _mm256_fmadd_ps(_mm256_loadu_ps(a + d), _mm256_loadu_ps(b + d), acc0);
    acc1 = _mm256_fmadd_ps(_mm256_loadu_ps(a + d + 8), _mm256_loadu_ps(b + d + 8), acc1);
  }
  for (; d + 8 <= dim; d += 8) {
    acc0 = _mm256_fmadd_ps(_mm256_loadu_ps(a + d), _mm256_loadu_ps(b + d), acc0);
  }
  acc0 = _mm256_add_ps(acc0, acc1);
  __m128 s = _mm_add_ps(_mm256_castps256_ps128(acc0), _mm256_extractf128_ps(acc0, 1));
  s = _mm_hadd_ps(s, s);
  s = _mm_hadd_ps(s, s);
  float sum = _mm_cvtss_f32(s);
  for (; d < dim; ++d) sum += a[d] * b[d];
  return sum;
}

// Four candidates per step: one candidate's dot is a chain of dependent FMAs (latency-bound,
// ~30 cycles with the reduction); four independent chains fill the FMA pipes. Each candidate's
// value is bit-identical to DotAvx2's (same per-candidate accumulators, and the transposed
// horizontal adds sum in the same order), so the 1-way tail and the 4-way body agree.
__attribute__((target("avx2,fma"))) void ListAvx2(const float* query, int dim, const float* rows,
                                                  const float* norms, const std::int32_t* slots,
                                                  int num_slots, const std::int32_t* tie_key,
                                                  Best2* out) {
  Best2 b{kInf, kInf, -1, -1};
  int k = 0;
  if (dim % 16 == 0) {
    for (; k + 4 <= num_slots; k += 4) {
      const float* r[4];
      for (int l = 0; l < 4; ++l) r[l] = rows + static_cast<std::ptrdiff_t>(slots[k + l]) * dim;
      __m256 a0[4], a1[4];
      for (int l = 0; l < 4; ++l) a0[l] = a1[l] = _mm256_setzero_ps();
      for (int d = 0; d < dim; d += 16) {
        const __m256 q0 = _mm256_loadu_ps(query + d), q1 = _mm256_loadu_ps(query + d + 8);
        for (int l = 0; l < 4; ++l) {
          a0[l] = _mm256_fmadd_ps(q0, _mm256_loadu_ps(r[l] + d), a0[l]);
          a1[l] = _mm256_fmadd_ps(q1, _mm256_loadu_ps(r[l] + d + 8), a1[l]);
        }
      }
      __m128 h[4];
      for (int l = 0; l < 4; ++l) {
        const __m256 v = _mm256_add_ps(a0[l], a1[l]);
        h[l] = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
      }
      const __m128 dots = _mm_hadd_ps(_mm_hadd_ps(h[0], h[1]), _mm_hadd_ps(h[2], h[3]));
      alignas(16) float dot[4];
      _mm_store_ps(dot, dots);
      for (int l = 0; l < 4; ++l) {
        const std::int32_t j = slots[k + l];
        Push(norms[j] - 2.f * dot[l], j, tie_key, &b);
      }
    }
  }
  for (; k < num_slots; ++k) {
    const std::int32_t j = slots[k];
    const float s =
        norms[j] - 2.f * DotAvx2(query, rows + static_cast<std::ptrdiff_t>(j) * dim, dim);
    Push(s, j, tie_key, &b);
  }
  *out = b;
}

#else  // not x86: portable kernels

// ---------------------------------------------------------------------------------------------
// Portable kernels (aarch64 and every other non-x86 target) until the SIMD kernels are written
// for them: the SSE4.2 kernels lane by lane, in the same order of operations (products and
// sums rounded separately: this file is compiled with -ffp-contract=off on such targets, see
// matching/CMakeLists.txt), so they return the same scores and the same matches.

inline void UpdateLane(float s, std::int32_t idx, float& b1, float& b2, std::int32_t& i1,
                       std::int32_t& i2) {
  // Strict comparisons: among equal scores in one lane the earlier slot stays best.
  const bool lt1 = s < b1, lt2 = s < b2;
  float nb2 = lt2 ? s : b2;
  std::int32_t ni2 = lt2 ? idx : i2;
  if (lt1) {
    nb2 = b1;
    ni2 = i1;
    b1 = s;
    i1 = idx;
  }
  b2 = nb2;
  i2 = ni2;
}

void TilePortable(const float* queries, int dim, const float* panels, const float* norms,
                  int slot_base, int num_slots, LaneTop2* state) {
  for (int c = 0; c < num_slots; c += kPanelWidth) {
    const float* p = panels + static_cast<std::ptrdiff_t>(c) * dim;
    float acc[kQueryTile][kPanelWidth] = {};
    for (int d = 0; d < dim; ++d) {
      for (int k = 0; k < kQueryTile; ++k) {
        const float qd = queries[k * dim + d];
        for (int l = 0; l < kPanelWidth; ++l) acc[k][l] += qd * p[d * kPanelWidth + l];
      }
    }
    for (int k = 0; k < kQueryTile; ++k) {
      for (int l = 0; l < kPanelWidth; ++l) {
        UpdateLane(norms[c + l] - 2.f * acc[k][l], slot_base + c + l, state[k].b1[l],
                   state[k].b2[l], state[k].i1[l], state[k].i2[l]);
      }
    }
  }
}

void StreamPortable(const float* const* rows, const float* norms, const std::int32_t* ids,
                    int dim, const float* panels, int num_panels, LaneTop2* state) {
  for (int p = 0; p < num_panels; ++p) {
    const float* pp = panels + static_cast<std::ptrdiff_t>(p) * dim * kPanelWidth;
    LaneTop2& st = state[p];
    for (int r = 0; r < kStreamRows; ++r) {
      float acc[kPanelWidth] = {};
      for (int d = 0; d < dim; ++d) {
        const float rd = rows[r][d];
        for (int l = 0; l < kPanelWidth; ++l) acc[l] += rd * pp[d * kPanelWidth + l];
      }
      for (int l = 0; l < kPanelWidth; ++l) {
        UpdateLane(norms[r] - 2.f * acc[l], ids[r], st.b1[l], st.b2[l], st.i1[l], st.i2[l]);
      }
    }
  }
}

// DotSse's order: two 4-lane accumulators, added lane-wise, then (l0 + l1) + (l2 + l3).
inline float DotPortable(const float* a, const float* b, int dim) {
  float acc[8] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
    for (int l = 0; l < 8; ++l) acc[l] += a[d + l] * b[d + l];
  }
  float sum = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
  for (; d < dim; ++d) sum += a[d] * b[d];
  return sum;
}

inline void Push(float s, std::int32_t slot, const std::int32_t* tie_key, Best2* b) {
  const auto better = [&](float sa, std::int32_t ja, float sb, std::int32_t jb) {
    return jb < 0 || sa < sb || (sa == sb && tie_key[ja] < tie_key[jb]);
  };
  if (better(s, slot, b->s1, b->j1)) {
    b->s2 = b->s1;
    b->j2 = b->j1;
    b->s1 = s;
    b->j1 = slot;
  } else if (better(s, slot, b->s2, b->j2)) {
    b->s2 = s;
    b->j2 = slot;
  }
}

void ListPortable(const float* query, int dim, const float* rows, const float* norms,
                  const std::int32_t* slots, int num_slots, const std::int32_t* tie_key,
                  Best2* out) {
  Best2 b{kInf, kInf, -1, -1};
  for (int k = 0; k < num_slots; ++k) {
    const std::int32_t j = slots[k];
    const float s =
        norms[j] - 2.f * DotPortable(query, rows + static_cast<std::ptrdiff_t>(j) * dim, dim);
    Push(s, j, tie_key, &b);
  }
  *out = b;
}

#endif  // x86

// Eight partial sums break the add latency chain (no -ffast-math reassociation to do it for us)
// and vectorise as four two-lane accumulators; sixteen spilled registers and were slower.
double ExactSsdScalar(const float* a, const float* b, int dim) {
  double s[8] = {};
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
    for (int k = 0; k < 8; ++k) {
      const double t = static_cast<double>(a[d + k]) - static_cast<double>(b[d + k]);
      s[k] += t * t;
    }
  }
  for (; d < dim; ++d) {
    const double t = static_cast<double>(a[d]) - static_cast<double>(b[d]);
    s[0] += t * t;
  }
  return ((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]));
}

#if defined(AEROVO_X86_KERNELS)
// The same sums, four lanes at a time: lanes 0-3 of lo are s[0..3], of hi s[4..7]. Target avx2
// without fma, so that the compiler cannot fuse the product into the sum (which would round
// differently from the scalar version).
__attribute__((target("avx2"))) double ExactSsdAvx(const float* a, const float* b, int dim) {
  __m256d lo = _mm256_setzero_pd(), hi = _mm256_setzero_pd();
  int d = 0;
  for (; d + 8 <= dim; d += 8) {
    const __m256 fa = _mm256_loadu_ps(a + d), fb = _mm256_loadu_ps(b + d);
    const __m256d tl = _mm256_sub_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(fa)),
                                     _mm256_cvtps_pd(_mm256_castps256_ps128(fb)));
    const __m256d th = _mm256_sub_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(fa, 1)),
                                     _mm256_cvtps_pd(_mm256_extractf128_ps(fb, 1)));
    lo = _mm256_add_pd(lo, _mm256_mul_pd(tl, tl));
    hi = _mm256_add_pd(hi, _mm256_mul_pd(th, th));
  }
  alignas(32) double s[8];
  _mm256_store_pd(s, lo);
  _mm256_store_pd(s + 4, hi);
  for (; d < dim; ++d) {
    const double t = static_cast<double>(a[d]) - static_cast<double>(b[d]);
    s[0] += t * t;
  }
  return ((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]));
}

#endif  // x86

float SquaredNormScalar(const float* d, int dim) {
  float acc[8] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  int k = 0;
  for (; k + 8 <= dim; k += 8) {
    for (int l = 0; l < 8; ++l) acc[l] += d[k + l] * d[k + l];
  }
  for (; k < dim; ++k) acc[0] += d[k] * d[k];
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

#if defined(AEROVO_X86_KERNELS)
// Lane l of the accumulator is acc[l] of the scalar version; avx2 without fma, as ExactSsdAvx.
__attribute__((target("avx2"))) float SquaredNormAvx(const float* d, int dim) {
  __m256 acc = _mm256_setzero_ps();
  int k = 0;
  for (; k + 8 <= dim; k += 8) {
    const __m256 v = _mm256_loadu_ps(d + k);
    acc = _mm256_add_ps(acc, _mm256_mul_ps(v, v));
  }
  alignas(32) float a[8];
  _mm256_store_ps(a, acc);
  for (; k < dim; ++k) a[0] += d[k] * d[k];
  return ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
}

bool CpuHasAvx2Fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

#endif  // x86

}  // namespace

const Kernels& SelectKernels(bool allow_avx2) {
#if defined(AEROVO_X86_KERNELS)
  static const Kernels kSse{&TileSse,        &ListSse,           &StreamSse,
                            &ExactSsdScalar, &SquaredNormScalar, "sse4"};
  static const Kernels kAvx2{&TileAvx2Any, &ListAvx2,       &StreamAvx2Any,
                             &ExactSsdAvx, &SquaredNormAvx, "avx2"};
  static const bool has_avx2 = CpuHasAvx2Fma();
  return (allow_avx2 && has_avx2) ? kAvx2 : kSse;
#else
  (void)allow_avx2;
  static const Kernels kPortable{&TilePortable,   &ListPortable,      &StreamPortable,
                                 &ExactSsdScalar, &SquaredNormScalar, "portable"};
  return kPortable;
#endif
}

void ResetLanes(LaneTop2* state) {
  for (int j = 0; j < kPanelWidth; ++j) {
    state->b1[j] = kInf;
    state->b2[j] = kInf;
    state->i1[j] = -1;
    state->i2[j] = -1;
  }
}

Best2 ReduceLanes(const LaneTop2& state) {
  Best2 b{kInf, kInf, -1, -1};
  for (int l = 0; l < kPanelWidth; ++l) {
    InsertTop2(state.b1[l], state.i1[l], &b);
    InsertTop2(state.b2[l], state.i2[l], &b);
  }
  return b;
}

}  // namespace aerovo::matching_detail
