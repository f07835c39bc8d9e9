// The reference maps' SURF points, detected once per map tile and kept (`aerovo run --map`;
// docs/map.md "What an attempt costs"): the map fixer's windows around consecutive predictions
// overlap by most of their area, and reading a window through GDAL and detecting its points is
// most of an attempt's cost, so the map is cut into square tiles of a fixed grid, each read
// (map/reference_map.h ReferenceMaps::Window, with a margin) and detected (odometry/map_match.h
// DetectMapFeatures) the first time a window needs it, and a window's points are gathered from
// the tiles it overlaps.
//
// Frames: the grid is north-up in the local East-North plane of the first map's centre (the
// anchor, geo/local_enu.h): tile (i, j) has its centre i tile_m east and j tile_m north of it,
// tile_m = core_px * m_per_px. Each tile is read in its own centre's plane and its points
// are carried into a window's plane (the window centre's) by the affine of the two planes at
// the tile's centre (their difference within a tile is far below a pixel).
//
// A tile's points are those whose centre lies in its core (core_px x core_px); the tile is read
// with a margin (margin_px each side) so that the SURF responses and descriptors of the core's
// points are those of the whole map (the largest SURF filter of 3 octaves, 99 px, and a
// descriptor disc of 12 scales up to scale 10: 120 px). Deterministic: the same sequence of
// windows gives the same points (the tiles kept, least recently used dropped first, depend on
// that sequence only).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <tuple>

#include "aerovo/core/image.h"
#include "aerovo/features/keypoint.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/odometry/map_match.h"

namespace aerovo::map {
class ReferenceMaps;
}

namespace aerovo::run_steps {

class MapTileCache {
 public:
  struct Options {
    int core_px = 512;        ///< Side of a tile's core, px at the level's resolution.
    int margin_px = 120;      ///< Margin read and detected around the core, px.
    std::size_t max_tiles = 48;  ///< Tiles kept (about 0.9 MB each at 512 px).
  };
  /// `maps` must outlive the cache and be read by no other thread while it reads. Throws
  /// InvalidArgument for a core under 64 px, a negative margin or no tile kept.
  MapTileCache(const map::ReferenceMaps& maps, const Options& options);
  explicit MapTileCache(const map::ReferenceMaps& maps) : MapTileCache(maps, Options{}) {}

  /// The window of `size_px` x `size_px` pixels of `m_per_px` metres centred on `centre`
  /// (map/reference_map.h MapWindow's geometry) given by its points: those of the tiles it
  /// overlaps whose descriptor disc (12 scales) lies inside it, at most `max_points` (spread
  /// over a 6 x 6 grid as SURF's adaptive selection spreads them), with its valid pixels and their robust range. `points_per_px`: the density a
  /// tile is detected at (its target: this times its valid pixels), fixed by the first window
  /// at this resolution and `upright`. Throws InvalidArgument for size_px < 2 or m_per_px not
  /// finite and > 0; InputError naming the map when reading it fails.
  MapWindowFeatures Window(const GeoPoint& centre, int size_px, double m_per_px, bool upright,
                           double points_per_px, int max_points);

  /// Tiles read and detected so far (the cost), and windows served.
  int tiles_made() const { return tiles_made_; }
  int windows() const { return windows_; }

 private:
  struct Tile {
    GeoPoint centre;
    FeatureSet features;  // in the core, tile-window px (size core + 2 margin)
    GrayImage grey, valid;  // the core's pixels (valid 0 where the map has no data)
    std::int64_t last_used = 0;
  };
  // (resolution as the ladder's k, upright, i, j)
  using Key = std::tuple<std::int64_t, bool, std::int64_t, std::int64_t>;
  Tile& Get(const Key& key, double m_per_px, bool upright, double points_per_px);
  Tile Make(std::int64_t i, std::int64_t j, double m_per_px, bool upright,
            double points_per_px) const;

  const map::ReferenceMaps& maps_;
  Options options_;
  LocalEnu anchor_;
  std::map<Key, Tile> tiles_;
  std::map<std::pair<std::int64_t, bool>, double> density_;  // per level: points per px
  std::int64_t clock_ = 0;
  int tiles_made_ = 0, windows_ = 0;
};

}  // namespace aerovo::run_steps
