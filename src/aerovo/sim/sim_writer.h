// File side of the simulator (kept apart from the in-memory core): loading an orthophoto, and
// writing a simulated flight as video or images, DJI-style SRT, GPX, ground truth (TUM, CSV)
// and a sim.json manifest that tells the pipeline everything it needs.
//
// Output folder layout (names fixed; sim.json lists them):
//   video.mp4 (or video.avi)   the frames, unless frames-only; or
//   frames/frame_000000.jpg    one image per frame (frames-only)
//   telemetry.srt              DJI-style subtitle telemetry, one entry per frame (noisy GPS)
//   track.gpx                  GPX 1.1 track of the GPS fixes (noisy GPS, at the GPS rate)
//   ground_truth.tum           exact camera poses, TUM format, GT ENU frame (see simulator.h)
//   ground_truth.csv           exact per-frame positions (ENU and WGS84) and attitude
//   sim.json                   the manifest (schema in ReadSimulationManifest below)
#pragma once

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "aerovo/geo/geo_point.h"
#include "aerovo/sim/render.h"
#include "aerovo/sim/simulator.h"

namespace aerovo::sim {

/// Reads an orthophoto (any format OpenCV reads; loaded as BGR). `metres_per_px` and the
/// outer north-west corner geo-reference it (north-up image assumed; the corner's alt_m is the
/// ground altitude above MSL). Throws InputError naming the file if it cannot be read, and
/// InvalidArgument for a bad georeference.
GroundImage LoadOrthophoto(const std::filesystem::path& path, double metres_per_px,
                           const GeoPoint& nw_corner);

struct WriterOptions {
  /// true: one video file; false: an image folder ("frames-only").
  bool write_video = true;
  /// FourCC of the video codec. Default "avc1" (H.264 through FFmpeg/libx264, available in
  /// Debian 12's OpenCV); when the writer cannot open it, "mp4v" (MPEG-4 Part 2) is tried, then
  /// MJPG in an .avi, and the output says which was used.
  std::string video_codec = "avc1";
  /// frames-only: "jpg" or "png"; and the JPEG quality of written images (1..100). Default 95
  /// (visually lossless; apply EffectsOptions::jpeg_quality to study compression).
  std::string image_format = "jpg";
  int image_jpeg_quality = 95;
  /// UTC date and time of the first frame, "YYYY-MM-DDTHH:MM:SS" (SRT and GPX time stamps).
  std::string start_time_utc = "2026-05-01T10:00:00";
};

/// Throws InvalidArgument naming the bad field.
void Validate(const WriterOptions& options);

struct SimulationOutput {
  std::filesystem::path dir;
  std::string video_file;     ///< Relative to dir; empty when frames-only.
  std::string video_codec;    ///< FourCC actually used; empty when frames-only.
  std::string frames_dir;     ///< Relative to dir; empty unless frames-only.
  std::string frame_pattern;  ///< printf pattern of frame files inside frames_dir.
  std::string srt_file, gpx_file, tum_file, csv_file, json_file;  ///< Relative to dir.
  int frames_written = 0;
  double render_seconds = 0.0;        ///< Wall time spent rendering frames (with effects).
  double total_seconds = 0.0;         ///< Wall time of the whole write.
  std::vector<std::string> messages;  ///< Codec fallbacks and the simulator's warnings.
};

/// Renders every frame of `sim` and writes all outputs into `out_dir` (created if missing;
/// existing files of the same names are replaced). Frames are rendered in parallel batches.
/// `progress(done, total)` is called after each batch when given. Throws OutputError when a
/// file cannot be written (naming it).
SimulationOutput WriteSimulation(const Simulator& sim, const WriterOptions& options,
                                 const std::filesystem::path& out_dir,
                                 const std::function<void(int, int)>& progress = {});

/// DJI-style SRT (telemetry/srt_writer.h DjiSrtEntry, the current bracketed format of DJI Mini/Air/
/// Mavic 3 video subtitles), one entry per frame with the latest GPS fix. rel_alt = height above
/// the take-off ground, abs_alt = altitude above MSL, both with the GPS vertical error; a flight
/// with an attitude (pitch, roll or wobble) adds the camera's as gimbal angles, exact to the
/// 0.1 deg DJI writes: gb_pitch = pitch_deg - 90, gb_roll = -roll_deg (CameraPose's roll tilts
/// the optical axis to the image right, a DJI gimbal's roll to the left; odometry/attitude.h).
/// focal_len = the camera's 35 mm-equivalent focal length in the EXIF (diagonal) convention,
/// f_px * 43.27 mm / image diagonal (px), which `aerovo run` converts back to the same f_px
/// (25.16 for the default 73.7 deg hfov camera).
void WriteDjiSrt(std::ostream& out, const Simulator& sim, const std::string& start_time_utc);

/// GPX 1.1 track at `path` with one point per GPS fix (lat, lon, ele = altitude, UTC time from
/// start_time_utc), written by outputs' GpxTrackWriter. Throws OutputError naming the file.
void WriteGpx(const std::filesystem::path& path, const Simulator& sim,
              const std::string& start_time_utc);

/// TUM trajectory at `path`: "t x y z qx qy qz qw" per frame; t in seconds from the first
/// frame, position in GT ENU metres, quaternion of enu_from_camera (camera x right, y down, z
/// optical axis); written by outputs' TumWriter. Throws OutputError naming the file.
void WriteTum(const std::filesystem::path& path, const Simulator& sim);

/// CSV with header: frame,time_s,east_m,north_m,up_m,lat_deg,lon_deg,alt_m,yaw_deg,pitch_deg,
/// roll_deg,nodata_fraction (ENU = GT ENU frame; up = height above ground; alt above MSL).
void WriteGroundTruthCsv(std::ostream& out, const Simulator& sim);

/// The sim.json text for `sim` written as `output` describes (2-space indented JSON).
std::string SimulationJsonText(const Simulator& sim, const SimulationOutput& output,
                               const WriterOptions& options);

/// The part of sim.json the pipeline and the experiments need.
///
/// sim.json schema, version 1 (all lengths metres, angles degrees):
/// {
///   "format": "aerovo-simulation", "version": 1,
///   "files": {"video": "video.mp4" | null, "frames_dir": "frames" | null,
///             "frame_pattern": "frame_%06d.jpg" | null, "srt": "telemetry.srt",
///             "gpx": "track.gpx", "ground_truth_tum": "ground_truth.tum",
///             "ground_truth_csv": "ground_truth.csv"},
///   "video_codec": "avc1" | null,
///   "frame_count": int, "fps": number, "duration_s": number,
///   "start_time_utc": "YYYY-MM-DDTHH:MM:SS",
///   "camera": {"model": "pinhole", "width_px", "height_px", "focal_px", "cx_px", "cy_px",
///              "hfov_deg"},
///   "height_above_ground_m": number, "gsd_m_per_px": number (nadir, h / f),
///   "ground_altitude_m": number (MSL),
///   "origin": {"lat_deg", "lon_deg", "alt_m"}  (GT ENU origin: ground below frame 0),
///   "distance_m": number (flown), "path_length_m": number,
///   "flight": {"pattern", "centre_east_m", "centre_north_m", "heading_deg", "leg_length_m",
///              "legs", "spacing_m", "first_turn_right", "turn_angle_deg", "turn_radius_m",
///              "height_m", "speed_mps", "yaw_mode": "follow"|"fixed", "yaw_deg",
///              "pitch_deg", "roll_deg", "wobble_deg", "wobble_period_s", "max_duration_s",
///              "waypoints_m": [[e, n], ...]},
///   "effects": {"illumination_k", "noise_sigma_dn", "motion_blur_px", "jpeg_quality"},
///   "gps": {"rate_hz", "horizontal_sigma_m", "vertical_sigma_m", "correlation_time_s"},
///   "ground": {"source": "terrain"|"orthophoto"|..., "path": string|null, "metres_per_px",
///              "width_px", "height_px", "nw_lat_deg", "nw_lon_deg", "terrain_seed"},
///   "seed": uint64, "frames_with_nodata": int, "max_nodata_fraction": number,
///   "warnings": [string, ...],
///   "conventions": {free-text descriptions of the frames}
/// }
struct SimulationManifest {
  std::filesystem::path dir;  ///< Folder of sim.json; file paths below are absolute.
  std::filesystem::path video, frames_dir, srt, gpx, tum, csv;  ///< Empty when absent.
  std::string frame_pattern;
  int frame_count = 0;
  double fps = 0.0;
  int width_px = 0, height_px = 0;
  double focal_px = 0.0, cx_px = 0.0, cy_px = 0.0, hfov_deg = 0.0;
  double height_above_ground_m = 0.0;
  double gsd_m_per_px = 0.0;
  double ground_altitude_m = 0.0;
  GeoPoint origin;
  double distance_m = 0.0;
  double illumination_k = 1.0;
  double gps_horizontal_sigma_m = 0.0;
  std::uint64_t seed = 0;
};

/// Reads sim.json. Throws InputError naming the file and the missing/bad field.
SimulationManifest ReadSimulationManifest(const std::filesystem::path& sim_json);

}  // namespace aerovo::sim
