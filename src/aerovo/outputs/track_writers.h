// Progressive writers of a run's outputs: per-frame CSV, TUM trajectories (evo), GeoJSON
// (RFC 7946), KML (Google Earth) and GPX tracks, and the summary JSON.
//
// Every file is valid after every Append (an interrupted run keeps everything written so far).
// How: CSV and TUM are append-only, one row per Append, flushed. GeoJSON, KML and GPX are kept
// valid by "tail rewriting": the file holds a body followed by a fixed closing tail
// (e.g. `]}}]}` or `</coordinates>...</kml>`); an Append seeks to where the tail starts and
// writes the new element plus the tail again in one write, then flushes. Cost is O(1) per
// point and memory stays bounded (no rewrite of the whole file, no point history), so it suits
// live runs of any length. Because a LineString needs two positions (RFC 7946 3.1.4, KML 2.2
// schema), a track with one point is written as a Point and a track with none as an empty
// collection/document; the small file is rewritten whole at those two transitions only.
// One track per file (tail rewriting can only grow the end of a file): vo.* and gps.*; run.kml
// holds both tracks as time-stamped points (one Placemark per frame and track, interleaved, so it
// grows at its end too) for GDAL/QGIS (`ogrinfo run.kml`) and Google Earth's time slider; a static
// run_live.kml links vo.kml and gps.kml (network links, refreshed every 2 s) for live viewing.
// Flushing hands the data to the OS: it survives the process being killed (SIGINT, SIGKILL,
// crash), not a power cut (no fsync per record). A reader racing an Append may briefly see a
// partial write. Numbers use the C locale: lat/lon with 9 decimals (1e-9 deg ~ 0.1 mm) in CSV,
// TUM and GeoJSON, 7 in KML and GPX (1e-7 deg ~ 1 cm, what viewers show; heights in mm), metres
// with 4, times with 6; longitudes are wrapped to [-180, 180] in GeoJSON/KML/GPX. Times in KML
// (<when>) and in the run's GPX (<time>) are ISO 8601 UTC: the telemetry's clock when it gives
// absolute time (TrackWriterOptions::time_origin_unix_s), else seconds from the start of the
// source counted from 1970-01-01T00:00:00Z (so a 2-minute video without clock reads 00:00-00:02
// on 1 January 1970).
// A write that fails (disk full, file size limit) leaves the file with its last valid content
// (the failed append is rolled back, outputs/output_file.h) and throws OutputError naming the file
// and the errno text.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "aerovo/geo/geo_point.h"
#include "aerovo/outputs/frame_record.h"

namespace aerovo {

/// A point of a geographic track: time (seconds from the start of the source) and position.
/// An altitude (geo.alt_m, and FrameRecord::geo's) that is NaN is not known (a track placed by a
/// map, which gives no height: odometry/georef.h altitude_known): the point is written without
/// one, never with an invented one: an empty alt_m cell in frames.csv, a GeoJSON position
/// [lon, lat], a KML coordinate tuple lon,lat (the tracks are clampToGround), a GPX trkpt
/// without <ele>. The GPS track's points always have one.
struct GeoTrackPoint {
  double time_s = 0.0;
  GeoPoint geo;
};

namespace detail {
/// A file whose content is body + tail, growing by inserting before the tail (see above).
class ProgressiveFile;
/// Closes and frees a ProgressiveFile (the deleter of ProgressiveWriter's file).
struct ProgressiveFileDeleter {
  void operator()(ProgressiveFile* file) const;
};
using ProgressiveFilePtr = std::unique_ptr<ProgressiveFile, ProgressiveFileDeleter>;
/// Creates (truncates) `path`, empty. Throws OutputError naming the path.
ProgressiveFilePtr CreateProgressiveFile(const std::filesystem::path& path);
const std::filesystem::path& PathOf(const ProgressiveFile& file);
void Close(ProgressiveFile& file);  ///< Idempotent; a write after it throws InvalidArgument.
}  // namespace detail

/// One progressive output file (see the top of this file) in the format `Format`, a policy class
/// that says what the file holds when it is created and what each Append adds:
///   Format(const std::filesystem::path& path, options...): the format's options (names,
///     colours, time origin), validated after the file is created (InvalidArgument naming it);
///   void Open(detail::ProgressiveFile& file): writes the content of an empty file;
///   void Append(detail::ProgressiveFile& file, element...): validates the element
///     (InvalidArgument, nothing written) and writes it; its overloads are the writer's Append.
/// The writer owns the file: created (truncated) by the constructor, closed by Close or the
/// destructor; movable, not copyable. A write that fails throws OutputError naming the file and
/// leaves it with its last valid content; Append after Close throws InvalidArgument.
template <typename Format>
class ProgressiveWriter {
 public:
  /// Creates `path` (OutputError naming it), then Format(path, options...) and Format::Open.
  template <typename... Options>
  explicit ProgressiveWriter(const std::filesystem::path& path, Options&&... options)
      : file_(detail::CreateProgressiveFile(path)),
        format_(path, std::forward<Options>(options)...) {
    format_.Open(*file_);
  }

  /// Format::Append. Arguments are forwarded: a braced list must name its type
  /// (Append(GeoTrackPoint{t, p}), not Append({t, p})).
  template <typename... Element>
  void Append(Element&&... element) {
    format_.Append(*file_, std::forward<Element>(element)...);
  }
  void Close() { detail::Close(*file_); }  ///< Idempotent.
  const std::filesystem::path& path() const { return detail::PathOf(*file_); }
  /// Points written, for the formats that count them (the GeoJSON and KML tracks).
  int size() const { return format_.size(); }

 private:
  detail::ProgressiveFilePtr file_;
  Format format_;
};

/// frames.csv: header `frame,time_s,x_m,y_m,lat_deg,lon_deg,alt_m,n_surf,n_matched,n_inliers,
/// cluster,detect_ms,describe_ms,correspond_ms,estimate_ms,total_ms,status,gps_lat_deg,
/// gps_lon_deg,gps_alt_m,gps_flag,height_m,height_source,roll_deg,pitch_deg,latency_ms,
/// camera_roll_deg,camera_pitch_deg` (RFC 4180; empty cells for absent geo/GPS/attitude or
/// latency). One flushed row per Append.
class CsvFrameFormat {
 public:
  explicit CsvFrameFormat(const std::filesystem::path&) {}
  void Open(detail::ProgressiveFile& file);
  /// Validates `record` (InvalidArgument) and appends one row; `gps` fills the gps_* columns.
  void Append(detail::ProgressiveFile& file, const FrameRecord& record,
              const std::optional<GeoPoint>& gps = std::nullopt);
  static const char* Header();  ///< The header line without newline.
};
using CsvFrameWriter = ProgressiveWriter<CsvFrameFormat>;

/// TUM trajectory `t tx ty tz qx qy qz qw` (space separated, one pose per line, no header),
/// readable by evo (`evo_traj tum vo.tum`, `evo_ape tum gps.tum vo.tum --align`).
class TumFormat {
 public:
  explicit TumFormat(const std::filesystem::path&) {}
  void Open(detail::ProgressiveFile&) {}
  /// Appends a pose: position in metres, orientation a rotation of yaw_rad about +z
  /// (q = [0, 0, sin(yaw/2), cos(yaw/2)]). InvalidArgument when not finite.
  void Append(detail::ProgressiveFile& file, double time_s, const Eigen::Vector3d& position_m,
              double yaw_rad);
  /// Appends a pose with a full orientation (e.g. the simulator's enu_from_camera): time and
  /// position with 6 decimals, the quaternion's x y z w with 9. InvalidArgument when not finite.
  void Append(detail::ProgressiveFile& file, double time_s, const Eigen::Vector3d& position_m,
              const Eigen::Quaterniond& orientation);
};
using TumWriter = ProgressiveWriter<TumFormat>;

/// transforms.csv (RunFileNames::kTransformsCsv): header `frame,a11,a12,tx,a21,a22,ty`, one
/// flushed row per frame with the 2x3 affine part of first_px_from_frame (see RunFileNames).
class TransformsCsvFormat {
 public:
  explicit TransformsCsvFormat(const std::filesystem::path&) {}
  void Open(detail::ProgressiveFile& file);
  /// Appends frame `frame`'s row.
  void Append(detail::ProgressiveFile& file, int frame, const Eigen::Matrix3d& first_px_from_frame);
};
using TransformsCsvWriter = ProgressiveWriter<TransformsCsvFormat>;

/// GeoJSON FeatureCollection (RFC 7946: WGS84, positions [lon, lat, alt]) with one Feature
/// holding the track: no feature when empty, a Point after the first point, a LineString from
/// the second on. Feature properties: {"name": name, "generator": "aerovo"}.
class GeoJsonTrackFormat {
 public:
  GeoJsonTrackFormat(const std::filesystem::path&, std::string name) : name_(std::move(name)) {}
  void Open(detail::ProgressiveFile& file);
  /// InvalidArgument for an invalid point.
  void Append(detail::ProgressiveFile& file, const GeoTrackPoint& point);
  int size() const { return count_; }

 private:
  std::string name_;
  int count_ = 0;
  GeoPoint first_;  ///< Kept to rewrite the Point as a LineString on the second point.
};
using GeoJsonTrackWriter = ProgressiveWriter<GeoJsonTrackFormat>;

/// GeoJSON FeatureCollection of Point features, each with its own properties (e.g. per-frame
/// counts and status), appended one by one.
class GeoJsonPointsFormat {
 public:
  explicit GeoJsonPointsFormat(const std::filesystem::path&) {}
  void Open(detail::ProgressiveFile& file);
  /// `properties` must be a JSON object (InvalidArgument otherwise); non-finite numbers in it
  /// are written as null.
  void Append(detail::ProgressiveFile& file, const GeoPoint& point,
              const nlohmann::json& properties);

 private:
  int count_ = 0;
};
using GeoJsonPointsWriter = ProgressiveWriter<GeoJsonPointsFormat>;

/// KML 2.2 document with one Placemark: a LineString (tessellated, clamped to ground, so it
/// drapes on the terrain in Google Earth; coordinates `lon,lat,alt`), a Point while the track
/// has one point, nothing while empty. `color_abgr` is KML's aabbggrr hex, e.g. "ff0000ff" red
/// (InvalidArgument naming the path when it is not 8 hex digits).
class KmlTrackFormat {
 public:
  KmlTrackFormat(const std::filesystem::path& path, std::string name,
                 std::string color_abgr = "ff0000ff");
  void Open(detail::ProgressiveFile& file);
  void Append(detail::ProgressiveFile& file, const GeoTrackPoint& point);
  int size() const { return count_; }

 private:
  std::string DocumentHead() const;
  std::string PlacemarkHead() const;

  std::string name_;
  std::string color_;
  int count_ = 0;
  GeoPoint first_;
};
using KmlTrackWriter = ProgressiveWriter<KmlTrackFormat>;

/// run.kml: a KML 2.2 document with both tracks of a run as time-stamped Point placemarks, in
/// the order appended: `<Placemark><name>NAME VO 12</name><styleUrl>#vo</styleUrl><TimeStamp>
/// <when>ISO 8601 UTC</when></TimeStamp><Point>...` (styles "vo" red, "gps" blue). Valid after
/// every Append (the tail `</Document></kml>` is rewritten). `time_origin_unix_s`: the absolute
/// time of time_s = 0; nullopt = 1970-01-01T00:00:00Z (see the top of this file).
class RunKmlFormat {
 public:
  RunKmlFormat(const std::filesystem::path& path, std::string name,
               std::optional<double> time_origin_unix_s = std::nullopt);
  void Open(detail::ProgressiveFile& file);
  /// One point of the VO (gps = false) or GPS track, frame index `frame` in its name.
  void Append(detail::ProgressiveFile& file, const GeoTrackPoint& point, bool gps, int frame);

 private:
  std::string name_;
  double time_origin_unix_s_ = 0.0;
};
using RunKmlWriter = ProgressiveWriter<RunKmlFormat>;

/// GPX 1.1 with one trk / trkseg; each point is a trkpt with lat, lon, ele and, when the
/// absolute time of time_s = 0 is known (`time_origin_unix_s`, seconds since 1970 UTC), a
/// <time> in ISO 8601 UTC with milliseconds. Without it <time> is omitted (optional in GPX
/// 1.1) rather than invented.
class GpxTrackFormat {
 public:
  /// `decimals`: of lat/lon (7 ~ 1 cm, the run's tracks; 9 ~ 0.1 mm for a truth track such as
  /// the simulator's, read back as telemetry), heights with decimals - 5 (at least 3).
  GpxTrackFormat(const std::filesystem::path& path, std::string name,
                 std::optional<double> time_origin_unix_s = std::nullopt, int decimals = 7);
  void Open(detail::ProgressiveFile& file);
  void Append(detail::ProgressiveFile& file, const GeoTrackPoint& point);

 private:
  std::string name_;
  std::optional<double> time_origin_unix_s_;
  int decimals_ = 7;
};
using GpxTrackWriter = ProgressiveWriter<GpxTrackFormat>;

/// The flight's name for track names and titles: the stem of the run's input (a video file
/// `DJI_0042.MP4` -> "DJI_0042", a photo folder `survey/` -> "survey"); "aerovo" when the input
/// is empty or a live source (a camera index, a URL).
std::string FlightNameOf(const std::string& input);

/// ISO 8601 UTC time with milliseconds, e.g. "2020-09-13T12:26:40.250Z".
std::string FormatUtcIso8601(double unix_time_s);

/// Writes `text` to `path` atomically (temporary file `path`.tmp in the same folder, then
/// rename), so readers see the old or the new file, never a partial one. Throws OutputError
/// naming the path.
void WriteTextFileAtomic(const std::filesystem::path& path, const std::string& text);

/// Writes `value` as indented JSON to `path` atomically (WriteTextFileAtomic). Throws
/// OutputError naming the path.
void WriteJsonFileAtomic(const std::filesystem::path& path, const nlohmann::json& value);

/// File names inside a run folder.
struct RunFileNames {
  static constexpr const char* kFramesCsv = "frames.csv";
  static constexpr const char* kVoTum = "vo.tum";
  static constexpr const char* kGpsTum = "gps.tum";
  static constexpr const char* kVoGeoJson = "vo.geojson";
  static constexpr const char* kGpsGeoJson = "gps.geojson";
  static constexpr const char* kVoFramesGeoJson = "vo_frames.geojson";
  static constexpr const char* kVoKml = "vo.kml";
  static constexpr const char* kGpsKml = "gps.kml";
  static constexpr const char* kRunKml = "run.kml";
  static constexpr const char* kRunLiveKml = "run_live.kml";
  static constexpr const char* kVoGpx = "vo.gpx";
  static constexpr const char* kGpsGpx = "gps.gpx";
  static constexpr const char* kSummaryJson = "summary.json";
  /// Written by report/runner.cc with TransformsCsvWriter, one flushed row per processed frame:
  /// header `frame,a11,a12,tx,a21,a22,ty`, the 2x3 affine first_px_from_frame = [a11 a12 tx;
  /// a21 a22 ty] mapping pixels of this frame to pixels of the run's first frame (the chained
  /// estimate, as the odometry integrated it; pixel centres, x right, y down). Used to warp
  /// frames into a mosaic (aerovo report).
  static constexpr const char* kTransformsCsv = "transforms.csv";
  static constexpr const char* kConfigJson = "config.json";
  /// The lens self-calibration's estimate when applied (pipeline/lens_prepass.h; OpenCV YAML).
  static constexpr const char* kLensEstimateYaml = "lens_estimate.yaml";
  /// The offline whole-flight optimisation's track (pipeline/run_steps.h OptimizeFlight), written
  /// after the last frame in the formats of vo.tum, vo.geojson, vo.kml and vo.gpx (the last three
  /// only when the run is geo-referenced).
  static constexpr const char* kVoOptimizedTum = "vo_optimized.tum";
  static constexpr const char* kVoOptimizedGeoJson = "vo_optimized.geojson";
  static constexpr const char* kVoOptimizedKml = "vo_optimized.kml";
  static constexpr const char* kVoOptimizedGpx = "vo_optimized.gpx";
  /// The offline optimisation's frame placements, in the format of transforms.csv: each frame's
  /// first_px_from_frame moved by the rigid motion of the local plane that takes its causal
  /// pose to its optimised one (pipeline/run_steps.h OptimizeFlight), the first frame's pixels
  /// those of transforms.csv. `aerovo report` builds its mosaics from it when present.
  static constexpr const char* kTransformsOptimizedCsv = "transforms_optimized.csv";
  /// The attempts to fix the position against a reference map (`--map`, pipeline/map_fixer.h),
  /// one row each, written after the last frame (docs/outputs.md).
  static constexpr const char* kMapFixesCsv = "map_fixes.csv";
  /// Every name above: the files a run writes (outputs/run_folder.h ClaimOutputFolder removes these
  /// and only these with --force, with the report's files).
  static std::vector<std::string> All();
};

/// Options of TrackWriterSet. Defaults write every format.
struct TrackWriterOptions {
  bool csv = true;      ///< frames.csv
  bool tum = true;      ///< vo.tum, gps.tum
  bool geojson = true;  ///< vo.geojson, gps.geojson, vo_frames.geojson
  bool kml = true;      ///< vo.kml, gps.kml, run.kml, run_live.kml
  bool gpx = true;      ///< vo.gpx, gps.gpx
  /// Origin of the ENU frame of FrameRecord x/y/z. Needed for gps.tum (GPS fixes converted to
  /// the same ENU frame as the VO so that evo can compare them); without it (and without
  /// TrackWriterSet::SetEnuOrigin) gps.tum stays empty.
  std::optional<GeoPoint> enu_origin;
  /// Absolute time (seconds since 1970 UTC) of time_s = 0, for GPX <time> and KML <when>;
  /// nullopt: time_s counted from 1970-01-01T00:00:00Z (see the top of this file).
  std::optional<double> time_origin_unix_s;
  /// Prefix of track names in GeoJSON/KML/GPX: the flight's name (FlightNameOf(input)).
  std::string run_name = "aerovo";
};

/// All per-frame outputs of one run folder, written progressively (see the top of this file).
/// Files present after construction (each valid, possibly empty): frames.csv, vo.tum, gps.tum,
/// vo/gps .geojson/.kml/.gpx, vo_frames.geojson, run.kml, run_live.kml (per the options). Existing
/// files of those names are replaced. Not thread-safe.
class TrackWriterSet {
 public:
  /// Creates `run_dir` (and parents) if needed and opens the outputs. Throws OutputError naming
  /// the folder or file that cannot be created, InvalidArgument for invalid options.
  explicit TrackWriterSet(const std::filesystem::path& run_dir,
                          const TrackWriterOptions& options = {});
  ~TrackWriterSet();  ///< Closes (never throws).
  TrackWriterSet(TrackWriterSet&&) noexcept;
  TrackWriterSet& operator=(TrackWriterSet&&) noexcept;

  /// Appends one frame to every output; `gps` is the GPS position associated with this frame
  /// (same time_s), added to the CSV gps_* columns and, unless record.gps_flag marks it rejected
  /// (non-empty but kGpsFlagWithheld), to the gps.* tracks. The VO geo tracks
  /// only get frames with record.geo. Throws InvalidArgument for an invalid record/gps (nothing
  /// is written then), OutputError naming the file when a write fails.
  void Append(const FrameRecord& record, const std::optional<GeoPoint>& gps = std::nullopt);
  /// Sets the origin of the ENU frame (TrackWriterOptions::enu_origin) when it is known only
  /// after the writers were opened (the run's origin is its first accepted GPS fix, which a
  /// plausibility check may settle frames after the first). Throws InvalidArgument when an
  /// origin is already set or a GPS fix has already been appended (gps.tum would mix frames).
  void SetEnuOrigin(const GeoPoint& origin);
  bool has_enu_origin() const;
  /// Closes every file (they are already valid). Idempotent. Append after Close throws.
  void Close();

  const std::filesystem::path& dir() const;
  std::vector<std::filesystem::path> Files() const;  ///< Paths of the files written.
  int num_records() const;
  /// Rows of frames.csv: num_records(), or one more when the last Append wrote its row and then
  /// failed in a later file.
  int csv_rows() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace aerovo
