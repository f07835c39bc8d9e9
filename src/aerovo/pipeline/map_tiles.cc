#include "aerovo/pipeline/map_tiles.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/map/reference_map.h"

namespace aerovo::run_steps {
namespace {

// The first map's centre (its WGS84 extent's): the grid's anchor.
GeoPoint AnchorOf(const map::ReferenceMaps& maps) {
  if (maps.infos().empty()) throw InvalidArgument("MapTileCache: no map");
  const auto& e = maps.infos().front().extent_lonlat;
  GeoPoint p;
  p.lat_deg = 0.5 * (e.min_y + e.max_y);
  p.lon_deg = 0.5 * (e.min_x + e.max_x);
  return p;
}

// A tile's points carried into a window: window px = window_from_tile * (tile px, 1).
struct TileToWindow {
  Eigen::Matrix2d linear = Eigen::Matrix2d::Identity();
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();
};

// The affine from tile-window pixels (centre `tile_c` px) to window pixels (centre `window_c`
// px) of two north-up planes of the same resolution: the tile centre's position `d_m` (m, in the
// window's plane) and the angle `theta` (rad, counter-clockwise) of the tile plane's north in
// the window's.
TileToWindow Affine(const Eigen::Vector2d& d_m, double theta, double m_per_px, double tile_c,
                    double window_c) {
  // Pixel axes are (east, south): the rotation by theta counter-clockwise seen from above is
  // clockwise in them.
  const double c = std::cos(theta), s = std::sin(theta);
  TileToWindow a;
  a.linear << c, s, -s, c;
  const Eigen::Vector2d centre(window_c + d_m.x() / m_per_px, window_c - d_m.y() / m_per_px);
  a.offset = centre - a.linear * Eigen::Vector2d(tile_c, tile_c);
  return a;
}

// The points of `tile` (tile-window px) whose descriptor disc (12 scales) lies in the window of
// `size_px`, carried into it, appended to `points` and `descriptors`.
void AddPoints(const FeatureSet& tile, const TileToWindow& affine, int size_px,
               std::vector<Keypoint>* points, std::vector<float>* descriptors) {
  const auto dsize = static_cast<std::size_t>(tile.descriptor_size);
  for (std::size_t k = 0; k < tile.size(); ++k) {
    Keypoint p = tile.keypoints[k];
    const Eigen::Vector2d w = affine.linear * Eigen::Vector2d(p.x, p.y) + affine.offset;
    const double r = 12.0 * p.scale;
    if (w.x() - r < 0.0 || w.y() - r < 0.0 || w.x() + r > size_px - 1.0 ||
        w.y() + r > size_px - 1.0) {
      continue;
    }
    p.x = static_cast<float>(w.x());
    p.y = static_cast<float>(w.y());
    points->push_back(p);
    descriptors->insert(descriptors->end(), tile.descriptor(k), tile.descriptor(k) + dsize);
  }
}

// The valid pixels of a tile's core whose pixel (0, 0) is window pixel (ox, oy) (to the nearest
// pixel), inside the window of `size_px`: counted and added to `histogram`.
void AddPixels(const GrayImage& grey, const GrayImage& valid, long ox, long oy, int size_px,
               std::array<std::int64_t, 256>* histogram, std::size_t* valid_px) {
  const long w = grey.width(), h = grey.height();
  for (long y = std::max(0L, -oy); y < std::min(h, size_px - oy); ++y) {
    const std::uint8_t* g = grey.row(static_cast<int>(y));
    const std::uint8_t* v = valid.row(static_cast<int>(y));
    for (long x = std::max(0L, -ox); x < std::min(w, size_px - ox); ++x) {
      if (v[x] == 0) continue;
      ++(*histogram)[g[x]];
      ++*valid_px;
    }
  }
}

// At most `max_points` of `points` (all when fewer), spread as SURF's adaptive selection
// spreads them (features/surf.h): each cell of a 6 x 6 grid over the window of `size_px` keeps
// its strongest max_points / 36, the rest of the count goes to the strongest of the others;
// strongest first (ties in their order).
FeatureSet Strongest(const std::vector<Keypoint>& points, const std::vector<float>& descriptors,
                     int size_px, int max_points) {
  constexpr int kGrid = 6;
  FeatureSet out;
  std::vector<std::size_t> order(points.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return points[x].response > points[y].response;
  });
  const auto cap = static_cast<std::size_t>(std::max(0, max_points));
  if (order.size() > cap) {
    const std::size_t per_cell = cap / (kGrid * kGrid);
    std::vector<std::size_t> in_cell(kGrid * kGrid, 0), kept, rest;
    for (const std::size_t k : order) {
      const auto cell = [&](float v) {
        return std::clamp(static_cast<int>(v * kGrid / size_px), 0, kGrid - 1);
      };
      std::size_t& n = in_cell[static_cast<std::size_t>(cell(points[k].y) * kGrid + cell(points[k].x))];
      (n < per_cell ? kept : rest).push_back(k);
      if (n < per_cell) ++n;
    }
    rest.resize(std::min(rest.size(), cap - kept.size()));
    kept.insert(kept.end(), rest.begin(), rest.end());
    std::stable_sort(kept.begin(), kept.end(), [&](std::size_t x, std::size_t y) {
      return points[x].response > points[y].response;
    });
    order = std::move(kept);
  }
  const auto dsize = static_cast<std::size_t>(out.descriptor_size);
  out.keypoints.reserve(order.size());
  out.descriptors.reserve(order.size() * dsize);
  for (const std::size_t k : order) {
    out.keypoints.push_back(points[k]);
    const auto from = descriptors.begin() + static_cast<std::ptrdiff_t>(k * dsize);
    out.descriptors.insert(out.descriptors.end(), from, from + static_cast<std::ptrdiff_t>(dsize));
  }
  return out;
}

}  // namespace

MapTileCache::MapTileCache(const map::ReferenceMaps& maps, const Options& options)
    : maps_(maps), options_(options), anchor_(AnchorOf(maps)) {
  if (options.core_px < 64 || options.margin_px < 0 || options.max_tiles < 1) {
    throw InvalidArgument(fmt::format("MapTileCache: core_px must be >= 64, margin_px >= 0 and "
                                      "max_tiles >= 1, got {}, {}, {}",
                                      options.core_px, options.margin_px, options.max_tiles));
  }
}

MapTileCache::Tile MapTileCache::Make(std::int64_t i, std::int64_t j, double m_per_px,
                                      bool upright, double points_per_px) const {
  const int core = options_.core_px, margin = options_.margin_px, size = core + 2 * margin;
  const double tile_m = core * m_per_px;
  Tile t;
  t.centre = anchor_.Reverse(static_cast<double>(i) * tile_m, static_cast<double>(j) * tile_m,
                             0.0);
  t.grey = GrayImage(core, core);
  t.valid = GrayImage(core, core);
  std::fill_n(t.grey.data(), static_cast<std::size_t>(core) * core, std::uint8_t{0});
  std::fill_n(t.valid.data(), static_cast<std::size_t>(core) * core, std::uint8_t{0});
  const std::optional<map::MapWindow> w = maps_.Window(t.centre, size, m_per_px);
  if (!w) return t;  // no data: no points, no valid pixel
  std::size_t valid = 0;
  for (int y = 0; y < size; ++y) {
    const std::uint8_t* v = w->valid.row(y);
    valid += static_cast<std::size_t>(std::count_if(v, v + size, [](std::uint8_t b) { return b; }));
  }
  const int target = static_cast<int>(std::min(1e6, points_per_px * static_cast<double>(valid)));
  FeatureSet all = DetectMapFeatures(w->pixels.view(), w->valid.view(), target, upright);
  // The core's points (pixel centres margin .. margin + core - 1).
  const float lo = margin - 0.5f, hi = margin + core - 0.5f;
  t.features.descriptor_size = all.descriptor_size;
  const auto d = static_cast<std::size_t>(all.descriptor_size);
  for (std::size_t k = 0; k < all.size(); ++k) {
    const Keypoint& p = all.keypoints[k];
    if (p.x < lo || p.x >= hi || p.y < lo || p.y >= hi) continue;
    t.features.keypoints.push_back(p);
    t.features.descriptors.insert(t.features.descriptors.end(), all.descriptor(k),
                                  all.descriptor(k) + d);
  }
  for (int y = 0; y < core; ++y) {
    std::copy_n(w->pixels.row(y + margin) + margin, core, t.grey.row(y));
    std::copy_n(w->valid.row(y + margin) + margin, core, t.valid.row(y));
  }
  return t;
}

MapTileCache::Tile& MapTileCache::Get(const Key& key, double m_per_px, bool upright,
                                      double points_per_px) {
  ++clock_;
  auto it = tiles_.find(key);
  if (it == tiles_.end()) {
    if (tiles_.size() >= options_.max_tiles) {  // the least recently used out
      auto oldest = tiles_.begin();
      for (auto o = tiles_.begin(); o != tiles_.end(); ++o) {
        if (o->second.last_used < oldest->second.last_used) oldest = o;
      }
      tiles_.erase(oldest);
    }
    it = tiles_.emplace(key, Make(std::get<2>(key), std::get<3>(key), m_per_px, upright,
                                  points_per_px)).first;
    ++tiles_made_;
  }
  it->second.last_used = clock_;
  return it->second;
}

MapWindowFeatures MapTileCache::Window(const GeoPoint& centre, int size_px, double m_per_px,
                                       bool upright, double points_per_px, int max_points) {
  if (size_px < 2 || !(m_per_px > 0.0) || !std::isfinite(m_per_px)) {
    throw InvalidArgument(fmt::format("MapTileCache::Window: size_px must be >= 2 and m_per_px "
                                      "finite and > 0, got {} and {}", size_px, m_per_px));
  }
  ++windows_;
  const std::int64_t level = std::llround(std::log2(m_per_px) * 1e6);
  const double density = density_.emplace(std::make_pair(level, upright), points_per_px)
                             .first->second;
  const int core = options_.core_px, margin = options_.margin_px;
  const double tile_m = core * m_per_px, window_c = 0.5 * (size_px - 1);
  const double tile_c = 0.5 * (core + 2 * margin - 1);
  const Eigen::Vector2d a = anchor_.Forward(centre).head<2>();
  const double half_m = 0.5 * size_px * m_per_px;
  const auto first = [&](double v) { return static_cast<std::int64_t>(std::floor(v / tile_m + 0.5)); };
  const LocalEnu at(centre);
  MapWindowFeatures out;
  out.size_px = size_px;
  out.m_per_px = m_per_px;
  std::array<std::int64_t, 256> histogram{};
  std::vector<Keypoint> points;
  std::vector<float> descriptors;
  for (std::int64_t j = first(a.y() - half_m); j <= first(a.y() + half_m); ++j) {
    for (std::int64_t i = first(a.x() - half_m); i <= first(a.x() + half_m); ++i) {
      const Tile& t = Get(Key{level, upright, i, j}, m_per_px, upright, density);
      const Eigen::Vector2d d_m = at.Forward(t.centre).head<2>();
      const Eigen::Vector2d north =
          at.Forward(LocalEnu(t.centre).Reverse(0.0, 100.0, 0.0)).head<2>() - d_m;
      const TileToWindow affine =
          Affine(d_m, std::atan2(-north.x(), north.y()), m_per_px, tile_c, window_c);
      AddPoints(t.features, affine, size_px, &points, &descriptors);
      const Eigen::Vector2d c = affine.linear * Eigen::Vector2d(tile_c, tile_c) + affine.offset;
      AddPixels(t.grey, t.valid, std::lround(c.x() - tile_c + margin),
                std::lround(c.y() - tile_c + margin), size_px, &histogram, &out.valid_px);
    }
  }
  out.features = Strongest(points, descriptors, size_px, max_points);
  out.contrast = MapRobustRange(histogram);
  return out;
}

}  // namespace aerovo::run_steps
