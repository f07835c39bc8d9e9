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
// (MapMatchOptions). Without a geo-reference (GPS denied from the start, no positions in the
// telemetry), a job is unanchored: the fixer searches the whole map for it (SearchWholeMap),
// and a hit, a candidate, must be confirmed by the next attempt, a local one predicted through
// it; the confirmed fix seeds the run's geo-reference (map_fix stage; docs/map.md "A start
// without GPS").
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
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
  /// False: the track has no geo-reference, `predicted` and `heading_rad` mean nothing; the
  /// fixer predicts through its candidate, else searches the whole map.
  bool anchored = true;
  /// The frame's position (m) and heading (rad, odometry/pose_chain.h) in the local VO frame.
  Eigen::Vector2d local_m = Eigen::Vector2d::Zero();
  double local_heading_rad = 0.0;
};

/// A fix's part in the geo-reference seeded from the map (MapFixJob::anchored false).
enum class MapSeedRole {
  kNone,
  kCandidate,  ///< A whole-map search's fix: to be confirmed by the next attempt.
  kConfirmed,  ///< The local fix predicted through the candidate: the seed.
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
  /// The map (index into ReferenceMaps::infos(), the order of --map) with data under the fit's
  /// position (the prediction's when nothing was fitted): the preferred map there, the one the
  /// window's pixels at the frame came from; nullopt where no map has data.
  std::optional<int> map;
  MapSeedRole seed = MapSeedRole::kNone;
  bool whole_map = false;  ///< A whole-map search (no prediction: `predicted` is its hit).
  Eigen::Vector2d local_m = Eigen::Vector2d::Zero();  ///< The job's.
  double local_heading_rad = 0.0;                     ///< The job's.
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
  void CountNoPrediction() {
    const std::lock_guard lock(mutex_);
    ++no_prediction_;
  }
  /// The newest finished attempt not taken yet when it confirms a candidate (MapSeedRole::
  /// kConfirmed), waiting as TakeFix does: the fix that seeds the geo-reference. Recorded as
  /// the seed (summary.json map_fixes.georef).
  std::optional<MapFixRecord> TakeSeed(bool due);
  /// map_fix.apply: the newest finished attempt not taken yet, when it is a fix (marked applied).
  /// A file source's fixes are taken at due frames only, after waiting for the attempt in flight
  /// (so that a fix is taken at a frame that does not depend on the machine's speed); a live
  /// source's at any frame, without waiting.
  std::optional<MapFixRecord> TakeFix(bool due);
  /// No seed came within MapMatchOptions::seed_wait_s: the run goes on in the local frame from
  /// frame `frame` at `time_s` (s) and takes no seed after (TakeSeed returns nullopt); the
  /// summary's georef note says so.
  void GiveUpSeed(int frame, double time_s);
  bool gave_up_seed() const { return gave_up_.has_value(); }
  /// The pose graph's verdict on the fix TakeFix returned last: fused (applied), or not
  /// (not applied; gated_by_graph when `gated`: rejected by its gate, FlightGraph::AddFix).
  void SetGraphVerdict(bool fused, bool gated);
  const MapMatchOptions& options() const { return options_; }
  /// Waits for the last attempt, stops the worker, writes `out_dir`/map_fixes.csv and fills in
  /// summary->map_fixes. Idempotent.
  void Finish(const std::filesystem::path& out_dir, RunSummary* summary);

 private:
  void Work();
  std::optional<MapFixRecord> Attempt(MapFixJob& job);
  // An attempt around the job's prediction (`may_search`: a wide search when due).
  MapFixRecord Anchored(const MapFixJob& job, bool may_search);
  // No geo-reference: the confirmation of the candidate, else a whole-map search (nullopt: none
  // due, counted as no prediction).
  std::optional<MapFixRecord> Unanchored(MapFixJob& job);
  // The whole map's data searched coarse to fine without a prior (tiles of at most
  // search_wide_radius_m, start_search_max_tiles of them nearest the maps' centre); the fix and
  // its WGS84 position (`at`, when fitted).
  MapFix SearchWholeMap(const MapFixJob& job, std::optional<GeoPoint>* at);
  // Match at the matching resolution around `hit` with `heading_rad` (a search's refinement);
  // the fix in `hit`'s ENU plane.
  MapFix Refine(const MapFixJob& job, const GeoPoint& hit, double heading_rad);
  // The coarse-to-fine search of `radius_m` around the job's prediction (`enu`: its ENU plane)
  // with the gate `gate_m`: MapMatcher::Search over a coarse window, then Match at the matching
  // resolution around its hit; the fix in `enu`.
  MapFix CoarseToFine(const MapFixJob& job, const LocalEnu& enu, double radius_m, double gate_m);
  // The resolution of the map with data at `p` (the finest map's where none has), m/px.
  double MapResolutionAt(const GeoPoint& p) const;
  // summary "map_fixes" georef: the seed and the whole-map searches, or why none.
  void SummarizeSeed(RunSummary::MapFixes* s) const;
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
  // The matching's map resolution, m/px: at each attempt, that of the map at the prediction
  // (ReferenceMaps::MapAt; the finest map's where none has data).
  double map_m_per_px_ = 0.0, finest_m_per_px_ = 0.0;
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
  // Unanchored jobs: the candidate (a whole-map search's fix), the due attempts to skip before
  // the next whole-map search, the seed taken (records_ index).
  std::optional<MapFixRecord> candidate_;
  int whole_map_skips_ = 0;
  std::optional<std::size_t> seed_record_;
  std::optional<std::pair<int, double>> gave_up_;  // GiveUpSeed's frame and time, s
  int whole_map_tiles_ = 0, whole_map_tiles_total_ = 0, whole_map_searches_ = 0;
  std::size_t taken_ = 0;  // records_ before it were offered to TakeFix
  std::thread worker_;
};

}  // namespace aerovo::run_steps
