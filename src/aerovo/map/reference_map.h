// The reference maps of a run (several allowed, in the order of preference: a recent survey
// given before an older satellite mosaic; each pixel of a window is read from the first map with
// data there, so a window the preferred map covers in part is filled from the next), read as
// windows: a north-up square of the
// ground around a geographic point, at a requested ground resolution, in the local East-North
// plane of that point (geo/local_enu.h) — what a frame brought to the map's geometry is matched
// against. GDAL reads the map's overview nearest the resolution asked (averaged), and the window
// is resampled bilinearly through the map's CRS (an affine fit of the window's corners: the
// CRS's curvature over a window of a few hundred metres is centimetres, checked). docs/map.md.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/map_info.h"

namespace aerovo::map {

/// A window of a map. Pixel (x, y) is at east = (x - (size - 1) / 2) m_per_px, north =
/// ((size - 1) / 2 - y) m_per_px of `centre` (row 0 is the northern edge).
struct MapWindow {
  GrayImage pixels;  ///< Grey (luma of RGB maps: 0.299 R + 0.587 G + 0.114 B); 0 where invalid.
  GrayImage valid;   ///< 255 where the map has data (inside it, alpha or nodata not empty), else 0.
  double valid_fraction = 0.0;
  double m_per_px = 0.0;
  GeoPoint centre;
  int map_index = 0;  ///< The map that gave the most pixels (ReferenceMaps::infos()).
  std::vector<int> pixels_from_map;  ///< Valid pixels from each map, in the order of infos().
};

/// How much of a set of positions the maps cover.
struct MapCover {
  int points = 0, covered = 0;
  bool none() const { return points > 0 && covered == 0; }
  bool partial() const { return covered > 0 && covered < points; }
};

class ReferenceMaps {
 public:
  /// Opens every map (ReadMapInfo: InputError naming a missing, corrupt, CRS-less or
  /// geotransform-less one). Throws InvalidArgument when `paths` is empty.
  explicit ReferenceMaps(const std::vector<std::filesystem::path>& paths);
  ~ReferenceMaps();
  ReferenceMaps(ReferenceMaps&&) noexcept;
  ReferenceMaps& operator=(ReferenceMaps&&) noexcept;

  const std::vector<MapInfo>& infos() const { return infos_; }

  /// Which of `points` fall on a map's data (its extent and a non-empty pixel there).
  MapCover CoverOf(const std::vector<GeoPoint>& points) const;

  /// The first map (index into infos()) with data at `p`; nullopt when none has.
  std::optional<int> MapAt(const GeoPoint& p) const;

  /// The window of `size_px` x `size_px` pixels of `m_per_px` metres centred on `centre`: each
  /// pixel from the first map (in the order given) with data there, so that a window the
  /// preferred map covers in part is filled from the next ones, whatever their CRS and
  /// resolution; nullopt when none has data in it.
  /// Throws InvalidArgument for size_px < 2 or m_per_px not finite and > 0, InputError naming
  /// the map when reading it fails.
  std::optional<MapWindow> Window(const GeoPoint& centre, int size_px, double m_per_px) const;

 private:
  struct Open;
  // Fills the pixels of `win` (centred on `enu`'s origin) still invalid from map `m`; the count.
  int Fill(std::size_t m, const LocalEnu& enu, MapWindow* win) const;
  std::vector<MapInfo> infos_;
  std::vector<std::unique_ptr<Open>> open_;
};

/// The flight's cover check of `aerovo run --map` before the run: InputError naming the maps when
/// none covers any of `track` (e.g. the telemetry's first fixes), a warning (returned) naming them
/// with the covered share when the cover is partial, "" when full.
std::string CheckCover(const ReferenceMaps& maps, const std::vector<GeoPoint>& track);

}  // namespace aerovo::map
