// The matcher's distance kernels (distance_kernels.h) written once with Google Highway and
// compiled for every target Highway offers on this architecture (x86: SSSE3/SSE4, AVX2, AVX3;
// aarch64: NEON, SVE, SVE2, SVE_256, SVE2_128), the best one chosen at run time.
//
// Vectors are CappedTag<float, 8>: 4 lanes on 128-bit targets (SSE4, NEON, 128-bit SVE), 8 on
// wider ones, so that a vector is always a whole part of a LaneTop2 (8 lanes). Scores use
// explicit MulAdd (fused where the target has FMA, as the AVX2 kernels; mul + add on SSE4,
// as the scalar ones); the exact SSD and the norms use the fixed 8-partial-sum order of the
// scalar versions without fusing (this file is compiled with -ffp-contract=off), so they are
// bit-identical to them on every target.
#include <cstddef>
#include <cstdint>
#include <limits>

#include "aerovo/matching/distance_kernels.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "aerovo/matching/distance_kernels_hwy.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace aerovo {
namespace matching_detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DF = hn::CappedTag<float, kPanelWidth>;
using DI = hn::RebindToSigned<DF>;
using VF = hn::Vec<DF>;
using VI = hn::Vec<DI>;

// Top-2 update of one vector of lanes, as the scalar Update: strict comparisons, so among equal
// scores in one lane the earlier slot stays best.
HWY_INLINE void Update(VF s, VI idx, VF& b1, VF& b2, VI& i1, VI& i2) {
  const DI di;
  const auto lt1 = hn::Lt(s, b1);
  const auto lt2 = hn::Lt(s, b2);
  const auto lt1i = hn::RebindMask(di, lt1);
  const auto lt2i = hn::RebindMask(di, lt2);
  VF nb2 = hn::IfThenElse(lt2, s, b2);
  VI ni2 = hn::IfThenElse(lt2i, idx, i2);
  nb2 = hn::IfThenElse(lt1, b1, nb2);
  ni2 = hn::IfThenElse(lt1i, i1, ni2);
  b1 = hn::IfThenElse(lt1, s, b1);
  i1 = hn::IfThenElse(lt1i, idx, i1);
  b2 = nb2;
  i2 = ni2;
}

// Updates lanes [lane, lane + Lanes) of one query's state with scores s of slots idx.
HWY_INLINE void UpdateState(LaneTop2* st, int lane, VF s, VI idx) {
  const DF df;
  const DI di;
  VF b1 = hn::LoadU(df, st->b1 + lane);
  VF b2 = hn::LoadU(df, st->b2 + lane);
  VI i1 = hn::LoadU(di, st->i1 + lane);
  VI i2 = hn::LoadU(di, st->i2 + lane);
  Update(s, idx, b1, b2, i1, i2);
  hn::StoreU(b1, df, st->b1 + lane);
  hn::StoreU(b2, df, st->b2 + lane);
  hn::StoreU(i1, di, st->i1 + lane);
  hn::StoreU(i2, di, st->i2 + lane);
}

// Tile: kQueryTile (4) queries x 2 vectors of candidate slots = 8 accumulators per pass over
// the dimensions; a pass covers slots [o, o + n) and [o + n, o + 2n) of each kCandStep group.
void TileImpl(const float* HWY_RESTRICT queries, int dim, const float* HWY_RESTRICT panels,
              const float* HWY_RESTRICT norms, int slot_base, int num_slots, LaneTop2* state) {
  static_assert(kQueryTile == 4, "four named accumulators per vector");
  const DF df;
  const DI di;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto two = hn::Set(df, 2.f);
  const auto iota = hn::Iota(di, 0);
  const float* q0 = queries;
  const float* q1 = queries + dim;
  const float* q2 = queries + 2 * dim;
  const float* q3 = queries + 3 * dim;
  for (int c = 0; c < num_slots; c += kCandStep) {
    for (int o = 0; o < kCandStep; o += 2 * n) {
      // Slot c + o + k sits in panel (c + o + k) / 8, lane (o + k) % 8.
      const int oa = o, ob = o + n;
      const float* pa = panels + static_cast<std::ptrdiff_t>(c + oa / kPanelWidth * kPanelWidth) *
                                     dim + oa % kPanelWidth;
      const float* pb = panels + static_cast<std::ptrdiff_t>(c + ob / kPanelWidth * kPanelWidth) *
                                     dim + ob % kPanelWidth;
      auto a0 = hn::Zero(df), a1 = hn::Zero(df), a2 = hn::Zero(df), a3 = hn::Zero(df);
      auto b0 = hn::Zero(df), b1 = hn::Zero(df), b2 = hn::Zero(df), b3 = hn::Zero(df);
      for (int d = 0; d < dim; ++d) {
        const auto va = hn::LoadU(df, pa + d * kPanelWidth);
        const auto vb = hn::LoadU(df, pb + d * kPanelWidth);
        const auto x0 = hn::Set(df, q0[d]), x1 = hn::Set(df, q1[d]);
        const auto x2 = hn::Set(df, q2[d]), x3 = hn::Set(df, q3[d]);
        a0 = hn::MulAdd(x0, va, a0);
        b0 = hn::MulAdd(x0, vb, b0);
        a1 = hn::MulAdd(x1, va, a1);
        b1 = hn::MulAdd(x1, vb, b1);
        a2 = hn::MulAdd(x2, va, a2);
        b2 = hn::MulAdd(x2, vb, b2);
        a3 = hn::MulAdd(x3, va, a3);
        b3 = hn::MulAdd(x3, vb, b3);
      }
      const auto na = hn::LoadU(df, norms + c + oa);
      const auto nb = hn::LoadU(df, norms + c + ob);
      const auto ia = hn::Add(hn::Set(di, slot_base + c + oa), iota);
      const auto ib = hn::Add(hn::Set(di, slot_base + c + ob), iota);
      const int la = oa % kPanelWidth, lb = ob % kPanelWidth;
      // Per lane, slot oa + k comes before slot ob + k (same lane when n = 8: two panels).
      UpdateState(&state[0], la, hn::NegMulAdd(two, a0, na), ia);
      UpdateState(&state[0], lb, hn::NegMulAdd(two, b0, nb), ib);
      UpdateState(&state[1], la, hn::NegMulAdd(two, a1, na), ia);
      UpdateState(&state[1], lb, hn::NegMulAdd(two, b1, nb), ib);
      UpdateState(&state[2], la, hn::NegMulAdd(two, a2, na), ia);
      UpdateState(&state[2], lb, hn::NegMulAdd(two, b2, nb), ib);
      UpdateState(&state[3], la, hn::NegMulAdd(two, a3, na), ia);
      UpdateState(&state[3], lb, hn::NegMulAdd(two, b3, nb), ib);
    }
  }
}

// Stream: the 8 candidate rows x one vector of query lanes = 8 accumulators per pass; the
// updates then go in row (= id) order.
void StreamImpl(const float* const* rows, const float* HWY_RESTRICT norms,
                const std::int32_t* HWY_RESTRICT ids, int dim, const float* HWY_RESTRICT panels,
                int num_panels, LaneTop2* state) {
  static_assert(kStreamRows == 8, "eight named accumulators");
  const DF df;
  const DI di;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto two = hn::Set(df, 2.f);
  const float* r0 = rows[0];
  const float* r1 = rows[1];
  const float* r2 = rows[2];
  const float* r3 = rows[3];
  const float* r4 = rows[4];
  const float* r5 = rows[5];
  const float* r6 = rows[6];
  const float* r7 = rows[7];
  for (int p = 0; p < num_panels; ++p) {
    const float* pp = panels + static_cast<std::ptrdiff_t>(p) * dim * kPanelWidth;
    for (int lane = 0; lane < kPanelWidth; lane += n) {
      auto a0 = hn::Zero(df), a1 = hn::Zero(df), a2 = hn::Zero(df), a3 = hn::Zero(df);
      auto a4 = hn::Zero(df), a5 = hn::Zero(df), a6 = hn::Zero(df), a7 = hn::Zero(df);
      for (int d = 0; d < dim; ++d) {
        const auto v = hn::LoadU(df, pp + d * kPanelWidth + lane);
        a0 = hn::MulAdd(hn::Set(df, r0[d]), v, a0);
        a1 = hn::MulAdd(hn::Set(df, r1[d]), v, a1);
        a2 = hn::MulAdd(hn::Set(df, r2[d]), v, a2);
        a3 = hn::MulAdd(hn::Set(df, r3[d]), v, a3);
        a4 = hn::MulAdd(hn::Set(df, r4[d]), v, a4);
        a5 = hn::MulAdd(hn::Set(df, r5[d]), v, a5);
        a6 = hn::MulAdd(hn::Set(df, r6[d]), v, a6);
        a7 = hn::MulAdd(hn::Set(df, r7[d]), v, a7);
      }
      LaneTop2* st = &state[p];
      VF b1 = hn::LoadU(df, st->b1 + lane);
      VF b2 = hn::LoadU(df, st->b2 + lane);
      VI i1 = hn::LoadU(di, st->i1 + lane);
      VI i2 = hn::LoadU(di, st->i2 + lane);
#define AEROVO_UPD(r, acc) \
  Update(hn::NegMulAdd(two, acc, hn::Set(df, norms[r])), hn::Set(di, ids[r]), b1, b2, i1, i2)
      AEROVO_UPD(0, a0);
      AEROVO_UPD(1, a1);
      AEROVO_UPD(2, a2);
      AEROVO_UPD(3, a3);
      AEROVO_UPD(4, a4);
      AEROVO_UPD(5, a5);
      AEROVO_UPD(6, a6);
      AEROVO_UPD(7, a7);
#undef AEROVO_UPD
      hn::StoreU(b1, df, st->b1 + lane);
      hn::StoreU(b2, df, st->b2 + lane);
      hn::StoreU(i1, di, st->i1 + lane);
      hn::StoreU(i2, di, st->i2 + lane);
    }
  }
}

// List: dot products over the dimensions at the full vector width, four candidates at a time
// (four independent FMA chains); each candidate's dot is computed by the same sequence of
// operations in the 4-way body and the 1-way tail (DotFinish), so both agree bit for bit.
using DW = hn::ScalableTag<float>;

HWY_INLINE float DotFinish(hn::Vec<DW> acc, const float* HWY_RESTRICT a,
                           const float* HWY_RESTRICT b, int d, int dim) {
  const DW dw;
  float sum = hn::GetLane(hn::SumOfLanes(dw, acc));
  for (; d < dim; ++d) sum += a[d] * b[d];
  return sum;
}

void ListImpl(const float* HWY_RESTRICT query, int dim, const float* HWY_RESTRICT rows,
              const float* HWY_RESTRICT norms, const std::int32_t* HWY_RESTRICT slots,
              int num_slots, const std::int32_t* HWY_RESTRICT tie_key, Best2* out) {
  const DW dw;
  const int n = static_cast<int>(hn::Lanes(dw));
  const int vec_dim = dim / n * n;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  Best2 b{kInf, kInf, -1, -1};
  int k = 0;
  for (; k + 4 <= num_slots; k += 4) {
    const std::int32_t j0 = slots[k], j1 = slots[k + 1], j2 = slots[k + 2], j3 = slots[k + 3];
    const float* c0 = rows + static_cast<std::ptrdiff_t>(j0) * dim;
    const float* c1 = rows + static_cast<std::ptrdiff_t>(j1) * dim;
    const float* c2 = rows + static_cast<std::ptrdiff_t>(j2) * dim;
    const float* c3 = rows + static_cast<std::ptrdiff_t>(j3) * dim;
    auto a0 = hn::Zero(dw), a1 = hn::Zero(dw), a2 = hn::Zero(dw), a3 = hn::Zero(dw);
    for (int d = 0; d < vec_dim; d += n) {
      const auto q = hn::LoadU(dw, query + d);
      a0 = hn::MulAdd(q, hn::LoadU(dw, c0 + d), a0);
      a1 = hn::MulAdd(q, hn::LoadU(dw, c1 + d), a1);
      a2 = hn::MulAdd(q, hn::LoadU(dw, c2 + d), a2);
      a3 = hn::MulAdd(q, hn::LoadU(dw, c3 + d), a3);
    }
    PushTop2ByTieKey(norms[j0] - 2.f * DotFinish(a0, query, c0, vec_dim, dim), j0, tie_key, &b);
    PushTop2ByTieKey(norms[j1] - 2.f * DotFinish(a1, query, c1, vec_dim, dim), j1, tie_key, &b);
    PushTop2ByTieKey(norms[j2] - 2.f * DotFinish(a2, query, c2, vec_dim, dim), j2, tie_key, &b);
    PushTop2ByTieKey(norms[j3] - 2.f * DotFinish(a3, query, c3, vec_dim, dim), j3, tie_key, &b);
  }
  for (; k < num_slots; ++k) {
    const std::int32_t j = slots[k];
    const float* c = rows + static_cast<std::ptrdiff_t>(j) * dim;
    auto a = hn::Zero(dw);
    for (int d = 0; d < vec_dim; d += n) {
      a = hn::MulAdd(hn::LoadU(dw, query + d), hn::LoadU(dw, c + d), a);
    }
    PushTop2ByTieKey(norms[j] - 2.f * DotFinish(a, query, c, vec_dim, dim), j, tie_key, &b);
  }
  *out = b;
}

// Exact SSD: partial sums s[k] over d = k mod 8 held as four 2-lane double vectors (s0 s1 |
// s2 s3 | s4 s5 | s6 s7), tail into s[0], the scalar combination order; no fusing.
double ExactImpl(const float* HWY_RESTRICT a, const float* HWY_RESTRICT b, int dim) {
  const hn::FixedTag<double, 2> dd;
  const hn::Rebind<float, decltype(dd)> df2;
  auto s01 = hn::Zero(dd), s23 = hn::Zero(dd), s45 = hn::Zero(dd), s67 = hn::Zero(dd);
  int d = 0;
#define AEROVO_SQ(off) \
  hn::Sub(hn::PromoteTo(dd, hn::LoadU(df2, a + d + (off))), hn::PromoteTo(dd, hn::LoadU(df2, b + d + (off))))
  for (; d + 8 <= dim; d += 8) {
    const auto t01 = AEROVO_SQ(0), t23 = AEROVO_SQ(2), t45 = AEROVO_SQ(4), t67 = AEROVO_SQ(6);
    s01 = hn::Add(s01, hn::Mul(t01, t01));
    s23 = hn::Add(s23, hn::Mul(t23, t23));
    s45 = hn::Add(s45, hn::Mul(t45, t45));
    s67 = hn::Add(s67, hn::Mul(t67, t67));
  }
#undef AEROVO_SQ
  alignas(16) double s[8];
  hn::Store(s01, dd, s);
  hn::Store(s23, dd, s + 2);
  hn::Store(s45, dd, s + 4);
  hn::Store(s67, dd, s + 6);
  for (; d < dim; ++d) {
    const double t = static_cast<double>(a[d]) - static_cast<double>(b[d]);
    s[0] += t * t;
  }
  return ((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]));
}

// Squared norm: acc[l] over d = l mod 8 as two 4-lane float vectors, tail into acc[0]; no fusing.
float NormImpl(const float* HWY_RESTRICT v, int dim) {
  const hn::FixedTag<float, 4> d4;
  auto lo = hn::Zero(d4), hi = hn::Zero(d4);
  int k = 0;
  for (; k + 8 <= dim; k += 8) {
    const auto x = hn::LoadU(d4, v + k), y = hn::LoadU(d4, v + k + 4);
    lo = hn::Add(lo, hn::Mul(x, x));
    hi = hn::Add(hi, hn::Mul(y, y));
  }
  alignas(16) float acc[8];
  hn::Store(lo, d4, acc);
  hn::Store(hi, d4, acc + 4);
  for (; k < dim; ++k) acc[0] += v[k] * v[k];
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

}  // namespace HWY_NAMESPACE
}  // namespace matching_detail
}  // namespace aerovo
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace aerovo::matching_detail {
namespace {

HWY_EXPORT(TileImpl);
HWY_EXPORT(StreamImpl);
HWY_EXPORT(ListImpl);
HWY_EXPORT(ExactImpl);
HWY_EXPORT(NormImpl);

void TileHwy(const float* queries, int dim, const float* panels, const float* norms,
             int slot_base, int num_slots, LaneTop2* state) {
  HWY_DYNAMIC_DISPATCH(TileImpl)(queries, dim, panels, norms, slot_base, num_slots, state);
}
void StreamHwy(const float* const* rows, const float* norms, const std::int32_t* ids, int dim,
               const float* panels, int num_panels, LaneTop2* state) {
  HWY_DYNAMIC_DISPATCH(StreamImpl)(rows, norms, ids, dim, panels, num_panels, state);
}
void ListHwy(const float* query, int dim, const float* rows, const float* norms,
             const std::int32_t* slots, int num_slots, const std::int32_t* tie_key, Best2* out) {
  HWY_DYNAMIC_DISPATCH(ListImpl)(query, dim, rows, norms, slots, num_slots, tie_key, out);
}
double ExactHwy(const float* a, const float* b, int dim) {
  return HWY_DYNAMIC_DISPATCH(ExactImpl)(a, b, dim);
}
float NormHwy(const float* v, int dim) { return HWY_DYNAMIC_DISPATCH(NormImpl)(v, dim); }

}  // namespace

const Kernels& HighwayKernels() {
  static const Kernels k{&TileHwy, &ListHwy, &StreamHwy, &ExactHwy, &NormHwy, "highway"};
  return k;
}

}  // namespace aerovo::matching_detail
#endif  // HWY_ONCE
