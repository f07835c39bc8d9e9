#include "aerovo/sim/sim_writer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <optional>
#include <ostream>
#include <sstream>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/options_json.h"
#include "aerovo/imageio/image_io.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/telemetry/srt_writer.h"

namespace aerovo::sim {

namespace fs = std::filesystem;

GroundImage LoadOrthophoto(const fs::path& path, double metres_per_px, const GeoPoint& nw_corner) {
  if (!fs::exists(path)) {
    throw InputError(fmt::format("orthophoto {}: no such file", path.string()));
  }
  GroundImage g;
  g.image = imageio::Read(path.string(), cv::IMREAD_COLOR);
  if (g.image.empty()) {
    throw InputError(fmt::format("orthophoto {}: cannot decode the image", path.string()));
  }
  g.metres_per_px = metres_per_px;
  g.nw_corner = nw_corner;
  g.source_kind = "orthophoto";
  g.source_path = fs::absolute(path).string();
  Validate(g);
  return g;
}

namespace {

// Seconds since the Unix epoch of "YYYY-MM-DDTHH:MM:SS" (UTC).
std::int64_t ParseUtc(const std::string& s) {
  int y, mo, d, h, mi, se;
  char tail;
  if (std::sscanf(s.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%c", &y, &mo, &d, &h, &mi, &se, &tail) != 6 ||
      mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || se > 60 || y < 1970) {
    throw InvalidArgument("WriterOptions: start_time_utc '" + s +
                          "' must look like 2026-05-01T10:00:00 (UTC, year >= 1970)");
  }
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = se;
  return static_cast<std::int64_t>(timegm(&tm));
}

// UTC time `t_s` seconds after `start`, as "YYYY-MM-DD{sep}HH:MM:SS.mmm".
std::string FormatUtc(std::int64_t start, double t_s, char sep) {
  const std::int64_t ms_total = start * 1000 + static_cast<std::int64_t>(std::llround(t_s * 1000));
  const std::time_t secs = static_cast<std::time_t>(ms_total / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return fmt::format("{:04d}-{:02d}-{:02d}{}{:02d}:{:02d}:{:02d}.{:03d}", tm.tm_year + 1900,
                     tm.tm_mon + 1, tm.tm_mday, sep, tm.tm_hour, tm.tm_min, tm.tm_sec,
                     static_cast<int>(ms_total % 1000));
}

std::ofstream OpenOut(const fs::path& path) {
  std::ofstream f(path);
  if (!f) throw OutputError(fmt::format("{}: cannot open for writing", path.string()));
  return f;
}

void CheckWritten(std::ofstream& f, const fs::path& path) {
  f.flush();
  if (!f) throw OutputError(fmt::format("{}: write failed (disk full?)", path.string()));
}

}  // namespace

void Validate(const WriterOptions& o) {
  if (o.write_video && o.video_codec.size() != 4) {
    throw InvalidArgument("WriterOptions: video_codec '" + o.video_codec +
                          "' must be a four-character code such as avc1, mp4v or MJPG");
  }
  if (o.image_format != "jpg" && o.image_format != "png") {
    throw InvalidArgument("WriterOptions: image_format '" + o.image_format +
                          "' must be jpg or png");
  }
  if (o.image_jpeg_quality < 1 || o.image_jpeg_quality > 100) {
    throw InvalidArgument(fmt::format("WriterOptions: image_jpeg_quality = {} must be in 1..100",
                                      o.image_jpeg_quality));
  }
  ParseUtc(o.start_time_utc);
}

void WriteDjiSrt(std::ostream& out, const Simulator& sim, const std::string& start_time_utc) {
  const std::int64_t start = ParseUtc(start_time_utc);
  const double fps = sim.options().fps;
  const int diff_ms = static_cast<int>(std::lround(1000.0 / fps));
  const double ground_alt = sim.renderer().ground().nw_corner.alt_m;
  const auto& gps = sim.gps();
  // 35 mm-equivalent focal length as EXIF/CIPA DC-008 defines it (same DIAGONAL angle of view
  // as on a 36 x 24 mm frame) and as aerovo's readers convert it back (camera/pinhole.h
  // FocalPxFrom35mm). Matching the 36 mm width instead would put a 16:9 frame's scale 4.6 %
  // off. 2 decimals as DJI writes it: the focal length survives to within 0.02 %.
  const CameraModel& cam = sim.options().camera;
  const double focal_35mm_mm = Focal35mmFromPx(FocalPx(cam), cam.width_px, cam.height_px);
  // A flight whose camera tilts at any frame (FlightPlan pitch_deg, roll_deg, wobble_deg, the
  // banked turns of the fixed-wing pattern) writes its attitude as gimbal angles; a nadir
  // flight's entries have none, as before.
  bool has_attitude = false;
  for (const auto& pose : sim.ground_truth()) {
    has_attitude = has_attitude || pose.pitch_deg != 0.0 || pose.roll_deg != 0.0;
  }
  DjiSrtEntry e;
  e.diff_ms = diff_ms;
  e.focal_35mm_mm = focal_35mm_mm;
  for (int i = 0; i < sim.frame_count(); ++i) {
    const double t = sim.ground_truth()[i].time_s;
    const GpsFix& fix = gps[LatestFixIndex(gps, t)];
    e.index = i + 1;
    e.start_s = t;
    e.end_s = (i + 1) / fps;
    e.date_time = FormatUtc(start, t, ' ');
    e.position = fix.position;
    e.rel_alt_m = fix.position.alt_m - ground_alt;
    if (has_attitude) {
      // The camera as a gimbal's (odometry/attitude.h: camera pitch = gimbal pitch + 90, the
      // simulator's roll tilts the optical axis towards the image right = gimbal roll < 0).
      e.gimbal_pitch_deg = sim.ground_truth()[i].pitch_deg - 90.0;
      e.gimbal_roll_deg = -sim.ground_truth()[i].roll_deg;
    }
    out << FormatDjiSrtEntry(e);
  }
}

void WriteGpx(const fs::path& path, const Simulator& sim, const std::string& start_time_utc) {
  GpxTrackWriter gpx(path, "aerovo simulated flight",
                     static_cast<double>(ParseUtc(start_time_utc)), /*decimals=*/9);  // truth
  for (const GpsFix& f : sim.gps()) gpx.Append(GeoTrackPoint{f.time_s, f.position});
  gpx.Close();
}

void WriteTum(const fs::path& path, const Simulator& sim) {
  TumWriter tum(path);
  for (const GroundTruthFrame& g : sim.ground_truth()) {
    tum.Append(g.time_s, g.enu_m, Eigen::Quaterniond(g.enu_from_camera));
  }
  tum.Close();
}

void WriteGroundTruthCsv(std::ostream& out, const Simulator& sim) {
  out << "frame,time_s,east_m,north_m,up_m,lat_deg,lon_deg,alt_m,yaw_deg,pitch_deg,roll_deg,"
         "nodata_fraction\n";
  for (const GroundTruthFrame& g : sim.ground_truth()) {
    out << fmt::format(
        "{},{:.6f},{:.6f},{:.6f},{:.6f},{:.9f},{:.9f},{:.4f},{:.6f},{:.6f},{:.6f},{:.4f}\n",
        g.index, g.time_s, g.enu_m.x(), g.enu_m.y(), g.enu_m.z(), g.position.lat_deg,
        g.position.lon_deg, g.position.alt_m, g.yaw_deg, g.pitch_deg, g.roll_deg,
        g.nodata_fraction);
  }
}

std::string SimulationJsonText(const Simulator& sim, const SimulationOutput& out,
                               const WriterOptions& wo) {
  using nlohmann::json;
  const SimulationOptions& o = sim.options();
  const GroundImage& g = sim.renderer().ground();
  const Eigen::Matrix3d k = IntrinsicMatrix(o.camera);
  auto or_null = [](const std::string& s) { return s.empty() ? json(nullptr) : json(s); };
  json j;
  j["format"] = "aerovo-simulation";
  j["version"] = 1;
  j["generator"] = "aerovo simulate";
  j["files"] = {{"video", or_null(out.video_file)},
                {"frames_dir", or_null(out.frames_dir)},
                {"frame_pattern", or_null(out.frame_pattern)},
                {"srt", out.srt_file},
                {"gpx", out.gpx_file},
                {"ground_truth_tum", out.tum_file},
                {"ground_truth_csv", out.csv_file}};
  j["video_codec"] = or_null(out.video_codec);
  j["frame_count"] = sim.frame_count();
  j["fps"] = o.fps;
  j["duration_s"] = sim.frame_count() > 0 ? sim.poses().back().time_s : 0.0;
  j["start_time_utc"] = wo.start_time_utc;
  j["camera"] = {{"model", LensModelName(o.camera.lens)},
                 {"distortion", o.camera.distortion},
                 {"width_px", o.camera.width_px},
                 {"height_px", o.camera.height_px},
                 {"focal_px", k(0, 0)},
                 {"cx_px", k(0, 2)},
                 {"cy_px", k(1, 2)},
                 {"hfov_deg", HorizontalFovDeg(o.camera)}};
  j["height_above_ground_m"] = o.flight.height_m;
  j["gsd_m_per_px"] = NadirGsdMetresPerPx(o.camera, o.flight.height_m);
  j["ground_altitude_m"] = g.nw_corner.alt_m;
  j["origin"] = {{"lat_deg", sim.origin().lat_deg},
                 {"lon_deg", sim.origin().lon_deg},
                 {"alt_m", sim.origin().alt_m}};
  j["distance_m"] = sim.flight().flown_length_m;
  j["path_length_m"] = sim.flight().path_length_m;
  const FlightPlan& f = o.flight;
  json waypoints = json::array();
  for (const auto& w : f.waypoints_m) waypoints.push_back({w.x(), w.y()});
  j["flight"] = {{"pattern", FlightPatternName(f.pattern)},
                 {"centre_east_m", f.centre_east_m},
                 {"centre_north_m", f.centre_north_m},
                 {"heading_deg", f.heading_deg},
                 {"leg_length_m", f.leg_length_m},
                 {"legs", f.legs},
                 {"spacing_m", f.spacing_m},
                 {"first_turn_right", f.first_turn_right},
                 {"turn_angle_deg", f.turn_angle_deg},
                 {"turn_radius_m", f.turn_radius_m},
                 {"height_m", f.height_m},
                 {"speed_mps", f.speed_mps},
                 {"yaw_mode", f.yaw_mode == YawMode::kFixed ? "fixed" : "follow"},
                 {"yaw_deg", f.yaw_deg},
                 {"pitch_deg", f.pitch_deg},
                 {"roll_deg", f.roll_deg},
                 {"wobble_deg", f.wobble_deg},
                 {"wobble_period_s", f.wobble_period_s},
                 {"max_duration_s", f.max_duration_s},
                 {"waypoints_m", waypoints}};
  j["effects"] = {{"illumination_k", o.effects.illumination_k},
                  {"noise_sigma_dn", o.effects.noise_sigma_dn},
                  {"motion_blur_px", o.effects.motion_blur_px},
                  {"jpeg_quality", o.effects.jpeg_quality},
                  {"grayscale", o.effects.grayscale},
                  {"contrast", o.effects.contrast},
                  {"optics_blur_sigma_px", o.effects.optics_blur_sigma_px},
                  {"vignetting_dn", o.effects.vignetting_dn},
                  {"fixed_pattern_dn", o.effects.fixed_pattern_dn},
                  {"fixed_pattern_seed", o.effects.fixed_pattern_seed}};
  j["gps"] = {{"rate_hz", o.gps.rate_hz},
              {"horizontal_sigma_m", o.gps.horizontal_sigma_m},
              {"vertical_sigma_m", o.gps.vertical_sigma_m},
              {"correlation_time_s", o.gps.correlation_time_s}};
  j["ground"] = {{"source", g.source_kind},           {"path", or_null(g.source_path)},
                 {"metres_per_px", g.metres_per_px},  {"width_px", g.image.cols},
                 {"height_px", g.image.rows},         {"nw_lat_deg", g.nw_corner.lat_deg},
                 {"nw_lon_deg", g.nw_corner.lon_deg}, {"terrain_seed", g.terrain_seed}};
  j["seed"] = o.seed;
  int bad = 0;
  for (const auto& t : sim.ground_truth()) bad += t.nodata_fraction > o.max_nodata_fraction;
  j["frames_with_nodata"] = bad;
  j["max_nodata_fraction"] = o.max_nodata_fraction;
  j["warnings"] = sim.warnings();
  j["conventions"] = {
      {"ground_truth_frame",
       "ENU metres (x east, y north, z up = height above the flat ground), origin on the ground "
       "below the first frame's camera centre (see 'origin')"},
      {"tum_quaternion",
       "rotation enu_from_camera; camera axes x = image right, y = image down, z = optical "
       "axis; nadir with image top towards 'yaw'"},
      {"yaw", "compass heading of the image's top direction, degrees clockwise from north"},
      {"image", "pixel centres at integer coordinates, (0,0) = top-left pixel"},
      {"srt", "DJI style; latitude/longitude/abs_alt from the simulated GPS (with noise)"},
      {"illumination",
       "f_k = k * f: every pixel's brightness multiplied by k (Ivanov & "
       "Muzychuk 2023)"}};
  return j.dump(2) + "\n";
}

SimulationOutput WriteSimulation(const Simulator& sim, const WriterOptions& options,
                                 const fs::path& out_dir,
                                 const std::function<void(int, int)>& progress) {
  Validate(options);
  const auto t_start = std::chrono::steady_clock::now();
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec || !fs::is_directory(out_dir)) {
    throw OutputError(fmt::format("{}: cannot create the output folder ({})", out_dir.string(),
                                  ec ? ec.message() : "not a folder"));
  }
  SimulationOutput out;
  out.dir = out_dir;
  const int n = sim.frame_count();
  const cv::Size size(sim.options().camera.width_px, sim.options().camera.height_px);
  const bool colour = sim.renderer().ground().image.channels() == 3;

  imageio::VideoWriter video;
  if (options.write_video) {
    struct Try {
      std::string codec, file;
    };
    const std::vector<Try> tries = {
        {options.video_codec, "video.mp4"}, {"mp4v", "video.mp4"}, {"MJPG", "video.avi"}};
    for (const Try& t : tries) {
      const fs::path path = out_dir / t.file;
      const int fourcc = imageio::Fourcc(t.codec[0], t.codec[1], t.codec[2], t.codec[3]);
      if (video.open(path.string(), cv::CAP_FFMPEG, fourcc, sim.options().fps, size, colour)) {
        out.video_file = t.file;
        out.video_codec = t.codec;
        break;
      }
      out.messages.push_back(
          fmt::format("video codec {} in {} is not available here", t.codec, t.file));
    }
    if (!video.isOpened()) {
      throw OutputError(fmt::format("{}: no video writer could be opened (tried {}, mp4v, MJPG)",
                                    out_dir.string(), options.video_codec));
    }
    if (out.video_codec != options.video_codec) {
      out.messages.push_back(
          fmt::format("wrote {} with codec {} instead", out.video_file, out.video_codec));
    }
  } else {
    out.frames_dir = "frames";
    out.frame_pattern = "frame_%06d." + options.image_format;
    fs::create_directories(out_dir / out.frames_dir, ec);
    if (ec) {
      throw OutputError(
          fmt::format("{}: cannot create ({})", (out_dir / out.frames_dir).string(), ec.message()));
    }
  }

  // Render in parallel batches (Render is thread-safe), write in order.
  const int batch = std::max(2, 2 * cv::getNumThreads());
  std::vector<cv::Mat> frames(batch);
  std::vector<int> write_failed(batch, 0);
  double render_s = 0.0;
  for (int first = 0; first < n; first += batch) {
    const int count = std::min(batch, n - first);
    const auto t0 = std::chrono::steady_clock::now();
    cv::parallel_for_(cv::Range(0, count), [&](const cv::Range& r) {
      for (int k = r.start; k < r.end; ++k) {
        frames[k] = sim.RenderFrame(first + k);
        if (!options.write_video) {
          const fs::path path = out_dir / out.frames_dir /
                                fmt::format("frame_{:06d}.{}", first + k, options.image_format);
          std::vector<int> params;
          if (options.image_format == "jpg") {
            params = {cv::IMWRITE_JPEG_QUALITY, options.image_jpeg_quality};
          }
          write_failed[k] = !imageio::Write(path.string(), frames[k], params);
        }
      }
    });
    render_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (int k = 0; k < count; ++k) {
      if (options.write_video) {
        video.write(frames[k]);
      } else if (write_failed[k]) {
        throw OutputError(fmt::format("{}: cannot write frame {}",
                                      (out_dir / out.frames_dir).string(), first + k));
      }
    }
    out.frames_written += count;
    if (progress) progress(out.frames_written, n);
  }
  if (options.write_video) video.release();
  out.render_seconds = render_s;

  out.srt_file = "telemetry.srt";
  out.gpx_file = "track.gpx";
  out.tum_file = "ground_truth.tum";
  out.csv_file = "ground_truth.csv";
  out.json_file = "sim.json";
  {
    auto f = OpenOut(out_dir / out.srt_file);
    WriteDjiSrt(f, sim, options.start_time_utc);
    CheckWritten(f, out_dir / out.srt_file);
  }
  WriteGpx(out_dir / out.gpx_file, sim, options.start_time_utc);
  WriteTum(out_dir / out.tum_file, sim);
  {
    auto f = OpenOut(out_dir / out.csv_file);
    WriteGroundTruthCsv(f, sim);
    CheckWritten(f, out_dir / out.csv_file);
  }
  for (const auto& w : sim.warnings()) out.messages.push_back("warning: " + w);
  {
    auto f = OpenOut(out_dir / out.json_file);
    f << SimulationJsonText(sim, out, options);
    CheckWritten(f, out_dir / out.json_file);
  }
  out.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return out;
}

SimulationManifest ReadSimulationManifest(const fs::path& sim_json) {
  std::ifstream in(sim_json);
  if (!in) throw InputError(fmt::format("{}: cannot open", sim_json.string()));
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not valid JSON ({})", sim_json.string(), e.what()));
  }
  SimulationManifest m;
  m.dir = fs::absolute(sim_json).parent_path();
  auto field = [&](const nlohmann::json& obj, const char* name) -> const nlohmann::json& {
    if (!obj.is_object() || !obj.contains(name)) {
      throw InputError(fmt::format("{}: missing field '{}'", sim_json.string(), name));
    }
    return obj.at(name);
  };
  // A whole number in [lo, hi] (nlohmann's get<int>() would cast 1e300 into an int: undefined
  // behaviour).
  auto whole = [&](const nlohmann::json& obj, const char* name, long long lo, long long hi) {
    const std::optional<long long> v = options::JsonValueIn<long long>(field(obj, name), lo, hi);
    if (!v) {
      throw InputError(fmt::format("{}: '{}' is not a whole number in [{}, {}]", sim_json.string(),
                                   name, lo, hi));
    }
    return *v;
  };
  try {
    if (field(j, "format").get<std::string>() != "aerovo-simulation") {
      throw InputError(fmt::format("{}: 'format' is not aerovo-simulation", sim_json.string()));
    }
    const long long version = whole(j, "version", 0, 1000000);
    if (version != 1) {
      throw InputError(
          fmt::format("{}: unsupported version {} (expected 1)", sim_json.string(), version));
    }
    const auto& files = field(j, "files");
    auto path_of = [&](const char* name) -> fs::path {
      const auto& v = field(files, name);
      return v.is_null() ? fs::path() : m.dir / v.get<std::string>();
    };
    m.video = path_of("video");
    m.frames_dir = path_of("frames_dir");
    if (!field(files, "frame_pattern").is_null()) {
      m.frame_pattern = field(files, "frame_pattern").get<std::string>();
    }
    m.srt = path_of("srt");
    m.gpx = path_of("gpx");
    m.tum = path_of("ground_truth_tum");
    m.csv = path_of("ground_truth_csv");
    m.frame_count = static_cast<int>(whole(j, "frame_count", 1, 100000000));
    m.fps = field(j, "fps").get<double>();
    const auto& cam = field(j, "camera");
    m.width_px = static_cast<int>(whole(cam, "width_px", 1, 1000000));
    m.height_px = static_cast<int>(whole(cam, "height_px", 1, 1000000));
    m.focal_px = field(cam, "focal_px").get<double>();
    m.cx_px = field(cam, "cx_px").get<double>();
    m.cy_px = field(cam, "cy_px").get<double>();
    m.hfov_deg = field(cam, "hfov_deg").get<double>();
    m.height_above_ground_m = field(j, "height_above_ground_m").get<double>();
    m.gsd_m_per_px = field(j, "gsd_m_per_px").get<double>();
    m.ground_altitude_m = field(j, "ground_altitude_m").get<double>();
    const auto& origin = field(j, "origin");
    m.origin =
        GeoPoint{field(origin, "lat_deg").get<double>(), field(origin, "lon_deg").get<double>(),
                 field(origin, "alt_m").get<double>()};
    m.distance_m = field(j, "distance_m").get<double>();
    m.illumination_k = field(field(j, "effects"), "illumination_k").get<double>();
    m.gps_horizontal_sigma_m = field(field(j, "gps"), "horizontal_sigma_m").get<double>();
    const std::optional<std::uint64_t> seed = options::JsonValueIn<std::uint64_t>(field(j, "seed"));
    if (!seed) {
      throw InputError(fmt::format("{}: 'seed' is not a whole number >= 0", sim_json.string()));
    }
    m.seed = *seed;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: bad field type ({})", sim_json.string(), e.what()));
  }
  if (m.frame_count < 1 || !(m.fps > 0) || m.width_px < 1 || m.height_px < 1 || !(m.focal_px > 0)) {
    throw InputError(fmt::format("{}: frame_count, fps, image size and focal_px must be positive",
                                 sim_json.string()));
  }
  return m;
}

}  // namespace aerovo::sim
