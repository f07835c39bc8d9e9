#include "aerovo/map/map_build.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <system_error>
#include <utility>

#include <cpl_error.h>
#include <cpl_string.h>
#include <fmt/format.h>
#include <gdal_priv.h>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/core/options_json.h"
#include "aerovo/core/text.h"
#include "aerovo/map/gdal_error.h"
#include "aerovo/map/map_pixels.h"
#include "aerovo/report/geo_mosaic.h"
#include "aerovo/report/mosaic.h"
#include "aerovo/report/run_reader.h"

namespace aerovo::map {
namespace fs = std::filesystem;

const char* ToString(PlaceBy place_by) {
  return place_by == PlaceBy::kGps ? "gps" : "track";
}

void Validate(const MapBuildOptions& o) {
  if (o.max_size_px < 100 || o.max_size_px > 20000) {
    throw InvalidArgument(fmt::format("map build: max_size_px must be in [100, 20000], got {}",
                                      o.max_size_px));
  }
  if (o.max_frames < 1) {
    throw InvalidArgument(fmt::format("map build: max_frames must be >= 1, got {}", o.max_frames));
  }
}

namespace {

// A scratch folder beside `out` for the mosaic, removed when it goes out of scope.
struct ScratchDir {
  fs::path dir;
  explicit ScratchDir(const fs::path& out)
      : dir(out.parent_path() / ("." + out.filename().string() + ".mosaic")) {
    std::error_code ec;
    fs::remove_all(dir, ec);
    fs::create_directories(dir, ec);
    if (ec) throw InputError("cannot write '" + out.string() + "': " + ec.message());
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

using internal::LastGdalError;

// `tif` (the mosaic's GeoTIFF, which WriteGeoMosaic wrote: GDAL is registered) copied to `out`
// as a COG, through a temporary file.
void WriteCog(const fs::path& tif, const fs::path& out) {
  CPLErrorReset();
  GDALDataset* src = static_cast<GDALDataset*>(GDALOpen(tif.c_str(), GA_ReadOnly));
  if (src == nullptr) {
    throw InputError("cannot read the mosaic '" + tif.string() + "': " + LastGdalError("GDAL error"));
  }
  GDALDriver* cog = GetGDALDriverManager()->GetDriverByName("COG");
  if (cog == nullptr) {
    GDALClose(src);
    throw InputError("cannot write '" + out.string() + "': GDAL has no COG driver");
  }
  const fs::path tmp = out.parent_path() / ("." + out.filename().string() + ".tmp");
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "COMPRESS", "DEFLATE");
  opts = CSLSetNameValue(opts, "BLOCKSIZE", "512");
  opts = CSLSetNameValue(opts, "OVERVIEWS", "AUTO");
  opts = CSLSetNameValue(opts, "OVERVIEW_RESAMPLING", "AVERAGE");
  opts = CSLSetNameValue(opts, "BIGTIFF", "IF_SAFER");
  CPLErrorReset();
  GDALDataset* dst = cog->CreateCopy(tmp.c_str(), src, FALSE, opts, nullptr, nullptr);
  CSLDestroy(opts);
  GDALClose(src);
  const bool ok = dst != nullptr;
  if (dst != nullptr) GDALClose(dst);
  std::error_code ec;
  if (!ok) {
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + out.string() + "': " + LastGdalError("GDAL error"));
  }
  fs::rename(tmp, out, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + out.string() + "': " + ec.message());
  }
}

// Whether `run` ran the offline optimisation with its GPS fixes as factors (config.json
// "backend.enable" and "backend.gps_sigma_m" > 0) and wrote its poses (transforms_optimized.csv, one
// row per row of transforms.csv).
bool OptimisedWithGps(const RunData& run) {
  if (run.transforms_optimized.empty() ||
      run.transforms_optimized.size() != run.transforms.size() || !run.config.is_object()) {
    return false;
  }
  // config.json's keys are the flat config keys ("backend.enable").
  const auto enable = run.config.find("backend.enable");
  const auto sigma = run.config.find("backend.gps_sigma_m");
  return enable != run.config.end() && enable->is_boolean() && enable->get<bool>() &&
         sigma != run.config.end() && sigma->is_number() && sigma->get<double>() > 0.0;
}

}  // namespace

std::string TiltedFramesWarning(const nlohmann::json& summary, const nlohmann::json& config,
                                bool records_attitude) {
  if (records_attitude || !summary.is_object() || !summary.contains("attitude_sources") ||
      !summary["attitude_sources"].is_object()) {
    return "";
  }
  long long per_frame = 0;
  std::string sources;
  for (const auto& [name, count] : summary["attitude_sources"].items()) {
    if (name == "estimated" || name == "none") continue;
    // A frame count (summary.json of aerovo run; one a user edited may hold anything).
    const std::optional<int> n = options::JsonValueIn<int>(count, 1, 100000000);
    if (!n) continue;
    per_frame += *n;
    sources += (sources.empty() ? "" : ", ") + Printable(name, 40);
  }
  const double tilt = summary.contains("max_tilt_deg") && summary["max_tilt_deg"].is_number()
                          ? summary["max_tilt_deg"].get<double>()
                          : 0.0;
  if (per_frame == 0 || !(tilt > 1.0)) return "";
  std::string lever = "h tan(tilt)";
  if (config.is_object() && config.contains("altitude_m") && config["altitude_m"].is_number() &&
      config["altitude_m"].get<double>() > 0.0) {
    lever = fmt::format("{:.1f} m at {:.0f} m",
                        config["altitude_m"].get<double>() * std::tan(tilt * kDegToRad),
                        config["altitude_m"].get<double>());
  }
  return fmt::format(
      "{} frames of the run were corrected with a per-frame camera attitude ({}; up to {:.1f} deg "
      "from nadir) that the run folder (written by an older build) does not record: the map draws them as read, so their "
      "ground lands up to {} behind its place along the image top",
      per_frame, sources, tilt, lever);
}

void CheckMapOutput(const fs::path& out) {
  std::string ext = out.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".tif" && ext != ".tiff") {
    throw InvalidArgument("map build: the map '" + out.string() +
                          "' must be named .tif or .tiff (it is a Cloud Optimized GeoTIFF)");
  }
  std::error_code ec;
  if (!fs::exists(out, ec)) return;
  if (fs::is_directory(out, ec)) {
    throw InputError("'" + out.string() + "': a folder, not a map to replace");
  }
  GDALAllRegister();
  const QuietGdal quiet;
  GDALDataset* ds = static_cast<GDALDataset*>(
      GDALOpenEx(out.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
  const bool geotiff = ds != nullptr && ds->GetDriver() != nullptr &&
                       std::string(ds->GetDriver()->GetDescription()) == "GTiff";
  if (ds != nullptr) GDALClose(ds);
  if (!geotiff) {
    throw InputError("'" + out.string() +
                     "' exists and is not a GeoTIFF map: map build replaces "
                     "only an earlier map; choose another name (-o)");
  }
}

MapBuildResult BuildMapFromRun(const fs::path& run_dir, const fs::path& out,
                               const MapBuildOptions& options) {
  Validate(options);
  CheckMapOutput(out);
  if (!IsRunDir(run_dir)) {
    throw InputError("'" + run_dir.string() + "': not a run folder (no frames.csv): give a run "
                     "folder of `aerovo run`, or the flight itself");
  }
  const RunData run = ReadRunDir(run_dir);
  const bool by_gps = options.place_by == PlaceBy::kGps;
  // (A run that is not geo-referenced is refused below by the mosaic, saying so.)
  const bool geo_referenced = std::count_if(run.frames.begin(), run.frames.end(),
                                            [](const RunFrameRow& f) { return f.geo; }) >= 3;
  if (by_gps && geo_referenced && !OptimisedWithGps(run)) {
    throw InputError(
        "'" + run_dir.string() + "': cannot build a map from this run by its GPS: it was not "
        "optimised with its GPS fixes (needs "
        "transforms_optimized.csv and backend.enable with backend.gps_sigma_m > 0 in its "
        "config.json): run the flight again with --backend-enable --backend-gps-sigma-m 3 (or "
        "give `map build` the flight itself), or place the frames by the VO track with "
        "--place-by track");
  }
  const ScratchDir scratch(fs::absolute(out));
  MosaicOptions mo;
  mo.max_size_px = options.max_size_px;
  mo.max_frames = options.max_frames;
  mo.optimized = by_gps;
  const GeoMosaicResult g =
      WriteGeoMosaic(run, scratch.dir, out.stem().string() + " (aerovo map)", mo);
  if (!g.written) {
    throw InputError("'" + run_dir.string() + "': cannot build a map from this run: " + g.note);
  }
  WriteCog(scratch.dir / GeoMosaicFileNames::kGeoTiff, out);
  MapBuildResult r;
  r.info = ReadMapInfo(out);
  r.frames_used = g.frames_used;
  r.fit_rmse_m = g.fit_rmse_m;
  r.placed_by_gps = g.optimized;
  if (std::string w = TiltedFramesWarning(run.summary, run.config, RecordsCameraAttitude(run));
      !w.empty()) {
    r.warnings.push_back(std::move(w));
  }
  return r;
}

}  // namespace aerovo::map
