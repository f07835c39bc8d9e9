#include "aerovo/outputs/track_writers.h"
#include "aerovo/core/text.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <fstream>
#include <utility>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/outputs/output_file.h"

namespace aerovo {
namespace fs = std::filesystem;

namespace detail {

// POSIX descriptor + pwrite rather than stdio: each Append is then a single write() of the new
// element plus the tail at a known offset, with no user-space buffer to lose on a kill.
// A write that fails (disk full, size limit: outputs/output_file.h) is rolled back: the previous
// tail is written again where it was (bytes inside the file's size, so no new space is needed)
// and the file truncated to its previous size, so the file stays valid with everything written
// before; then OutputError names the file and the errno text. A file that fails before its
// first complete content is removed (an empty GPX or GeoJSON file would not be valid).
class ProgressiveFile {
 public:
  explicit ProgressiveFile(fs::path path) : path_(std::move(path)) {
    fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) ThrowOutputError("cannot create", path_, errno);
  }
  ~ProgressiveFile() { Close(); }
  ProgressiveFile(const ProgressiveFile&) = delete;
  ProgressiveFile& operator=(const ProgressiveFile&) = delete;

  const fs::path& path() const { return path_; }

  /// Replaces the whole content with body + tail.
  void Reset(const std::string& body, const std::string& tail) {
    Write(0, body, tail);
    reset_body_ = body;
  }

  /// Writes `chunk` where the tail starts, then the tail again.
  void Append(const std::string& chunk, const std::string& tail) {
    Write(body_end_, chunk, tail);
    reset_body_.reset();  // the body is no longer only the last Reset's
  }

  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  bool closed() const { return fd_ < 0; }

 private:
  // The file becomes its first `at` bytes + chunk + tail.
  void Write(size_t at, const std::string& chunk, const std::string& tail) {
    if (fd_ < 0) throw InvalidArgument("write to closed output file " + path_.string());
    const std::string data = chunk + tail;
    try {
      WriteAllAt(fd_, data.data(), data.size(), static_cast<off_t>(at), path_);
      const size_t end = at + data.size();
      if (end < size_ && !TruncateOutput(fd_, static_cast<off_t>(end))) {
        ThrowOutputError("cannot truncate", path_, errno);
      }
      body_end_ = at + chunk.size();
      size_ = end;
      tail_ = tail;
    } catch (const OutputError&) {
      RollBack(at);
      throw;
    }
  }

  // Restores the content before a failed Write at `at` (see the class comment).
  void RollBack(size_t at) {
    bool restored = false;
    if (size_ > 0) {
      try {
        if (at == body_end_) {
          WriteAllAt(fd_, tail_.data(), tail_.size(), static_cast<off_t>(body_end_), path_);
          restored = true;
        } else if (at == 0 && reset_body_) {
          const std::string old = *reset_body_ + tail_;
          WriteAllAt(fd_, old.data(), old.size(), 0, path_);
          restored = true;
        }
        if (restored && !TruncateOutput(fd_, static_cast<off_t>(size_))) restored = false;
      } catch (const OutputError&) {
        restored = false;
      }
    }
    if (!restored) {
      if (fd_ >= 0) (void)TruncateOutput(fd_, 0);
      Close();
      ::unlink(path_.c_str());
    }
  }

  fs::path path_;
  int fd_ = -1;
  size_t body_end_ = 0;                    ///< Offset where the tail starts.
  size_t size_ = 0;                        ///< Current (valid) file size.
  std::string tail_;                       ///< The tail now at body_end_.
  std::optional<std::string> reset_body_;  ///< The body, while it is the last Reset's.
};

void ProgressiveFileDeleter::operator()(ProgressiveFile* file) const { delete file; }
ProgressiveFilePtr CreateProgressiveFile(const fs::path& path) {
  return ProgressiveFilePtr(new ProgressiveFile(path));
}
const fs::path& PathOf(const ProgressiveFile& file) { return file.path(); }
void Close(ProgressiveFile& file) { file.Close(); }

}  // namespace detail

namespace {

using detail::ProgressiveFile;

void CheckFinite(double v, const char* what, const std::string& where) {
  if (!std::isfinite(v)) {
    throw InvalidArgument(where + ": " + what + " is not finite (" + fmt::format("{}", v) + ")");
  }
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

// GeoJSON (RFC 7946 3.1.1), KML and GPX expect longitudes in [-180, 180]; GeoPoint allows any.
double WrapLon(double lon_deg) { return std::remainder(lon_deg, 360.0); }

// A position written: finite latitude and longitude (geo/geo_point.h Validate), an altitude
// finite, or NaN when it is not known (written without one: GeoTrackPoint).
void ValidateGeo(const GeoPoint& p, const std::string& what) {
  if (std::isinf(p.alt_m)) {
    throw InvalidArgument(what + ": altitude " + std::to_string(p.alt_m) + " is not finite");
  }
  GeoPoint horizontal = p;
  if (std::isnan(horizontal.alt_m)) horizontal.alt_m = 0.0;
  Validate(horizontal, what.c_str());
}

// Positions as text, C locale (fmt never uses the global locale for these specs); without the
// altitude when it is not known (a GeoJSON position has two or more elements, RFC 7946 3.1.1; a
// KML coordinate tuple's altitude is optional, KML 2.2 <coordinates>).
std::string LonLatAltJson(const GeoPoint& p) {
  if (std::isnan(p.alt_m)) return fmt::format("[{:.9f},{:.9f}]", WrapLon(p.lon_deg), p.lat_deg);
  return fmt::format("[{:.9f},{:.9f},{:.4f}]", WrapLon(p.lon_deg), p.lat_deg, p.alt_m);
}
std::string LonLatAltKml(const GeoPoint& p) {  // 1e-7 deg ~ 1 cm, 1 mm in height
  if (std::isnan(p.alt_m)) return fmt::format("{:.7f},{:.7f}", WrapLon(p.lon_deg), p.lat_deg);
  return fmt::format("{:.7f},{:.7f},{:.3f}", WrapLon(p.lon_deg), p.lat_deg, p.alt_m);
}

void ValidatePoint(const GeoTrackPoint& p, const std::string& file) {
  CheckFinite(p.time_s, "time_s", "track point for " + file);
  ValidateGeo(p.geo, "track point for " + file);
}

}  // namespace

void Validate(const FrameRecord& r) {
  const std::string where = "FrameRecord of frame " + std::to_string(r.frame);
  if (r.frame < 0) throw InvalidArgument(where + ": frame index must be >= 0");
  CheckFinite(r.time_s, "time_s", where);
  CheckFinite(r.x_m, "x_m", where);
  CheckFinite(r.y_m, "y_m", where);
  CheckFinite(r.z_m, "z_m", where);
  CheckFinite(r.yaw_rad, "yaw_rad", where);
  for (double ms : {r.detect_ms, r.describe_ms, r.correspond_ms, r.estimate_ms, r.total_ms}) {
    CheckFinite(ms, "a stage time", where);
  }
  if (std::isinf(r.latency_ms)) throw InvalidArgument(where + ": latency_ms must be finite or NaN");
  for (const std::optional<double>& a : {r.roll_deg, r.pitch_deg, r.camera_roll_deg,
                                         r.camera_pitch_deg}) {
    if (a) CheckFinite(*a, "an attitude angle", where);
  }
  if (r.geo) ValidateGeo(*r.geo, where);
}

// ---------------------------------------------------------------------------------------------
// CSV

const char* CsvFrameFormat::Header() {
  return "frame,time_s,x_m,y_m,lat_deg,lon_deg,alt_m,n_surf,n_matched,n_inliers,cluster,"
         "detect_ms,describe_ms,correspond_ms,estimate_ms,total_ms,status,gps_lat_deg,"
         "gps_lon_deg,gps_alt_m,gps_flag,height_m,height_source,roll_deg,pitch_deg,latency_ms,"
         "camera_roll_deg,camera_pitch_deg";
}

void CsvFrameFormat::Open(ProgressiveFile& file) { file.Reset(std::string(Header()) + "\n", ""); }

void CsvFrameFormat::Append(ProgressiveFile& file, const FrameRecord& r,
                            const std::optional<GeoPoint>& gps) {
  Validate(r);
  if (gps) Validate(*gps, ("GPS of frame " + std::to_string(r.frame)).c_str());
  const auto geo_cells = [](const std::optional<GeoPoint>& g) {
    if (!g) return std::string(",,");
    if (std::isnan(g->alt_m)) return fmt::format("{:.9f},{:.9f},", g->lat_deg, g->lon_deg);
    return fmt::format("{:.9f},{:.9f},{:.4f}", g->lat_deg, g->lon_deg, g->alt_m);
  };
  std::string row =
      fmt::format("{},{:.6f},{:.4f},{:.4f},{},{},{},{},{},", r.frame, r.time_s, r.x_m, r.y_m,
                  geo_cells(r.geo), r.n_surf, r.n_matched, r.n_inliers, r.cluster);
  row += fmt::format("{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},", r.detect_ms, r.describe_ms,
                     r.correspond_ms, r.estimate_ms, r.total_ms);
  const auto opt = [](const std::optional<double>& v) {
    return v ? fmt::format("{:.4f}", *v) : std::string();
  };
  row += CsvField(r.status) + "," + geo_cells(gps) + "," + CsvField(r.gps_flag) +
         fmt::format(",{:.3f},{},{},{},", r.height_m, CsvField(r.height_source), opt(r.roll_deg),
                     opt(r.pitch_deg));
  if (std::isfinite(r.latency_ms)) row += fmt::format("{:.3f}", r.latency_ms);
  row += "," + opt(r.camera_roll_deg) + "," + opt(r.camera_pitch_deg) + "\n";
  file.Append(row, "");
}

// ---------------------------------------------------------------------------------------------
// TUM

void TumFormat::Append(ProgressiveFile& file, double time_s, const Eigen::Vector3d& p,
                       double yaw_rad) {
  const std::string where = "TUM pose for " + file.path().string();
  CheckFinite(time_s, "time", where);
  if (!p.allFinite()) throw InvalidArgument(where + ": position is not finite");
  CheckFinite(yaw_rad, "yaw", where);
  file.Append(fmt::format("{:.6f} {:.6f} {:.6f} {:.6f} 0 0 {:.9f} {:.9f}\n", time_s, p.x(), p.y(),
                          p.z(), std::sin(0.5 * yaw_rad), std::cos(0.5 * yaw_rad)),
              "");
}

void TumFormat::Append(ProgressiveFile& file, double time_s, const Eigen::Vector3d& p,
                       const Eigen::Quaterniond& q) {
  const std::string where = "TUM pose for " + file.path().string();
  CheckFinite(time_s, "time", where);
  if (!p.allFinite()) throw InvalidArgument(where + ": position is not finite");
  if (!q.coeffs().allFinite()) throw InvalidArgument(where + ": orientation is not finite");
  file.Append(fmt::format("{:.6f} {:.6f} {:.6f} {:.6f} {:.9f} {:.9f} {:.9f} {:.9f}\n", time_s,
                          p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()),
              "");
}

void TransformsCsvFormat::Open(ProgressiveFile& file) {
  file.Reset("frame,a11,a12,tx,a21,a22,ty\n", "");
}

void TransformsCsvFormat::Append(ProgressiveFile& file, int frame, const Eigen::Matrix3d& m) {
  file.Append(fmt::format("{},{:.9g},{:.9g},{:.6f},{:.9g},{:.9g},{:.6f}\n", frame, m(0, 0), m(0, 1),
                          m(0, 2), m(1, 0), m(1, 1), m(1, 2)),
              "");
}

// ---------------------------------------------------------------------------------------------
// GeoJSON

namespace {
constexpr const char* kFeatureCollectionHead = "{\"type\":\"FeatureCollection\",\"features\":[";
constexpr const char* kGeoJsonLineTail = "\n]}}]}\n";

std::string GeoJsonFeatureHead(const std::string& name, const char* geometry_type) {
  const nlohmann::json props = {{"name", name}, {"generator", "aerovo"}};
  return std::string("{\"type\":\"Feature\",\"properties\":") + props.dump() +
         ",\"geometry\":{\"type\":\"" + geometry_type + "\",\"coordinates\":";
}
}  // namespace

void GeoJsonTrackFormat::Open(ProgressiveFile& file) { file.Reset(kFeatureCollectionHead, "]}\n"); }

void GeoJsonTrackFormat::Append(ProgressiveFile& file, const GeoTrackPoint& point) {
  ValidatePoint(point, file.path().string());
  const std::string head = kFeatureCollectionHead;
  if (count_ == 0) {
    file.Reset(head + GeoJsonFeatureHead(name_, "Point") + LonLatAltJson(point.geo), "}}]}\n");
    first_ = point.geo;
  } else if (count_ == 1) {
    file.Reset(head + GeoJsonFeatureHead(name_, "LineString") + "[\n" + LonLatAltJson(first_) +
                   ",\n" + LonLatAltJson(point.geo),
               kGeoJsonLineTail);
  } else {
    file.Append(",\n" + LonLatAltJson(point.geo), kGeoJsonLineTail);
  }
  ++count_;
}

void GeoJsonPointsFormat::Open(ProgressiveFile& file) {
  file.Reset(kFeatureCollectionHead, "\n]}\n");
}

void GeoJsonPointsFormat::Append(ProgressiveFile& file, const GeoPoint& point,
                                 const nlohmann::json& properties) {
  ValidateGeo(point, "point for " + file.path().string());
  if (!properties.is_object()) {
    throw InvalidArgument("GeoJSON point properties for " + file.path().string() +
                          " must be a JSON object");
  }
  const std::string feature =
      "{\"type\":\"Feature\",\"properties\":" + properties.dump() +
      ",\"geometry\":{\"type\":\"Point\",\"coordinates\":" + LonLatAltJson(point) + "}}";
  file.Append((count_ == 0 ? "\n" : ",\n") + feature, "\n]}\n");
  ++count_;
}

// ---------------------------------------------------------------------------------------------
// KML

namespace {
// A <Style> for a track: its children in the order of the OGC KML 2.2 schema (IconStyle,
// LabelStyle, LineStyle, PolyStyle; the last two absent here).
std::string KmlStyle(const std::string& id, const std::string& color_abgr) {
  return "<Style id=\"" + id + "\"><IconStyle><color>" + XmlEscape(color_abgr) +
         "</color><scale>0.6</scale></IconStyle><LabelStyle><scale>0</scale></LabelStyle>"
         "<LineStyle><color>" +
         XmlEscape(color_abgr) +
         "</color><width>3</width></LineStyle>"
         "</Style>\n";
}
}  // namespace

namespace {
constexpr const char* kKmlDocumentTail = "</Document>\n</kml>\n";
constexpr const char* kKmlLineTail =
    "\n</coordinates></LineString></Placemark>\n</Document>\n</kml>\n";
}  // namespace

KmlTrackFormat::KmlTrackFormat(const fs::path& path, std::string name, std::string color_abgr)
    : name_(std::move(name)), color_(std::move(color_abgr)) {
  if (color_.size() != 8 ||
      color_.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos) {
    throw InvalidArgument("KML colour \"" + color_ + "\" for " + path.string() +
                          " must be 8 hex digits aabbggrr");
  }
}

std::string KmlTrackFormat::DocumentHead() const {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n<name>" +
         XmlEscape(name_) + "</name>\n" + KmlStyle("track", color_);
}

std::string KmlTrackFormat::PlacemarkHead() const {
  return "<Placemark><name>" + XmlEscape(name_) + "</name><styleUrl>#track</styleUrl>";
}

void KmlTrackFormat::Open(ProgressiveFile& file) { file.Reset(DocumentHead(), kKmlDocumentTail); }

void KmlTrackFormat::Append(ProgressiveFile& file, const GeoTrackPoint& point) {
  ValidatePoint(point, file.path().string());
  if (count_ == 0) {
    file.Reset(DocumentHead() + PlacemarkHead() + "<Point><coordinates>" + LonLatAltKml(point.geo) +
                   "</coordinates></Point></Placemark>\n",
               kKmlDocumentTail);
    first_ = point.geo;
  } else if (count_ == 1) {
    file.Reset(DocumentHead() + PlacemarkHead() +
                   "<LineString><tessellate>1</tessellate><altitudeMode>clampToGround"
                   "</altitudeMode><coordinates>\n" +
                   LonLatAltKml(first_) + "\n" + LonLatAltKml(point.geo),
               kKmlLineTail);
  } else {
    file.Append("\n" + LonLatAltKml(point.geo), kKmlLineTail);
  }
  ++count_;
}

// ---------------------------------------------------------------------------------------------
// GPX

std::string FlightNameOf(const std::string& input) {
  if (input.empty() || input.find("://") != std::string::npos ||
      input.find_first_not_of("0123456789") == std::string::npos) {
    return "aerovo";
  }
  fs::path p = input;
  while (!p.empty() && p.filename().empty()) p = p.parent_path();  // "survey/" -> "survey"
  const std::string stem = p.stem().string();
  return stem.empty() || stem == "." || stem == ".." ? "aerovo" : stem;
}

std::string FormatUtcIso8601(double unix_time_s) {
  if (!std::isfinite(unix_time_s)) {
    throw InvalidArgument("FormatUtcIso8601: time " + fmt::format("{}", unix_time_s) +
                          " is not finite");
  }
  // Round to whole milliseconds first so that 59.9996 s carries into the next minute.
  const long long total_ms = std::llround(unix_time_s * 1000.0);
  long long secs = total_ms / 1000;
  long long ms = total_ms % 1000;
  if (ms < 0) ms += 1000, secs -= 1;
  const std::time_t t = static_cast<std::time_t>(secs);
  std::tm tm{};
  if (gmtime_r(&t, &tm) == nullptr) {
    throw InvalidArgument("FormatUtcIso8601: time " + fmt::format("{}", unix_time_s) +
                          " is out of range");
  }
  return fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:03d}Z", tm.tm_year + 1900,
                     tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, ms);
}

namespace {
constexpr const char* kGpxTail = "\n</trkseg></trk>\n</gpx>\n";
}  // namespace

GpxTrackFormat::GpxTrackFormat(const fs::path& path, std::string name,
                               std::optional<double> time_origin_unix_s, int decimals)
    : name_(std::move(name)), time_origin_unix_s_(time_origin_unix_s), decimals_(decimals) {
  if (decimals_ < 5 || decimals_ > 12) {
    throw InvalidArgument("GPX decimals for " + path.string() + " must be within 5..12");
  }
  if (time_origin_unix_s_ && !std::isfinite(*time_origin_unix_s_)) {
    throw InvalidArgument("GPX time origin for " + path.string() + " is not finite");
  }
}

void GpxTrackFormat::Open(ProgressiveFile& file) {
  file.Reset(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<gpx version=\"1.1\" creator=\"aerovo\" xmlns=\"http://www.topografix.com/GPX/1/1\">\n"
      "<trk><name>" +
          XmlEscape(name_) + "</name><trkseg>",
      kGpxTail);
}

void GpxTrackFormat::Append(ProgressiveFile& file, const GeoTrackPoint& point) {
  ValidatePoint(point, file.path().string());
  std::string pt = fmt::format("\n<trkpt lat=\"{:.{}f}\" lon=\"{:.{}f}\">", point.geo.lat_deg,
                               decimals_, WrapLon(point.geo.lon_deg), decimals_);
  // <ele> is optional (GPX 1.1 wptType): left out when the altitude is not known.
  if (!std::isnan(point.geo.alt_m)) {
    pt += fmt::format("<ele>{:.{}f}</ele>", point.geo.alt_m, std::max(3, decimals_ - 5));
  }
  if (time_origin_unix_s_) {
    pt += "<time>" + FormatUtcIso8601(*time_origin_unix_s_ + point.time_s) + "</time>";
  }
  file.Append(pt + "</trkpt>", kGpxTail);
}

// ---------------------------------------------------------------------------------------------
// Atomic text and JSON files

void WriteTextFileAtomic(const fs::path& path, const std::string& text) {
  WriteFileAtomic(path, text);
}

void WriteJsonFileAtomic(const fs::path& path, const nlohmann::json& value) {
  // Non-finite numbers become null (JSON has no NaN/inf); replace keeps invalid UTF-8 from
  // throwing.
  WriteTextFileAtomic(path,
                      value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + '\n');
}

std::vector<std::string> RunFileNames::All() {
  return {kFramesCsv,   kVoTum,           kGpsTum,     kVoGeoJson,
          kGpsGeoJson,  kVoFramesGeoJson, kVoKml,      kGpsKml,
          kRunKml,      kRunLiveKml,      kVoGpx,      kGpsGpx,
          kSummaryJson, kTransformsCsv,   kConfigJson, kLensEstimateYaml,
          kVoOptimizedTum, kVoOptimizedGeoJson, kVoOptimizedKml, kVoOptimizedGpx,
          kTransformsOptimizedCsv, kMapFixesCsv};
}

// ---------------------------------------------------------------------------------------------
// TrackWriterSet

struct TrackWriterSet::Impl {
  fs::path dir;
  TrackWriterOptions options;
  std::optional<LocalEnu> enu;
  std::optional<CsvFrameWriter> csv;
  std::optional<TumWriter> vo_tum, gps_tum;
  std::optional<GeoJsonTrackWriter> vo_geojson, gps_geojson;
  std::optional<GeoJsonPointsWriter> vo_frames_geojson;
  std::optional<KmlTrackWriter> vo_kml, gps_kml;
  std::optional<RunKmlWriter> run_kml;
  std::optional<GpxTrackWriter> vo_gpx, gps_gpx;
  std::vector<fs::path> files;
  int num_records = 0;
  int csv_rows = 0;
  bool appended_gps = false;  // a GPS fix reached the tracks (gps.tum needs its origin before)
  bool closed = false;
};

namespace {
// run_live.kml: a static document pulling in both track files (network links, refreshed by
// Google Earth while they grow). GDAL and QGIS do not follow network links: run.kml has the data.
void WriteRunLiveKml(const fs::path& path, const std::string& run_name) {
  ProgressiveFile f(path);
  std::string body =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n<name>" +
      XmlEscape(run_name) + " (live)</name>\n";
  for (const char* file : {RunFileNames::kVoKml, RunFileNames::kGpsKml}) {
    body += std::string("<NetworkLink><name>") + file + "</name><Link><href>" + file +
            "</href><refreshMode>onInterval</refreshMode><refreshInterval>2</refreshInterval>"
            "</Link></NetworkLink>\n";
  }
  f.Reset(body, kKmlDocumentTail);
}
}  // namespace

// run.kml (see RunKmlWriter in the header).
RunKmlFormat::RunKmlFormat(const fs::path& path, std::string name,
                           std::optional<double> time_origin_unix_s)
    : name_(std::move(name)), time_origin_unix_s_(time_origin_unix_s.value_or(0.0)) {
  if (!std::isfinite(time_origin_unix_s_)) {
    throw InvalidArgument("KML time origin for " + path.string() + " is not finite");
  }
}

void RunKmlFormat::Open(ProgressiveFile& file) {
  file.Reset(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n<name>" +
          XmlEscape(name_) + "</name>\n" + KmlStyle("vo", "ff0000ff") + KmlStyle("gps", "ffff0000"),
      kKmlDocumentTail);
}

void RunKmlFormat::Append(ProgressiveFile& file, const GeoTrackPoint& point, bool gps, int frame) {
  ValidatePoint(point, file.path().string());
  const char* track = gps ? "GPS" : "VO";
  file.Append(
      fmt::format("<Placemark><name>{} {} {}</name><styleUrl>#{}</styleUrl>"
                  "<TimeStamp><when>{}</when></TimeStamp><Point><coordinates>{}</coordinates>"
                  "</Point></Placemark>\n",
                  XmlEscape(name_), track, frame, gps ? "gps" : "vo",
                  FormatUtcIso8601(time_origin_unix_s_ + point.time_s), LonLatAltKml(point.geo)),
      kKmlDocumentTail);
}

TrackWriterSet::TrackWriterSet(const fs::path& run_dir, const TrackWriterOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.dir = run_dir;
  m.options = options;
  if (options.enu_origin) m.enu.emplace(*options.enu_origin);
  if (options.time_origin_unix_s && !std::isfinite(*options.time_origin_unix_s)) {
    throw InvalidArgument("TrackWriterOptions.time_origin_unix_s is not finite");
  }
  std::error_code ec;
  fs::create_directories(run_dir, ec);
  if (ec || !fs::is_directory(run_dir)) {
    throw OutputError("cannot create run folder " + run_dir.string() + ": " +
                      (ec ? ec.message() : std::string("not a directory")));
  }
  const auto p = [&](const char* name) {
    m.files.push_back(run_dir / name);
    return run_dir / name;
  };
  const std::string& n = options.run_name;
  if (options.csv) m.csv.emplace(p(RunFileNames::kFramesCsv));
  if (options.tum) {
    m.vo_tum.emplace(p(RunFileNames::kVoTum));
    m.gps_tum.emplace(p(RunFileNames::kGpsTum));
  }
  if (options.geojson) {
    m.vo_geojson.emplace(p(RunFileNames::kVoGeoJson), n + " VO");
    m.gps_geojson.emplace(p(RunFileNames::kGpsGeoJson), n + " GPS");
    m.vo_frames_geojson.emplace(p(RunFileNames::kVoFramesGeoJson));
  }
  if (options.kml) {
    m.vo_kml.emplace(p(RunFileNames::kVoKml), n + " VO", "ff0000ff");     // red
    m.gps_kml.emplace(p(RunFileNames::kGpsKml), n + " GPS", "ffff0000");  // blue
    m.run_kml.emplace(p(RunFileNames::kRunKml), n, options.time_origin_unix_s);
    WriteRunLiveKml(p(RunFileNames::kRunLiveKml), n);
  }
  if (options.gpx) {
    // Times of the telemetry's clock when known, else from 1970-01-01T00:00:00Z (see the header).
    const double t0 = options.time_origin_unix_s.value_or(0.0);
    m.vo_gpx.emplace(p(RunFileNames::kVoGpx), n + " VO", t0);
    m.gps_gpx.emplace(p(RunFileNames::kGpsGpx), n + " GPS", t0);
  }
}

TrackWriterSet::~TrackWriterSet() {
  try {
    if (impl_) Close();
  } catch (...) {
  }
}
TrackWriterSet::TrackWriterSet(TrackWriterSet&&) noexcept = default;
TrackWriterSet& TrackWriterSet::operator=(TrackWriterSet&&) noexcept = default;
const fs::path& TrackWriterSet::dir() const { return impl_->dir; }
std::vector<fs::path> TrackWriterSet::Files() const { return impl_->files; }
int TrackWriterSet::num_records() const { return impl_->num_records; }
int TrackWriterSet::csv_rows() const { return impl_->csv_rows; }

void TrackWriterSet::Append(const FrameRecord& r, const std::optional<GeoPoint>& gps) {
  Impl& m = *impl_;
  if (m.closed) throw InvalidArgument("TrackWriterSet for " + m.dir.string() + " is closed");
  // Validate everything before writing anything, so that a bad record leaves all files
  // consistent with each other.
  Validate(r);
  if (gps) Validate(*gps, ("GPS of frame " + std::to_string(r.frame)).c_str());
  if (m.csv) {
    m.csv->Append(r, gps);
    ++m.csv_rows;
  }
  if (m.vo_tum) m.vo_tum->Append(r.time_s, Eigen::Vector3d(r.x_m, r.y_m, r.z_m), r.yaw_rad);
  // A fix the run rejected as implausible (gps_flag) stays in frames.csv with its flag, and out of
  // the GPS tracks, which users load as the reference; a withheld one (GPS denial) is a reference.
  const bool gps_track = gps && (r.gps_flag.empty() || r.gps_flag == kGpsFlagWithheld);
  if (gps_track && m.gps_tum && m.enu) m.gps_tum->Append(r.time_s, m.enu->Forward(*gps), 0.0);
  if (gps_track) m.appended_gps = true;
  if (r.geo) {
    const GeoTrackPoint vo{r.time_s, *r.geo};
    if (m.vo_geojson) m.vo_geojson->Append(vo);
    if (m.vo_frames_geojson) {
      m.vo_frames_geojson->Append(*r.geo, nlohmann::json{{"frame", r.frame},
                                                         {"time_s", r.time_s},
                                                         {"x_m", r.x_m},
                                                         {"y_m", r.y_m},
                                                         {"n_surf", r.n_surf},
                                                         {"n_matched", r.n_matched},
                                                         {"n_inliers", r.n_inliers},
                                                         {"cluster", r.cluster},
                                                         {"total_ms", r.total_ms},
                                                         {"status", r.status}});
    }
    if (m.vo_kml) m.vo_kml->Append(vo);
    if (m.run_kml) m.run_kml->Append(vo, false, r.frame);
    if (m.vo_gpx) m.vo_gpx->Append(vo);
  }
  if (gps_track) {
    const GeoTrackPoint g{r.time_s, *gps};
    if (m.gps_geojson) m.gps_geojson->Append(g);
    if (m.gps_kml) m.gps_kml->Append(g);
    if (m.run_kml) m.run_kml->Append(g, true, r.frame);
    if (m.gps_gpx) m.gps_gpx->Append(g);
  }
  ++m.num_records;
}

void TrackWriterSet::SetEnuOrigin(const GeoPoint& origin) {
  Impl& m = *impl_;
  if (m.enu) throw InvalidArgument("TrackWriterSet::SetEnuOrigin: the ENU origin is already set");
  if (m.appended_gps) {
    throw InvalidArgument("TrackWriterSet::SetEnuOrigin after a GPS fix was written");
  }
  m.enu.emplace(origin);  // validates
}

bool TrackWriterSet::has_enu_origin() const { return impl_->enu.has_value(); }

void TrackWriterSet::Close() {
  Impl& m = *impl_;
  if (m.closed) return;
  m.closed = true;
  if (m.csv) m.csv->Close();
  for (auto* w : {&m.vo_tum, &m.gps_tum}) {
    if (*w) (*w)->Close();
  }
  for (auto* w : {&m.vo_geojson, &m.gps_geojson}) {
    if (*w) (*w)->Close();
  }
  if (m.vo_frames_geojson) m.vo_frames_geojson->Close();
  for (auto* w : {&m.vo_kml, &m.gps_kml}) {
    if (*w) (*w)->Close();
  }
  if (m.run_kml) m.run_kml->Close();
  for (auto* w : {&m.vo_gpx, &m.gps_gpx}) {
    if (*w) (*w)->Close();
  }
}

}  // namespace aerovo
