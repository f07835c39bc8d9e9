// Absolute fixes against the reference maps beside the odometry (`aerovo run --map`;
// docs/map.md): every map_fix.every_n_frames-th frame, once the track is geo-referenced, is
// handed with its prediction (the track's position and heading) to a worker thread that reads
// the map window around it (map/reference_map.h) and matches the frame against it
// (odometry/map_match.h). The frame loop never waits for a fix to be computed but in one case:
// from a file (video, photos), the next attempt waits for the one before to finish, so that
// the same input gives the same attempts and fixes whatever the machine's speed; from a live
// source, a frame due while the worker is busy is skipped (counted). The fixes are recorded
// (map_fixes.csv, summary.json "map_fixes") and compared with the GPS, withheld or not; with
// map_fix.apply the map-fix stage fuses them into the pose graph (stage_map_fix.cc). Lost and
// found: the run's first attempt, and the attempt after map_fix.search_after_failures failed
// ones in a row, is a wide search (search_wide_radius_m, coarse to fine), gated by the radius
// before the run's first fix and by the track's drift since the last fix after it
// (MapMatchOptions).
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "aerovo/core/image.h"
#include "aerovo/geo/geo_point.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/odometry/map_match.h"
#include "aerovo/pipeline/map_tiles.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo::map {
class ReferenceMaps;
}

namespace aerovo::run_steps {

/// One attempt's input: a copy of the preprocessed frame and its prediction.
struct MapFixJob {
  int frame = 0;
  double time_s = 0.0;
  GrayImage pixels;
  double focal_px = 0.0, height_m = 0.0;
  std::optional<double> heading_rad;  ///< ENU (odometry/map_match.h).
  GeoPoint predicted;                 ///< The track's position of the frame.
  std::optional<GeoPoint> gps;        ///< The frame's GPS (withheld or not), for the comparison.
};

/// One attempt's outcome (a row of map_fixes.csv).
struct MapFixRecord {
  int frame = 0;
  double time_s = 0.0;
  GeoPoint predicted;    ///< The job's prediction.
  bool applied = false;  ///< Fused into the pose graph: it moved the track (map_fix.apply).
  bool gated_by_graph = false;  ///< Taken (map_fix.apply) and rejected by the graph's gate.
  /// A search, coarse to fine (a wide search, or search_radius_m above coarse_above_radius_m).
  bool search = false;
  MapFix fix;
  std::optional<GeoPoint> geo;              ///< The fit's position (when fitted).
  std::optional<double> gps_error_m;        ///< |fit - GPS|, m (fitted, with GPS).
  std::optional<double> track_gps_error_m;  ///< |track - GPS| at the frame, m.
};

class MapFixer {
 public:
  /// `maps` must outlive this object and be used by no other thread until Finish. `live`: a
  /// frame due while the worker is busy is skipped instead of waited for.
  MapFixer(const map::ReferenceMaps& maps, const MapMatchOptions& options, bool live);
  ~MapFixer();
  MapFixer(const MapFixer&) = delete;
  MapFixer& operator=(const MapFixer&) = delete;

  /// An attempt is due at the `processed`-th frame processed (0-based).
  bool Due(int processed) const { return processed % options_.every_n_frames == 0; }
  /// The attempt (waiting first for the previous one unless live; an error of the previous one,
  /// e.g. an unreadable map, is rethrown here).
  void Submit(MapFixJob job);
  /// A frame was due but the track is not geo-referenced yet (no prediction).
  void CountNoPrediction() { ++no_prediction_; }
  /// map_fix.apply: the newest finished attempt not taken yet, when it is a fix (marked applied).
  /// A file source's fixes are taken at due frames only, after waiting for the attempt in flight
  /// (so that a fix is taken at a frame that does not depend on the machine's speed); a live
  /// source's at any frame, without waiting.
  std::optional<MapFixRecord> TakeFix(bool due);
  /// The pose graph's verdict on the fix TakeFix returned last: fused (applied), or not
  /// (not applied; gated_by_graph when `gated`: rejected by its gate, FlightGraph::AddFix).
  void SetGraphVerdict(bool fused, bool gated);
  const MapMatchOptions& options() const { return options_; }
  /// Waits for the last attempt, stops the worker, writes `out_dir`/map_fixes.csv and fills in
  /// summary->map_fixes. Idempotent.
  void Finish(const std::filesystem::path& out_dir, RunSummary* summary);

 private:
  void Work();
  MapFixRecord Attempt(MapFixJob& job);
  // The coarse-to-fine search of `radius_m` around the job's prediction (`enu`: its ENU plane)
  // with the gate `gate_m`: MapMatcher::Search over a coarse window, then Match at the matching
  // resolution around its hit; the fix in `enu`.
  MapFix CoarseToFine(const MapFixJob& job, const LocalEnu& enu, double radius_m, double gate_m);
  // The attempt in the window of `radius_m` around the job's prediction (its ENU plane): read
  // and matched, or from the tiles' points (map_fix.tile_cache).
  MapFix Local(const MapFixJob& job, double radius_m);
  // After an attempt: the failures in a row, the first fix, the distance since the last fix.
  void Follow(const MapFixRecord& record);

  const map::ReferenceMaps& maps_;
  MapMatchOptions options_;
  bool live_;
  MapMatcher matcher_;
  std::optional<MapTileCache> tiles_;  // map_fix.tile_cache: the worker's
  double map_m_per_px_ = 0.0;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::optional<MapFixJob> job_;  // waiting for the worker
  bool busy_ = false, stop_ = false, finished_ = false;
  std::exception_ptr error_;
  std::vector<MapFixRecord> records_;  // in the order of the attempts
  int skipped_busy_ = 0, no_prediction_ = 0;
  // The worker's own (Attempt, Follow): failed attempts in a row (MapMatchOptions::
  // search_after_failures), whether the run had a fix, the track's distance since the last one
  // (m, along the predictions), the previous prediction.
  int failures_ = 0, records_seen_ = 0;
  bool had_fix_ = false;
  double flown_since_fix_m_ = 0.0;
  std::optional<GeoPoint> last_predicted_;
  std::size_t taken_ = 0;  // records_ before it were offered to TakeFix
  std::thread worker_;
};

}  // namespace aerovo::run_steps
