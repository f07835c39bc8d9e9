// A map's pixels as the grey that map fixes match (GDAL, private to this module: the header only
// declares GDAL's classes): grey from one band (a palette's colours through their luma) or the
// luma of the first three, brought to 0-255 by the map's radiometry (8-bit maps as they are;
// 16-bit and floating-point maps stretched between percentiles of their own samples), validity
// from the mask band (alpha, nodata) and from non-finite samples. docs/map.md.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

class GDALDataset;

namespace aerovo::map {

/// GDAL's messages silenced on this thread for the object's life (GDAL's handler stack is per
/// thread); the last one stays readable (CPLGetLastErrorMsg) for the error aerovo gives, which
/// names the file and quotes it.
class QuietGdal {
 public:
  QuietGdal();
  ~QuietGdal();
  QuietGdal(const QuietGdal&) = delete;
  QuietGdal& operator=(const QuietGdal&) = delete;
};

/// How a map's samples become grey 0-255.
struct MapRadiometry {
  /// Band 1's sample type as GDAL names it ("Byte", "UInt16", "Int16", "Float32", ...).
  std::string sample_type;
  /// Grey (band 1, or the luma 0.299 R + 0.587 G + 0.114 B of bands 1-3) `lo` and `hi` map to 0
  /// and 255: 0 and 255 for 8-bit samples (used as they are); for other types the 1st and 99th
  /// percentiles of the map's valid grey (ProbeMapPixels).
  double lo = 0.0, hi = 255.0;
  /// One band of palette indices: grey is the luma of each index's colour (entries 0-255).
  bool palette = false;
  std::array<float, 256> palette_grey{};
};

/// A block of a map read into memory: `w` x `h` samples covering map pixels
/// [x0, x0 + w dx) x [y0, y0 + h dy) (full-resolution pixel units), grey 0-255 and validity
/// (255 valid, 0 not; between them at a mask's edges).
struct GreyBlock {
  int w = 0, h = 0;
  double x0 = 0, y0 = 0, dx = 1, dy = 1;
  std::vector<float> grey, valid;
};

/// The most pixels (of the level read) ReadGreyBlock averages for one block: 2^28, a 16384 x
/// 16384 px area (our choice: GDAL averages that many pixels of a tiled DEFLATE GeoTIFF into
/// 1024 x 1024 in 1.5 s on one core of the development machine, `gdal_translate -r average
/// -outsize 1024 1024`). A map without overviews much finer than the resolution matched exceeds
/// it (a 1 mm map matched at 0.5 m: 500^2 pixels per sample); the docs' 4x finer map does not.
inline constexpr double kMaxMapPixelsPerRead = 268435456.0;

/// Reads the map around full-resolution pixels [c0, c1) x [r0, r1) (continuous) from the
/// coarsest overview at least as fine as `px_per_sample` map pixels per sample (each level read
/// pixel for pixel, on its own grid: GDAL's resampling of a window that is not aligned with an
/// overview's pixels would shift it by up to half of one). False when the area is off the map;
/// throws InputError naming `path` (with GDAL's message) when the pixels cannot be read, and
/// when the read would exceed kMaxMapPixelsPerRead (no overview coarse enough). GDAL's
/// own messages are not printed. Not thread-safe per dataset (GDAL's rule).
bool ReadGreyBlock(GDALDataset& ds, const std::filesystem::path& path,
                   const MapRadiometry& radiometry, double c0, double r0, double c1, double r1,
                   double px_per_sample, GreyBlock* block);

/// The map's radiometry, from its pixels read once at a reduced size (its coarsest overview when
/// it has one; else a 3 x 3 grid of 128 x 128 windows at full resolution): a map whose pixels
/// cannot be read there (a truncated file, a VRT whose source file is missing) is an InputError
/// naming `path` — so is one with no valid pixel there. Cheap whatever the map's size.
MapRadiometry ProbeMapPixels(GDALDataset& ds, const std::filesystem::path& path);

}  // namespace aerovo::map
