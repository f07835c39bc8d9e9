#include "aerovo/map/map_pixels.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <cpl_error.h>
#include <fmt/format.h>
#include <gdal_priv.h>

#include "aerovo/core/error.h"
#include "aerovo/map/gdal_error.h"

namespace aerovo::map {
namespace {

using internal::LastGdalError;

constexpr float kLuma[3] = {0.299f, 0.587f, 0.114f};  // ITU-R BT.601, as OpenCV's grey

[[noreturn]] void Unreadable(const std::filesystem::path& path) {
  throw InputError(fmt::format(
      "'{}': the map's pixels cannot be read ({}): a damaged or truncated file, or a VRT whose "
      "source is missing",
      path.string(), LastGdalError("no reason given")));
}

// `band` at overview `level` (-1: itself); null when it has no such overview.
GDALRasterBand* AtLevel(GDALRasterBand* band, int level) {
  if (level < 0) return band;
  return level < band->GetOverviewCount() ? band->GetOverview(level) : nullptr;
}

// Grey and validity of the window (x0, y0, w, h) of overview `level` (-1: full resolution) read
// into a buffer of bw x bh samples (smaller: GDAL subsamples, or averages when `average`, a
// palette's indices excepted), raw: before the radiometry's stretch. Throws InputError naming
// `path` when a band cannot be read.
void ReadRawGrey(GDALDataset& ds, const std::filesystem::path& path,
                 const MapRadiometry& radiometry, int level, int x0, int y0, int w, int h, int bw,
                 int bh, std::vector<float>* grey, std::vector<float>* valid,
                 bool average = false) {
  const std::size_t n = static_cast<std::size_t>(bw) * bh;
  const int bands = ds.GetRasterCount() >= 3 ? 3 : 1;
  std::vector<float> band(n);
  grey->assign(n, 0.0f);
  valid->assign(n, 255.0f);
  const QuietGdal quiet;
  GDALRasterIOExtraArg extra;
  INIT_RASTERIO_EXTRA_ARG(extra);
  if (average && !radiometry.palette) extra.eResampleAlg = GRIORA_Average;
  const auto read = [&](GDALRasterBand* src, float* out) {
    if (src == nullptr ||
        src->RasterIO(GF_Read, x0, y0, w, h, out, bw, bh, GDT_Float32, 0, 0, &extra) != CE_None) {
      Unreadable(path);
    }
  };
  for (int k = 0; k < bands; ++k) {
    read(AtLevel(ds.GetRasterBand(k + 1), level), band.data());
    const float wk = bands == 1 ? 1.0f : kLuma[k];
    for (std::size_t i = 0; i < n; ++i) {
      float v = band[i];
      if (radiometry.palette) {
        v = radiometry.palette_grey[static_cast<std::size_t>(std::clamp(v, 0.0f, 255.0f))];
      }
      (*grey)[i] += wk * v;
    }
  }
  GDALRasterBand* first = ds.GetRasterBand(1);
  if ((first->GetMaskFlags() & GMF_ALL_VALID) == 0)
    read(AtLevel(first->GetMaskBand(), level), valid->data());
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite((*grey)[i])) (*grey)[i] = 0.0f, (*valid)[i] = 0.0f;
  }
}

// The palette of band 1 when it is the only band and holds palette indices.
void ReadPalette(GDALDataset& ds, MapRadiometry* r) {
  GDALRasterBand* b = ds.GetRasterBand(1);
  const GDALColorTable* table = b->GetColorTable();
  if (ds.GetRasterCount() != 1 || b->GetColorInterpretation() != GCI_PaletteIndex ||
      table == nullptr) {
    return;
  }
  r->palette = true;
  for (int i = 0; i < 256; ++i) {
    const GDALColorEntry* e = i < table->GetColorEntryCount() ? table->GetColorEntry(i) : nullptr;
    r->palette_grey[static_cast<std::size_t>(i)] =
        e == nullptr ? 0.0f : kLuma[0] * e->c1 + kLuma[1] * e->c2 + kLuma[2] * e->c3;
  }
}

}  // namespace

QuietGdal::QuietGdal() {
  CPLErrorReset();
  CPLPushErrorHandler(CPLQuietErrorHandler);
}

QuietGdal::~QuietGdal() { CPLPopErrorHandler(); }

bool ReadGreyBlock(GDALDataset& ds, const std::filesystem::path& path,
                   const MapRadiometry& radiometry, double c0, double r0, double c1, double r1,
                   double px_per_sample, GreyBlock* b) {
  const QuietGdal quiet;
  GDALRasterBand* first = ds.GetRasterBand(1);
  int level = -1;
  for (int i = 0; i < first->GetOverviewCount(); ++i) {
    const double f = static_cast<double>(ds.GetRasterXSize()) / first->GetOverview(i)->GetXSize();
    if (f <= px_per_sample) level = i;
  }
  GDALRasterBand* base = AtLevel(first, level);
  const int level_w = base->GetXSize(), level_h = base->GetYSize();
  const double fx = static_cast<double>(ds.GetRasterXSize()) / level_w;
  const double fy = static_cast<double>(ds.GetRasterYSize()) / level_h;
  // No overview coarse enough (a fine map without overviews): blocks of k x k pixels of that
  // level averaged as they are read, on a grid aligned to k (as an overview of k would be), so
  // that the read holds about as many samples as the window needs, not k^2 times as many (the
  // same density as from overviews: k fx <= px_per_sample < 2 k fx); the map's last partial
  // block of k pixels on the right and at the bottom is left out. k = 1 with overviews.
  // (1e-6: a window's step computed as 3.9999... map pixels still reads blocks of 4.)
  // Everything is computed in doubles and bounded by the level's size before it becomes an int:
  // a map of absurdly fine pixels (1e-9 degree) makes k and the window's corners too large for
  // an int.
  const double kd = std::max(1.0, std::floor(px_per_sample / std::max(fx, fy) * (1 + 1e-6)));
  const double x0d = std::max(0.0, std::floor(c0 / fx / kd) - 1);
  const double y0d = std::max(0.0, std::floor(r0 / fy / kd) - 1);
  const double x1d = std::min(std::floor(level_w / kd), std::ceil(c1 / fx / kd) + 1);
  const double y1d = std::min(std::floor(level_h / kd), std::ceil(r1 / fy / kd) + 1);
  if (!(x1d - x0d >= 1) || !(y1d - y0d >= 1)) return false;
  // The read's cost is the pixels GDAL averages, k^2 per sample: bounded, so that a huge map
  // much finer than the window and without overviews (200000 x 200000 px, 7 MB on disk when
  // sparse) is an error naming it, not minutes per window.
  const double pixels = (x1d - x0d) * (y1d - y0d) * kd * kd;
  if (pixels > kMaxMapPixelsPerRead) {
    throw InputError(fmt::format(
        "'{}': a window at {:.4g} map pixels per sample would read {:.3g} of the map's pixels "
        "(at most {:.3g} are read per window): the map ({} x {} px) has no overview that "
        "coarse; add overviews (gdaladdo '{}') or give a coarser map",
        path.string(), px_per_sample, pixels, kMaxMapPixelsPerRead, ds.GetRasterXSize(),
        ds.GetRasterYSize(), path.string()));
  }
  const int k = static_cast<int>(kd);
  const int x0 = static_cast<int>(x0d), y0 = static_cast<int>(y0d);
  const int x1 = static_cast<int>(x1d), y1 = static_cast<int>(y1d);
  const int w = x1 - x0, h = y1 - y0;
  *b = GreyBlock{w, h, x0 * k * fx, y0 * k * fy, k * fx, k * fy, {}, {}};
  ReadRawGrey(ds, path, radiometry, level, x0 * k, y0 * k, w * k, h * k, w, h, &b->grey, &b->valid,
              /*average=*/k > 1);
  if (radiometry.lo != 0.0 || radiometry.hi != 255.0) {
    const float lo = static_cast<float>(radiometry.lo);
    const float gain = static_cast<float>(255.0 / (radiometry.hi - radiometry.lo));
    for (float& g : b->grey) g = std::clamp((g - lo) * gain, 0.0f, 255.0f);
  }
  return true;
}

MapRadiometry ProbeMapPixels(GDALDataset& ds, const std::filesystem::path& path) {
  const QuietGdal quiet;
  MapRadiometry r;
  GDALRasterBand* first = ds.GetRasterBand(1);
  r.sample_type = GDALGetDataTypeName(first->GetRasterDataType());
  ReadPalette(ds, &r);
  // What is read: the coarsest overview (at most 512 samples a side), or a small map whole, or
  // a 3 x 3 grid of windows of a large map without overviews.
  std::vector<float> grey, valid, g, v;
  const int n_ov = first->GetOverviewCount();
  const int W = ds.GetRasterXSize(), H = ds.GetRasterYSize();
  const bool whole = n_ov > 0 || static_cast<long long>(W) * H <= 4LL << 20;
  if (whole) {
    const int level = n_ov - 1;
    GDALRasterBand* base = AtLevel(first, level);
    const int bw = std::min(base->GetXSize(), 512), bh = std::min(base->GetYSize(), 512);
    ReadRawGrey(ds, path, r, level, 0, 0, base->GetXSize(), base->GetYSize(), bw, bh, &grey,
                &valid);
  } else {
    const int s = 128;
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) {
        const int x0 = std::clamp((2 * i + 1) * W / 6 - s / 2, 0, std::max(0, W - s));
        const int y0 = std::clamp((2 * j + 1) * H / 6 - s / 2, 0, std::max(0, H - s));
        const int w = std::min(s, W), h = std::min(s, H);
        ReadRawGrey(ds, path, r, -1, x0, y0, w, h, w, h, &g, &v);
        grey.insert(grey.end(), g.begin(), g.end());
        valid.insert(valid.end(), v.begin(), v.end());
      }
    }
  }
  std::vector<float> samples;
  samples.reserve(grey.size());
  for (std::size_t i = 0; i < grey.size(); ++i) {
    if (valid[i] >= 128.0f) samples.push_back(grey[i]);
  }
  if (samples.empty()) {
    if (whole) {
      throw InputError("'" + path.string() + "': the map has no valid pixel (all of it " +
                       "transparent, nodata or not a number)");
    }
    return r;  // windows of a sparse map: data elsewhere, if any, read as it is
  }
  if (r.sample_type == "Byte") return r;
  // The 1st and 99th percentiles.
  const auto at = [&](double q) {
    const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(samples.size() - 1));
    std::nth_element(samples.begin(), samples.begin() + k, samples.end());
    return static_cast<double>(samples[static_cast<std::size_t>(k)]);
  };
  r.lo = at(0.01);
  r.hi = at(0.99);
  if (!(r.hi > r.lo)) r.hi = r.lo + 1.0;  // a flat map: no texture either way
  return r;
}

}  // namespace aerovo::map
