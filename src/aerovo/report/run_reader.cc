#include "aerovo/report/run_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include <fmt/format.h>

#include "aerovo/core/error.h"
#include "aerovo/core/text.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/telemetry/csv_lines.h"
#include "aerovo/telemetry/reference_track.h"

namespace aerovo {
namespace fs = std::filesystem;

namespace {

// The largest frame index a run folder may hold (as telemetry's frame numbers,
// telemetry/parse_util.h IsFrameNumber), and the largest count (of points, matches, maps).
constexpr int kMaxFrame = 100'000'000;
constexpr int kMaxCount = std::numeric_limits<int>::max();

// True when the file's last byte is a line end (LF; CR for a file saved with lone CRs), or the
// file is empty.
bool EndsWithNewline(const fs::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const std::streamoff size = in ? static_cast<std::streamoff>(in.tellg()) : 0;
  if (size <= 0) return true;
  in.seekg(size - 1);
  const int last = in.get();
  return last == '\n' || last == '\r';
}

// A CSV file read into rows of named columns.
class CsvTable {
 public:
  CsvTable(const fs::path& path, const std::vector<std::string>& required) : path_(path) {
    std::ifstream in(path);
    if (!in) throw InputError("cannot open '" + path.string() + "'");
    CsvLines csv(in, path.string());
    const std::vector<std::string>& header = csv.header();
    for (std::size_t i = 0; i < header.size(); ++i) columns_[header[i]] = i;
    for (const std::string& r : required) {
      if (columns_.count(r) == 0) {
        throw InputError("'" + path.string() + "': the header lacks the column '" + r + "'");
      }
    }
    struct Record {
      std::vector<std::string> cells;
      long line = 0;
      bool whole = true;  // no unterminated quote
    };
    std::vector<Record> records;
    for (Record r; csv.Next(r.cells);) {
      r.line = csv.line();
      r.whole = !csv.unterminated_quote();
      records.push_back(std::move(r));
    }
    // A progressive file killed mid-write may end with a partial record: drop a broken last one.
    // aerovo writes every record with its line end (outputs/output_file.h), so a last line
    // without one is cut too, even with every field: its last value may be cut short
    // (transforms.csv's ty -34.132989 read as -34.1, a silently wrong mosaic).
    const bool cut_last_line = !EndsWithNewline(path);
    for (std::size_t i = 0; i < records.size(); ++i) {
      Record& r = records[i];
      if (i + 1 == records.size() && cut_last_line) break;
      if (!r.whole || r.cells.size() != header.size()) {
        if (i + 1 == records.size()) break;
        throw InputError("'" + path.string() + "' line " + std::to_string(r.line) + ": " +
                         (r.whole ? std::to_string(r.cells.size()) + " fields, the header has " +
                                        std::to_string(header.size())
                                  : std::string("unterminated quote")));
      }
      rows_.push_back(std::move(r.cells));
      line_numbers_.push_back(r.line);
    }
  }
  std::size_t size() const { return rows_.size(); }
  bool has(const std::string& col) const { return columns_.count(col) > 0; }
  const std::string& cell(std::size_t row, const std::string& col) const {
    return rows_[row][columns_.at(col)];
  }
  // InputError "'<file>' line <n>: column '<col>' <what>".
  [[noreturn]] void Fail(std::size_t row, const std::string& col, const std::string& what) const {
    throw InputError(
        fmt::format("'{}' line {}: column '{}' {}", path_.string(), line_numbers_[row], col, what));
  }
  std::optional<double> OptNumber(std::size_t row, const std::string& col) const {
    const std::string& c = cell(row, col);
    if (c.empty()) return std::nullopt;
    const std::optional<double> v = ParseDecimal(c);
    if (!v) Fail(row, col, fmt::format("is not a number: '{}'", Printable(c)));
    return v;
  }
  double Number(std::size_t row, const std::string& col) const {
    const std::optional<double> v = OptNumber(row, col);
    if (!v) Fail(row, col, "is empty");
    return *v;
  }
  // A whole number in [lo, hi] (checked before the cast: converting a double outside int's range
  // is undefined behaviour).
  int Integer(std::size_t row, const std::string& col, int lo, int hi) const {
    const double v = Number(row, col);
    if (!(v >= lo && v <= hi && v == std::floor(v))) {
      Fail(row, col,
           fmt::format("is not a whole number in [{}, {}]: '{}'", lo, hi,
                       Printable(cell(row, col))));
    }
    return static_cast<int>(v);
  }
  std::optional<int> OptInteger(std::size_t row, const std::string& col, int lo, int hi) const {
    if (cell(row, col).empty()) return std::nullopt;
    return Integer(row, col, lo, hi);
  }
  // The frame index of a row: 0 ... kMaxFrame, after the previous row's (strictly: frames.csv
  // and transforms.csv hold one row per frame, in order) or not before it (map_fixes.csv: one
  // row per map tried on a frame).
  int FrameIndex(std::size_t row, std::optional<int>& previous, bool strictly_after) const {
    const int frame = Integer(row, "frame", 0, kMaxFrame);
    if (previous && (frame < *previous || (strictly_after && frame == *previous))) {
      Fail(row, "frame", fmt::format("{} comes after frame {}", frame, *previous));
    }
    previous = frame;
    return frame;
  }

 private:
  fs::path path_;
  std::map<std::string, std::size_t> columns_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<long> line_numbers_;
};

nlohmann::json ReadJsonIfPresent(const fs::path& path) {
  if (!fs::exists(path)) return nullptr;
  std::ifstream in(path);
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError("'" + path.string() + "': " + e.what());
  }
}

std::optional<GeoPoint> GeoOf(const CsvTable& t, std::size_t r, const char* lat, const char* lon,
                              const char* alt) {
  const std::optional<double> la = t.OptNumber(r, lat), lo = t.OptNumber(r, lon);
  if (!la || !lo) return std::nullopt;
  if (!(std::fabs(*la) <= 90.0)) t.Fail(r, lat, fmt::format("is not a latitude: {}", *la));
  if (!(std::fabs(*lo) <= 180.0)) t.Fail(r, lon, fmt::format("is not a longitude: {}", *lo));
  GeoPoint p;
  p.lat_deg = *la;
  p.lon_deg = *lo;
  p.alt_m = alt != nullptr ? t.OptNumber(r, alt).value_or(0.0) : 0.0;
  return p;
}

// A transforms.csv-format file (RunFileNames::kTransformsCsv), when present.
std::vector<FrameTransformRow> ReadTransformsIfPresent(const fs::path& path) {
  std::vector<FrameTransformRow> out;
  if (!fs::exists(path)) return out;
  const CsvTable tt(path, {"frame", "a11", "a12", "tx", "a21", "a22", "ty"});
  std::optional<int> previous;
  for (std::size_t r = 0; r < tt.size(); ++r) {
    FrameTransformRow row;
    row.frame = tt.FrameIndex(r, previous, /*strictly_after=*/true);
    const char* names[6] = {"a11", "a12", "tx", "a21", "a22", "ty"};
    for (int k = 0; k < 6; ++k) row.a[static_cast<std::size_t>(k)] = tt.Number(r, names[k]);
    out.push_back(row);
  }
  return out;
}

// map_fixes.csv (RunFileNames::kMapFixesCsv), when present.
std::vector<MapFixRow> ReadMapFixesIfPresent(const fs::path& path) {
  std::vector<MapFixRow> out;
  if (!fs::exists(path)) return out;
  const CsvTable t(path, {"frame", "time_s", "status", "lat_deg", "lon_deg", "gps_error_m",
                          "applied"});
  std::optional<int> previous;
  for (std::size_t r = 0; r < t.size(); ++r) {
    MapFixRow row;
    row.frame = t.FrameIndex(r, previous, /*strictly_after=*/false);
    row.time_s = t.Number(r, "time_s");
    row.status = t.cell(r, "status");
    const std::optional<double> lat = t.OptNumber(r, "lat_deg"), lon = t.OptNumber(r, "lon_deg");
    if (lat && lon) row.geo = GeoOf(t, r, "lat_deg", "lon_deg", nullptr);
    row.gps_error_m = t.OptNumber(r, "gps_error_m");
    row.applied = t.Number(r, "applied") != 0.0;
    if (t.has("gated_by_graph")) row.gated_by_graph = t.Number(r, "gated_by_graph") != 0.0;
    if (t.has("map")) {
      row.map = t.OptInteger(r, "map", 0, kMaxCount);
    }
    out.push_back(std::move(row));
  }
  return out;
}

// A TUM track written by the run, when present: t, x, y of each pose (ReadTumPoints; a last
// line without its newline, of a run killed mid-write, is dropped).
std::vector<TrajectoryPoint2D> ReadTumIfPresent(const fs::path& path) {
  std::vector<TrajectoryPoint2D> out;
  if (!fs::exists(path)) return out;
  for (const ReferencePoint& p : ReadTumPoints(path, /*last_line_may_be_cut=*/true)) {
    TrajectoryPoint2D q;
    q.t = p.time_s;
    q.x = p.x_m;
    q.y = p.y_m;
    out.push_back(q);
  }
  return out;
}

void Compare(RunComparison& c) {
  if (c.vo.size() < 3) return;
  try {
    c.comparison = CompareTrajectories(c.vo, c.reference);
  } catch (const InvalidArgument&) {
    c.comparison.reset();  // degenerate (e.g. the drone did not move): no comparison
  }
}

}  // namespace

bool IsRunDir(const fs::path& dir) { return fs::is_regular_file(dir / RunFileNames::kFramesCsv); }

RunData ReadRunDir(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw InputError("'" + dir.string() + "' is not a folder");
  RunData run;
  run.dir = dir;
  const CsvTable t(dir / RunFileNames::kFramesCsv,
                   {"frame",    "time_s",    "x_m",         "y_m",           "lat_deg",
                    "lon_deg",  "alt_m",     "n_surf",      "n_matched",     "n_inliers",
                    "cluster",  "detect_ms", "describe_ms", "correspond_ms", "estimate_ms",
                    "total_ms", "status",    "gps_lat_deg", "gps_lon_deg",   "gps_alt_m"});
  run.records_camera_attitude = t.has("camera_roll_deg") && t.has("camera_pitch_deg");
  run.frames.reserve(t.size());
  std::optional<int> previous;
  for (std::size_t r = 0; r < t.size(); ++r) {
    RunFrameRow f;
    f.frame = t.FrameIndex(r, previous, /*strictly_after=*/true);
    f.time_s = t.Number(r, "time_s");
    f.x_m = t.Number(r, "x_m");
    f.y_m = t.Number(r, "y_m");
    f.geo = GeoOf(t, r, "lat_deg", "lon_deg", "alt_m");
    f.geo_alt_known = f.geo && t.OptNumber(r, "alt_m").has_value();
    f.n_surf = t.Integer(r, "n_surf", 0, kMaxCount);
    f.n_matched = t.Integer(r, "n_matched", 0, kMaxCount);
    f.n_inliers = t.Integer(r, "n_inliers", 0, kMaxCount);
    f.cluster = t.Integer(r, "cluster", -1, kMaxCount);
    f.detect_ms = t.Number(r, "detect_ms");
    f.describe_ms = t.Number(r, "describe_ms");
    f.correspond_ms = t.Number(r, "correspond_ms");
    f.estimate_ms = t.Number(r, "estimate_ms");
    f.total_ms = t.Number(r, "total_ms");
    f.status = t.cell(r, "status");
    f.gps = GeoOf(t, r, "gps_lat_deg", "gps_lon_deg", "gps_alt_m");
    // A fix the run rejected as implausible (gps_flag; docs/reliability.md) is not a GPS position;
    // one withheld by GPS denial is (the run did not use it, the comparison does).
    if (t.has("gps_flag") && !t.cell(r, "gps_flag").empty() &&
        t.cell(r, "gps_flag") != kGpsFlagWithheld) {
      f.gps.reset();
    }
    // The camera attitude the odometry applied (absent from run folders of older builds).
    if (run.records_camera_attitude && !t.cell(r, "camera_roll_deg").empty() &&
        !t.cell(r, "camera_pitch_deg").empty()) {
      f.camera_roll_deg = t.Number(r, "camera_roll_deg");
      f.camera_pitch_deg = t.Number(r, "camera_pitch_deg");
    }
    run.frames.push_back(std::move(f));
  }
  run.transforms = ReadTransformsIfPresent(dir / RunFileNames::kTransformsCsv);
  run.transforms_optimized = ReadTransformsIfPresent(dir / RunFileNames::kTransformsOptimizedCsv);
  run.optimized = ReadTumIfPresent(dir / RunFileNames::kVoOptimizedTum);
  run.map_fixes = ReadMapFixesIfPresent(dir / RunFileNames::kMapFixesCsv);
  run.summary = ReadJsonIfPresent(dir / RunFileNames::kSummaryJson);
  run.config = ReadJsonIfPresent(dir / RunFileNames::kConfigJson);
  return run;
}

std::optional<LocalEnu> RunEnuFrame(const RunData& run) {
  if (run.summary.is_object() && run.summary.contains("enu_origin")) {
    const nlohmann::json& o = run.summary["enu_origin"];
    // alt_m null: the altitude is not known (a map's position; odometry/georef.h
    // altitude_known): 0, the height the run's own ENU plane had (the map fix's position).
    if (o.is_object() && o.contains("lat_deg") && o.contains("lon_deg") && o.contains("alt_m") &&
        o["lat_deg"].is_number() && o["lon_deg"].is_number() &&
        (o["alt_m"].is_number() || o["alt_m"].is_null())) {
      try {
        return LocalEnu(o["lat_deg"].get<double>(), o["lon_deg"].get<double>(),
                        o["alt_m"].is_null() ? 0.0 : o["alt_m"].get<double>());
      } catch (const InvalidArgument&) {
        // Not a position: fall back on frames.csv.
      }
    }
  }
  for (const RunFrameRow& f : run.frames) {
    if (f.gps) return LocalEnu(*f.gps);  // rejected fixes were dropped when read
  }
  return std::nullopt;
}

RunComparison CompareWithGps(const RunData& run) {
  RunComparison c;
  c.reference_name = "GPS";
  const std::optional<LocalEnu> enu = RunEnuFrame(run);
  for (std::size_t i = 0; i < run.frames.size(); ++i) {
    const RunFrameRow& f = run.frames[i];
    if (!f.gps) continue;
    const Eigen::Vector3d e = enu->Forward(*f.gps);
    c.vo.push_back({f.time_s, f.x_m, f.y_m});
    c.reference.push_back({f.time_s, e.x(), e.y()});
    c.row.push_back(static_cast<int>(i));
  }
  Compare(c);
  return c;
}

RunComparison CompareWithReference(const RunData& run, const ReferenceTrack& ground_truth) {
  if (ground_truth.geographic) {
    throw InvalidArgument("CompareWithReference: '" + ground_truth.path +
                          "' is geographic; it needs the simulator's local ground truth");
  }
  RunComparison c;
  c.reference_name = "ground truth";
  std::map<int, const ReferencePoint*> by_frame;
  for (const ReferencePoint& g : ground_truth.points) {
    if (g.frame_index) by_frame[*g.frame_index] = &g;
  }
  for (std::size_t i = 0; i < run.frames.size(); ++i) {
    const RunFrameRow& f = run.frames[i];
    const auto it = by_frame.find(f.frame);
    if (it == by_frame.end()) continue;
    c.vo.push_back({f.time_s, f.x_m, f.y_m});
    c.reference.push_back({f.time_s, it->second->x_m, it->second->y_m});
    c.row.push_back(static_cast<int>(i));
  }
  Compare(c);
  return c;
}

AssociatedTrajectories AssociateWithTruth(const std::vector<TrajectoryPoint2D>& estimate,
                                          const std::vector<int>& frames,
                                          const ReferenceTrack& truth,
                                          const std::optional<LocalEnu>& enu) {
  std::vector<TrajectoryPoint2D> reference;
  reference.reserve(truth.points.size());
  if (truth.geographic) {
    const LocalEnu frame = enu ? *enu : LocalEnu(*truth.points.front().geo);
    for (const ReferencePoint& p : truth.points) {
      const Eigen::Vector3d e = frame.Forward(*p.geo);
      reference.push_back({p.time_s, e.x(), e.y()});
    }
  } else {
    for (const ReferencePoint& p : truth.points) reference.push_back({p.time_s, p.x_m, p.y_m});
  }
  const bool by_index = std::all_of(truth.points.begin(), truth.points.end(),
                                    [](const ReferencePoint& p) { return p.frame_index; });
  if (!by_index) return AssociateByTime(estimate, reference);
  std::unordered_map<int, std::size_t> at;
  for (std::size_t i = 0; i < truth.points.size(); ++i) at[*truth.points[i].frame_index] = i;
  AssociatedTrajectories pairs;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const auto it = at.find(frames[i]);
    if (it == at.end()) continue;
    pairs.estimate.push_back(estimate[i]);
    pairs.reference.push_back(reference[it->second]);
    pairs.estimate_index.push_back(static_cast<int>(i));
    pairs.reference_index.push_back(static_cast<int>(it->second));
  }
  pairs.num_unmatched = static_cast<int>(estimate.size() - pairs.estimate.size());
  return pairs;
}

RunComparison CompareWithTruthFile(const RunData& run, const fs::path& truth_path) {
  const ReferenceTrack truth = ReadReferenceTrack(truth_path);
  RunComparison c;
  c.reference_name = "ground truth";
  std::vector<TrajectoryPoint2D> estimate;
  std::vector<int> frames;
  const std::optional<LocalEnu> enu = RunEnuFrame(run);
  for (const RunFrameRow& f : run.frames) {
    estimate.push_back({f.time_s, f.x_m, f.y_m});
    frames.push_back(f.frame);
  }
  try {
    const AssociatedTrajectories a = AssociateWithTruth(estimate, frames, truth, enu);
    c.vo = a.estimate;
    c.reference = a.reference;
    c.row = a.estimate_index;
  } catch (const InvalidArgument&) {
    return c;  // no pairs: no comparison
  }
  Compare(c);
  return c;
}

}  // namespace aerovo
