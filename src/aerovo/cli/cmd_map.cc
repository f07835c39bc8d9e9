// `aerovo map info MAP...` and `aerovo map build RUN_DIR_OR_SOURCE -o map.tif`: reference maps
// (docs/map.md). The work is in aerovo/map/ (map_info.h, map_build.h); this file maps flags onto
// it, and runs the flight first when `map build` is given a source instead of a run folder.
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/cli/run_cli.h"
#include "aerovo/core/error.h"
#include "aerovo/map/map_build.h"
#include "aerovo/map/map_info.h"
#include "aerovo/pipeline/runner.h"
#include "aerovo/report/run_reader.h"

namespace aerovo::cli {
namespace {

namespace fs = std::filesystem;

struct InfoArgs {
  std::vector<std::string> maps;
  bool json = false;
};

void RunInfo(const InfoArgs& a) {
  nlohmann::json all = nlohmann::json::array();
  for (std::size_t i = 0; i < a.maps.size(); ++i) {
    const map::MapInfo m = map::ReadMapInfo(a.maps[i]);
    if (a.json) {
      all.push_back(map::ToJson(m));
    } else {
      std::cout << (i > 0 ? "\n" : "") << map::FormatMapInfo(m);
    }
  }
  if (a.json) std::cout << (all.size() == 1 ? all[0] : all).dump(2) << "\n";
}

// backend.gps_sigma_m of a flight that `map build --place-by gps` runs when the flags give
// none: a consumer GPS's horizontal error, metres per axis (docs/map.md).
constexpr double kGpsSigmaM = 3.0;

struct BuildArgs {
  RunFlags run;
  std::string out;
  std::string run_dir;
  map::MapBuildOptions options;
};

// The run folder of `map build SOURCE`: --run-dir, else beside the map (map.tif -> map_run).
fs::path RunDirFor(const BuildArgs& a) {
  if (!a.run_dir.empty()) return a.run_dir;
  const fs::path out(a.out);
  return out.parent_path() / (out.stem().string() + "_run");
}

// Runs the flight of `config` (its input a source) into `dir`; exits as `aerovo run` does when
// stopped by a signal.
void RunFlightFirst(RunConfig config, const fs::path& dir) {
  config.out = dir.string();
  std::cout << fmt::format("map build: running the flight into '{}' first\n", dir.string());
  RunCallbacks cb;
  cb.log = &std::cout;
  int signal = 0;
  const RunSummary s = WithStopSignals(
      &signal, [&](const std::atomic<bool>* stop) { return RunFlight(config, cb, stop); });
  for (const std::string& w : s.warnings) std::cerr << "warning: " << w << "\n";
  std::cout << RunHeadline(s) << "\n";
  if (s.interrupted) {
    std::cerr << fmt::format("aerovo map build: interrupted by {}: no map\n",
                             StopSignals::Name(signal));
    std::exit(StopSignals::ExitCode(signal));
  }
}

void RunBuild(BuildArgs& a) {
  const RunConfig config = CheckUsage([&] {
    map::Validate(a.options);
    map::CheckMapOutput(a.out);
    RunConfig c = a.run.Resolve();
    if (IsRunDir(c.input)) return c;  // a run folder: no run, its flags are not used
    c.out = RunDirFor(a).string();
    if (a.options.place_by == map::PlaceBy::kGps) {
      // The offline optimisation with the GPS fixes as position factors (docs/map.md).
      c.backend.enable = true;
      if (!(c.backend.gps_sigma_m > 0.0)) c.backend.gps_sigma_m = kGpsSigmaM;
    }
    Validate(c);
    return c;
  });
  fs::path run_dir = config.input;
  if (!IsRunDir(run_dir)) {
    run_dir = RunDirFor(a);
    RunFlightFirst(config, run_dir);
  }
  const map::MapBuildResult r = map::BuildMapFromRun(run_dir, a.out, a.options);
  for (const std::string& w : r.warnings) std::cerr << "warning: " << w << "\n";
  std::cout << fmt::format("map build: {} from the run '{}' ({} frames warped, placed by {}; "
                           "their centres fit the geo-referenced track to {:.2f} m RMS)\n",
                           a.out, run_dir.string(), r.frames_used,
                           r.placed_by_gps ? "the track optimised with the GPS fixes"
                                           : "the VO track",
                           r.fit_rmse_m)
            << map::FormatMapInfo(r.info);
}

void RegisterMapCommand(CLI::App& app) {
  CLI::App* group = app.add_subcommand(
      "map", "Reference maps: describe a geo-referenced raster, build one from a flight with GPS");
  group->require_subcommand(1);

  auto info = std::make_shared<InfoArgs>();
  CLI::App* info_cmd = group->add_subcommand(
      "info",
      "Describe maps (any raster GDAL opens: GeoTIFF/COG, VRT, MBTiles): size, CRS,\n"
      "resolution (m/px), extent in the CRS and in WGS84, overviews; an error names a map\n"
      "that is missing, corrupt, or has no CRS or geotransform");
  info_cmd->add_option("map", info->maps, "Map files")->required();
  info_cmd->add_flag("--json", info->json, "Print JSON (an array for several maps)");
  info_cmd->callback([info] { RunInfo(*info); });

  auto build = std::make_shared<BuildArgs>();
  CLI::App* build_cmd = group->add_subcommand(
      "build",
      "Build a reference map (Cloud Optimized GeoTIFF: tiled, DEFLATE, overviews) from a\n"
      "flight with GPS: its geo-referenced mosaic. INPUT is a run folder of `aerovo run`, or\n"
      "a flight (then run first with the run flags below, into --run-dir)");
  AddRunFlags(build_cmd, build->run, {"out"});
  build_cmd->add_option("-o,--out", build->out, "The map to write (.tif)")->required();
  build_cmd->add_option("--run-dir", build->run_dir,
                        "Where to run a flight given as INPUT (default: beside the map, "
                        "MAP_run for MAP.tif)");
  build_cmd->add_option("--mosaic-size-px", build->options.max_size_px,
                        "Longer side of the map, px (never finer than the frames' ground "
                        "sampling)")
      ->capture_default_str()
      ->check(CLI::Range(100, 20000));
  build_cmd->add_option("--mosaic-frames", build->options.max_frames,
                        "At most this many frames warped (every n-th)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  build_cmd
      ->add_option_function<std::string>(
          "--place-by",
          [build](const std::string& v) {
            build->options.place_by = v == "track" ? map::PlaceBy::kTrack : map::PlaceBy::kGps;
          },
          "How the frames are placed: gps (the track optimised with the GPS fixes as position "
          "factors: a flight is run with --backend-enable and --backend-gps-sigma-m, default "
          "3 m; a run folder must have been) or track (the causal VO track)")
      ->check(CLI::IsMember({"gps", "track"}))
      ->default_str("gps");
  build_cmd->callback([build] { RunBuild(*build); });
}

}  // namespace

AEROVO_REGISTER_COMMAND(RegisterMapCommand);

}  // namespace aerovo::cli
