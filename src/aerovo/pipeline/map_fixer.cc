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
  const double gsd = job.height_m / job.focal_px;
  const double mpp = MapMatchResolution(options_, job.pixels.width(), gsd, map_m_per_px_);
  const int size =
      MapWindowSizePx(job.pixels.width(), job.pixels.height(), gsd, options_.search_radius_m, mpp);
  const LocalEnu enu(job.predicted);
  if (job.gps) r.track_gps_error_m = enu.Forward(*job.gps).head<2>().norm();
  const std::optional<map::MapWindow> window = maps_.Window(job.predicted, size, mpp);
  if (!window) {
    r.fix.status = MapFixStatus::kNoMap;
  } else {
    r.fix = matcher_.Match(
        MapMatchFrame{job.pixels.view(), job.focal_px, job.height_m, job.heading_rad},
        MapMatchWindow{window->pixels.view(), window->valid.view(), mpp}, Eigen::Vector2d::Zero());
  }
  if (r.fix.fitted) {
    r.geo = enu.Reverse(r.fix.enu_m.x(), r.fix.enu_m.y(), 0.0);
    if (job.gps) r.gps_error_m = (enu.Forward(*job.gps).head<2>() - r.fix.enu_m).norm();
  }
  r.fix.ms = watch.elapsed_ms();
  return r;
}

namespace {

std::string Cell(const std::optional<double>& v, const char* format) {
  return v ? fmt::format(fmt::runtime(format), *v) : std::string();
}

// map_fixes.csv: one row per attempt (docs/outputs.md).
std::string FixesCsv(const std::vector<MapFixRecord>& records) {
  std::string text =
      "frame,time_s,status,lat_deg,lon_deg,heading_deg,sigma_m,inliers,matches,residual_m,scale,"
      "track_distance_m,gps_error_m,track_gps_error_m,ms,applied\n";
  for (const MapFixRecord& r : records) {
    const MapFix& f = r.fix;
    const bool fitted = f.fitted;
    const auto when = [&](double v) { return fitted ? std::optional<double>(v) : std::nullopt; };
    text +=
        fmt::format("{},{:.3f},{},{},{},{},{},{},{},{},{},{},{},{},{:.1f},{}\n", r.frame, r.time_s,
                    ToString(f.status), r.geo ? fmt::format("{:.8f}", r.geo->lat_deg) : "",
                    r.geo ? fmt::format("{:.8f}", r.geo->lon_deg) : "",
                    Cell(when(f.heading_rad * 180.0 / 3.14159265358979323846), "{:.3f}"),
                    Cell(when(std::sqrt(f.position_cov_m2.trace())), "{:.3f}"), f.inliers,
                    f.matches, Cell(when(f.residual_m), "{:.3f}"), Cell(when(f.scale), "{:.4f}"),
                    Cell(when(f.prior_distance_m), "{:.3f}"), Cell(r.gps_error_m, "{:.3f}"),
                    Cell(r.track_gps_error_m, "{:.3f}"), f.ms, r.applied ? 1 : 0);
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
  for (const MapFixRecord& r : records_) {
    ++counts[static_cast<std::size_t>(r.fix.status)];
    if (r.applied) ++s.applied;
    if (r.gated_by_graph) ++s.gated_by_graph;
    total_ms += r.fix.ms;
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
