#include "aerovo/pipeline/run_steps.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <iostream>
#include <system_error>
#include <utility>

#include <fmt/format.h>
#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "aerovo/core/error.h"
#include "aerovo/io/camera.h"
#include "aerovo/io/telemetry_readers.h"
#include "aerovo/pipeline/pose_quality.h"
#include "aerovo/report/run_reader.h"  // AssociateWithTruth
#include "aerovo/sim/sim_writer.h"

namespace aerovo::run_steps {

std::optional<GeoPoint> GpsOf(const std::optional<TelemetrySample>& s) {
  if (!s) return std::nullopt;
  GeoPoint p;
  p.lat_deg = s->lat_deg;
  p.lon_deg = s->lon_deg;
  p.alt_m = s->abs_alt_m.value_or(s->rel_alt_m.value_or(0.0));
  return p;
}

// ---------------------------------------------------------------------------------------------
// 1. Inputs

namespace {

// The sim.json of `aerovo simulate` when `input` is its video or frames folder (sim.json sits in
// the folder above either). An unreadable or foreign sim.json is reported and ignored.
std::optional<sim::SimulationManifest> FindSimulationManifest(const std::string& input,
                                                              std::vector<std::string>* warnings) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path in = fs::path(input).lexically_normal();
  if (!in.has_filename()) in = in.parent_path();                  // "frames/" -> "frames"
  if (input.empty() || !fs::exists(in, ec)) return std::nullopt;  // live source
  const fs::path dir = in.has_parent_path() ? in.parent_path() : fs::path(".");
  const fs::path json = dir / "sim.json";
  if (!fs::is_regular_file(json, ec)) return std::nullopt;
  try {
    sim::SimulationManifest m = sim::ReadSimulationManifest(json);
    const bool same_video = !m.video.empty() && fs::equivalent(in, m.video, ec);
    const bool same_frames = !m.frames_dir.empty() && fs::equivalent(in, m.frames_dir, ec);
    if (same_video || same_frames) return m;
  } catch (const InputError& e) {
    warnings->push_back(std::string("ignored ") + json.string() + ": " + e.what());
  }
  return std::nullopt;
}

}  // namespace

RunInputs ResolveInputs(const RunConfig& given, std::vector<std::string>* warnings) {
  RunInputs in;
  in.config = given;
  RunConfig& config = in.config;
  if (const auto m = FindSimulationManifest(config.input, warnings)) {
    in.sim_manifest = (m->dir / "sim.json").string();
    if (config.telemetry.empty() && !m->srt.empty()) config.telemetry = m->srt.string();
    if (config.truth.empty() && !m->csv.empty()) config.truth = m->csv.string();
    if (config.focal_px == 0.0 && config.hfov_deg == 0.0) {
      config.focal_px = m->focal_px;  // exact, whatever the SRT's 35 mm equivalent says
      in.focal_from_sim = true;
    }
  }
  if (!config.truth.empty()) in.truth = ReadReferenceTrack(config.truth);
  return in;
}

RunTelemetry::RunTelemetry(Telemetry telemetry, bool by_frame_index, std::string origin)
    : telemetry_(std::move(telemetry)),
      by_frame_index_(by_frame_index),
      origin_(std::move(origin)) {}

RunTelemetry RunTelemetry::Load(const std::string& path, bool lenient,
                                const ImageFolderSource* folder,
                                std::vector<std::string>* warnings) {
  if (!path.empty()) {
    TelemetryReadOptions to;
    to.lenient = lenient;
    TelemetryReadResult t;
    try {
      t = ReadTelemetryFile(path, to);
    } catch (const MalformedRecordError& e) {
      // Only a malformed record (not a missing file, a bad header or a foreign format): say how
      // to go on.
      throw InputError(std::string(e.what()) +
                       " (--lenient-telemetry skips malformed records instead)");
    }
    if (t.skipped_records > 0) {
      warnings->push_back(fmt::format(
          "{}: {} malformed telemetry record(s) skipped (--lenient-telemetry), the first ones:",
          path, t.skipped_records));
    }
    for (auto& w : t.warnings) warnings->push_back(std::move(w));
    const bool by_frame_index = t.telemetry.HasFrameIndices();
    return RunTelemetry(std::move(t.telemetry), by_frame_index, path);
  }
  if (folder != nullptr) {
    try {
      TelemetryReadResult t = TelemetryFromImages(folder->metadata());
      for (auto& w : t.warnings) warnings->push_back(std::move(w));
      return RunTelemetry(std::move(t.telemetry), true, "photo EXIF/XMP");
    } catch (const InputError& e) {
      warnings->push_back(std::string("no telemetry from the photos: ") + e.what());
    }
  }
  return RunTelemetry();
}

std::optional<TelemetrySample> RunTelemetry::SampleOf(const Frame& f) const {
  if (telemetry_.empty()) return std::nullopt;
  return by_frame_index_ ? telemetry_.AtFrame(f.index) : telemetry_.Lookup(f.time_s, 0.5);
}

std::string RunTelemetry::Describe() const {
  return telemetry_.empty() ? std::string("none")
                            : std::to_string(telemetry_.size()) + " fixes from " + origin_;
}

// ---------------------------------------------------------------------------------------------
// 2. Camera

RunCamera ResolveRunCamera(const RunConfig& config, bool focal_from_sim, int w, int h,
                           const ImageMetadata* photo, const std::optional<TelemetrySample>& sample,
                           const std::string& frame_name) {
  CameraOptions camera;
  if (config.focal_px > 0.0) camera.focal_px = config.focal_px;
  if (config.hfov_deg > 0.0) camera.hfov_deg = config.hfov_deg;
  ResolvedCamera resolved;
  try {
    resolved = ResolveCamera(camera, w, h, photo,
                             sample ? sample->focal_length_35mm_mm : std::nullopt);
  } catch (const InputError&) {
    throw InputError(frame_name +
                     ": the camera focal length is unknown (no EXIF/telemetry "
                     "35 mm focal length): give --focal-px or --hfov-deg");
  }
  RunCamera c;
  c.focal_px = resolved.intrinsics.fx_px;
  c.focal_source = focal_from_sim && resolved.source_key == "flag" ? "sim.json" : resolved.source_key;
  return c;
}

std::unique_ptr<FrameUndistorter> MakeUndistorter(const RunConfig& config, int w, int h,
                                                  double focal_px) {
  if (config.k1 == 0.0 && config.k2 == 0.0 && config.p1 == 0.0 && config.p2 == 0.0 &&
      config.k3 == 0.0) {
    return nullptr;
  }
  return std::make_unique<FrameUndistorter>(w, h, focal_px, config.k1, config.k2, config.p1,
                                            config.p2, config.k3);
}

// ---------------------------------------------------------------------------------------------
// 3. Height above ground

double HeightProvider::HeightOf(const std::string& frame_name,
                                const std::optional<TelemetrySample>& sample,
                                std::vector<std::string>* warnings) {
  if (flag_m_ > 0.0) return flag_m_;
  if (sample && sample->rel_alt_m && *sample->rel_alt_m > 0.0) {
    last_m_ = *sample->rel_alt_m;
    return *last_m_;
  }
  if (last_m_) {
    if (!warned_) {
      warnings->push_back(frame_name + ": no relative altitude, using the last known (" +
                          fmt::format("{:.1f}", *last_m_) + " m)");
      warned_ = true;
    }
    return *last_m_;
  }
  throw InputError(frame_name +
                   ": no height above ground (the telemetry has no relative "
                   "altitude): give --altitude");
}

// ---------------------------------------------------------------------------------------------
// 4. Outputs

PendingFrame PendingFrameOf(const Frame& frame, const FrameResult& r,
                            const std::optional<GeoPoint>& gps, double height_m) {
  PendingFrame p;
  p.local_m = r.position_m;
  p.heading_rad = r.heading_rad;
  p.gps = gps;
  p.height_m = height_m;
  p.quality = PoseQuality(r);
  FrameRecord& rec = p.record;
  rec.frame = frame.index;
  rec.time_s = frame.time_s;
  rec.n_surf = r.n_surf;
  rec.n_matched = r.n_matched;
  rec.n_inliers = r.n_inliers;
  rec.cluster = r.cluster;
  rec.detect_ms = r.detect_ms;
  rec.describe_ms = r.describe_ms;
  rec.correspond_ms = r.correspond_ms;
  rec.estimate_ms = r.estimate_ms;
  rec.total_ms = r.total_ms;
  rec.status = ToString(r.status);
  if (r.failure != StepFailure::kNone) rec.status += std::string(":") + ToString(r.failure);
  return p;
}

namespace {

double Degrees(double rad) { return rad * 180.0 / M_PI; }

// The geographic fields of a pose-stream line.
void AddGeoFields(const PendingFrame& p, const GeoReferencer& georef, nlohmann::ordered_json& j) {
  const GeoPoint g = georef.Wgs84FromLocal(p.local_m);
  const Eigen::Vector2d enu = georef.EnuFromLocal(p.local_m);
  j["lat_deg"] = g.lat_deg;
  j["lon_deg"] = g.lon_deg;
  j["east_m"] = enu.x();
  j["north_m"] = enu.y();
  j["yaw_enu_deg"] = Degrees(std::remainder(p.heading_rad + georef.rotation_rad(), 2.0 * M_PI));
}

// A finite number, or null (JSON has no NaN).
nlohmann::ordered_json NumberOrNull(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json();
}

}  // namespace

std::string PoseJsonLine(const PendingFrame& p, const GeoReferencer& georef) {
  const FrameRecord& r = p.record;
  nlohmann::ordered_json j{{"type", "pose"},
                           {"index", r.frame},
                           {"time_s", r.time_s},
                           {"x_m", p.local_m.x()},
                           {"y_m", p.local_m.y()},
                           {"z_m", p.height_m},
                           {"heading_deg", Degrees(p.heading_rad)},
                           {"status", r.status},
                           {"quality", p.quality},
                           {"latency_ms", NumberOrNull(r.latency_ms)}};
  if (georef.ready()) AddGeoFields(p, georef, j);
  return j.dump() + "\n";
}

std::string GeoJsonLine(const PendingFrame& p, const GeoReferencer& georef) {
  nlohmann::ordered_json j{{"type", "geo"}, {"index", p.record.frame}, {"time_s", p.record.time_s}};
  AddGeoFields(p, georef, j);
  return j.dump() + "\n";
}

RunOutputs::RunOutputs(const std::filesystem::path& out_dir, const RunConfig& config,
                       const RunCamera& camera, const std::string& height_source, int w, int h,
                       double first_time_s, const std::optional<TelemetrySample>& first_sample,
                       const RunCallbacks& callbacks, bool wait_for_heading)
    : callbacks_(callbacks), wait_for_heading_(wait_for_heading) {
  TrackWriterOptions wo;
  wo.enu_origin = GpsOf(first_sample);
  if (first_sample && first_sample->unix_time_s)
    wo.time_origin_unix_s = *first_sample->unix_time_s - first_time_s;
  wo.run_name = "aerovo";
  writers_ = std::make_unique<TrackWriterSet>(out_dir, wo);
  nlohmann::json effective = ToJson(config);
  effective["resolved"] = {{"focal_px", camera.focal_px},
                           {"focal_source", camera.focal_source},
                           {"height_source", height_source},
                           {"frame_width_px", w},
                           {"frame_height_px", h}};
  WriteJsonFileAtomic(out_dir / RunFileNames::kConfigJson, effective);
  transforms_csv_.emplace(out_dir / RunFileNames::kTransformsCsv);
  jsonl_name_ = config.poses_jsonl == "-" ? "stdout" : config.poses_jsonl;
  if (config.poses_jsonl == "-") {
    jsonl_ = &std::cout;
  } else if (!config.poses_jsonl.empty()) {
    auto file = std::make_unique<std::ofstream>(config.poses_jsonl, std::ios::trunc);
    if (!*file) {
      throw InputError("cannot write the pose stream '" + config.poses_jsonl +
                       "': " + std::strerror(errno));
    }
    jsonl_file_ = std::move(file);
    jsonl_ = jsonl_file_.get();
  }
}

void RunOutputs::AppendTransform(int frame_index, const Eigen::Matrix3d& world_from_frame) {
  if (!have_first_) {
    first_px_from_world_ = world_from_frame.inverse();
    have_first_ = true;
  }
  const Eigen::Matrix3d first_px_from_frame = first_px_from_world_ * world_from_frame;
  transforms_csv_->Append(frame_index, first_px_from_frame);
}

// Writes a frame: geo-referenced when possible, else in the local VO frame.
void RunOutputs::Emit(PendingFrame& p, const GeoReferencer& georef) {
  if (georef.ready()) {
    const Eigen::Vector2d enu = georef.EnuFromLocal(p.local_m);
    p.record.x_m = enu.x();
    p.record.y_m = enu.y();
    p.record.geo = georef.Wgs84FromLocal(p.local_m);
    p.record.yaw_rad = std::remainder(p.heading_rad + georef.rotation_rad(), 2.0 * M_PI);
  } else {
    p.record.x_m = p.local_m.x();
    p.record.y_m = p.local_m.y();
    p.record.yaw_rad = p.heading_rad;
  }
  if (jsonl_ != nullptr && !p.sent_geo && georef.ready()) {
    *jsonl_ << GeoJsonLine(p, georef) << std::flush;
    p.sent_geo = true;
  }
  writers_->Append(p.record, p.gps);
  if (callbacks_.frame) callbacks_.frame(p.record);
  if (callbacks_.poses != nullptr) {
    const FrameRecord& q = p.record;
    *callbacks_.poses << fmt::format("{} {:.6f} {:.4f} {:.4f} {} {} {}\n", q.frame, q.time_s, q.x_m,
                                     q.y_m, q.geo ? fmt::format("{:.9f}", q.geo->lat_deg) : "-",
                                     q.geo ? fmt::format("{:.9f}", q.geo->lon_deg) : "-", q.status)
                      << std::flush;
  }
}

void RunOutputs::Flush(const GeoReferencer& georef, bool final) {
  // With GPS in the telemetry, wait for the heading (bounded: GeoRefOptions::min_segment_m).
  if (!final && !georef.ready() && wait_for_heading_) return;
  while (!pending_.empty()) {
    Emit(pending_.front(), georef);
    pending_.pop_front();
  }
}

void RunOutputs::Add(PendingFrame frame, const GeoReferencer& georef) {
  if (jsonl_ != nullptr) {
    // Frames held back for the heading are still sent at once, in the local frame.
    *jsonl_ << PoseJsonLine(frame, georef) << std::flush;
    frame.sent_geo = georef.ready();
    if (!*jsonl_) {
      throw InputError("cannot write the pose stream '" + jsonl_name_ +
                       "' (disk full, or the reader of the pipe went away)");
    }
  }
  pending_.push_back(std::move(frame));
  Flush(georef, false);
}

void RunOutputs::Finish(GeoReferencer& georef) {
  if (!georef.ready() && georef.has_enu()) georef.FixWithAvailable();
  Flush(georef, true);
  writers_->Close();
  if (jsonl_ != nullptr) jsonl_->flush();
}

// ---------------------------------------------------------------------------------------------
// 5. The per-frame loop

void RunTotals::Add(int frame_index, double time_s, const FrameResult& r,
                    const std::optional<GeoPoint>& gps, const GeoReferencer& georef) {
  if (r.status == FrameStatus::kOk || r.status == FrameStatus::kReacquired) ++measured_steps;
  if (keep_track) {
    local_track.push_back({time_s, r.position_m.x(), r.position_m.y()});
    track_frames.push_back(frame_index);
  }
  if (gps && georef.has_enu()) {
    const Eigen::Vector3d e = georef.enu().Forward(*gps);
    gps_track.push_back({time_s, e.x(), e.y()});
    local_at_gps.push_back({time_s, r.position_m.x(), r.position_m.y()});
    ++frames_with_gps;
  }
  if (frames > 0) path_length_m += (r.position_m - last_local_m).norm();
  last_local_m = r.position_m;
  sum_ms.detect_ms += r.detect_ms;
  sum_ms.describe_ms += r.describe_ms;
  sum_ms.correspond_ms += r.correspond_ms;
  sum_ms.estimate_ms += r.estimate_ms;
  sum_ms.total_ms += r.total_ms;
  ++frames;
}

namespace {

GeoRefOptions GeoRefOptionsOf(const RunConfig& config) {
  GeoRefOptions o;
  o.heading_source = config.heading;
  return o;
}

}  // namespace

FrameLoop::FrameLoop(const RunInputs& inputs, const RunTelemetry& telemetry,
                     const ImageFolderSource* folder, OdometryOptions vo_options,
                     const std::filesystem::path& out_dir, const RunCallbacks& callbacks,
                     std::ostream* log)
    : config_(inputs.config),
      focal_from_sim_(inputs.focal_from_sim),
      telemetry_(telemetry),
      folder_(folder),
      vo_options_(std::move(vo_options)),
      out_dir_(out_dir),
      callbacks_(callbacks),
      log_(log),
      height_(inputs.config.altitude_m),
      georef_(GeoRefOptionsOf(inputs.config)),
      totals_(inputs.truth.has_value()) {}

// First frame: the camera and the outputs can now be set up.
void FrameLoop::Start(const Frame& frame, const std::optional<TelemetrySample>& sample,
                      RunSummary* summary) {
  const int w = frame.gray.width(), h = frame.gray.height();
  const ImageMetadata* photo =
      folder_ != nullptr && !folder_->metadata().empty() ? &folder_->metadata().front() : nullptr;
  const RunCamera camera =
      ResolveRunCamera(config_, focal_from_sim_, w, h, photo, sample, frame.name);
  summary->focal_px = camera.focal_px;
  summary->focal_source = camera.focal_source;
  vo_options_.focal_px = camera.focal_px;
  vo_options_.default_height_m = config_.altitude_m;
  summary->height_source = height_.source();
  vo_ = std::make_unique<VisualOdometry>(vo_options_);
  undistorter_ = MakeUndistorter(config_, w, h, camera.focal_px);
  outputs_.emplace(out_dir_, config_, camera, summary->height_source, w, h, frame.time_s, sample,
                   callbacks_, !telemetry_.empty());
  if (log_) {
    *log_ << fmt::format("camera: {}x{} px, focal {:.1f} px ({}), height from {}\n", w, h,
                         camera.focal_px, camera.focal_source, summary->height_source);
  }
}

LoopEnd FrameLoop::Run(FrameSource& source, const std::atomic<bool>* stop, const Stopwatch& wall,
                       RunSummary* summary) {
  LoopEnd end;
  Frame& frame = frame_;
  while (true) {
    if (stop != nullptr && stop->load()) {
      end.stopped = true;
      break;
    }
    if (config_.max_frames > 0 && summary->frames_processed >= config_.max_frames) break;
    bool more = false;
    frame.received_s = std::numeric_limits<double>::quiet_NaN();
    try {
      more = source.Next(frame);
    } catch (const InputError& e) {
      if (summary->frames_processed == 0) throw;
      end.failure = e.what();
      break;
    }
    if (!more) break;
    // A PrefetchSource stamps the frame when decoded; else it is received now.
    if (!std::isfinite(frame.received_s)) frame.received_s = SteadySeconds();
    const std::optional<TelemetrySample> sample = telemetry_.SampleOf(frame);
    const std::optional<GeoPoint> gps = GpsOf(sample);
    if (!sample) ++end.frames_without_fix;
    if (!vo_) Start(frame, sample, summary);

    const double height_m = height_.HeightOf(frame.name, sample, &summary->warnings);
    const std::optional<double> yaw = sample ? sample->CameraYawDeg() : std::nullopt;
    GrayImageView view = undistorter_ ? undistorter_->Apply(frame.gray.view()) : frame.gray.view();
    if (config_.illumination_k != 1.0) {
      view = ScaleBrightness(view, config_.illumination_k, &dimmed_);
    }
    FrameResult r;
    try {
      r = vo_->Process(view, frame.time_s, height_m, yaw);
    } catch (const InputError& e) {
      if (summary->frames_processed == 0) throw;
      end.failure = frame.name + ": " + e.what();
      break;
    }
    georef_.Observe(r.position_m, gps, yaw);
    outputs_->AppendTransform(frame.index, r.world_from_frame);
    PendingFrame pending = PendingFrameOf(frame, r, gps, height_m);
    pending.record.latency_ms = (SteadySeconds() - frame.received_s) * 1000.0;
    const float latency_ms = static_cast<float>(pending.record.latency_ms);
    outputs_->Add(std::move(pending), georef_);
    totals_.Add(frame.index, frame.time_s, r, gps, georef_);
    totals_.latency_ms.push_back(latency_ms);
    ++summary->frames_processed;
    if (callbacks_.progress) {
      callbacks_.progress(summary->frames_processed, summary->frames_expected,
                          summary->frames_processed / std::max(1e-9, wall.elapsed_ms() / 1000.0));
    }
  }
  return end;
}

void FrameLoop::Finish() {
  if (outputs_) outputs_->Finish(georef_);
}

// ---------------------------------------------------------------------------------------------
// 6. Summary

namespace {

// Compares the processed frames' track (ENU when geo-referenced, else local) with the ground
// truth, paired by AssociateWithTruth in the run's ENU frame (origin: first GPS fix; without GPS
// an ENU frame at the truth's first point, and then only the aligned figures mean anything).
void CompareWithTruth(const ReferenceTrack& truth, const std::vector<TrajectoryPoint2D>& track,
                      const std::vector<int>& track_frames, const GeoReferencer& georef,
                      RunSummary* summary) {
  std::vector<TrajectoryPoint2D> estimate = track;
  if (georef.ready()) {
    for (TrajectoryPoint2D& q : estimate) {
      const Eigen::Vector2d e = georef.EnuFromLocal({q.x, q.y});
      q.x = e.x();
      q.y = e.y();
    }
  } else {
    summary->warnings.push_back(
        "the track is not geo-referenced: compare it with the truth after alignment only");
  }
  try {
    const AssociatedTrajectories pairs =
        AssociateWithTruth(estimate, track_frames, truth,
                           georef.has_enu() ? std::optional<LocalEnu>(georef.enu()) : std::nullopt);
    summary->frames_with_truth = static_cast<int>(pairs.estimate.size());
    if (pairs.estimate.size() < 3) {
      summary->warnings.push_back(
          fmt::format("no comparison with the truth: only {} frames fall inside its time span",
                      pairs.estimate.size()));
      return;
    }
    summary->truth_evaluation = CompareTrajectories(pairs.estimate, pairs.reference);
  } catch (const InvalidArgument& e) {
    summary->warnings.push_back(std::string("no comparison with the truth: ") + e.what());
  }
}

// The SE(2) / Sim(2) comparison with GPS (ENU when geo-referenced) of at least 3 fixes.
void CompareWithGps(const GeoReferencer& georef, RunTotals& totals, RunSummary* summary) {
  if (totals.gps_track.size() < 3) return;
  if (georef.ready()) {
    for (TrajectoryPoint2D& q : totals.local_at_gps) {
      const Eigen::Vector2d e = georef.EnuFromLocal({q.x, q.y});
      q.x = e.x();
      q.y = e.y();
    }
  }
  try {
    summary->evaluation = CompareTrajectories(totals.local_at_gps, totals.gps_track);
  } catch (const InvalidArgument& e) {
    summary->warnings.push_back(std::string("no comparison with GPS: ") + e.what());
  }
}

}  // namespace

void Summarize(const std::vector<std::string>& source_warnings, bool has_telemetry,
               const LoopEnd& end, const OdometryStats* vo_stats, const GeoReferencer& georef,
               RunTotals totals, const ReferenceTrack* truth, double wall_s, RunSummary* summary) {
  RunSummary& s = *summary;
  for (const std::string& w : source_warnings) s.warnings.push_back(w);
  if (has_telemetry && end.frames_without_fix > 0) {
    s.warnings.push_back(fmt::format(
        "{} of {} frames have no telemetry fix (the telemetry does not cover them); their gps_* "
        "cells are empty and they are not in the comparison with GPS",
        end.frames_without_fix, s.frames_processed));
  }
  s.interrupted = end.stopped;
  if (vo_stats != nullptr) {
    s.frames_ok = vo_stats->ok;
    s.frames_reacquired = vo_stats->reacquired;
    s.frames_bridged = vo_stats->bridged;
    if (vo_stats->frames > 1 && totals.measured_steps == 0) {
      // Only the first frame "succeeded": nothing was measured, the track is a placeholder.
      s.warnings.push_back(
          "no frame could be matched to another (dark, blank or textureless frames?): the "
          "trajectory was not measured, every position is bridged");
    }
  }
  s.frames_with_gps = totals.frames_with_gps;
  s.vo_path_length_m = totals.path_length_m;
  s.heading_source = georef.heading_source_used();
  const double n = std::max(1, s.frames_processed);
  const StageTimes& sum = totals.sum_ms;
  s.mean = {sum.detect_ms / n, sum.describe_ms / n, sum.correspond_ms / n, sum.estimate_ms / n,
            sum.total_ms / n};
  s.wall_s = wall_s;
  s.fps = s.frames_processed / std::max(1e-9, s.wall_s);
  if (!totals.latency_ms.empty()) {
    std::vector<float>& l = totals.latency_ms;
    const auto at = [&l](double q) {  // nearest-rank percentile
      const std::size_t k = static_cast<std::size_t>(
          std::clamp<double>(std::ceil(q * l.size()) - 1.0, 0.0, l.size() - 1.0));
      std::nth_element(l.begin(), l.begin() + k, l.end());
      return static_cast<double>(l[k]);
    };
    s.latency.frames = static_cast<int>(l.size());
    s.latency.median_ms = at(0.5);
    s.latency.p95_ms = at(0.95);
    s.latency.max_ms = *std::max_element(l.begin(), l.end());
  }
  if (s.frames_dropped > 0) {
    s.warnings.push_back(fmt::format(
        "{} frames of the live source were dropped: they came faster than they were processed "
        "(the newest frame is always taken; frames_dropped in summary.json)",
        s.frames_dropped));
  }
  CompareWithGps(georef, totals, summary);
  if (truth != nullptr && !totals.local_track.empty()) {
    CompareWithTruth(*truth, totals.local_track, totals.track_frames, georef, summary);
  }
  s.error = end.failure;
}

void WriteSummary(const std::filesystem::path& out_dir, const RunSummary& summary) {
  WriteJsonFileAtomic(out_dir / RunFileNames::kSummaryJson, ToJson(summary));
  if (!summary.error.empty()) {
    throw InputError(fmt::format(
        "{} (the run stopped there: the {} frames processed before are in '{}', each file "
        "valid, summary.json included)",
        summary.error, summary.frames_processed, out_dir.string()));
  }
}

}  // namespace aerovo::run_steps
