#include "aerovo/pipeline/map_fixer.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

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
    map_m_per_px_ = map_m_per_px_ > 0.0 ? std::min(map_m_per_px_, mpp) : mpp;
  }
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
    MapFixRecord record;
    try {
      record = Attempt(job);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error) {
      error_ = error;
    } else {
      records_.push_back(std::move(record));
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

void MapFixer::SetGraphVerdict(bool fused, bool gated) {
  const std::lock_guard lock(mutex_);
  if (taken_ == 0) return;
  MapFixRecord& r = records_[taken_ - 1];
  r.applied = fused;
  r.gated_by_graph = !fused && gated;
}

MapFixRecord MapFixer::Attempt(MapFixJob& job) {
  const Stopwatch watch;
  MapFixRecord r;
  r.frame = job.frame;
  r.time_s = job.time_s;
  r.predicted = job.predicted;
  const LocalEnu enu(job.predicted);
  if (last_predicted_) flown_since_fix_m_ += enu.Forward(*last_predicted_).head<2>().norm();
  last_predicted_ = job.predicted;
  // A wide search at the run's first attempt and after search_after_failures failures in a row.
  const int after = options_.search_after_failures;
  const bool wide =
      after > 0 && (failures_ >= after || (options_.search_at_start && records_seen_ == 0));
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
  r.fix.ms = watch.elapsed_ms();
  Follow(r);
  if (wide) failures_ = 0;  // the next wide search after as many failures again
  return r;
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
      "track_distance_m,gps_error_m,track_gps_error_m,ms,applied,search,second_inliers\n";
  for (const MapFixRecord& r : records) {
    const MapFix& f = r.fix;
    const bool fitted = f.fitted;
    const auto when = [&](double v) { return fitted ? std::optional<double>(v) : std::nullopt; };
    text += fmt::format(
        "{},{:.3f},{},{},{},{},{},{},{},{},{},{},{},{},{:.1f},{},{},{}\n", r.frame, r.time_s,
        ToString(f.status), r.geo ? fmt::format("{:.8f}", r.geo->lat_deg) : "",
        r.geo ? fmt::format("{:.8f}", r.geo->lon_deg) : "",
        Cell(when(f.heading_rad * 180.0 / 3.14159265358979323846), "{:.3f}"),
        Cell(when(std::sqrt(f.position_cov_m2.trace())), "{:.3f}"), f.inliers, f.matches,
        Cell(when(f.residual_m), "{:.3f}"), Cell(when(f.scale), "{:.4f}"),
        Cell(when(f.prior_distance_m), "{:.3f}"), Cell(r.gps_error_m, "{:.3f}"),
        Cell(r.track_gps_error_m, "{:.3f}"), f.ms, r.applied ? 1 : 0, r.search ? "wide" : "local",
        r.search && f.fitted ? std::to_string(f.second_inliers) : std::string());
  }
  return text;
}

double Rmse(const std::vector<double>& v) {
  double sum = 0.0;
  for (const double e : v) sum += e * e;
  return std::sqrt(sum / static_cast<double>(v.size()));
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
  for (const MapFixRecord& r : records_) {
    ++counts[static_cast<std::size_t>(r.fix.status)];
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
  summary->map_fixes = s;
}

}  // namespace aerovo::run_steps
