#include "aerovo/features/surf.h"
#include "aerovo/core/cancel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "aerovo/core/error.h"
#include "aerovo/core/parallel.h"
#include "aerovo/core/timer.h"
#include "aerovo/features/hessian.h"
#include "aerovo/features/integral_image.h"

namespace aerovo {

using surf_detail::BoxFilterLayout;
using surf_detail::MakeBoxFilterLayout;

namespace {

constexpr int kBaseSize = 9;       // Smallest box filter (Bay et al. 2008, Sec. 4.1).
constexpr int kSizeIncrement = 6;  // Filter size increment per layer in octave 0.
constexpr float kTwoPi = 6.28318530717958647692f;

// Orientation (Bay et al. 2008, Sec. 4.1; OpenCV): Haar responses of side 4s at the points of a
// disc of radius 6s sampled every s, Gaussian weights sigma 2.5s, sliding 60-degree window.
constexpr int kOriRadius = 6;
constexpr float kOriSigma = 2.5f;
constexpr int kOriBins = 72;        // 5-degree bins, as OpenCV's search increment.
constexpr int kOriWindowBins = 12;  // 60 degrees.
// Descriptor: 20s window, 4x4 sub-regions of 5x5 samples, Haar side 2s, Gaussian sigma 3.3s.
constexpr int kPatch = 20;
constexpr float kDescSigma = 3.3f;

constexpr int kOriMaxSamples = 128;  // >= samples in the disc (113), padded for SIMD.

// Adaptive mode's cell floors for the next frame, as a fraction of each cell's first dropped
// response (SurfResult::next_cell_min_response): after a frame whose cell floors held, and
// after one where some were cut (or that had none).
constexpr double kCellMarginHeld = 0.8;
constexpr double kCellMarginCut = 0.5;

struct Tables {
  // Orientation disc, structure of arrays: offsets in units of s and Gaussian weights.
  int ori_count = 0;
  alignas(32) float ori_i[kOriMaxSamples] = {};
  alignas(32) float ori_j[kOriMaxSamples] = {};
  alignas(32) float ori_w[kOriMaxSamples] = {};
  // Descriptor grid, row-major 20x20: Gaussian weight and offsets in units of s.
  alignas(32) float desc_w[kPatch * kPatch] = {};
  alignas(32) float grid[kPatch] = {};  // (k - 9.5)
  Tables() {
    for (int i = -kOriRadius; i <= kOriRadius; ++i) {
      for (int j = -kOriRadius; j <= kOriRadius; ++j) {
        if (i * i + j * j > kOriRadius * kOriRadius) continue;
        ori_i[ori_count] = static_cast<float>(i);
        ori_j[ori_count] = static_cast<float>(j);
        ori_w[ori_count] = std::exp(-(i * i + j * j) / (2.f * kOriSigma * kOriSigma));
        ++ori_count;
      }
    }
    for (int k = 0; k < kPatch; ++k) grid[k] = k - (kPatch - 1) * 0.5f;
    for (int r = 0; r < kPatch; ++r) {
      for (int c = 0; c < kPatch; ++c) {
        desc_w[r * kPatch + c] =
            std::exp(-(grid[c] * grid[c] + grid[r] * grid[r]) / (2.f * kDescSigma * kDescSigma));
      }
    }
  }
};

const Tables& GetTables() {
  static const Tables tables;
  return tables;
}

// atan2 in [0, 2*pi) with about 1e-5 rad error (minimax polynomial for atan on [-1, 1]),
// written without branches so that the loop over orientation samples vectorises; libm's atan2
// and a branchy version dominated the orientation cost.
inline float FastAtan2(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  const float z = mn / std::max(mx, 1e-30f), z2 = z * z;
  float a =
      z * (0.99997726f +
           z2 * (-0.33262347f +
                 z2 * (0.19354346f + z2 * (-0.11643287f + z2 * (0.05265332f - z2 * 0.01172120f)))));
  a = ay > ax ? 1.57079632679f - a : a;
  a = x < 0.f ? 3.14159265359f - a : a;
  a = y < 0.f ? kTwoPi - a : a;
  return a;
}

void CheckImage(const GrayImageView& image) {
  if (image.data == nullptr || image.width <= 0 || image.height <= 0) {
    throw InvalidArgument("Surf: the image is empty (" + std::to_string(image.width) + "x" +
                          std::to_string(image.height) + ", data " + (image.data ? "set" : "null") +
                          ")");
  }
  if (image.stride < image.width) {
    throw InvalidArgument("Surf: image stride " + std::to_string(image.stride) +
                          " is smaller than its width " + std::to_string(image.width));
  }
  if (image.width < kBaseSize || image.height < kBaseSize) {
    throw InvalidArgument("Surf: the image is " + std::to_string(image.width) + "x" +
                          std::to_string(image.height) +
                          ", smaller than the smallest SURF filter (9x9)");
  }
}

// Sum over the 3x3x3 neighbourhood check and quadratic fit of one candidate. Returns false when
// the fit is singular or moves by more than one sample in any direction.
bool Interpolate(const float* lo, const float* mid, const float* hi, std::ptrdiff_t s,
                 float offset[3]) {
  const double v = mid[0];
  const double dx = (mid[1] - mid[-1]) * 0.5, dy = (mid[s] - mid[-s]) * 0.5;
  const double ds = (hi[0] - lo[0]) * 0.5;
  const double dxx = mid[1] - 2 * v + mid[-1];
  const double dyy = mid[s] - 2 * v + mid[-s];
  const double dss = hi[0] - 2 * v + lo[0];
  const double dxy = (mid[s + 1] - mid[s - 1] - mid[-s + 1] + mid[-s - 1]) * 0.25;
  const double dxs = (hi[1] - hi[-1] - lo[1] + lo[-1]) * 0.25;
  const double dys = (hi[s] - hi[-s] - lo[s] + lo[-s]) * 0.25;
  // Solve H * o = -g by Cramer's rule (3x3, symmetric).
  const double c00 = dyy * dss - dys * dys, c01 = dxs * dys - dxy * dss,
               c02 = dxy * dys - dxs * dyy;
  const double det = dxx * c00 + dxy * c01 + dxs * c02;
  if (!(std::fabs(det) > 1e-30)) return false;
  const double c11 = dxx * dss - dxs * dxs, c12 = dxy * dxs - dxx * dys;
  const double c22 = dxx * dyy - dxy * dxy;
  const double inv = -1.0 / det;
  const double ox = (c00 * dx + c01 * dy + c02 * ds) * inv;
  const double oy = (c01 * dx + c11 * dy + c12 * ds) * inv;
  const double os = (c02 * dx + c12 * dy + c22 * ds) * inv;
  if (!(std::fabs(ox) <= 1.0 && std::fabs(oy) <= 1.0 && std::fabs(os) <= 1.0)) return false;
  offset[0] = static_cast<float>(ox);
  offset[1] = static_cast<float>(oy);
  offset[2] = static_cast<float>(os);
  return true;
}

inline bool IsMaximum(float v, const float* p, std::ptrdiff_t stride) {
  return v > p[-stride - 1] && v > p[-stride] && v > p[-stride + 1] && v > p[-1] && v > p[0] &&
         v > p[1] && v > p[stride - 1] && v > p[stride] && v > p[stride + 1];
}

// Keypoints sorted by decreasing response; ties broken by position and scale so that the order
// is a total order (deterministic whatever the thread count). A function object, so that the
// heaps, nth_element and sort inline it (a function pointer is called per comparison).
struct StrongerFirstOrder {
  bool operator()(const Keypoint& a, const Keypoint& b) const {
    if (a.response != b.response) return a.response > b.response;
    if (a.y != b.y) return a.y < b.y;
    if (a.x != b.x) return a.x < b.x;
    return a.scale < b.scale;
  }
};
constexpr StrongerFirstOrder StrongerFirst{};

// The largest float below b (std::nextafter towards -infinity), without the libm call for the
// usual b (positive and finite: the previous bit pattern).
inline float JustBelow(float b) {
  if (b > 0.f && b <= std::numeric_limits<float>::max()) {
    std::uint32_t u;
    std::memcpy(&u, &b, sizeof u);
    --u;
    std::memcpy(&b, &u, sizeof b);
    return b;
  }
  return std::nextafter(b, -std::numeric_limits<float>::infinity());
}

// Cell of the adaptive grid (g cells per side over [origin, origin + extent)) holding coordinate
// v; monotone non-decreasing in v. The one formula of the selection and of the early rejection.
inline int GridCell(float v, int origin, int extent, int g) {
  return std::clamp(static_cast<int>((v - origin) * g / extent), 0, g - 1);
}

// Adaptive mode: what the selection (Surf::Impl::Select) has seen so far, enough to reject a
// candidate it cannot keep before the costly steps (outer layers, refinement). A candidate of
// response v in cell c cannot be selected, nor be the cell's first dropped point (which sets
// next_min_response), when among the points already found
//  - its cell has quota + 1 points stronger than v (it is not among the cell's quota; the
//    (quota + 1)-th strongest of the cell is the strongest beyond the quota: rest_max[c]), and
//  - more + 1 points beyond their cells' quotas are stronger than v, where more (the part of
//    the target filled from the strongest of the others) is at most target - (cells * quota -
//    deficit): the strongest of those is then out of reach too, and the frame keeps more than
//    target points (Select's branch).
// Both counts only grow and the bound on `more` only falls as points are added, so a rejection
// stays right whatever is found later, and the set Select keeps is exactly the one it keeps
// from every candidate (SurfAdaptive.TheSelectionIsExactlyThePlainSelectionOverAllCandidates).
// Ties: only v strictly below a stronger point's response is rejected. Buffers are reused.
class SelectionBar {
 public:
  void Reset(int cells, int quota, int target) {
    cells_ = cells;
    quota_ = quota;
    target_ = target;
    top_.resize(static_cast<std::size_t>(cells) * quota);
    top_n_.assign(cells, 0);
    rest_max_.assign(cells, -std::numeric_limits<float>::infinity());
    rest_.clear();
    deficit_ = cells * quota;
    rest_bar_ = -std::numeric_limits<float>::infinity();
  }
  void CopyFrom(const SelectionBar& o) {
    cells_ = o.cells_;
    quota_ = o.quota_;
    target_ = o.target_;
    top_.assign(o.top_.begin(), o.top_.end());
    top_n_.assign(o.top_n_.begin(), o.top_n_.end());
    rest_max_.assign(o.rest_max_.begin(), o.rest_max_.end());
    rest_.assign(o.rest_.begin(), o.rest_.end());
    deficit_ = o.deficit_;
    rest_bar_ = o.rest_bar_;
  }
  // A point of `cell` was found (it reaches the selection).
  void Add(int cell, const Keypoint& kp) {
    Keypoint* h = top_.data() + static_cast<std::size_t>(cell) * quota_;  // weakest at h[0]
    int& n = top_n_[cell];
    if (n < quota_) {
      h[n++] = kp;
      std::push_heap(h, h + n, StrongerFirst);
      --deficit_;
      Trim();
      return;
    }
    Keypoint out = kp;
    if (StrongerFirst(kp, h[0])) {
      std::pop_heap(h, h + quota_, StrongerFirst);
      out = h[quota_ - 1];
      h[quota_ - 1] = kp;
      std::push_heap(h, h + quota_, StrongerFirst);
    }
    rest_max_[cell] = std::max(rest_max_[cell], out.response);
    const std::size_t keep = KeepInRest();
    if (rest_.size() < keep) {
      rest_.push_back(out);
      std::push_heap(rest_.begin(), rest_.end(), StrongerFirst);
    } else if (StrongerFirst(out, rest_.front())) {
      std::pop_heap(rest_.begin(), rest_.end(), StrongerFirst);
      rest_.back() = out;
      std::push_heap(rest_.begin(), rest_.end(), StrongerFirst);
    }
    Trim();
  }
  // Candidates of `cell` with a response below this cannot be selected (-inf: none rejected).
  float Bar(int cell) const { return std::min(rest_max_[cell], rest_bar_); }

 private:
  // more + 1 with more's bound (the strongest beyond the quotas that can matter).
  std::size_t KeepInRest() const {
    return static_cast<std::size_t>(std::max(0, target_ - (cells_ * quota_ - deficit_))) + 1;
  }
  void Trim() {
    const std::size_t keep = KeepInRest();
    while (rest_.size() > keep) {
      std::pop_heap(rest_.begin(), rest_.end(), StrongerFirst);
      rest_.pop_back();
    }
    rest_bar_ =
        rest_.size() == keep ? rest_.front().response : -std::numeric_limits<float>::infinity();
  }
  int cells_ = 0, quota_ = 1, target_ = 0, deficit_ = 0;
  std::vector<Keypoint> top_;    // cells x quota: each cell's strongest (a heap per cell)
  std::vector<int> top_n_;       // entries used per cell
  std::vector<float> rest_max_;  // per cell: strongest response beyond its quota
  std::vector<Keypoint> rest_;   // heap: the strongest beyond their quotas (KeepInRest)
  float rest_bar_ = 0.f;         // response of the weakest of rest_ when full, else -inf
};

// Adaptive mode: a column range of samples whose refined x (within one sample of the sample's
// centre) falls in grid columns cx0..cx1 (cx1 = cx0 or cx0 + 1).
struct ColumnSpan {
  int j_begin, j_end, cx0, cx1;
};

}  // namespace

void Validate(const SurfOptions& o) {
  options::CheckRanges(o, "surf");
  if (o.roi && (o.roi->x < 0 || o.roi->y < 0 || o.roi->width <= 0 || o.roi->height <= 0)) {
    throw InvalidArgument(
        "SurfOptions::roi must have x, y >= 0 and positive width and height, got (" +
        std::to_string(o.roi->x) + ", " + std::to_string(o.roi->y) + ", " +
        std::to_string(o.roi->width) + "x" + std::to_string(o.roi->height) + ")");
  }
}

float OpenCvKeypointSize(const Keypoint& kp) { return kp.scale * 9.f / 1.2f; }

struct Surf::Impl {
  SurfOptions options;
  IntegralImage ii;
  std::vector<std::vector<float>> rings;     // Per thread: 3 response rows per layer.
  std::vector<std::vector<Keypoint>> found;  // Per row block, merged after each octave.
  // Adaptive mode's early rejection (SelectionBar): the points of the octaves done, and per row
  // block that plus its own; the column spans of an octave.
  SelectionBar bar;
  std::vector<SelectionBar> band_bars;
  std::vector<ColumnSpan> spans;

  void Prepare(const GrayImageView& image) {
    CheckImage(image);
    if (options.roi) {
      const RectI& r = *options.roi;
      if (r.x + r.width > image.width || r.y + r.height > image.height) {
        throw InvalidArgument("SurfOptions::roi (" + std::to_string(r.x) + ", " +
                              std::to_string(r.y) + ", " + std::to_string(r.width) + "x" +
                              std::to_string(r.height) + ") does not lie inside the " +
                              std::to_string(image.width) + "x" + std::to_string(image.height) +
                              " image");
      }
    }
    ii.Compute(image);
  }

  std::vector<std::uint32_t> order;  // Scratch for SpatialOrder.

  // Indices of `kps` ordered by row band then column, so that consecutive keypoints read
  // nearby integral-image rows (cache reuse); the results do not depend on the order.
  const std::vector<std::uint32_t>& SpatialOrder(const std::vector<Keypoint>& kps) {
    order.resize(kps.size());
    for (std::size_t k = 0; k < kps.size(); ++k) order[k] = static_cast<std::uint32_t>(k);
    std::sort(order.begin(), order.end(), [&kps](std::uint32_t a, std::uint32_t b) {
      const int ba = static_cast<int>(kps[a].y) >> 4, bb = static_cast<int>(kps[b].y) >> 4;
      if (ba != bb) return ba < bb;
      return kps[a].x < kps[b].x;
    });
    return order;
  }

  // Calls fn(k) for every index k of `kps`, in SpatialOrder, on options.num_threads threads
  // (dynamic chunks of 32); a stop request (core/cancel.h) skips the rest and then throws
  // Cancelled naming `stage`. fn must only touch keypoint k's own data.
  template <class Fn>
  void ForEachInSpatialOrder(const std::vector<Keypoint>& kps, const char* stage, Fn&& fn) {
    const int threads = ResolveThreadCount(options.num_threads);
    const std::vector<std::uint32_t>& sorted = SpatialOrder(kps);
    const long n = static_cast<long>(kps.size());
    ParallelFor(threads, n, 32, [&](long begin, long end, int /*worker*/) {
      for (long k = begin; k < end; ++k) {
        if (CancelRequested()) return;  // thrown below
        fn(sorted[k]);
      }
    });
    ThrowIfCancelled(stage);
  }

  // Adaptive selection (SurfOptions::adaptive); buffers reused between calls.
  std::vector<std::uint32_t> cell_start;
  std::vector<Keypoint> by_cell, kept, rest;
  int last_candidates = 0;
  double last_range = 0.0, last_floor = 0.0, last_c2 = 1.0, last_min_response = 0.0;
  double next_min_response = 0.0;
  // Adaptive mode's cell floors (determinant units, grid x grid row-major; empty: none): a
  // candidate of cell c needs a response above cell_floor[c] (>= the frame's floor) and, when
  // cell_ceiling is not empty, not above cell_ceiling[c]. Set from the steering
  // (SetCellFloors), then by RedoCells.
  std::vector<float> cell_floor, cell_ceiling;
  // Set by Select: the cells whose floor may have cut a point the selection over every
  // candidate above the frame's floor keeps or uses (CellFloorsCut), and the next frame's cell
  // floors (SurfResult::next_cell_min_response).
  std::vector<int> cut_cells;
  std::vector<float> next_cell_min_response;
  // RedoCells: every candidate so far, the bar they set, the cells' floors before the redo.
  std::vector<Keypoint> all_found;
  SelectionBar seed_bar;
  std::vector<float> pass_floor;
  bool redoing = false;

  // The threshold of the fast-Hessian for this image: hessian_threshold, or in adaptive mode the
  // floor min_response * (range / 255)^2 (sets last_range, last_floor).
  float DetectionThreshold(const GrayImageView& image, double steered_min_response);
  // Adaptive mode: cell_floor from the steering's cells (min_response units, full contrast):
  // max(frame's floor, steered * contrast factor); none when `steered` is empty or all its
  // floors are at or below the frame's. Throws InvalidArgument for a wrong size or value.
  void SetCellFloors(const std::vector<float>& steered);
  // Adaptive mode, after Select with cell floors: whether the floors cut a point that the
  // selection over every candidate above the frame's floor would keep or use (see Select).
  void CellFloorsCut(std::size_t quota, std::size_t more, float weakest_pick);
  // Adaptive mode: next_cell_min_response from each cell's first dropped response and the
  // weakest point kept beyond the quotas (infinity when none was needed).
  void SteerCells(std::size_t quota, float weakest_pick);
  // Adaptive mode: keeps per cell its strongest points, then the strongest of the rest up to
  // target_points; then sorts (StrongerFirst) and applies max_keypoints in both modes.
  void Select(std::vector<Keypoint>& kps);
  // DetectionThreshold, SetCellFloors, FastHessian and Select; then RedoCells for the cells
  // whose floor cut a point the selection needs (*redone: how many; grid x grid when the whole
  // frame was detected again). The points are those of a call without cell floors either way.
  std::vector<Keypoint> DetectSelected(const GrayImageView& image, double steered_min_response,
                                       const std::vector<float>& steered_cells, int* redone);
  // After Select reported cut_cells: each of them searched again, over its own rectangle, for
  // the candidates between the frame's floor and its cell floor, and the selection made again
  // over every candidate. Returns the kept points.
  std::vector<Keypoint> RedoCells(float threshold);
  // The rectangle (pixels) that holds every point GridCell puts in cells c0..c1 of one grid row
  // of `sel`.
  RectI CellsRect(const RectI& sel, int c0, int c1) const;
  // The fast-Hessian's candidates above `threshold` (and the cell floors); with `scan`, only
  // those within one sample of that rectangle (pixels) are searched, and in adaptive mode the
  // bar starts from seed_bar instead of empty.
  std::vector<Keypoint> FastHessian(float threshold, const RectI* scan = nullptr);
  void Orient(std::vector<Keypoint>& kps);
  void DescribeAll(const std::vector<Keypoint>& kps, float* out, int dsize);
  float Orientation(const Keypoint& kp) const;
  void DescribeOne(const Keypoint& kp, float* out) const;
};

float Surf::Impl::DetectionThreshold(const GrayImageView& image, double steered_min_response) {
  last_candidates = 0;
  last_range = last_floor = next_min_response = 0.0;
  if (!options.adaptive) return static_cast<float>(options.hessian_threshold);
  // Robust intensity range: 1st to 99th percentile of the pixels of the image (or roi) sampled
  // every 4th pixel of every 4th row (enough for a percentile; cost in BENCHMARKS.md, "Adaptive
  // threshold histogram").
  const RectI r = options.roi ? *options.roi : RectI{0, 0, image.width, image.height};
  std::array<std::uint32_t, 256> hist{};
  std::uint32_t n = 0;
  for (int y = r.y; y < r.y + r.height; y += 4) {
    const std::uint8_t* row = image.data + static_cast<std::ptrdiff_t>(y) * image.stride;
    for (int x = r.x; x < r.x + r.width; x += 4) ++hist[row[x]];
  }
  for (std::uint32_t h : hist) n += h;
  const std::uint32_t lo_rank = n / 100, hi_rank = n - 1 - n / 100;
  int lo = 0, hi = 255;
  std::uint32_t cum = 0;
  for (int v = 0; v < 256; ++v) {
    if (cum <= lo_rank && cum + hist[v] > lo_rank) lo = v;
    if (cum <= hi_rank && cum + hist[v] > hi_rank) hi = v;
    cum += hist[v];
  }
  constexpr double kMinRange = 8.0;  // A nearly uniform frame is not amplified into noise.
  last_range = hi - lo;
  const double c = std::max(last_range, kMinRange) / 255.0;
  last_c2 = c * c;
  last_min_response = std::max(options.min_response, steered_min_response);
  last_floor = last_min_response * last_c2;
  return static_cast<float>(last_floor);
}

void Surf::Impl::SetCellFloors(const std::vector<float>& steered) {
  cell_floor.clear();
  if (!options.adaptive || steered.empty()) return;
  const std::size_t cells = static_cast<std::size_t>(options.grid) * options.grid;
  if (steered.size() != cells) {
    throw InvalidArgument("Surf: steered_cell_min_response has " + std::to_string(steered.size()) +
                          " values; the grid (SurfOptions::grid " + std::to_string(options.grid) +
                          ") needs " + std::to_string(cells));
  }
  const float floor = static_cast<float>(last_floor);
  bool any = false;
  cell_floor.resize(cells);
  for (std::size_t c = 0; c < cells; ++c) {
    if (!(std::isfinite(steered[c]) && steered[c] >= 0.f)) {
      throw InvalidArgument("Surf: steered_cell_min_response[" + std::to_string(c) + "] is " +
                            std::to_string(steered[c]) + "; it must be finite and >= 0");
    }
    cell_floor[c] = std::max(floor, static_cast<float>(steered[c] * last_c2));
    any = any || cell_floor[c] > floor;
  }
  if (!any) cell_floor.clear();
}

// A cell whose floor is above the frame's may have lost candidates below it. The selection over
// every candidate above the frame's floor is still this one when, for each such cell, the cell
// kept more than its quota (its quota and first dropped point are above its floor, so the same)
// and every point taken beyond the quotas is stronger than the cell's floor (a lost point would
// have lost to each of them); the frame then had more than target_points candidates either way.
void Surf::Impl::CellFloorsCut(std::size_t quota, std::size_t more, float weakest_pick) {
  const float floor = static_cast<float>(last_floor);
  const std::size_t target = static_cast<std::size_t>(options.target_points);
  const bool short_of_target = kept.size() + more < target;  // every candidate was kept
  for (std::size_t c = 0; c < cell_floor.size(); ++c) {
    if (!(cell_floor[c] > floor)) continue;
    if (short_of_target || cell_start[c + 1] - cell_start[c] <= quota ||
        !(weakest_pick > cell_floor[c])) {
      cut_cells.push_back(static_cast<int>(c));
    }
  }
}

void Surf::Impl::SteerCells(std::size_t quota, float weakest_pick) {
  const std::size_t cells = cell_start.size() - 1;
  // The margin for the next frame's change: kCellMarginHeld when this frame's cell floors all
  // held (a stream of similar frames: few candidates), kCellMarginCut after any was cut or
  // when there were none (BENCHMARKS.md, "SURF at the same number of points").
  const double margin = (redoing || !cut_cells.empty()) ? kCellMarginCut : kCellMarginHeld;
  next_cell_min_response.assign(cells, 0.f);
  for (std::size_t c = 0; c < cells; ++c) {
    if (cell_start[c + 1] - cell_start[c] <= quota) continue;
    const float first_dropped = by_cell[cell_start[c] + quota].response;
    next_cell_min_response[c] =
        static_cast<float>(margin * std::min(first_dropped, weakest_pick) / last_c2);
  }
}

void Surf::Impl::Select(std::vector<Keypoint>& kps) {
  last_candidates = options.adaptive ? static_cast<int>(kps.size()) : 0;
  cut_cells.clear();
  next_cell_min_response.clear();
  const std::size_t target = static_cast<std::size_t>(options.target_points);
  const std::size_t all_cells = static_cast<std::size_t>(options.grid) * options.grid;
  if (options.adaptive && kps.size() <= target) {
    next_min_response = 0.5 * last_min_response;
    next_cell_min_response.assign(all_cells, 0.f);
    // Every candidate is kept: a cell floor above the frame's may have lost one.
    for (std::size_t c = 0; c < cell_floor.size(); ++c) {
      if (cell_floor[c] > static_cast<float>(last_floor)) cut_cells.push_back(static_cast<int>(c));
    }
    if (!cut_cells.empty()) by_cell.assign(kps.begin(), kps.end());  // for RedoCells
  }
  if (options.adaptive && kps.size() > target) {
    const int g = options.grid, cells = g * g;
    const RectI r = options.roi ? *options.roi : RectI{0, 0, ii.width(), ii.height()};
    const auto cell_of = [&](const Keypoint& kp) {
      return GridCell(kp.y, r.y, r.height, g) * g + GridCell(kp.x, r.x, r.width, g);
    };
    // Counting sort of the candidates by cell.
    cell_start.assign(cells + 1, 0);
    for (const Keypoint& kp : kps) ++cell_start[cell_of(kp) + 1];
    for (int c = 0; c < cells; ++c) cell_start[c + 1] += cell_start[c];
    by_cell.resize(kps.size());
    for (const Keypoint& kp : kps) by_cell[cell_start[cell_of(kp)]++] = kp;
    for (int c = cells; c > 0; --c) cell_start[c] = cell_start[c - 1];
    cell_start[0] = 0;
    // Each cell's strongest `quota` (StrongerFirst is a total order: the same set whatever the
    // order the threads found them in), then the strongest of the others up to the target.
    const std::size_t quota = std::max<std::size_t>(1, target / cells);
    kept.clear();
    rest.clear();
    // The floor the next frame could use: half the weakest cell's first dropped response (a
    // margin for the next frame's change), or half this one when a cell had too few.
    double weakest = std::numeric_limits<double>::infinity();
    for (int c = 0; c < cells; ++c) {
      const auto b = by_cell.begin() + cell_start[c], e = by_cell.begin() + cell_start[c + 1];
      if (static_cast<std::size_t>(e - b) > quota) {
        std::nth_element(b, b + quota, e, StrongerFirst);
        weakest = std::min(weakest, static_cast<double>(b[quota].response));
        kept.insert(kept.end(), b, b + quota);
        rest.insert(rest.end(), b + quota, e);
      } else {
        kept.insert(kept.end(), b, e);
        weakest = std::min(weakest, last_floor);
      }
    }
    next_min_response = 0.5 * weakest / last_c2;
    std::size_t more = 0;
    float weakest_pick = std::numeric_limits<float>::infinity();
    if (kept.size() < target && !rest.empty()) {
      more = std::min(target - kept.size(), rest.size());
      std::nth_element(rest.begin(), rest.begin() + more, rest.end(), StrongerFirst);
      for (std::size_t k = 0; k < more; ++k) {
        weakest_pick = std::min(weakest_pick, rest[k].response);
      }
    }
    CellFloorsCut(quota, more, weakest_pick);
    if (kept.size() + more < target) weakest_pick = 0.f;  // all kept: no cell floor next time
    SteerCells(quota, weakest_pick);
    kept.insert(kept.end(), rest.begin(), rest.begin() + more);
    kps.swap(kept);
  }
  std::sort(kps.begin(), kps.end(), StrongerFirst);
  if (options.max_keypoints > 0 && kps.size() > static_cast<std::size_t>(options.max_keypoints)) {
    kps.resize(options.max_keypoints);
  }
}

std::vector<Keypoint> Surf::Impl::FastHessian(float threshold, const RectI* scan) {
  const int W = ii.width(), H = ii.height();
  const int levels = options.num_scale_levels;
  const int threads = ResolveThreadCount(options.num_threads);
  // Samples above the threshold that are maxima of their 3x3 in the layer (SIMD, hessian.h).
  const surf_detail::InLayerMaximumFn next_in_layer_max = surf_detail::ActiveInLayerMaximum();
  std::vector<Keypoint> keypoints;

  // Adaptive mode: candidates the selection cannot keep are rejected as early as the scan for
  // samples above the floor (SelectionBar). The octaves run coarse to fine, so that the finest
  // (three quarters of the candidates) meets the bars of the coarser ones; the rows are split in
  // kAdaptiveBands blocks whatever the thread count, each starting from the octaves done, so
  // that the points examined (SurfResult::candidates) do not depend on it either.
  // The bars keep up to target_points points (each cell's quota) per row block; beyond
  // kMaxBarPoints (far above the defaults' 1500) every candidate is examined instead.
  // 4 blocks: the candidates examined against the block count are in BENCHMARKS.md ("Adaptive
  // interest points"); the adaptive fast-Hessian uses up to 4 threads.
  constexpr int kAdaptiveBands = 4;
  constexpr long kMaxBarPoints = 1 << 16;
  const int g = options.grid, cells = g * g;
  const bool early =
      options.adaptive &&
      static_cast<long>(cells) * std::max(1, options.target_points / cells) <= kMaxBarPoints;
  const RectI sel = options.roi ? *options.roi : RectI{0, 0, W, H};
  if (early && scan != nullptr) {
    bar.CopyFrom(seed_bar);
  } else if (early) {
    bar.Reset(cells, std::max(1, options.target_points / cells), options.target_points);
  } else {
    cell_floor.clear();
    cell_ceiling.clear();
  }
  if (scan == nullptr && options.roi) scan = &*options.roi;

  for (int step = 0; step < options.num_octaves; ++step) {
    ThrowIfCancelled("SURF detection");  // a band stopped early by a stop request
    const int octave = early ? options.num_octaves - 1 - step : step;
    const int p = 1 << octave;
    std::vector<BoxFilterLayout> layouts(levels);
    for (int l = 0; l < levels; ++l) {
      layouts[l] = MakeBoxFilterLayout((kBaseSize + kSizeIncrement * l) * p, p);
    }
    // Sample (i, j) of this octave is centred on pixel (p*j + (p-1)/2, p*i + (p-1)/2) in every
    // layer. Its filter lies inside the image for j in [border/p, (W - size + border)/p].
    const auto lo_x = [&](int l) { return layouts[l].border / p; };
    const auto hi_x = [&](int l, int extent) {
      return (extent - layouts[l].size + layouts[l].border) / p;
    };
    // Candidate range of each middle layer (inclusive): neighbours in the next (larger) layer
    // must be inside the image; ROI limits centres to within one sample of the rectangle.
    std::vector<std::array<int, 4>> cand(levels);  // j0, j1, i0, i1 inclusive
    bool any = false;
    int span_j0 = W, span_j1 = -1;
    for (int l = 1; l + 1 < levels; ++l) {
      int j0 = lo_x(l + 1) + 1, j1 = hi_x(l + 1, W) - 1;
      int i0 = lo_x(l + 1) + 1, i1 = hi_x(l + 1, H) - 1;
      if (layouts[l + 1].size > W || layouts[l + 1].size > H) j1 = j0 - 1;
      if (scan != nullptr) {
        const RectI& r = *scan;
        // centre c = p*j + (p-1)/2 moves by at most p in refinement.
        j0 = std::max(j0, (r.x - p) / p - 1);
        j1 = std::min(j1, (r.x + r.width + p) / p + 1);
        i0 = std::max(i0, (r.y - p) / p - 1);
        i1 = std::min(i1, (r.y + r.height + p) / p + 1);
      }
      cand[l] = {j0, j1, i0, i1};
      if (j0 <= j1 && i0 <= i1) {
        any = true;
        span_j0 = std::min(span_j0, j0);
        span_j1 = std::max(span_j1, j1);
      }
    }
    if (!any) continue;
    const float centre_offset = (p - 1) * 0.5f;
    // The refined centre is p * (j + offset) + centre_offset with |offset| <= 1 (Interpolate):
    // the grid cells a sample's point can fall in, by the selection's own formula.
    const auto cells_of = [&](int k, int origin, int extent) {
      return std::pair<int, int>(GridCell(p * (k + -1.f) + centre_offset, origin, extent, g),
                                 GridCell(p * (k + 1.f) + centre_offset, origin, extent, g));
    };
    spans.clear();
    if (early) {
      for (int j = span_j0; j <= span_j1; ++j) {
        const auto [c0, c1] = cells_of(j, sel.x, sel.width);
        if (spans.empty() || spans.back().cx0 != c0 || spans.back().cx1 != c1) {
          spans.push_back({j, j + 1, c0, c1});
        } else {
          spans.back().j_end = j + 1;
        }
      }
    } else {
      spans.push_back({span_j0, span_j1 + 1, 0, 0});
    }

    // Rows of samples are processed in bands (one per task). Within a band the determinants
    // of the middle layers are computed row by row into a ring of three rows per layer, and
    // row i is searched for maxima as soon as row i + 1 exists: the response maps never leave
    // the cache. The first and last layers only serve as neighbours of maxima of the layers
    // next to them, so they are evaluated at the few samples that reach that test; this halves
    // the box filtering at the default 4 levels.
    const int grid_w = W / p + 2;
    std::vector<std::array<int, 4>> region(levels);  // Where each middle layer is needed.
    int c_begin = H, c_end = -1;                     // Candidate rows, all middle layers.
    for (int l = 1; l + 1 < levels; ++l) {
      int j0 = W, j1 = -1, i0 = H, i1 = -1;
      for (int m = std::max(1, l - 1); m <= std::min(levels - 2, l + 1); ++m) {
        if (cand[m][0] > cand[m][1] || cand[m][2] > cand[m][3]) continue;
        j0 = std::min(j0, cand[m][0] - 1);
        j1 = std::max(j1, cand[m][1] + 1);
        i0 = std::min(i0, cand[m][2] - 1);
        i1 = std::max(i1, cand[m][3] + 1);
      }
      region[l] = {std::max(j0, lo_x(l)), std::min(j1, hi_x(l, W)), std::max(i0, lo_x(l)),
                   std::min(i1, hi_x(l, H))};
      if (cand[l][0] <= cand[l][1] && cand[l][2] <= cand[l][3]) {
        c_begin = std::min(c_begin, cand[l][2]);
        c_end = std::max(c_end, cand[l][3]);
      }
    }
    const int rows = c_end - c_begin + 1;
    const int bands =
        early ? std::min(rows, kAdaptiveBands) : (threads > 1 ? std::min(rows, threads * 4) : 1);
    if (static_cast<int>(found.size()) < bands) found.resize(bands);
    for (int b = 0; b < bands; ++b) found[b].clear();
    if (early) {
      if (static_cast<int>(band_bars.size()) < bands) band_bars.resize(bands);
      for (int b = 0; b < bands; ++b) band_bars[b].CopyFrom(bar);
    }
    if (static_cast<int>(rings.size()) < threads) rings.resize(threads);
    const std::size_t ring_floats = static_cast<std::size_t>(3) * levels * grid_w;

    ParallelFor(threads, bands, 1, [&](long band_begin, long band_end, int worker) {
      for (int b = static_cast<int>(band_begin); b < band_end; ++b) {
        const int cb = c_begin + static_cast<int>(static_cast<long>(rows) * b / bands);
        const int ce = c_begin + static_cast<int>(static_cast<long>(rows) * (b + 1) / bands);
        std::vector<float>& ring = rings[worker];
        if (ring.size() < ring_floats) ring.resize(ring_floats);
        const auto row_of = [&](int l, int r) {
          return ring.data() + (static_cast<std::size_t>(l) * 3 + r % 3) * grid_w;
        };
        std::vector<Keypoint>& out = found[b];
        SelectionBar* band_bar = early ? &band_bars[b] : nullptr;
        for (int r = cb - 1; r <= ce; ++r) {
          if ((r & 15) == 0 && CancelRequested()) break;  // core/cancel.h; thrown below
          for (int l = 1; l + 1 < levels; ++l) {
            const auto [j0, j1, i0, i1] = region[l];
            if (r < i0 || r > i1 || j0 > j1) continue;
            surf_detail::ComputeHessianRow(ii, layouts[l], r, j0, j1 + 1, row_of(l, r) + j0);
          }
          const int i = r - 1;  // Rows i - 1, i, i + 1 are ready.
          if (i < cb || i >= ce) continue;
          // Plain variables, not a structured binding: C++17 does not let a lambda capture one.
          const std::pair<int, int> cy = cells_of(i, sel.y, sel.height);
          const int cy0 = cy.first, cy1 = cy.second;
          // The scan's threshold over a span: the floor, or in adaptive mode the lowest bar of
          // the cells its points can fall in when that is higher (responses >= the bar pass).
          // With cell floors (SetCellFloors), a cell's own requirement is the higher of its floor
          // and its bar, and the span's threshold the lowest requirement of its cells.
          const auto span_threshold = [&](const ColumnSpan& s) {
            if (band_bar == nullptr) return threshold;
            const auto need = [&](int c) {
              const float b = JustBelow(band_bar->Bar(c));
              return cell_floor.empty() ? b : std::max(cell_floor[c], b);
            };
            const float t = std::min(std::min(need(cy0 * g + s.cx0), need(cy0 * g + s.cx1)),
                                     std::min(need(cy1 * g + s.cx0), need(cy1 * g + s.cx1)));
            return std::max(threshold, t);
          };
          for (int l = 1; l + 1 < levels; ++l) {
            const auto [j0, j1, i0, i1] = cand[l];
            if (i < i0 || i > i1 || j0 > j1) continue;
            const float* m0 = row_of(l, i - 1);
            const float* m1 = row_of(l, i);
            const float* m2 = row_of(l, i + 1);
            const bool lazy_lo = l - 1 == 0, lazy_hi = l + 1 == levels - 1;
            // Whether sample j (above the threshold and a maximum of its 3x3 in the layer) is a
            // keypoint: appended to `out`.
            const auto examine = [&](int j) {
              const float v = m1[j];
              // 3x3 neighbourhoods of the three layers, row-major (stride 3); full neighbour
              // layers are tested first (cheap), lazily evaluated ones last.
              float n[3][9];
              const auto copy3x3 = [&](int layer, float* dst) {
                for (int di = 0; di < 3; ++di) {
                  const float* src = row_of(layer, i - 1 + di) + j - 1;
                  dst[di * 3] = src[0];
                  dst[di * 3 + 1] = src[1];
                  dst[di * 3 + 2] = src[2];
                }
              };
              // Evaluates the 3x3 neighbourhood of a lazily evaluated layer, centre first, and
              // stops at the first value >= v (false: not a maximum). The same decision as
              // evaluating all nine then IsMaximum, at a fraction of the cost on the many
              // candidates of a low threshold (adaptive mode).
              const auto eval3x3 = [&](int layer, float* dst) {
                static constexpr int kOrder[9] = {4, 1, 3, 5, 7, 0, 2, 6, 8};
                for (const int k : kOrder) {
                  dst[k] = surf_detail::HessianDeterminant(ii, layouts[layer], i - 1 + k / 3,
                                                           j - 1 + k % 3);
                  if (!(v > dst[k])) return false;
                }
                return true;
              };
              if (!lazy_lo) {
                copy3x3(l - 1, n[0]);
                if (!IsMaximum(v, n[0] + 4, 3)) return false;
              }
              if (!lazy_hi) {
                copy3x3(l + 1, n[2]);
                if (!IsMaximum(v, n[2] + 4, 3)) return false;
              }
              if (lazy_lo && !eval3x3(l - 1, n[0])) return false;
              if (lazy_hi && !eval3x3(l + 1, n[2])) return false;
              copy3x3(l, n[1]);
              float off[3];
              if (!Interpolate(n[0] + 4, n[1] + 4, n[2] + 4, 3, off)) return false;
              Keypoint kp;
              kp.x = p * (j + off[0]) + centre_offset;
              kp.y = p * (i + off[1]) + centre_offset;
              if (options.roi && !options.roi->contains(kp.x, kp.y)) return false;
              const float size = layouts[l].size + off[2] * (layouts[l].size - layouts[l - 1].size);
              kp.scale = 1.2f * size / kBaseSize;
              kp.response = v;
              kp.laplacian = surf_detail::HessianTrace(ii, layouts[l], i, j) >= 0.f ? 1 : -1;
              kp.octave = static_cast<std::int8_t>(octave);
              out.push_back(kp);
              return true;
            };
            for (const ColumnSpan& s : spans) {
              const int a = std::max(s.j_begin, j0), e = std::min(s.j_end, j1 + 1);
              if (a >= e) continue;
              float t = span_threshold(s);
              for (int j = next_in_layer_max(m0, m1, m2, a, e, t); j < e;
                   j = next_in_layer_max(m0, m1, m2, j + 1, e, t)) {
                if (!examine(j) || band_bar == nullptr) continue;
                const Keypoint& kp = out.back();
                const int cell =
                    GridCell(kp.y, sel.y, sel.height, g) * g + GridCell(kp.x, sel.x, sel.width, g);
                if (!cell_floor.empty() &&
                    (!(kp.response > cell_floor[cell]) ||
                     (!cell_ceiling.empty() && kp.response > cell_ceiling[cell]))) {
                  out.pop_back();  // outside its own cell's range: not a candidate
                  continue;
                }
                band_bar->Add(cell, kp);
                t = span_threshold(s);
              }
            }
          }
        }
      }
    });
    for (int b = 0; b < bands; ++b) {
      keypoints.insert(keypoints.end(), found[b].begin(), found[b].end());
      if (!early) continue;
      for (const Keypoint& kp : found[b]) {
        bar.Add(GridCell(kp.y, sel.y, sel.height, g) * g + GridCell(kp.x, sel.x, sel.width, g), kp);
      }
    }
  }
  ThrowIfCancelled("SURF detection");
  return keypoints;
}

float Surf::Impl::Orientation(const Keypoint& kp) const {
  const Tables& t = GetTables();
  const int W = ii.width(), H = ii.height();
  const float s = kp.scale;
  const int half = std::max(1, static_cast<int>(std::lround(2.f * s)));  // Haar side 4s.
  const int side = 2 * half;
  const std::ptrdiff_t st = ii.stride();
  const std::uint32_t* base = ii.data();
  const int n = t.ori_count;
  // Top-left of the wavelet centred on (x, y): round(x - (side - 1) / 2).
  const float cx = kp.x - (side - 1) * 0.5f + 0.5f, cy = kp.y - (side - 1) * 0.5f + 0.5f;
  alignas(32) std::int32_t x0[kOriMaxSamples], y0[kOriMaxSamples];
  alignas(32) float fx[kOriMaxSamples], fy[kOriMaxSamples];
  for (int k = 0; k < n; ++k) {
    x0[k] = static_cast<std::int32_t>(std::floor(cx + t.ori_i[k] * s));
    y0[k] = static_cast<std::int32_t>(std::floor(cy + t.ori_j[k] * s));
  }
  const float reach = kOriRadius * s + side + 2.f;
  const bool inside =
      kp.x - reach >= 0.f && kp.y - reach >= 0.f && kp.x + reach <= W && kp.y + reach <= H;
  for (int k = 0; k < n; ++k) {
    // Wavelets leaving the image are skipped (OpenCV does the same): a zero vector adds
    // nothing to any window.
    if (!inside && (x0[k] < 0 || y0[k] < 0 || x0[k] + side > W || y0[k] + side > H)) {
      fx[k] = fy[k] = 0.f;
      continue;
    }
    const std::uint32_t* r0 = base + y0[k] * st + x0[k];
    const std::uint32_t* r1 = r0 + half * st;
    const std::uint32_t* r2 = r0 + side * st;
    // dx = right half - left half; dy = bottom half - top half.
    const std::int32_t dx = static_cast<std::int32_t>((r2[side] - r0[side]) -
                                                      2u * (r2[half] - r0[half]) + (r2[0] - r0[0]));
    const std::int32_t dy = static_cast<std::int32_t>((r2[side] - r2[0]) - 2u * (r1[side] - r1[0]) +
                                                      (r0[side] - r0[0]));
    fx[k] = static_cast<float>(dx) * t.ori_w[k];
    fy[k] = static_cast<float>(dy) * t.ori_w[k];
  }
  alignas(32) std::int32_t bin[kOriMaxSamples];
  for (int k = 0; k < n; ++k) {
    const int b = static_cast<int>(FastAtan2(fy[k], fx[k]) * (kOriBins / kTwoPi));
    bin[k] = std::min(b, kOriBins - 1);
  }
  std::array<float, kOriBins> bx{}, by{};
  for (int k = 0; k < n; ++k) {
    bx[bin[k]] += fx[k];
    by[bin[k]] += fy[k];
  }
  float sx = 0.f, sy = 0.f;
  for (int b = 0; b < kOriWindowBins; ++b) {
    sx += bx[b];
    sy += by[b];
  }
  float best = 0.f, best_x = 0.f, best_y = 0.f;
  for (int b = 0; b < kOriBins; ++b) {
    const float m = sx * sx + sy * sy;
    if (m > best) {
      best = m;
      best_x = sx;
      best_y = sy;
    }
    const int in =
        b + kOriWindowBins < kOriBins ? b + kOriWindowBins : b + kOriWindowBins - kOriBins;
    sx += bx[in] - bx[b];
    sy += by[in] - by[b];
  }
  if (best == 0.f) return 0.f;  // Flat neighbourhood.
  float angle = std::atan2(best_y, best_x);
  if (angle < 0.f) angle += kTwoPi;
  if (angle >= kTwoPi) angle = 0.f;
  return angle;
}

void Surf::Impl::Orient(std::vector<Keypoint>& kps) {
  if (options.upright) {
    for (Keypoint& kp : kps) kp.orientation = 0.f;
    return;
  }
  ForEachInSpatialOrder(kps, "SURF orientation",
                        [&](std::uint32_t k) { kps[k].orientation = Orientation(kps[k]); });
}

void Surf::Impl::DescribeOne(const Keypoint& kp, float* out) const {
  constexpr int kN = kPatch * kPatch;
  const Tables& t = GetTables();
  const bool extended = options.extended;
  const int dsize = extended ? 128 : 64;
  const int W = ii.width(), H = ii.height();
  const float s = kp.scale;
  const int half = std::max(1, static_cast<int>(std::lround(s)));  // Haar side 2s.
  const int side = 2 * half;
  const float co = std::cos(kp.orientation), si = std::sin(kp.orientation);
  const std::ptrdiff_t st = ii.stride();
  const std::uint32_t* base = ii.data();

  // 1. Top-left corners of the 400 wavelets on the rotated grid (vectorised).
  alignas(32) std::int32_t x0[kN], y0[kN];
  alignas(32) float gu[kPatch], gv[kPatch];
  for (int k = 0; k < kPatch; ++k) {
    gu[k] = t.grid[k] * s;
    gv[k] = t.grid[k] * s;
  }
  const float ox = kp.x - (side - 1) * 0.5f + 0.5f, oy = kp.y - (side - 1) * 0.5f + 0.5f;
  for (int r = 0; r < kPatch; ++r) {
    const float bx = ox - gv[r] * si, by = oy + gv[r] * co;
    for (int c = 0; c < kPatch; ++c) {
      x0[r * kPatch + c] = static_cast<std::int32_t>(std::floor(bx + gu[c] * co));
      y0[r * kPatch + c] = static_cast<std::int32_t>(std::floor(by + gu[c] * si));
    }
  }
  // 2. Haar responses (8 integral-image lookups each).
  alignas(32) float dxs[kN], dys[kN];
  const float reach = (kPatch * 0.5f) * s * 1.4143f + side + 2.f;
  const bool inside =
      kp.x - reach >= 0.f && kp.y - reach >= 0.f && kp.x + reach <= W && kp.y + reach <= H;
  if (inside) {
    for (int k = 0; k < kN; ++k) {
      const std::uint32_t* a0 = base + y0[k] * st + x0[k];
      const std::uint32_t* a1 = a0 + half * st;
      const std::uint32_t* a2 = a0 + side * st;
      dxs[k] = static_cast<float>(static_cast<std::int32_t>(
          (a2[side] - a0[side]) - 2u * (a2[half] - a0[half]) + (a2[0] - a0[0])));
      dys[k] = static_cast<float>(static_cast<std::int32_t>(
          (a2[side] - a2[0]) - 2u * (a1[side] - a1[0]) + (a0[side] - a0[0])));
    }
  } else {
    // Clamp the wavelets' corners to the image: the parts outside contribute nothing.
    for (int k = 0; k < kN; ++k) {
      const int xs[3] = {std::clamp(x0[k], 0, W), std::clamp(x0[k] + half, 0, W),
                         std::clamp(x0[k] + side, 0, W)};
      const std::ptrdiff_t ys[3] = {std::clamp(y0[k], 0, H) * st,
                                    std::clamp(y0[k] + half, 0, H) * st,
                                    std::clamp(y0[k] + side, 0, H) * st};
      const auto A = [&](int yi, int xi) { return base[ys[yi] + xs[xi]]; };
      dxs[k] = static_cast<float>(static_cast<std::int32_t>(
          (A(2, 2) - A(0, 2)) - 2u * (A(2, 1) - A(0, 1)) + (A(2, 0) - A(0, 0))));
      dys[k] = static_cast<float>(static_cast<std::int32_t>(
          (A(2, 2) - A(2, 0)) - 2u * (A(1, 2) - A(1, 0)) + (A(0, 2) - A(0, 0))));
    }
  }
  // 3. Rotate into the keypoint's frame (u along the orientation), weight, and sum over the
  // 4x4 sub-regions: first per column over each band of 5 rows (element-wise, vectorises), then
  // 5 columns per sub-region.
  constexpr int kMaxSums = 8;
  const int nsums = extended ? 8 : 4;
  for (int band = 0; band < 4; ++band) {
    alignas(32) float col[kMaxSums][kPatch] = {};
    for (int r = band * 5; r < band * 5 + 5; ++r) {
      const float* w = t.desc_w + r * kPatch;
      const float* dx = dxs + r * kPatch;
      const float* dy = dys + r * kPatch;
      if (!extended) {
        for (int c = 0; c < kPatch; ++c) {
          const float ru = w[c] * (dx[c] * co + dy[c] * si);
          const float rv = w[c] * (dy[c] * co - dx[c] * si);
          col[0][c] += ru;
          col[1][c] += rv;
          col[2][c] += std::fabs(ru);
          col[3][c] += std::fabs(rv);
        }
      } else {
        // OpenCV's extended layout: sums of du split by the sign of dv, and of dv by du's sign.
        for (int c = 0; c < kPatch; ++c) {
          const float ru = w[c] * (dx[c] * co + dy[c] * si);
          const float rv = w[c] * (dy[c] * co - dx[c] * si);
          const bool vpos = rv >= 0.f, upos = ru >= 0.f;
          col[0][c] += vpos ? ru : 0.f;
          col[1][c] += vpos ? std::fabs(ru) : 0.f;
          col[2][c] += vpos ? 0.f : ru;
          col[3][c] += vpos ? 0.f : std::fabs(ru);
          col[4][c] += upos ? rv : 0.f;
          col[5][c] += upos ? std::fabs(rv) : 0.f;
          col[6][c] += upos ? 0.f : rv;
          col[7][c] += upos ? 0.f : std::fabs(rv);
        }
      }
    }
    for (int b = 0; b < 4; ++b) {
      float* cell = out + (band * 4 + b) * nsums;
      for (int q = 0; q < nsums; ++q) {
        const float* cq = col[q] + b * 5;
        cell[q] = cq[0] + cq[1] + cq[2] + cq[3] + cq[4];
      }
    }
  }
  float norm2 = 0.f;
  for (int k = 0; k < dsize; ++k) norm2 += out[k] * out[k];
  if (norm2 > 0.f) {
    const float inv = 1.f / std::sqrt(norm2);
    for (int k = 0; k < dsize; ++k) out[k] *= inv;
  }
}

void Surf::Impl::DescribeAll(const std::vector<Keypoint>& kps, float* out, int dsize) {
  ForEachInSpatialOrder(kps, "SURF description",
                        [&](std::uint32_t k) { DescribeOne(kps[k], out + k * dsize); });
}

Surf::Surf(const SurfOptions& options) : impl_(nullptr) {
  Validate(options);
  impl_ = new Impl;
  impl_->options = options;
}

Surf::~Surf() { delete impl_; }

Surf::Surf(Surf&& other) noexcept : impl_(other.impl_) { other.impl_ = nullptr; }

Surf& Surf::operator=(Surf&& other) noexcept {
  if (this != &other) {
    delete impl_;
    impl_ = other.impl_;
    other.impl_ = nullptr;
  }
  return *this;
}

const SurfOptions& Surf::options() const { return impl_->options; }

std::vector<Keypoint> Surf::Impl::DetectSelected(const GrayImageView& image,
                                                 double steered_min_response,
                                                 const std::vector<float>& steered_cells,
                                                 int* redone) {
  const float threshold = DetectionThreshold(image, steered_min_response);
  SetCellFloors(steered_cells);
  cell_ceiling.clear();
  std::vector<Keypoint> kps = FastHessian(threshold);
  Select(kps);
  *redone = static_cast<int>(cut_cells.size());
  if (!cut_cells.empty()) kps = RedoCells(threshold);
  if (!cut_cells.empty()) {  // Not expected (RedoCells): the whole frame at its floor alone.
    *redone = options.grid * options.grid;
    cell_floor.clear();
    cell_ceiling.clear();
    kps = FastHessian(threshold);
    Select(kps);
  }
  return kps;
}

RectI Surf::Impl::CellsRect(const RectI& sel, int c0, int c1) const {
  const int g = options.grid;
  // GridCell clamps: the first and last cells of a row or column reach beyond the image (the
  // roi test of FastHessian still applies). One pixel of margin against rounding.
  constexpr int kFar = 1 << 20;
  const auto begin = [&](int k, int origin, int extent) {
    return k == 0 ? -kFar : origin + static_cast<int>(static_cast<long>(k) * extent / g) - 1;
  };
  const auto end = [&](int k, int origin, int extent) {
    return k == g - 1 ? kFar : origin + static_cast<int>(static_cast<long>(k + 1) * extent / g) + 1;
  };
  const int x0 = begin(c0 % g, sel.x, sel.width), y0 = begin(c0 / g, sel.y, sel.height);
  return RectI{x0, y0, end(c1 % g, sel.x, sel.width) - x0, end(c0 / g, sel.y, sel.height) - y0};
}

std::vector<Keypoint> Surf::Impl::RedoCells(float threshold) {
  const int g = options.grid, cells = g * g;
  const RectI sel = options.roi ? *options.roi : RectI{0, 0, ii.width(), ii.height()};
  all_found.assign(by_cell.begin(), by_cell.end());  // Select keeps every candidate there
  redoing = true;
  seed_bar.Reset(cells, std::max(1, options.target_points / cells), options.target_points);
  for (const Keypoint& kp : all_found) {
    seed_bar.Add(GridCell(kp.y, sel.y, sel.height, g) * g + GridCell(kp.x, sel.x, sel.width, g),
                 kp);
  }
  pass_floor.assign(cell_floor.begin(), cell_floor.end());
  const std::vector<int> redo = cut_cells;
  cell_ceiling.assign(cells, std::numeric_limits<float>::infinity());
  // Runs of consecutive cells of one grid row, each searched over one rectangle: only its cells,
  // only between the frame's floor and their old floors (the first pass found the rest).
  for (std::size_t k = 0; k < redo.size();) {
    std::size_t e = k + 1;
    while (e < redo.size() && redo[e] == redo[e - 1] + 1 && redo[e] % g != 0) ++e;
    std::fill(cell_floor.begin(), cell_floor.end(), std::numeric_limits<float>::infinity());
    for (std::size_t i = k; i < e; ++i) {
      cell_floor[redo[i]] = threshold;
      cell_ceiling[redo[i]] = pass_floor[redo[i]];
    }
    const RectI rect = CellsRect(sel, redo[k], redo[e - 1]);
    const std::vector<Keypoint> more = FastHessian(threshold, &rect);
    all_found.insert(all_found.end(), more.begin(), more.end());
    for (std::size_t i = k; i < e; ++i)
      cell_ceiling[redo[i]] = std::numeric_limits<float>::infinity();
    k = e;
  }
  // The candidates now are those of cell floors at the frame's floor in the redone cells.
  cell_floor.swap(pass_floor);
  for (const int c : redo) cell_floor[c] = threshold;
  cell_ceiling.clear();
  std::vector<Keypoint> kps(all_found.begin(), all_found.end());
  Select(kps);
  redoing = false;
  return kps;
}

SurfResult Surf::DetectAndDescribe(const GrayImageView& image, double steered_min_response,
                                   const std::vector<float>& steered_cell_min_response) {
  SurfResult result;
  Stopwatch watch;
  impl_->Prepare(image);
  std::vector<Keypoint> kps = impl_->DetectSelected(
      image, steered_min_response, steered_cell_min_response, &result.cells_redone);
  impl_->Orient(kps);
  result.detect_ms = watch.elapsed_ms();
  result.candidates = impl_->last_candidates;
  result.contrast_range = impl_->last_range;
  result.floor_response = impl_->last_floor;
  result.next_min_response = impl_->next_min_response;
  result.next_cell_min_response = impl_->next_cell_min_response;
  watch.restart();
  FeatureSet& fs = result.features;
  fs.descriptor_size = impl_->options.extended ? 128 : 64;
  fs.descriptors.resize(kps.size() * fs.descriptor_size);
  impl_->DescribeAll(kps, fs.descriptors.data(), fs.descriptor_size);
  fs.keypoints = std::move(kps);
  result.describe_ms = watch.elapsed_ms();
  return result;
}

std::vector<Keypoint> Surf::Detect(const GrayImageView& image) {
  impl_->Prepare(image);
  int redone = 0;
  std::vector<Keypoint> kps = impl_->DetectSelected(image, 0.0, {}, &redone);
  impl_->Orient(kps);
  return kps;
}

FeatureSet Surf::Describe(const GrayImageView& image, std::vector<Keypoint> keypoints) {
  impl_->Prepare(image);
  const float max_scale = static_cast<float>(std::max(image.width, image.height));
  for (std::size_t k = 0; k < keypoints.size(); ++k) {
    const Keypoint& kp = keypoints[k];
    if (!std::isfinite(kp.x) || !std::isfinite(kp.y) || !std::isfinite(kp.orientation) ||
        !(kp.scale > 0.f && kp.scale <= max_scale)) {
      throw InvalidArgument("Surf::Describe: keypoint " + std::to_string(k) + " (x " +
                            std::to_string(kp.x) + ", y " + std::to_string(kp.y) + ", scale " +
                            std::to_string(kp.scale) +
                            ") needs finite coordinates and orientation and a scale in (0, " +
                            std::to_string(max_scale) + "]");
    }
  }
  FeatureSet fs;
  fs.descriptor_size = impl_->options.extended ? 128 : 64;
  fs.descriptors.resize(keypoints.size() * fs.descriptor_size);
  impl_->DescribeAll(keypoints, fs.descriptors.data(), fs.descriptor_size);
  fs.keypoints = std::move(keypoints);
  return fs;
}

}  // namespace aerovo
