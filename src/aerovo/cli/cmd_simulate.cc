// `aerovo simulate`: renders a nadir camera flight over an orthophoto or the built-in terrain,
// with exact ground truth, DJI-style SRT and GPX telemetry (noisy GPS) and a sim.json manifest.
#include <fmt/core.h>
#include <fmt/ranges.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "aerovo/cli/command.h"
#include "aerovo/cli/conventions.h"
#include "aerovo/cli/progress.h"
#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/outputs/run_folder.h"
#include "aerovo/sim/ground.h"
#include "aerovo/sim/sim_writer.h"
#include "aerovo/sim/simulator.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::cli {
namespace {

struct SimulateArgs {
  // Ground.
  std::string ortho;
  double mpp = 0.0;
  double nw_lat = 1000.0, nw_lon = 1000.0;  // unset markers
  double ground_alt_m = sim::kDefaultTerrainAltM;
  std::uint64_t terrain_seed = 1;
  int terrain_size_px = 0;   // 0 = fit to the flight
  double terrain_mpp = 0.0;  // 0 = the camera's ground sampling distance
  // Flight.
  std::string pattern = "lawnmower";
  std::string waypoints;         // "e,n;e,n;..." metres from the ground centre
  std::string waypoints_latlon;  // "lat,lon;lat,lon;..."
  std::string yaw = "follow";
  // Output.
  std::string out;
  bool frames_only = false;
  std::string image_format = "jpg";
  std::string codec = "avc1";
  std::string start_time = "2026-05-01T10:00:00";
  std::string render = "visible";  // visible | thermal
  std::string lens = "pinhole";    // pinhole | fisheye
  bool quiet = false;
  bool force = false;
};

std::vector<std::vector<double>> ParsePairs(const std::string& text, const char* what) {
  std::vector<std::vector<double>> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ';')) {
    if (item.find_first_not_of(" \t") == std::string::npos) continue;
    double a = 0, b = 0;
    char comma = 0, tail = 0;
    if (std::sscanf(item.c_str(), " %lf %c %lf %c", &a, &comma, &b, &tail) != 3 || comma != ',') {
      throw InvalidArgument(fmt::format("{}: '{}' is not 'number,number'", what, item));
    }
    out.push_back({a, b});
  }
  return out;
}

// The flags of `aerovo simulate` named in the checks of the options they set (sim/*.cc
// Validate: "FlightPlan: height_m = 0 must be in [1, 10000]"), in the order of the help.
const std::vector<std::pair<const char*, const char*>> kFlagOfField = {
    {"terrain_size_px", "--terrain-size-px"},
    {"terrain_mpp", "--terrain-mpp"},
    {"nw_lat_deg", "--nw-lat"},
    {"nw_lon_deg", "--nw-lon"},
    {"centre, heading and yaw", "--centre-east-m, --centre-north-m, --heading-deg, --yaw-deg"},
    {"leg_length_m", "--length-m"},
    {"legs =", "--legs"},
    {"spacing_m", "--spacing-m"},
    {"turn_angle_deg", "--turn-angle-deg"},
    {"turn_radius_m", "--turn-radius-m"},
    {"max_bank_deg", "--max-bank-deg"},
    {"height_m", "--height-m"},
    {"speed_mps", "--speed-mps"},
    {"pitch_deg", "--pitch-deg"},
    {"roll_deg", "--roll-deg"},
    {"wobble_deg", "--wobble-deg"},
    {"wobble_period_s", "--wobble-period-s"},
    {"max_duration_s", "--duration-s"},
    {"SimulationOptions: fps", "--fps"},
    {"CameraModel: image size", "--width, --height"},
    {"hfov_deg", "--hfov-deg"},
    {"focal_px", "--focal-px"},
    {"distortion", "--distortion"},
    {"illumination_k", "--k"},
    {"noise_sigma_dn", "--noise"},
    {"motion_blur_px", "--blur"},
    {"jpeg_quality", "--jpeg-quality"},
    {"contrast =", "--contrast"},
    {"optics_blur_sigma_px", "--optics-blur"},
    {"vignetting_dn", "--vignetting"},
    {"fixed_pattern_dn", "--fixed-pattern"},
    {"horizontal_sigma_m", "--gps-noise-m"},
    {"vertical_sigma_m", "--gps-vertical-noise-m"},
    {"rate_hz", "--gps-rate-hz"},
    {"correlation_time_s", "--gps-tau-s"},
};

// Reads the flags that are not the options' fields into `o` and checks every option, before the
// output folder is touched: an option out of its range, or options that disagree, is an
// InvalidArgument naming the flag (a usage error through CheckUsage: exit 2, no folder made).
// Returns the ground's options.
sim::GroundOptions CheckedOptions(const SimulateArgs& a, sim::SimulationOptions& o) {
  try {
    // Flight (waypoints in metres are needed before the terrain can be fitted to the flight).
    o.flight.pattern = sim::ParseFlightPattern(a.pattern);
    if (!a.waypoints.empty() && !a.waypoints_latlon.empty()) {
      throw InvalidArgument("give --waypoints or --waypoints-latlon, not both");
    }
    if (!a.waypoints.empty()) {
      for (const auto& p : ParsePairs(a.waypoints, "--waypoints")) {
        o.flight.waypoints_m.emplace_back(p[0], p[1]);
      }
    }
    if ((!a.waypoints.empty() || !a.waypoints_latlon.empty()) &&
        o.flight.pattern != sim::FlightPattern::kWaypoints) {
      throw InvalidArgument("waypoints given: use --pattern waypoints");
    }
    if (a.yaw == "follow") {
      o.flight.yaw_mode = sim::YawMode::kFollowTrack;
    } else if (a.yaw == "fixed") {
      o.flight.yaw_mode = sim::YawMode::kFixed;
    } else {
      throw InvalidArgument("--yaw must be 'follow' or 'fixed', not '" + a.yaw + "'");
    }

    // Ground.
    if (!a.ortho.empty()) {
      if (!(a.mpp > 0)) throw InvalidArgument("--ortho needs --mpp (metres per pixel, > 0)");
      if (a.nw_lat > 90 || a.nw_lon > 360) {
        throw InvalidArgument(
            "--ortho needs --nw-lat and --nw-lon (the image's north-west corner)");
      }
    } else if (!a.waypoints_latlon.empty() && !(a.terrain_size_px > 0 && a.terrain_mpp > 0)) {
      throw InvalidArgument(
          "--waypoints-latlon over the built-in terrain needs --terrain-size-px and --terrain-mpp "
          "(the terrain's extent must be known to place it)");
    }
    sim::GroundOptions go;
    go.ortho = a.ortho;
    go.ortho_mpp = a.mpp;
    if (a.nw_lat <= 90) go.nw_lat_deg = a.nw_lat;
    if (a.nw_lon <= 360) go.nw_lon_deg = a.nw_lon;
    go.ground_alt_m = a.ground_alt_m;
    go.terrain_seed = a.terrain_seed;
    go.terrain_size_px = a.terrain_size_px;
    go.terrain_mpp = a.terrain_mpp;
    sim::Validate(go);
    // The flight with the waypoints of --waypoints-latlon is checked once the ground places them.
    sim::SimulationOptions checked = o;
    if (!a.waypoints_latlon.empty()) checked.flight.waypoints_m = {{0.0, 0.0}, {100.0, 0.0}};
    sim::Validate(checked);
    // The flight's frame count and the terrain fitted to its view, before the folder is made
    // (a flight of too many frames, or a terrain beyond 32768 px a side, was found only then).
    // With --waypoints-latlon the waypoints are placed by the ground itself: checked later.
    if (a.waypoints_latlon.empty()) {
      try {
        const sim::TerrainOptions terrain = sim::TerrainOptionsOf(go, checked);
        if (go.ortho.empty()) sim::Validate(terrain);
      } catch (const InvalidArgument& e) {
        // The terrain's own check (FitTerrainToFlight runs it too); the flight's frame limit
        // goes on as it is.
        if (std::string(e.what()).rfind("TerrainOptions:", 0) != 0) throw;
        throw InvalidArgument(fmt::format(
            "--terrain-size-px, --terrain-mpp: the terrain for this flight cannot be made: {} "
            "(a shorter flight, a coarser --terrain-mpp or --ortho)",
            e.what()));
      }
    }
    return go;
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(NameFlags(e.what(), kFlagOfField));
  }
}

void Run(const SimulateArgs& a, sim::SimulationOptions o, const sim::WriterOptions& w) {
  const sim::GroundOptions go = CheckUsage([&] { return CheckedOptions(a, o); });
  Stopwatch clock;
  // Like aerovo run: one writer at a time in a folder, a new or empty folder unless --force
  // (which removes what an earlier simulation wrote there, and run folders inside it; other
  // files are kept).
  const RunFolderLock lock(a.out);
  const ClaimResult claim = ClaimOutputFolder(
      a.out, a.force,
      OwnEntries(a.out, {"video.mp4", "video.avi", "frames", "telemetry.srt", "track.gpx",
                         "ground_truth.tum", "ground_truth.csv", "sim.json"}),
      "aerovo simulate");
  if (!claim.removed.empty()) {
    fmt::print(stderr, "aerovo simulate: --force: removed from '{}': {}\n", a.out,
               fmt::join(claim.removed, ", "));
  }
  sim::GroundImage ground = sim::MakeGround(go, o);
  if (!a.waypoints_latlon.empty()) {
    std::vector<GeoPoint> geo;
    for (const auto& p : ParsePairs(a.waypoints_latlon, "--waypoints-latlon")) {
      geo.push_back(GeoPoint{p[0], p[1], 0.0});
    }
    o.flight.waypoints_m = sim::WaypointsFromGeo(ground, geo);
  }
  const double ground_ms = clock.elapsed_ms();

  const sim::Simulator simulator(std::move(ground), o);
  const double plan_ms = clock.elapsed_ms() - ground_ms;
  const auto& g = simulator.renderer().ground();
  if (!a.quiet) {
    fmt::print("aerovo simulate\n");
    fmt::print(
        "  ground     {} {}x{} px at {} m/px, NW corner {:.6f} N {:.6f} E ({:.0f} ms)\n",
        g.source_kind == "terrain" ? fmt::format("terrain seed {}", g.terrain_seed) : g.source_path,
        g.image.cols, g.image.rows, g.metres_per_px, g.nw_corner.lat_deg, g.nw_corner.lon_deg,
        ground_ms);
    fmt::print("  flight     {} {:.0f} m at {} m height, {} m/s, {} frames at {} fps ({:.1f} s)\n",
               sim::FlightPatternName(o.flight.pattern), simulator.flight().flown_length_m,
               o.flight.height_m, o.flight.speed_mps, simulator.frame_count(), o.fps,
               simulator.poses().back().time_s);
    fmt::print("  camera     {}x{} px, focal {:.1f} px (hfov {:.1f} deg), GSD {:.3f} m/px\n",
               o.camera.width_px, o.camera.height_px, sim::FocalPx(o.camera),
               sim::HorizontalFovDeg(o.camera),
               sim::NadirGsdMetresPerPx(o.camera, o.flight.height_m));
    fmt::print(
        "  effects    {}contrast {}, optics blur {} px, k {}, noise {} DN, blur {} px, "
        "jpeg {}; GPS noise {} m (seed {})\n",
        o.effects.grayscale ? "grey, " : "", o.effects.contrast, o.effects.optics_blur_sigma_px,
        o.effects.illumination_k, o.effects.noise_sigma_dn, o.effects.motion_blur_px,
        o.effects.jpeg_quality, o.gps.horizontal_sigma_m, o.seed);
    fmt::print("  origin     {:.7f} N {:.7f} E (ground truth ENU origin; planned in {:.0f} ms)\n",
               simulator.origin().lat_deg, simulator.origin().lon_deg, plan_ms);
    std::fflush(stdout);
  }
  // Warnings on stderr, with -q too (it hides the progress and the description only).
  for (const auto& warning : simulator.warnings()) fmt::print(stderr, "warning: {}\n", warning);
  Progress progress(DefaultProgressStyle(a.quiet));
  const sim::SimulationOutput out = sim::WriteSimulation(
      simulator, w, a.out,
      [&](int done, int total) { progress.Update(done, total, "  rendering  "); });
  progress.Finish();
  for (const auto& m : out.messages) {
    if (m.rfind("warning: ", 0) == 0) {
      fmt::print(stderr, "{}\n", m);
    } else {
      fmt::print("  note       {}\n", m);
    }
  }
  const auto p = [&](const std::string& f) { return (out.dir / f).string(); };
  fmt::print("wrote {} frames in {:.1f} s (render {:.1f} s, {:.1f} frames/s):\n",
             out.frames_written, out.total_seconds, out.render_seconds,
             out.frames_written / std::max(1e-9, out.total_seconds));
  if (!out.video_file.empty()) {
    fmt::print("  video         {} ({})\n", p(out.video_file), out.video_codec);
  } else {
    fmt::print("  frames        {}/{}\n", p(out.frames_dir), out.frame_pattern);
  }
  fmt::print("  telemetry     {}\n", p(out.srt_file));
  fmt::print("  gps track     {}\n", p(out.gpx_file));
  fmt::print("  ground truth  {} , {}\n", p(out.tum_file), p(out.csv_file));
  fmt::print("  manifest      {}\n", p(out.json_file));
}

void RegisterSimulateCommand(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  auto opt = std::make_shared<sim::SimulationOptions>();
  auto writer = std::make_shared<sim::WriterOptions>();
  opt->effects = {};
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Render a nadir camera flight over an orthophoto or the built-in terrain, with exact ground "
      "truth (TUM, CSV), DJI-style SRT and GPX telemetry, and a sim.json manifest");
  // Ground.
  cmd->add_option("--ortho", args->ortho, "Orthophoto file (north-up); default: built-in terrain")
      ->check(CLI::ExistingFile);
  cmd->add_option("--mpp", args->mpp, "Orthophoto metres per pixel");
  cmd->add_option(
      "--nw-lat", args->nw_lat,
      "Latitude of the ground image's north-west corner (deg); terrain default 49.8397");
  cmd->add_option("--nw-lon", args->nw_lon,
                  "Longitude of the north-west corner (deg); terrain default 24.0297");
  cmd->add_option("--ground-alt-m", args->ground_alt_m, "Ground altitude above MSL (m)")
      ->capture_default_str();
  cmd->add_option("--terrain-seed", args->terrain_seed, "Seed of the built-in terrain")
      ->capture_default_str();
  cmd->add_option("--terrain-size-px", args->terrain_size_px,
                  "Terrain side (px); default: fitted to the flight's view");
  cmd->add_option("--terrain-mpp", args->terrain_mpp,
                  "Terrain metres per pixel; default: the camera's ground sampling distance");
  // Flight.
  cmd->add_option("--pattern", args->pattern,
                  "line | lawnmower | turns | waypoints | fixed-wing (turns banked at up to "
                  "--max-bank-deg, the camera rolling with the wings)")
      ->capture_default_str();
  cmd->add_option("--waypoints", args->waypoints,
                  "'e,n;e,n;...' metres east,north of the ground image centre");
  cmd->add_option("--waypoints-latlon", args->waypoints_latlon, "'lat,lon;lat,lon;...' degrees");
  cmd->add_option("--centre-east-m", opt->flight.centre_east_m,
                  "Pattern centre east of the ground centre (m)")
      ->capture_default_str();
  cmd->add_option("--centre-north-m", opt->flight.centre_north_m,
                  "Pattern centre north of the ground centre (m)")
      ->capture_default_str();
  cmd->add_option("--heading-deg", opt->flight.heading_deg, "Heading of the first leg (deg)")
      ->capture_default_str();
  cmd->add_option("--length-m", opt->flight.leg_length_m, "Length of each leg (m)")
      ->capture_default_str();
  cmd->add_option("--legs", opt->flight.legs, "Number of legs (lawnmower, turns)")
      ->capture_default_str();
  cmd->add_option("--spacing-m", opt->flight.spacing_m, "Lawnmower leg spacing (m)")
      ->capture_default_str();
  cmd->add_flag("!--first-turn-left", opt->flight.first_turn_right,
                "Lawnmower: the second leg lies to the left of the first");
  cmd->add_option("--turn-angle-deg", opt->flight.turn_angle_deg,
                  "Turns: heading change per turn (deg, + = right)")
      ->capture_default_str();
  cmd->add_option("--turn-radius-m", opt->flight.turn_radius_m,
                  "Turn radius (turns; corner rounding for waypoints) (m)")
      ->capture_default_str();
  cmd->add_option("--max-bank-deg", opt->flight.max_bank_deg,
                  "Fixed-wing: largest bank in turns (deg); turn radius >= v^2 / (g tan(bank))")
      ->capture_default_str();
  cmd->add_option("--height-m", opt->flight.height_m, "Height above ground (m)")
      ->capture_default_str();
  cmd->add_option("--speed-mps", opt->flight.speed_mps, "Ground speed (m/s)")
      ->capture_default_str();
  cmd->add_option("--yaw", args->yaw, "follow (image top along the track) | fixed")
      ->capture_default_str();
  cmd->add_option("--yaw-deg", opt->flight.yaw_deg,
                  "Fixed yaw, or offset to the track (deg clockwise from north)")
      ->capture_default_str();
  cmd->add_option("--pitch-deg", opt->flight.pitch_deg, "Constant camera pitch (deg)")
      ->capture_default_str();
  cmd->add_option("--roll-deg", opt->flight.roll_deg, "Constant camera roll (deg)")
      ->capture_default_str();
  cmd->add_option("--wobble-deg", opt->flight.wobble_deg, "Attitude oscillation amplitude (deg)")
      ->capture_default_str();
  cmd->add_option("--wobble-period-s", opt->flight.wobble_period_s,
                  "Period of the attitude oscillation (s)")
      ->capture_default_str();
  cmd->add_option("--duration-s", opt->flight.max_duration_s, "Stop after this time (0 = all)")
      ->capture_default_str();
  // Camera.
  cmd->add_option("--fps", opt->fps, "Frame rate")->capture_default_str();
  cmd->add_option("--width", opt->camera.width_px, "Image width (px)")->capture_default_str();
  cmd->add_option("--height", opt->camera.height_px, "Image height (px)")->capture_default_str();
  cmd->add_option("--hfov-deg", opt->camera.hfov_deg, "Horizontal field of view (deg)")
      ->capture_default_str();
  cmd->add_option("--focal-px", opt->camera.focal_px, "Focal length (px); overrides --hfov-deg");
  cmd->add_option("--lens", args->lens,
                  "pinhole | fisheye: the lens model of --distortion (OpenCV's; docs/lenses.md)")
      ->capture_default_str();
  cmd->add_option(
         "--distortion", opt->camera.distortion,
         "Lens distortion coefficients, comma-separated, OpenCV order (pinhole: k1,k2,p1,p2"
         "[,k3]; fisheye: k1,k2,k3,k4); the focal is that of the undistorted pinhole")
      ->delimiter(',');
  // Effects and GPS.
  cmd->add_option("--k", opt->effects.illumination_k, "Illumination factor k: f_k = k f")
      ->capture_default_str();
  cmd->add_option("--noise", opt->effects.noise_sigma_dn, "Sensor noise sigma (DN)")
      ->capture_default_str();
  cmd->add_option("--blur", opt->effects.motion_blur_px, "Motion blur length (px)")
      ->capture_default_str();
  cmd->add_option("--jpeg-quality", opt->effects.jpeg_quality,
                  "JPEG round trip of every frame (1..100; 0 = none)")
      ->capture_default_str();
  cmd->add_option("--contrast", opt->effects.contrast,
                  "Contrast factor c in (0, 1]: v -> mean + c (v - mean)")
      ->capture_default_str();
  cmd->add_option("--optics-blur", opt->effects.optics_blur_sigma_px,
                  "Gaussian blur of the optics, sigma (px)")
      ->capture_default_str();
  cmd->add_flag("--grey", opt->effects.grayscale, "No colour (luminance in every channel)");
  cmd->add_option("--vignetting", opt->effects.vignetting_dn,
                  "Vignetting, DN: a static offset falling from 0 at the centre to -DN at the "
                  "corners (squared distance)")
      ->capture_default_str();
  cmd->add_option("--fixed-pattern", opt->effects.fixed_pattern_dn,
                  "Fixed-pattern noise, DN: static Gaussian per-pixel and per-column offsets of "
                  "this standard deviation each")
      ->capture_default_str();
  cmd->add_option("--render", args->render,
                  "visible | thermal: a thermal-like camera (640x512, 45 deg hfov, grey, contrast "
                  "0.15, optics blur 1.2 px, vignetting 30 DN, fixed pattern 3 DN, noise 1.5 DN; "
                  "flags given explicitly win)")
      ->capture_default_str();
  cmd->add_option("--gps-noise-m", opt->gps.horizontal_sigma_m,
                  "GPS horizontal error sigma per axis (m)")
      ->capture_default_str();
  cmd->add_option("--gps-vertical-noise-m", opt->gps.vertical_sigma_m,
                  "GPS vertical error sigma (m)")
      ->capture_default_str();
  cmd->add_option("--gps-rate-hz", opt->gps.rate_hz, "GPS fix rate (Hz)")->capture_default_str();
  cmd->add_option("--gps-tau-s", opt->gps.correlation_time_s,
                  "GPS error correlation time (s; 0 = white)")
      ->capture_default_str();
  cmd->add_option("--seed", opt->seed, "Seed of all simulation noise")->capture_default_str();
  // Output.
  cmd->add_option("-o,--out", args->out, "Output folder")->required();
  cmd->add_flag("--frames-only", args->frames_only, "Write an image folder instead of a video");
  cmd->add_option("--image-format", args->image_format, "Frames-only image format: jpg | png")
      ->capture_default_str();
  cmd->add_option("--codec", args->codec, "Video FourCC (falls back to mp4v, then MJPG .avi)")
      ->capture_default_str();
  cmd->add_option("--start-time", args->start_time, "UTC time of the first frame")
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", args->quiet,
                "Print only what was written (and the warnings, on stderr)");
  cmd->add_flag("--force", args->force,
                "Write into a non-empty output folder: first remove what an earlier simulation "
                "wrote there (other files are kept)");
  cmd->callback([args, opt, writer, cmd] {
    if (args->render == "thermal") {
      // The preset fills what the command line did not give.
      const sim::EffectsOptions t = sim::ThermalEffects();
      const auto unset = [cmd](const char* flag) { return cmd->count(flag) == 0; };
      if (unset("--width")) opt->camera.width_px = sim::kThermalWidthPx;
      if (unset("--height")) opt->camera.height_px = sim::kThermalHeightPx;
      if (unset("--hfov-deg") && unset("--focal-px")) opt->camera.hfov_deg = sim::kThermalHfovDeg;
      if (unset("--grey")) opt->effects.grayscale = t.grayscale;
      if (unset("--contrast")) opt->effects.contrast = t.contrast;
      if (unset("--optics-blur")) opt->effects.optics_blur_sigma_px = t.optics_blur_sigma_px;
      if (unset("--noise")) opt->effects.noise_sigma_dn = t.noise_sigma_dn;
      if (unset("--vignetting")) opt->effects.vignetting_dn = t.vignetting_dn;
      if (unset("--fixed-pattern")) opt->effects.fixed_pattern_dn = t.fixed_pattern_dn;
    } else if (args->render != "visible") {
      throw UsageError("--render must be 'visible' or 'thermal', not '" + args->render + "'");
    }
    opt->effects.fixed_pattern_seed = opt->seed;  // one sensor per seed
    opt->camera.lens = CheckUsage([&] { return ParseLensModel(args->lens); });
    writer->write_video = !args->frames_only;
    writer->video_codec = args->codec;
    writer->image_format = args->image_format;
    writer->start_time_utc = args->start_time;
    Run(*args, *opt, *writer);
  });
}

AEROVO_REGISTER_COMMAND(RegisterSimulateCommand);

}  // namespace
}  // namespace aerovo::cli
