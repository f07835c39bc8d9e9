#include "aerovo/pipeline/runner.h"

#include "aerovo/io/camera.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <Eigen/LU>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/eval/trajectory_eval_json.h"
#include "aerovo/io/frame_source.h"
#include "aerovo/io/image_metadata.h"
#include "aerovo/io/reference_track.h"
#include "aerovo/io/telemetry.h"
#include "aerovo/io/telemetry_readers.h"
#include "aerovo/io/track_writers.h"
#include "aerovo/matching/matcher.h"
#include "aerovo/report/run_reader.h"
#include "aerovo/sim/sim_writer.h"

namespace aerovo {

// ---------------------------------------------------------------------------------------------
// Summary

nlohmann::json ToJson(const RunSummary& s) {
  nlohmann::json j{{"input", s.input},
                   {"source", s.source_description},
                   {"out_dir", s.out_dir.string()},
                   {"frames_processed", s.frames_processed},
                   {"frames_expected", s.frames_expected},
                   {"frames_ok", s.frames_ok},
                   {"frames_reacquired", s.frames_reacquired},
                   {"frames_bridged", s.frames_bridged},
                   {"frames_with_gps", s.frames_with_gps},
                   {"interrupted", s.interrupted},
                   {"wall_s", s.wall_s},
                   {"fps", s.fps},
                   {"mean_stage_ms",
                    {{"detect", s.mean.detect_ms},
                     {"describe", s.mean.describe_ms},
                     {"correspond", s.mean.correspond_ms},
                     {"estimate", s.mean.estimate_ms},
                     {"total", s.mean.total_ms}}},
                   {"focal_px", s.focal_px},
                   {"focal_source", s.focal_source},
                   {"height_source", s.height_source},
                   {"heading_source", s.heading_source},
                   {"sim_manifest", s.sim_manifest},
                   {"vo_path_length_m", s.vo_path_length_m},
                   {"truth", s.truth},
                   {"frames_with_truth", s.frames_with_truth},
                   {"warnings", s.warnings},
                   {"error", s.error}};
  j["evaluation"] = s.evaluation ? ToJson(*s.evaluation) : nlohmann::json();
  j["truth_evaluation"] = s.truth_evaluation ? ToJson(*s.truth_evaluation) : nlohmann::json();
  return j;
}

std::string FormatSummaryTable(const RunSummary& s) {
  std::string t;
  t += fmt::format("{:<28}{}\n", "Input", s.input);
  t += fmt::format("{:<28}{}{}\n", "Frames processed", s.frames_processed,
                   s.interrupted ? "  (interrupted)" : "");
  t += fmt::format("{:<28}ok {}, re-acquired {}, flagged (bridged) {}\n", "  of which", s.frames_ok,
                   s.frames_reacquired, s.frames_bridged);
  t += fmt::format("{:<28}{}\n", "Frames with GPS", s.frames_with_gps);
  t += fmt::format("{:<28}{:.1f} m\n", "VO path length", s.vo_path_length_m);
  t += fmt::format("{:<28}{:.1f} px ({})\n", "Focal length", s.focal_px, s.focal_source);
  t += fmt::format("{:<28}{}\n", "Heading source",
                   s.heading_source.empty() ? "-" : s.heading_source);
  if (s.evaluation) {
    t += "\nComparison with GPS (ENU, after alignment):\n";
    t += FormatTrajectoryTable(*s.evaluation);
  } else {
    t += "\nNo comparison with GPS (fewer than 3 frames with a fix).\n";
  }
  if (s.truth_evaluation) {
    t += fmt::format("\nComparison with the ground truth {} ({} frames):\n", s.truth,
                     s.frames_with_truth);
    t += FormatTrajectoryTable(*s.truth_evaluation, "truth");
  }
  t += fmt::format(
      "\n{:<28}detect {:.1f}, describe {:.1f}, correspond {:.1f}, estimate {:.1f}, total "
      "{:.1f}\n",
      "Mean stage times (ms)", s.mean.detect_ms, s.mean.describe_ms, s.mean.correspond_ms,
      s.mean.estimate_ms, s.mean.total_ms);
  t += fmt::format("{:<28}{:.2f} fps ({:.1f} s)\n", "Throughput", s.fps, s.wall_s);
  return t;
}

// ---------------------------------------------------------------------------------------------
// The run

namespace {

// A frame whose outputs wait for the geo-referencing (heading from the first GPS segment).
struct PendingFrame {
  FrameRecord record;
  Eigen::Vector2d local_m;
  double heading_rad = 0.0;
  std::optional<GeoPoint> gps;
};

std::optional<GeoPoint> GpsOf(const std::optional<TelemetrySample>& s) {
  if (!s) return std::nullopt;
  GeoPoint p;
  p.lat_deg = s->lat_deg;
  p.lon_deg = s->lon_deg;
  p.alt_m = s->abs_alt_m.value_or(s->rel_alt_m.value_or(0.0));
  return p;
}

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

}  // namespace

RunSummary RunFlight(const RunConfig& config, const RunCallbacks& cb,
                     const std::atomic<bool>* stop) {
  Validate(config);
  FrameSourceOptions so;
  so.step = config.step;
  so.start_time_s = config.start_s;
  if (config.end_s >= 0.0) so.end_time_s = config.end_s;
  return RunFlight(config, OpenFrameSource(config.input, so), cb, stop);
}

RunSummary RunFlight(const RunConfig& given, std::unique_ptr<FrameSource> source,
                     const RunCallbacks& cb, const std::atomic<bool>* stop) {
  Validate(given);
  if (!source) throw InvalidArgument("RunFlight: the frame source is null");
  Stopwatch wall;
  RunSummary summary;
  // A simulated flight: fill in what was not given from its sim.json.
  RunConfig config = given;
  bool focal_from_sim = false;
  if (const auto m = FindSimulationManifest(config.input, &summary.warnings)) {
    summary.sim_manifest = (m->dir / "sim.json").string();
    if (config.telemetry.empty() && !m->srt.empty()) config.telemetry = m->srt.string();
    if (config.truth.empty() && !m->csv.empty()) config.truth = m->csv.string();
    if (config.focal_px == 0.0 && config.hfov_deg == 0.0) {
      config.focal_px = m->focal_px;  // exact, whatever the SRT's 35 mm equivalent says
      focal_from_sim = true;
    }
  }
  std::optional<ReferenceTrack> truth;
  if (!config.truth.empty()) {
    truth = ReadReferenceTrack(config.truth);
    summary.truth = config.truth;
  }
  summary.input = config.input;
  summary.out_dir = config.out;
  std::ostream* log = config.quiet ? nullptr : cb.log;
  namespace fs = std::filesystem;
  const fs::path out_dir(config.out);
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw InputError("cannot create output folder '" + config.out + "': " + ec.message());
  WriteJsonFileAtomic(out_dir / RunFileNames::kConfigJson, ToJson(config));
  if (log) *log << "aerovo run: effective configuration\n" << ToJson(config).dump(2) << "\n";

  // Source.
  summary.source_description = source->Describe();
  summary.frames_expected = source->ExpectedFrameCount();
  if (config.max_frames > 0 &&
      (summary.frames_expected < 0 || summary.frames_expected > config.max_frames)) {
    summary.frames_expected = config.max_frames;
  }
  const auto* folder = dynamic_cast<const ImageFolderSource*>(source.get());
  if (log) *log << "source: " << summary.source_description << "\n";
  if (log && !summary.sim_manifest.empty()) {
    *log << "simulated flight: " << summary.sim_manifest << " (telemetry, focal, truth)\n";
  }

  // Telemetry: a file, or the photos' own EXIF/XMP.
  Telemetry telemetry;
  bool by_frame_index = false;
  if (!config.telemetry.empty()) {
    TelemetryReadOptions to;
    to.lenient = config.lenient_telemetry;
    TelemetryReadResult t;
    try {
      t = ReadTelemetryFile(config.telemetry, to);
    } catch (const MalformedRecordError& e) {
      // Only a malformed record (not a missing file, a bad header or a foreign format): say how
      // to go on.
      throw InputError(std::string(e.what()) +
                       " (--lenient-telemetry skips malformed records instead)");
    }
    telemetry = std::move(t.telemetry);
    if (t.skipped_records > 0) {
      summary.warnings.push_back(fmt::format(
          "{}: {} malformed telemetry record(s) skipped (--lenient-telemetry), the first ones:",
          config.telemetry, t.skipped_records));
    }
    for (auto& w : t.warnings) summary.warnings.push_back(std::move(w));
    by_frame_index = telemetry.HasFrameIndices();
  } else if (folder != nullptr) {
    try {
      TelemetryReadResult t = TelemetryFromImages(folder->metadata());
      telemetry = std::move(t.telemetry);
      for (auto& w : t.warnings) summary.warnings.push_back(std::move(w));
      by_frame_index = true;
    } catch (const InputError& e) {
      summary.warnings.push_back(std::string("no telemetry from the photos: ") + e.what());
    }
  }
  if (log) {
    *log << "telemetry: "
         << (telemetry.empty() ? std::string("none")
                               : std::to_string(telemetry.size()) + " fixes from " +
                                     (config.telemetry.empty() ? std::string("photo EXIF/XMP")
                                                               : config.telemetry))
         << "\n";
  }
  auto sample_of = [&](const Frame& f) -> std::optional<TelemetrySample> {
    if (telemetry.empty()) return std::nullopt;
    return by_frame_index ? telemetry.AtFrame(f.index) : telemetry.Lookup(f.time_s, 0.5);
  };

  OdometryOptions vo_options = config.odometry;
  std::unique_ptr<VisualOdometry> vo;
  std::unique_ptr<FrameUndistorter> undistorter;
  GrayImage dimmed;  // the frame at illumination_k < 1
  GeoRefOptions geo_options;
  geo_options.heading_source = config.heading;
  GeoReferencer georef(geo_options);
  std::unique_ptr<TrackWriterSet> writers;
  std::deque<PendingFrame> pending;
  // For the final comparisons, the only memory that grows with the run (the rest of the
  // per-frame output is streamed to the files): per frame with a GPS fix, the VO position (local
  // frame) and the fix (ENU), 48 bytes; with a truth file, every frame's VO position and index, 28
  // bytes.
  std::vector<TrajectoryPoint2D> local_at_gps, gps_track, local_track;
  std::vector<int> track_frames;  // frame index of each local_track point (with a truth file)
  std::optional<double> last_height;
  bool warned_height = false;
  StageTimes sum;
  Eigen::Vector2d last_local = Eigen::Vector2d::Zero();
  // transforms.csv (RunFileNames::kTransformsCsv): first_px_from_frame per frame, for mosaics.
  std::optional<TransformsCsvWriter> transforms_csv;
  Eigen::Matrix3d first_px_from_world = Eigen::Matrix3d::Identity();

  // Writes a frame: geo-referenced when possible, else in the local VO frame.
  auto emit = [&](PendingFrame& p) {
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
    writers->Append(p.record, p.gps);
    if (cb.frame) cb.frame(p.record);
    if (cb.poses != nullptr) {
      const FrameRecord& q = p.record;
      *cb.poses << fmt::format("{} {:.6f} {:.4f} {:.4f} {} {} {}\n", q.frame, q.time_s, q.x_m,
                               q.y_m, q.geo ? fmt::format("{:.9f}", q.geo->lat_deg) : "-",
                               q.geo ? fmt::format("{:.9f}", q.geo->lon_deg) : "-", q.status)
                << std::flush;
    }
  };
  auto flush = [&](bool final) {
    if (final && !georef.ready() && georef.has_enu()) georef.FixWithAvailable();
    // With GPS in the telemetry, wait for the heading (bounded: GeoRefOptions::min_segment_m).
    if (!final && !georef.ready() && !telemetry.empty()) return;
    while (!pending.empty()) {
      emit(pending.front());
      pending.pop_front();
    }
  };

  Frame frame;
  bool stopped = false;
  int frames_without_fix = 0;
  int measured_steps = 0;  // frames whose step was estimated (ok or reacquired)
  // An input error after the first frame (an undecodable photo, a frame of another size): the
  // run stops there but keeps what it computed (outputs closed, summary.json written), then
  // reports the error.
  std::string failure;
  while (true) {
    if (stop != nullptr && stop->load()) {
      stopped = true;
      break;
    }
    if (config.max_frames > 0 && summary.frames_processed >= config.max_frames) break;
    bool more = false;
    try {
      more = source->Next(frame);
    } catch (const InputError& e) {
      if (summary.frames_processed == 0) throw;
      failure = e.what();
      break;
    }
    if (!more) break;
    const std::optional<TelemetrySample> sample = sample_of(frame);
    const std::optional<GeoPoint> gps = GpsOf(sample);
    if (!sample) ++frames_without_fix;

    if (!vo) {
      // First frame: the camera and the outputs can now be set up.
      const int w = frame.gray.width(), h = frame.gray.height();
      if (config.focal_px > 0.0) {
        summary.focal_px = config.focal_px;
        summary.focal_source = focal_from_sim ? "sim.json" : "flag";
      } else if (config.hfov_deg > 0.0) {
        summary.focal_px = FocalPxFromHorizontalFov(config.hfov_deg, w);
        summary.focal_source = "hfov";
      } else if (folder != nullptr && !folder->metadata().empty() &&
                 folder->metadata().front().calibrated_focal_px &&
                 folder->metadata().front().width_px == w) {
        summary.focal_px = *folder->metadata().front().calibrated_focal_px;
        summary.focal_source = "xmp-calibrated";
      } else if (folder != nullptr && !folder->metadata().empty() &&
                 folder->metadata().front().focal_length_35mm_mm) {
        summary.focal_px = FocalPxFrom35mm(*folder->metadata().front().focal_length_35mm_mm, w, h);
        summary.focal_source = "exif-35mm";
      } else if (sample && sample->focal_length_35mm_mm) {
        summary.focal_px = FocalPxFrom35mm(*sample->focal_length_35mm_mm, w, h);
        summary.focal_source = "telemetry-35mm";
      } else {
        throw InputError(frame.name +
                         ": the camera focal length is unknown (no EXIF/telemetry "
                         "35 mm focal length): give --focal-px or --hfov-deg");
      }
      vo_options.focal_px = summary.focal_px;
      vo_options.default_height_m = config.altitude_m;
      summary.height_source = config.altitude_m > 0.0 ? "flag" : "telemetry";
      vo = std::make_unique<VisualOdometry>(vo_options);
      if (config.k1 != 0.0 || config.k2 != 0.0 || config.p1 != 0.0 || config.p2 != 0.0 ||
          config.k3 != 0.0) {
        undistorter = std::make_unique<FrameUndistorter>(
            w, h, summary.focal_px, config.k1, config.k2, config.p1, config.p2, config.k3);
      }

      TrackWriterOptions wo;
      wo.enu_origin = gps;
      if (sample && sample->unix_time_s)
        wo.time_origin_unix_s = *sample->unix_time_s - frame.time_s;
      wo.run_name = "aerovo";
      writers = std::make_unique<TrackWriterSet>(out_dir, wo);
      nlohmann::json effective = ToJson(config);
      effective["resolved"] = {{"focal_px", summary.focal_px},
                               {"focal_source", summary.focal_source},
                               {"height_source", summary.height_source},
                               {"frame_width_px", w},
                               {"frame_height_px", h}};
      WriteJsonFileAtomic(out_dir / RunFileNames::kConfigJson, effective);
      transforms_csv.emplace(out_dir / RunFileNames::kTransformsCsv);
      if (log) {
        *log << fmt::format("camera: {}x{} px, focal {:.1f} px ({}), height from {}\n", w, h,
                            summary.focal_px, summary.focal_source, summary.height_source);
      }
    }

    // Height above ground: the flag, else the telemetry's relative altitude.
    std::optional<double> height;
    if (config.altitude_m > 0.0) {
      height = config.altitude_m;
    } else if (sample && sample->rel_alt_m && *sample->rel_alt_m > 0.0) {
      height = *sample->rel_alt_m;
      last_height = height;
    } else if (last_height) {
      height = last_height;
      if (!warned_height) {
        summary.warnings.push_back(frame.name + ": no relative altitude, using the last known (" +
                                   fmt::format("{:.1f}", *last_height) + " m)");
        warned_height = true;
      }
    } else {
      throw InputError(frame.name +
                       ": no height above ground (the telemetry has no relative "
                       "altitude): give --altitude");
    }
    const std::optional<double> yaw = sample ? sample->CameraYawDeg() : std::nullopt;

    GrayImageView view = undistorter ? undistorter->Apply(frame.gray.view()) : frame.gray.view();
    if (config.illumination_k != 1.0) view = ScaleBrightness(view, config.illumination_k, &dimmed);
    FrameResult r;
    try {
      r = vo->Process(view, frame.time_s, height, yaw);
    } catch (const InputError& e) {
      if (summary.frames_processed == 0) throw;
      failure = frame.name + ": " + e.what();
      break;
    }
    georef.Observe(r.position_m, gps, yaw);
    if (r.status == FrameStatus::kOk || r.status == FrameStatus::kReacquired) ++measured_steps;
    // world_from_frame is metric (local metres) or first-frame pixels depending on the scale
    // mode; relative to the first frame's it is first_px_from_frame in both.
    if (summary.frames_processed == 0) first_px_from_world = r.world_from_frame.inverse();
    const Eigen::Matrix3d first_px_from_frame = first_px_from_world * r.world_from_frame;
    transforms_csv->Append(frame.index, first_px_from_frame);

    PendingFrame p;
    p.local_m = r.position_m;
    p.heading_rad = r.heading_rad;
    p.gps = gps;
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
    pending.push_back(std::move(p));
    flush(false);

    if (truth) {
      local_track.push_back({frame.time_s, r.position_m.x(), r.position_m.y()});
      track_frames.push_back(frame.index);
    }
    if (gps && georef.has_enu()) {
      const Eigen::Vector3d e = georef.enu().Forward(*gps);
      gps_track.push_back({frame.time_s, e.x(), e.y()});
      local_at_gps.push_back({frame.time_s, r.position_m.x(), r.position_m.y()});
      ++summary.frames_with_gps;
    }
    if (summary.frames_processed > 0)
      summary.vo_path_length_m += (r.position_m - last_local).norm();
    last_local = r.position_m;
    sum.detect_ms += r.detect_ms;
    sum.describe_ms += r.describe_ms;
    sum.correspond_ms += r.correspond_ms;
    sum.estimate_ms += r.estimate_ms;
    sum.total_ms += r.total_ms;
    ++summary.frames_processed;
    if (cb.progress) {
      cb.progress(summary.frames_processed, summary.frames_expected,
                  summary.frames_processed / std::max(1e-9, wall.elapsed_ms() / 1000.0));
    }
  }
  if (writers) {
    flush(true);
    writers->Close();
  }
  for (const std::string& w : source->warnings()) summary.warnings.push_back(w);
  if (!telemetry.empty() && frames_without_fix > 0) {
    summary.warnings.push_back(fmt::format(
        "{} of {} frames have no telemetry fix (the telemetry does not cover them); their gps_* "
        "cells are empty and they are not in the comparison with GPS",
        frames_without_fix, summary.frames_processed));
  }

  summary.interrupted = stopped;
  if (vo) {
    const OdometryStats& st = vo->stats();
    summary.frames_ok = st.ok;
    summary.frames_reacquired = st.reacquired;
    summary.frames_bridged = st.bridged;
    if (st.frames > 1 && measured_steps == 0) {
      // Only the first frame "succeeded": nothing was measured, the track is a placeholder.
      summary.warnings.push_back(
          "no frame could be matched to another (dark, blank or textureless frames?): the "
          "trajectory was not measured, every position is bridged");
    }
  }
  summary.heading_source = georef.heading_source_used();
  const double n = std::max(1, summary.frames_processed);
  summary.mean = {sum.detect_ms / n, sum.describe_ms / n, sum.correspond_ms / n,
                  sum.estimate_ms / n, sum.total_ms / n};
  summary.wall_s = wall.elapsed_ms() / 1000.0;
  summary.fps = summary.frames_processed / std::max(1e-9, summary.wall_s);

  if (gps_track.size() >= 3) {
    if (georef.ready()) {
      for (TrajectoryPoint2D& q : local_at_gps) {
        const Eigen::Vector2d e = georef.EnuFromLocal({q.x, q.y});
        q.x = e.x();
        q.y = e.y();
      }
    }
    try {
      summary.evaluation = CompareTrajectories(local_at_gps, gps_track);
    } catch (const InvalidArgument& e) {
      summary.warnings.push_back(std::string("no comparison with GPS: ") + e.what());
    }
  }
  if (truth && !local_track.empty()) {
    CompareWithTruth(*truth, local_track, track_frames, georef, &summary);
  }
  summary.error = failure;
  WriteJsonFileAtomic(out_dir / RunFileNames::kSummaryJson, ToJson(summary));
  if (!failure.empty()) {
    throw InputError(fmt::format(
        "{} (the run stopped there: the {} frames processed before are in '{}', each file "
        "valid, summary.json included)",
        failure, summary.frames_processed, out_dir.string()));
  }
  return summary;
}

}  // namespace aerovo
