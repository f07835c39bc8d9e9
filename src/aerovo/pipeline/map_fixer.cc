#include "aerovo/pipeline/map_fixer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>

#include "aerovo/core/statistics.h"
#include "aerovo/core/timer.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/map/reference_map.h"
#include "aerovo/outputs/track_writers.h"

namespace aerovo::run_steps {

MapFixer::MapFixer(const map::ReferenceMaps& maps, const MapMatchOptions& options, bool live)
    : maps_(maps), options_(options), live_(live), matcher_(options) {
  for (const map::MapInfo& info : maps_.infos()) {
    const double mpp = std::min(info.m_per_px_x, info.m_per_px_y);
    finest_m_per_px_ = finest_m_per_px_ > 0.0 ? std::min(finest_m_per_px_, mpp) : mpp;
  }
  map_m_per_px_ = finest_m_per_px_;
  if (options_.tile_cache) tiles_.emplace(maps_);
  worker_ = std::thread([this] { Work(); });
}

MapFixer::~MapFixer() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void MapFixer::Submit(MapFixJob job) {
  std::unique_lock lock(mutex_);
  if (live_ && (busy_ || job_)) {
    ++skipped_busy_;
    return;
  }
  done_.wait(lock, [this] { return !busy_ && !job_; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  job_ = std::move(job);
  lock.unlock();
  wake_.notify_all();
}

void MapFixer::Work() {
  for (;;) {
    std::unique_lock lock(mutex_);
    wake_.wait(lock, [this] { return stop_ || job_.has_value(); });
    if (!job_) return;  // stopping with nothing left
    MapFixJob job = std::move(*job_);
    job_.reset();
    busy_ = true;
    lock.unlock();
    std::exception_ptr error;
    std::optional<MapFixRecord> record;
    try {
      record = Attempt(job);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error) {
      error_ = error;
    } else if (record) {
      records_.push_back(std::move(*record));
    } else {
      ++no_prediction_;  // unanchored, no whole-map search due
    }
    busy_ = false;
    lock.unlock();
    done_.notify_all();
  }
}

std::optional<MapFixRecord> MapFixer::TakeFix(bool due) {
  if (!due && !live_) return std::nullopt;  // a file source: at due frames only
  std::unique_lock lock(mutex_);
  if (due && !live_) done_.wait(lock, [this] { return !busy_ && !job_; });
  if (taken_ >= records_.size()) return std::nullopt;
  MapFixRecord& newest = records_.back();
  taken_ = records_.size();
  if (newest.fix.status != MapFixStatus::kFix) return std::nullopt;
  newest.applied = true;
  return newest;
}

void MapFixer::GiveUpSeed(int frame, double time_s) {
  const std::lock_guard lock(mutex_);
  if (!gave_up_) gave_up_.emplace(frame, time_s);
}

std::optional<MapFixRecord> MapFixer::TakeSeed(bool due) {
  if (gave_up_ || (!due && !live_)) return std::nullopt;  // a file source: at due frames only
  std::unique_lock lock(mutex_);
  if (due && !live_) done_.wait(lock, [this] { return !busy_ && !job_; });
  if (taken_ >= records_.size()) return std::nullopt;
  taken_ = records_.size();
  if (records_.back().seed != MapSeedRole::kConfirmed || !records_.back().geo) return std::nullopt;
  seed_record_ = records_.size() - 1;
  return records_.back();
}

void MapFixer::SetGraphVerdict(bool fused, bool gated) {
  const std::lock_guard lock(mutex_);
  if (taken_ == 0) return;
  MapFixRecord& r = records_[taken_ - 1];
  r.applied = fused;
  r.gated_by_graph = !fused && gated;
}

std::optional<MapFixRecord> MapFixer::Attempt(MapFixJob& job) {
  const Stopwatch watch;
  std::optional<MapFixRecord> r = job.anchored ? Anchored(job, true) : Unanchored(job);
  if (r) r->fix.ms = watch.elapsed_ms();
  return r;
}

MapFixRecord MapFixer::Anchored(const MapFixJob& job, bool may_search) {
  MapFixRecord r;
  r.frame = job.frame;
  r.time_s = job.time_s;
  r.predicted = job.predicted;
  r.local_m = job.local_m;
  r.local_heading_rad = job.local_heading_rad;
  const LocalEnu enu(job.predicted);
  map_m_per_px_ = MapResolutionAt(job.predicted);
  if (last_predicted_) flown_since_fix_m_ += enu.Forward(*last_predicted_).head<2>().norm();
  last_predicted_ = job.predicted;
  // A wide search at the run's first attempt and after search_after_failures failures in a row.
  const int after = options_.search_after_failures;
  const bool wide = may_search && after > 0 &&
                    (failures_ >= after || (options_.search_at_start && records_seen_ == 0));
  ++records_seen_;
  const double radius = wide ? options_.search_wide_radius_m : options_.search_radius_m;
  double gate = options_.gate_m > 0.0 ? options_.gate_m : options_.search_radius_m;
  if (wide) {
    gate = had_fix_ ? std::min(radius, gate + options_.search_gate_per_m * flown_since_fix_m_)
                    : radius;
  }
  if (job.gps) r.track_gps_error_m = enu.Forward(*job.gps).head<2>().norm();
  r.search = radius > options_.coarse_above_radius_m;
  if (r.search) {
    r.fix = CoarseToFine(job, enu, radius, gate);
  } else {
    r.fix = Local(job, radius);
  }
  if (r.fix.fitted) {
    r.geo = enu.Reverse(r.fix.enu_m.x(), r.fix.enu_m.y(), 0.0);
    if (job.gps) r.gps_error_m = (enu.Forward(*job.gps).head<2>() - r.fix.enu_m).norm();
  }
  r.map = maps_.MapAt(r.geo ? *r.geo : job.predicted);
  Follow(r);
  if (wide) failures_ = 0;  // the next wide search after as many failures again
  return r;
}

double MapFixer::MapResolutionAt(const GeoPoint& p) const {
  const std::optional<int> m = maps_.MapAt(p);
  if (!m) return finest_m_per_px_;
  const map::MapInfo& info = maps_.infos()[static_cast<std::size_t>(*m)];
  return std::min(info.m_per_px_x, info.m_per_px_y);
}

std::optional<MapFixRecord> MapFixer::Unanchored(MapFixJob& job) {
  if (candidate_) {
    // The candidate's enu_from_local (rotation = fix heading - local heading) predicts the frame.
    const MapFixRecord& c = *candidate_;
    const double rotation = c.fix.heading_rad - c.local_heading_rad;
    const Eigen::Vector2d d = Eigen::Rotation2Dd(rotation) * (job.local_m - c.local_m);
    job.predicted = LocalEnu(*c.geo).Reverse(d.x(), d.y(), 0.0);
    job.heading_rad = job.local_heading_rad + rotation;
    MapFixRecord r = Anchored(job, false);
    switch (r.fix.status) {
      case MapFixStatus::kFix:
        r.seed = MapSeedRole::kConfirmed;
        candidate_.reset();
        break;
      case MapFixStatus::kNoMap:  // nothing to confirm it with here: kept for the next attempt
      case MapFixStatus::kNoMapTexture:
      case MapFixStatus::kNoFrameTexture:
      case MapFixStatus::kMapTooCoarse:
        break;
      default:  // disproved: the next attempt searches the whole map again
        candidate_.reset();
        break;
    }
    return r;
  }
  const int after = options_.search_after_failures;
  if (after == 0) return std::nullopt;  // no search, ever
  if (records_seen_ == 0 && !options_.search_at_start && whole_map_skips_ == 0) {
    whole_map_skips_ = after;
  }
  if (whole_map_skips_ > 0) {
    --whole_map_skips_;
    ++records_seen_;
    return std::nullopt;
  }
  ++records_seen_;
  MapFixRecord r;
  r.frame = job.frame;
  r.time_s = job.time_s;
  r.local_m = job.local_m;
  r.local_heading_rad = job.local_heading_rad;
  r.search = true;
  r.whole_map = true;
  r.fix = SearchWholeMap(job, &r.geo);
  ++whole_map_searches_;
  r.predicted = r.geo ? *r.geo : GeoPoint{};
  if (r.geo && job.gps) r.gps_error_m = LocalEnu(*r.geo).Forward(*job.gps).head<2>().norm();
  if (r.fix.status == MapFixStatus::kFix) {
    r.seed = MapSeedRole::kCandidate;
    candidate_ = r;
  } else {
    whole_map_skips_ = after;  // one whole-map search per after + 1 due attempts
  }
  return r;
}

namespace {

// "1 search", "2 searches".
std::string Counted(int n, const char* one, const char* many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

// A whole-map search's coarse hit in one tile.
struct TileHit {
  MapFix coarse;
  GeoPoint at;  // its WGS84 position
};

// The hit with the most inliers among the tiles' fixes (nullopt: none), and in `second` the
// most inliers of a fit elsewhere: the best's own second place (MapMatcher::Search) and the
// other tiles' fits farther than `footprint_m` from it (the tiles overlap by a footprint: the
// same place found twice is no rival).
// The centres of the square tiles of at most 2 `o.search_wide_radius_m` a side that cover the
// maps' extent (WGS84 bounds of every map), or the square of 2 o.start_radius_m a side around
// the start position when given, nearest the area's centre first; `half` their half side, m.
std::vector<GeoPoint> WholeMapTiles(const map::ReferenceMaps& maps, const MapMatchOptions& o,
                                    double* half) {
  double lon0 = 1e9, lon1 = -1e9, lat0 = 1e9, lat1 = -1e9;
  for (const map::MapInfo& info : maps.infos()) {
    lon0 = std::min(lon0, info.extent_lonlat.min_x);
    lon1 = std::max(lon1, info.extent_lonlat.max_x);
    lat0 = std::min(lat0, info.extent_lonlat.min_y);
    lat1 = std::max(lat1, info.extent_lonlat.max_y);
  }
  const double radius_m = o.search_wide_radius_m;
  LocalEnu centre(GeoPoint{0.5 * (lat0 + lat1), 0.5 * (lon0 + lon1), 0.0});
  Eigen::Vector2d sw = centre.Forward(GeoPoint{lat0, lon0, 0.0}).head<2>();
  Eigen::Vector2d size = centre.Forward(GeoPoint{lat1, lon1, 0.0}).head<2>() - sw;
  if (o.start_radius_m > 0.0) {
    centre = LocalEnu(GeoPoint{o.start_lat_deg, o.start_lon_deg, 0.0});
    sw = Eigen::Vector2d::Constant(-o.start_radius_m);
    size = Eigen::Vector2d::Constant(2.0 * o.start_radius_m);
  }
  // A side at most 2 % over 2 radius_m is not another row or column of tiles (the extent's edges
  // in degrees bulge out of the map's own square; the windows reach a footprint beyond a tile).
  const int nx = std::max(1, static_cast<int>(std::ceil(size.x() / (2.0 * radius_m) - 0.02)));
  const int ny = std::max(1, static_cast<int>(std::ceil(size.y() / (2.0 * radius_m) - 0.02)));
  *half = 0.5 * std::max(size.x() / nx, size.y() / ny);
  std::vector<Eigen::Vector2d> enu;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      enu.push_back(sw + Eigen::Vector2d((i + 0.5) * size.x() / nx, (j + 0.5) * size.y() / ny));
    }
  }
  std::stable_sort(enu.begin(), enu.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.squaredNorm() < b.squaredNorm();
  });
  std::vector<GeoPoint> tiles;
  for (const Eigen::Vector2d& t : enu) tiles.push_back(centre.Reverse(t.x(), t.y(), 0.0));
  return tiles;
}

std::optional<std::size_t> BestHit(const std::vector<TileHit>& hits, double footprint_m,
                                   double* second) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (hits[i].coarse.status != MapFixStatus::kFix) continue;
    if (!best || hits[i].coarse.inliers > hits[*best].coarse.inliers) best = i;
  }
  if (!best) return best;
  const LocalEnu at(hits[*best].at);
  *second = hits[*best].coarse.second_inliers;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (i == *best || at.Forward(hits[i].at).head<2>().norm() <= footprint_m) continue;
    *second = std::max(*second, static_cast<double>(hits[i].coarse.inliers));
  }
  return best;
}

}  // namespace

MapFix MapFixer::SearchWholeMap(const MapFixJob& job, std::optional<GeoPoint>* at) {
  double half = 0.0;
  std::vector<GeoPoint> tiles = WholeMapTiles(maps_, options_, &half);
  whole_map_tiles_total_ = static_cast<int>(tiles.size());
  if (static_cast<int>(tiles.size()) > options_.whole_map_max_tiles) {
    tiles.resize(static_cast<std::size_t>(options_.whole_map_max_tiles));
  }
  whole_map_tiles_ = static_cast<int>(tiles.size());
  const int w = job.pixels.width(), h = job.pixels.height();
  const double gsd = job.height_m / job.focal_px;
  const double coarse_mpp = MapSearchResolution(options_, w, gsd, map_m_per_px_);
  const MapMatchFrame frame{job.pixels.view(), job.focal_px, job.height_m, std::nullopt};
  std::vector<TileHit> hits;
  MapFix none;
  none.status = MapFixStatus::kNoMap;
  for (const GeoPoint& c : tiles) {
    const std::optional<map::MapWindow> window =
        maps_.Window(c, MapWindowSizePx(w, h, gsd, half, coarse_mpp), coarse_mpp);
    if (!window) continue;
    const MapFix coarse = matcher_.Search(
        frame, MapMatchWindow{window->pixels.view(), window->valid.view(), coarse_mpp},
        Eigen::Vector2d::Zero(), 4.0 * half);
    if (!coarse.fitted) {
      if (none.status == MapFixStatus::kNoMap) none = coarse;  // the first tile's reason
      continue;
    }
    hits.push_back({coarse, LocalEnu(c).Reverse(coarse.enu_m.x(), coarse.enu_m.y(), 0.0)});
  }
  const double footprint_m = gsd * std::hypot(w, h);
  double second = 0.0;
  const std::optional<std::size_t> best = BestHit(hits, footprint_m, &second);
  if (!best) {
    if (hits.empty()) return none;
    // No tile's hit is a fix: the one with the most inliers says why.
    const auto most = std::max_element(
        hits.begin(), hits.end(),
        [](const TileHit& a, const TileHit& b) { return a.coarse.inliers < b.coarse.inliers; });
    *at = most->at;
    return most->coarse;
  }
  const TileHit& hit = hits[*best];
  *at = hit.at;
  MapFix verdict = hit.coarse;
  verdict.second_inliers = static_cast<int>(second);
  if (hit.coarse.inliers < options_.min_margin * second ||
      hit.coarse.inliers < second + options_.min_inliers) {
    verdict.status = MapFixStatus::kAmbiguous;  // another tile holds a place as good
    return verdict;
  }
  MapFix fix = Refine(job, hit.at, hit.coarse.heading_rad);
  fix.second_inliers = verdict.second_inliers;
  if (fix.fitted) *at = LocalEnu(hit.at).Reverse(fix.enu_m.x(), fix.enu_m.y(), 0.0);
  return fix;
}

MapFix MapFixer::Refine(const MapFixJob& job, const GeoPoint& hit, double heading_rad) {
  const int w = job.pixels.width(), h = job.pixels.height();
  const double gsd = job.height_m / job.focal_px;
  const double coarse_mpp = MapSearchResolution(options_, w, gsd, map_m_per_px_);
  MapMatcher fine(MapRefineOptions(options_, coarse_mpp));
  const double mpp = MapMatchResolution(options_, w, gsd, map_m_per_px_);
  const std::optional<map::MapWindow> window =
      maps_.Window(hit, MapWindowSizePx(w, h, gsd, fine.options().search_radius_m, mpp), mpp);
  if (!window) return MapFix{};  // kNoMap
  return fine.Match(MapMatchFrame{job.pixels.view(), job.focal_px, job.height_m, heading_rad},
                    MapMatchWindow{window->pixels.view(), window->valid.view(), mpp},
                    Eigen::Vector2d::Zero());
}

MapFix MapFixer::CoarseToFine(const MapFixJob& job, const LocalEnu& enu, double radius_m,
                              double gate_m) {
  const int w = job.pixels.width(), h = job.pixels.height();
  const double gsd = job.height_m / job.focal_px;
  const double coarse_mpp = MapSearchResolution(options_, w, gsd, map_m_per_px_);
  MapFix none;
  none.status = MapFixStatus::kNoMap;
  const std::optional<map::MapWindow> wide =
      maps_.Window(job.predicted, MapWindowSizePx(w, h, gsd, radius_m, coarse_mpp), coarse_mpp);
  if (!wide) return none;
  MapMatchFrame frame{job.pixels.view(), job.focal_px, job.height_m, job.heading_rad};
  const MapFix coarse =
      matcher_.Search(frame, MapMatchWindow{wide->pixels.view(), wide->valid.view(), coarse_mpp},
                      Eigen::Vector2d::Zero(), gate_m);
  if (coarse.status != MapFixStatus::kFix) return coarse;
  // The refinement around the coarse hit, with its heading, at the matching resolution.
  const GeoPoint hit = enu.Reverse(coarse.enu_m.x(), coarse.enu_m.y(), 0.0);
  MapMatcher fine(MapRefineOptions(options_, coarse_mpp));
  const double mpp = MapMatchResolution(options_, w, gsd, map_m_per_px_);
  const std::optional<map::MapWindow> window =
      maps_.Window(hit, MapWindowSizePx(w, h, gsd, fine.options().search_radius_m, mpp), mpp);
  if (!window) return none;
  frame.heading_rad = coarse.heading_rad;
  MapFix fix = fine.Match(frame, MapMatchWindow{window->pixels.view(), window->valid.view(), mpp},
                          Eigen::Vector2d::Zero());
  fix.second_inliers = coarse.second_inliers;
  if (!fix.fitted) return fix;
  // From the hit's ENU plane into the prediction's, and the gate against the prediction.
  const LocalEnu at_hit(hit);
  fix.enu_m = enu.Forward(at_hit.Reverse(fix.enu_m.x(), fix.enu_m.y(), 0.0)).head<2>();
  fix.prior_distance_m = fix.enu_m.norm();
  if (fix.status == MapFixStatus::kFix && fix.prior_distance_m > gate_m) {
    fix.status = MapFixStatus::kGate;
  }
  return fix;
}

MapFix MapFixer::Local(const MapFixJob& job, double radius_m) {
  const int w = job.pixels.width(), h = job.pixels.height();
  const double gsd = job.height_m / job.focal_px;
  double mpp = MapMatchResolution(options_, w, gsd, map_m_per_px_);
  if (tiles_ && options_.match_m_per_px == 0.0) {  // the frame's part on the ladder
    mpp = std::max(map_m_per_px_, MapLadderResolution(gsd * w / options_.match_width_px));
  }
  const int size = MapWindowSizePx(w, h, gsd, radius_m, mpp);
  const MapMatchFrame frame{job.pixels.view(), job.focal_px, job.height_m, job.heading_rad};
  MapFix none;
  none.status = MapFixStatus::kNoMap;
  if (tiles_) {
    // The tiles' density of points: the frame's points over its area at this resolution, at
    // most max_map_points over the window's (the window's target of MapMatcher::Match).
    const double frame_px = static_cast<double>(w) * h * (gsd / mpp) * (gsd / mpp);
    const double density =
        std::min(options_.frame_points / std::max(1.0, frame_px),
                 options_.max_map_points / (static_cast<double>(size) * size));
    const MapWindowFeatures window = tiles_->Window(
        job.predicted, size, mpp, job.heading_rad.has_value(), density, options_.max_map_points);
    if (window.valid_px == 0) return none;
    return matcher_.MatchFeatures(frame, window, Eigen::Vector2d::Zero());
  }
  const std::optional<map::MapWindow> window = maps_.Window(job.predicted, size, mpp);
  if (!window) return none;
  return matcher_.Match(frame, MapMatchWindow{window->pixels.view(), window->valid.view(), mpp},
                        Eigen::Vector2d::Zero());
}

void MapFixer::Follow(const MapFixRecord& record) {
  switch (record.fix.status) {
    case MapFixStatus::kFix:
      failures_ = 0;
      had_fix_ = true;
      flown_since_fix_m_ = 0.0;
      break;
    case MapFixStatus::kTooFewInliers:
    case MapFixStatus::kSpread:
    case MapFixStatus::kScale:
    case MapFixStatus::kGate:
    case MapFixStatus::kAmbiguous:
      ++failures_;
      break;
    case MapFixStatus::kNoMap:  // nothing to match against: neither lost nor found
    case MapFixStatus::kNoMapTexture:
    case MapFixStatus::kNoFrameTexture:
    case MapFixStatus::kMapTooCoarse:
      break;
  }
}

namespace {

std::string Cell(const std::optional<double>& v, const char* format) {
  return v ? fmt::format(fmt::runtime(format), *v) : std::string();
}

// map_fixes.csv: one row per attempt (docs/outputs.md).
std::string FixesCsv(const std::vector<MapFixRecord>& records) {
  std::string text =
      "frame,time_s,status,lat_deg,lon_deg,heading_deg,sigma_m,inliers,matches,residual_m,scale,"
      "track_distance_m,gps_error_m,track_gps_error_m,ms,applied,search,second_inliers,map,"
      "gated_by_graph,seed\n";
  for (const MapFixRecord& r : records) {
    const MapFix& f = r.fix;
    const bool fitted = f.fitted;
    const auto when = [&](double v) { return fitted ? std::optional<double>(v) : std::nullopt; };
    text += fmt::format(
        "{},{:.3f},{},{},{},{},{},{},{},{},{},{},{},{},{:.1f},{},{},{},{},{},{}\n", r.frame, r.time_s,
        ToString(f.status), r.geo ? fmt::format("{:.8f}", r.geo->lat_deg) : "",
        r.geo ? fmt::format("{:.8f}", r.geo->lon_deg) : "",
        Cell(when(f.heading_rad * 180.0 / 3.14159265358979323846), "{:.3f}"),
        Cell(when(std::sqrt(f.position_cov_m2.trace())), "{:.3f}"), f.inliers, f.matches,
        Cell(when(f.residual_m), "{:.3f}"), Cell(when(f.scale), "{:.4f}"),
        Cell(when(f.prior_distance_m), "{:.3f}"), Cell(r.gps_error_m, "{:.3f}"),
        Cell(r.track_gps_error_m, "{:.3f}"), f.ms, r.applied ? 1 : 0,
        r.whole_map ? "whole_map" : (r.search ? "wide" : "local"),
        r.search && f.fitted ? std::to_string(f.second_inliers) : std::string(),
        r.map ? std::to_string(*r.map) : std::string(), r.gated_by_graph ? 1 : 0,
        r.seed == MapSeedRole::kCandidate   ? "candidate"
        : r.seed == MapSeedRole::kConfirmed ? "confirmed"
                                            : "");
  }
  return text;
}

double Rmse(const std::vector<double>& v) {
  double sum = 0.0;
  for (const double e : v) sum += e * e;
  return std::sqrt(sum / static_cast<double>(v.size()));
}

// The warning for a map too coarse for the frames, empty when there is none: the attempts not
// made (MapFixStatus::kMapTooCoarse); or, when most of the attempts matched failed with the frame
// under twice min_frame_width_px pixels across at their resolution, that the map may be too
// coarse. Each names the maps and the resolution a map would need.
std::string MapResolutionWarning(const std::vector<MapFixRecord>& records,
                                 const std::vector<map::MapInfo>& infos,
                                 const MapMatchOptions& options) {
  const int wide_px = 2 * options.min_frame_width_px;
  int not_made = 0, matched = 0, narrow_failed = 0;
  double coarsest_m_per_px = 0.0, narrowest_m = std::numeric_limits<double>::infinity();
  std::vector<std::string> names;
  for (const MapFixRecord& r : records) {
    const MapFix& f = r.fix;
    if (!(f.m_per_px > 0.0)) continue;  // no map window: nothing was matched
    const bool too_coarse = f.status == MapFixStatus::kMapTooCoarse;
    const bool narrow_failed_here =
        !too_coarse && f.status != MapFixStatus::kFix && f.frame_width_m < wide_px * f.m_per_px;
    not_made += too_coarse ? 1 : 0;
    matched += too_coarse ? 0 : 1;
    narrow_failed += narrow_failed_here ? 1 : 0;
    if (!too_coarse && !narrow_failed_here) continue;
    coarsest_m_per_px = std::max(coarsest_m_per_px, f.m_per_px);
    narrowest_m = std::min(narrowest_m, f.frame_width_m);
    const std::size_t m = r.map ? static_cast<std::size_t>(*r.map) : 0;
    if (m < infos.size()) {
      const std::string name = infos[m].path.string();
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
  }
  if (not_made > 0) {
    return fmt::format(
        "'{}': {} of {} map fix attempts not made, the map too coarse for the frames: a frame "
        "{:.0f} m wide on the ground is {:.0f} pixels across at {:.2f} m per pixel, under "
        "map_fix.min_frame_width_px ({}); a map of at most {:.2f} m per pixel is needed",
        fmt::join(names, "', '"), not_made, records.size(), narrowest_m,
        narrowest_m / coarsest_m_per_px, coarsest_m_per_px, options.min_frame_width_px,
        narrowest_m / options.min_frame_width_px);
  }
  if (2 * narrow_failed > matched) {
    return fmt::format(
        "'{}': {} of {} map fix attempts failed with the frame under {} pixels across at the "
        "map's resolution (a frame {:.0f} m wide on the ground is {:.0f} pixels across at {:.2f} "
        "m per pixel): the map may be too coarse for the frames; at most {:.2f} m per pixel gives "
        "the matching {} pixels",
        fmt::join(names, "', '"), narrow_failed, records.size(), wide_px, narrowest_m,
        narrowest_m / coarsest_m_per_px, coarsest_m_per_px, narrowest_m / wide_px, wide_px);
  }
  return "";
}

}  // namespace

void MapFixer::Finish(const std::filesystem::path& out_dir, RunSummary* summary) {
  {
    std::unique_lock lock(mutex_);
    if (finished_) return;
    finished_ = true;
    done_.wait(lock, [this] { return !busy_ && !job_; });
    stop_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  WriteTextFileAtomic(out_dir / RunFileNames::kMapFixesCsv, FixesCsv(records_));
  RunSummary::MapFixes s;
  s.every_n_frames = options_.every_n_frames;
  s.attempted = static_cast<int>(records_.size());
  s.no_prediction = no_prediction_;
  s.skipped_busy = skipped_busy_;
  std::vector<int> counts(kNumMapFixStatus, 0);
  std::vector<double> errors, track_errors;
  double total_ms = 0.0;
  double search_ms = 0.0;
  for (const map::MapInfo& info : maps_.infos()) {
    s.by_map.push_back({info.path.string(), 0, 0, 0});
  }
  for (const MapFixRecord& r : records_) {
    ++counts[static_cast<std::size_t>(r.fix.status)];
    if (r.map) {
      RunSummary::MapFixes::ByMap& m = s.by_map[static_cast<std::size_t>(*r.map)];
      ++m.attempted;
      if (r.fix.status == MapFixStatus::kFix) ++m.fixes;
      if (r.applied) ++m.fused;
    }
    if (r.applied) ++s.applied;
    if (r.gated_by_graph) ++s.gated_by_graph;
    total_ms += r.fix.ms;
    if (r.search) {
      ++s.searches;
      search_ms += r.fix.ms;
      if (r.fix.status == MapFixStatus::kFix) ++s.found;
    }
    if (r.fix.status == MapFixStatus::kFix && !s.time_to_first_fix_s) {
      s.time_to_first_fix_s = r.time_s - records_.front().time_s;
    }
    if (r.fix.status == MapFixStatus::kFix && r.gps_error_m && r.track_gps_error_m) {
      errors.push_back(*r.gps_error_m);
      track_errors.push_back(*r.track_gps_error_m);
    }
  }
  for (int i = 0; i < kNumMapFixStatus; ++i) {
    s.by_status.emplace_back(ToString(static_cast<MapFixStatus>(i)),
                             counts[static_cast<std::size_t>(i)]);
  }
  s.fused = s.applied;
  s.fixes = counts[static_cast<std::size_t>(MapFixStatus::kFix)];
  s.mean_ms = s.attempted > 0 ? total_ms / s.attempted : 0.0;
  s.search_ms = s.searches > 0 ? search_ms / s.searches : 0.0;
  s.with_gps = static_cast<int>(errors.size());
  if (!errors.empty()) {
    s.median_m = Median(errors);
    s.rmse_m = Rmse(errors);
    s.max_m = *std::max_element(errors.begin(), errors.end());
    s.track_median_m = Median(track_errors);
    s.track_rmse_m = Rmse(track_errors);
    s.track_max_m = *std::max_element(track_errors.begin(), track_errors.end());
  }
  SummarizeSeed(&s);
  if (const std::string w = MapResolutionWarning(records_, maps_.infos(), options_); !w.empty()) {
    summary->warnings.push_back(w);
  }
  if (!s.georef_note.empty()) {
    summary->warnings.push_back("no geo-reference from the map: " + s.georef_note);
  }
  summary->map_fixes = s;
}

void MapFixer::SummarizeSeed(RunSummary::MapFixes* s) const {
  std::vector<int> counts(kNumMapFixStatus, 0);
  for (std::size_t i = 0; i < records_.size(); ++i) {
    const MapFixRecord& r = records_[i];
    if (r.seed == MapSeedRole::kCandidate) ++s->candidates;
    if (r.seed == MapSeedRole::kConfirmed && seed_record_ && *seed_record_ == i) {
      RunSummary::MapFixes::Seed seed;
      seed.frame = r.frame;
      seed.time_s = r.time_s;
      for (std::size_t k = i; k-- > 0;) {
        if (records_[k].seed != MapSeedRole::kCandidate) continue;
        seed.candidate_frame = records_[k].frame;
        seed.candidate_time_s = records_[k].time_s;
        break;
      }
      s->georef_seed = seed;
    }
  }
  s->whole_map_searches = whole_map_searches_;
  s->whole_map_tiles = whole_map_tiles_;
  s->whole_map_tiles_total = whole_map_tiles_total_;
  if (s->georef_seed) return;
  if (gave_up_) {
    s->georef_note = fmt::format(
        "no seed within map_fix.seed_wait_s ({} s): the frames were written in the local frame "
        "from frame {} ({:.3f} s) on and the run stayed local",
        options_.seed_wait_s, gave_up_->first, gave_up_->second);
    if (whole_map_searches_ == 0) return;
    s->georef_note += "; ";
  }
  if (whole_map_searches_ == 0) return;
  std::string statuses;
  int confirmed = 0;  // confirmations not taken (after GiveUpSeed)
  for (const MapFixRecord& r : records_) {
    if (r.whole_map && r.seed == MapSeedRole::kNone)
      ++counts[static_cast<std::size_t>(r.fix.status)];
    confirmed += r.seed == MapSeedRole::kConfirmed;
  }
  for (int i = 0; i < kNumMapFixStatus; ++i) {
    if (counts[static_cast<std::size_t>(i)] == 0) continue;
    statuses +=
        fmt::format("{}{} {}", statuses.empty() ? "" : ", ", ToString(static_cast<MapFixStatus>(i)),
                    counts[static_cast<std::size_t>(i)]);
  }
  s->georef_note +=
      s->candidates == 0
          ? fmt::format(
                "no whole-map search found the frame ({} over {} of the map's {} tiles: {})",
                Counted(whole_map_searches_, "search", "searches"), whole_map_tiles_,
                whole_map_tiles_total_, statuses)
          : fmt::format("{} found by {}, {}", Counted(s->candidates, "candidate", "candidates"),
                        Counted(whole_map_searches_, "whole-map search", "whole-map searches"),
                        confirmed == 0
                            ? std::string("none confirmed by the next attempt")
                            : fmt::format("{} confirmed after the wait (not taken)", confirmed));
  if (options_.start_radius_m > 0.0) {
    s->georef_note += fmt::format(
        "; searched within {} m of the start position given "
        "(map_fix.start_lat_deg, start_lon_deg)",
        options_.start_radius_m);
  }
  if (whole_map_tiles_ < whole_map_tiles_total_) {
    s->georef_note +=
        fmt::format("; the map has {} tiles, {} searched (map_fix.whole_map_max_tiles)",
                    whole_map_tiles_total_, whole_map_tiles_);
  }
}

}  // namespace aerovo::run_steps
