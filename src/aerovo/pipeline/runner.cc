#include "aerovo/pipeline/runner.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "aerovo/core/error.h"
#include "aerovo/core/timer.h"
#include "aerovo/eval/trajectory_eval_json.h"
#include "aerovo/frames/frame_source.h"
#include "aerovo/outputs/output_file.h"
#include "aerovo/outputs/run_folder.h"
#include "aerovo/frames/prefetch_source.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/matching/matcher.h"
#include "aerovo/pipeline/lens_prepass.h"
#include "aerovo/pipeline/frame_loop.h"
#include "aerovo/pipeline/run_steps.h"
#include "aerovo/map/reference_map.h"
#include "aerovo/telemetry/clock.h"

namespace aerovo {

// ---------------------------------------------------------------------------------------------
// Summary

// summary.json "optimized".
nlohmann::json ToJson(const RunSummary::Optimized& o) {
  return {{"keyframes", o.keyframes},
          {"pairs_tried", o.pairs_tried},
          {"pairs_verified", o.pairs_verified},
          {"pairs_rejected", o.pairs_rejected},
          {"pairs_gated", o.pairs_gated},
          {"outliers", o.outliers},
          {"closures_tried", o.closures_tried},
          {"closures_verified", o.closures_verified},
          {"closures_gated", o.closures_gated},
          {"gps_factors", o.gps_factors},
          {"gps_outliers", o.gps_outliers},
          {"match_s", o.match_s},
          {"solve_s", o.solve_s},
          {"cpu_s", o.cpu_s},
          {"iterations", o.iterations},
          {"pairs", o.pairs},
          {"evaluation", o.evaluation ? ToJson(*o.evaluation) : nlohmann::json()},
          {"truth_evaluation", o.truth_evaluation ? ToJson(*o.truth_evaluation) : nlohmann::json()},
          {"gps_denied_error", o.gps_denied_error ? ToJson(*o.gps_denied_error) : nlohmann::json()}};
}

// summary.json "pose_resets".
nlohmann::json ToJson(const RunSummary::PoseResets& r) {
  return {{"frames", r.frames},          {"reacquired", r.reacquired},
          {"lens_switch", r.lens_switch}, {"loop_closure", r.loop_closure},
          {"map_fix", r.map_fix},         {"heading_only", r.heading_only}};
}

// summary.json "online".
nlohmann::json ToJson(const RunSummary::Online& o) {
  return {{"window", o.window},
          {"pairs_tried", o.pairs_tried},
          {"pairs_verified", o.pairs_verified},
          {"pairs_gated", o.pairs_gated},
          {"closures_tried", o.closures_tried},
          {"closures_verified", o.closures_verified},
          {"closures_gated", o.closures_gated},
          {"full_solves", o.full_solves},
          {"full_solve_ms", o.full_solve_ms},
          {"total_ms", o.total_ms}};
}

namespace {

// summary.json "map".
nlohmann::json ToJson(const RunSummary::MapCover& m) {
  return {{"path", m.path},
          {"paths", m.paths},
          {"track_points", m.track_points},
          {"covered", m.covered},
          {"note", m.note}};
}

// summary.json "map_fixes" "georef": the geo-reference seeded from the map (null when no
// attempt was made without one).
nlohmann::json MapSeedJson(const RunSummary::MapFixes& m) {
  if (m.whole_map_searches == 0 && !m.georef_seed) return nullptr;
  nlohmann::json j = {{"whole_map_searches", m.whole_map_searches},
                      {"tiles", m.whole_map_tiles},
                      {"tiles_total", m.whole_map_tiles_total},
                      {"candidates", m.candidates},
                      {"seeded", m.georef_seed.has_value()},
                      {"frame", nullptr},
                      {"time_s", nullptr},
                      {"candidate_frame", nullptr},
                      {"candidate_time_s", nullptr},
                      {"note", m.georef_note}};
  if (m.georef_seed) {
    j["frame"] = m.georef_seed->frame;
    j["time_s"] = m.georef_seed->time_s;
    j["candidate_frame"] = m.georef_seed->candidate_frame;
    j["candidate_time_s"] = m.georef_seed->candidate_time_s;
  }
  return j;
}

// summary.json "map_fixes".
nlohmann::json ToJson(const RunSummary::MapFixes& m) {
  nlohmann::json by_status = nlohmann::json::object();
  for (const auto& [status, count] : m.by_status) by_status[status] = count;
  nlohmann::json gps;
  if (m.with_gps > 0) {
    gps = {{"fixes", m.with_gps},  {"median_m", m.median_m},
           {"rmse_m", m.rmse_m},   {"max_m", m.max_m},
           {"track_median_m", m.track_median_m}, {"track_rmse_m", m.track_rmse_m},
           {"track_max_m", m.track_max_m}};
  }
  nlohmann::json by_map = nlohmann::json::array();
  for (const RunSummary::MapFixes::ByMap& b : m.by_map) {
    by_map.push_back({{"path", b.path}, {"attempted", b.attempted}, {"fixes", b.fixes},
                      {"fused", b.fused}});
  }
  return {{"every_n_frames", m.every_n_frames}, {"attempted", m.attempted},
          {"fixes", m.fixes},                   {"applied", m.applied},
          {"fused", m.fused},                   {"gated_by_graph", m.gated_by_graph},
          {"by_status", by_status},
          {"no_prediction", m.no_prediction},   {"skipped_busy", m.skipped_busy},
          {"mean_ms", m.mean_ms},               {"searches", m.searches},
          {"search_ms", m.search_ms},           {"found", m.found},
          {"time_to_first_fix_s",
           m.time_to_first_fix_s ? nlohmann::json(*m.time_to_first_fix_s) : nlohmann::json()},
          {"against_gps", gps},
          {"by_map", by_map},
          {"georef", MapSeedJson(m)}};
}

// summary.json "gps_denied".
nlohmann::json ToJson(const RunSummary::GpsDenied& d) {
  return {{"after_s", d.after_s},
          {"from_frame", d.from_frame >= 0 ? nlohmann::json(d.from_frame) : nlohmann::json()},
          {"from_time_s", d.from_frame >= 0 ? nlohmann::json(d.from_time_s) : nlohmann::json()},
          {"fixes_withheld", d.fixes_withheld},
          {"error", d.error ? ToJson(*d.error) : nlohmann::json()},
          {"note", d.note}};
}

// The blocks of summary.json that are null unless their feature ran: optimized, online,
// gps_denied, map.
void AddOptionalBlocks(const RunSummary& s, nlohmann::json* j) {
  (*j)["optimized"] = s.optimized ? ToJson(*s.optimized) : nlohmann::json();
  (*j)["online"] = s.online ? ToJson(*s.online) : nlohmann::json();
  (*j)["gps_denied"] = s.gps_denied ? ToJson(*s.gps_denied) : nlohmann::json();
  (*j)["map"] = s.map ? ToJson(*s.map) : nlohmann::json();
  (*j)["map_fixes"] = s.map_fixes ? ToJson(*s.map_fixes) : nlohmann::json();
  (*j)["pose_resets"] = ToJson(s.pose_resets);
}

}  // namespace

nlohmann::json ToJson(const RunSummary& s) {
  nlohmann::json j{{"input", s.input},
                   {"source", s.source_description},
                   {"out_dir", s.out_dir.string()},
                   {"frames_processed", s.frames_processed},
                   {"frames_not_written", s.frames_not_written},
                   {"frames_expected", s.frames_expected},
                   {"frames_ok", s.frames_ok},
                   {"frames_reacquired", s.frames_reacquired},
                   {"frames_bridged", s.frames_bridged},
                   {"frames_with_gps", s.frames_with_gps},
                   {"frames_flagged", s.frames_flagged},
                   {"processed_width_px", s.processed_width_px},
                   {"processed_height_px", s.processed_height_px},
                   {"frame_scale", s.frame_scale},
                   {"frames_dropped", s.frames_dropped},
                   {"interrupted", s.interrupted},
                   {"wall_s", s.wall_s},
                   {"fps", s.fps},
                   {"cpu_s", s.cpu_s},
                   {"cpu_ms_per_frame", s.cpu_ms_per_frame},
                   {"mean_stage_ms",
                    {{"detect", s.mean.detect_ms},
                     {"describe", s.mean.describe_ms},
                     {"correspond", s.mean.correspond_ms},
                     {"estimate", s.mean.estimate_ms},
                     {"total", s.mean.total_ms}}},
                   {"focal_px", s.focal_px},
                   {"focal_source", s.focal_source},
                   {"undistortion", s.undistortion},
                   {"lens_scale_change", s.lens_scale_change},
                   {"lens_estimate", s.lens_estimate},
                   {"attitude_estimate", s.attitude_estimate},
                   {"flat_field",
                    {{"mode", s.flat_field.mode},
                     {"estimate", s.flat_field.estimate},
                     {"applied", s.flat_field.applied},
                     {"frames_corrected", s.flat_field.frames_corrected},
                     {"samples", s.flat_field.samples},
                     {"significance", s.flat_field.significance},
                     {"pattern_std_dn", s.flat_field.pattern_std_dn},
                     {"varying_std_dn", s.flat_field.varying_std_dn},
                     {"ground_seen", s.flat_field.ground_seen},
                     {"ground_overlap", s.flat_field.ground_overlap},
                     {"gain", s.flat_field.gain},
                     {"prepass_ms", s.flat_field.prepass_ms},
                     {"mean_frame_ms", s.flat_field.mean_frame_ms},
                     {"why", s.flat_field.why}}},
                   {"height_source", s.height_source},
                   {"height_sources", s.height_sources},
                   {"attitude_sources", s.attitude_sources},
                   {"max_tilt_deg", s.max_tilt_deg},
                   {"mavlink", s.mavlink},
                   {"heading_source", s.heading_source},
                   {"sim_manifest", s.sim_manifest},
                   {"telemetry", s.telemetry},
                   {"telemetry_beside", s.telemetry_beside},
                   {"telemetry_in_video", s.telemetry_in_video},
                   {"telemetry_camera_triggers", s.telemetry_camera_triggers},
                   {"vo_path_length_m", s.vo_path_length_m},
                   {"truth", s.truth},
                   {"frames_with_truth", s.frames_with_truth},
                   {"warnings", s.warnings},
                   {"error", s.error}};
  const auto number_or_null = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
  };
  j["latency_ms"] = {{"frames", s.latency.frames},
                     {"median", number_or_null(s.latency.median_ms)},
                     {"p95", number_or_null(s.latency.p95_ms)},
                     {"max", number_or_null(s.latency.max_ms)}};
  j["enu_origin"] = s.enu_origin ? nlohmann::json{{"lat_deg", s.enu_origin->lat_deg},
                                                   {"lon_deg", s.enu_origin->lon_deg},
                                                   {"alt_m", number_or_null(s.enu_origin->alt_m)}}
                                 : nlohmann::json();
  j["gps_comparison_note"] = s.gps_comparison_note;
  j["gps_rejected"] = s.gps_rejected;
  nlohmann::json rejected = nlohmann::json::array();
  for (const auto& r : s.gps_rejected_fixes) {
    rejected.push_back(
        {{"frame", r.frame}, {"time_s", r.time_s}, {"kind", r.kind}, {"message", r.message}});
  }
  j["gps_rejected_fixes"] = rejected;
  j["telemetry_offset_s"] = s.telemetry_offset_s;
  j["telemetry_offset_estimate"] =
      s.telemetry_offset_estimate_valid
          ? nlohmann::json{{"offset_s", s.telemetry_offset_estimate_s},
                           {"correlation", s.telemetry_offset_correlation},
                           {"clear", s.telemetry_offset_clear}}
          : nlohmann::json();
  j["evaluation"] = s.evaluation ? ToJson(*s.evaluation) : nlohmann::json();
  j["truth_evaluation"] = s.truth_evaluation ? ToJson(*s.truth_evaluation) : nlohmann::json();
  AddOptionalBlocks(s, &j);
  return j;
}

// ---------------------------------------------------------------------------------------------
// The run

namespace {

// Space held for summary.json during a run (a summary is a few kB; its warnings are bounded).
constexpr size_t kSummaryReserveBytes = size_t{1} << 20;

// The run folder: created, with config.json of the effective configuration (sim.json's settings
// filled in; RunOutputs rewrites it with the "resolved" block on the first frame), which the
// log names (and shows, with log_config).
std::filesystem::path PrepareRunFolder(const RunConfig& config, bool log_config,
                                       std::ostream* log) {
  namespace fs = std::filesystem;
  const fs::path out_dir(config.out);
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw InputError("cannot create output folder '" + config.out + "': " + ec.message());
  WriteJsonFileAtomic(out_dir / RunFileNames::kConfigJson, ToJson(config));
  if (log && log_config) {
    *log << "aerovo run: effective configuration\n" << ToJson(config).dump(2) << "\n";
  } else if (log) {
    *log << "configuration: " << (out_dir / RunFileNames::kConfigJson).string() << "\n";
  }
  return out_dir;
}

// The source's description and expected frame count (capped by max_frames) in `summary` and
// the log.
void DescribeSource(const FrameSource& source, int max_frames, std::ostream* log,
                    RunSummary* summary) {
  summary->source_description = source.Describe();
  summary->frames_expected = source.ExpectedFrameCount();
  if (max_frames > 0 && (summary->frames_expected < 0 || summary->frames_expected > max_frames)) {
    summary->frames_expected = max_frames;
  }
  if (log) *log << "source: " << summary->source_description << "\n";
  if (log && !summary->sim_manifest.empty()) {
    *log << "simulated flight: " << summary->sim_manifest << " (telemetry, focal, truth)\n";
  }
}

// ", lasting 12.3 s" for a video whose container gives its frame count and rate, else "".
std::string DurationOf(const FrameSource& source) {
  const auto* video = dynamic_cast<const VideoFileSource*>(&source);
  if (video == nullptr || video->fps() <= 0.0 || video->frame_count() <= 0) return "";
  return fmt::format(", lasting {:.3f} s", video->frame_count() / video->fps());
}

}  // namespace

RunSummary RunFlight(const RunConfig& config, const RunCallbacks& cb,
                     const std::atomic<bool>* stop) {
  Validate(config);
  const FrameSourceOptions so = run_steps::SourceOptionsOf(config);
  if (!config.telemetry_auto_offset) return RunFlight(config, OpenFrameSource(config.input, so), cb, stop);
  // telemetry_auto_offset: a first run estimates the offset; when it is clear and differs from
  // the applied one, the flight is run again with it (the second run's outputs replace the
  // first's).
  RunConfig first = config;
  first.telemetry_auto_offset = false;
  RunSummary s = RunFlight(first, OpenFrameSource(config.input, so), cb, stop);
  // Photos paired with the log's camera triggers have no offset to apply: an offset would match
  // them by time on the log's own clock instead (run_steps::RunTelemetry::Load).
  if (s.interrupted || s.telemetry_camera_triggers || !s.telemetry_offset_estimate_valid ||
      !s.telemetry_offset_clear ||
      std::abs(s.telemetry_offset_estimate_s - config.telemetry_offset_s) <= 0.2) {
    if (s.telemetry_offset_estimate_valid && !s.telemetry_offset_clear) {
      s.warnings.push_back(fmt::format(
          "telemetry_auto_offset: the offset estimated from the motion ({:+.2f} s, correlation "
          "{:.2f}) is not clear: not applied",
          s.telemetry_offset_estimate_s, s.telemetry_offset_correlation));
      WriteJsonFileAtomic(std::filesystem::path(config.out) / RunFileNames::kSummaryJson,
                          ToJson(s));
    }
    return s;
  }
  RunConfig second = first;
  second.telemetry_offset_s = s.telemetry_offset_estimate_s;
  if (cb.log && !config.quiet) {
    *cb.log << fmt::format("telemetry_auto_offset: running again with --telemetry-offset-s {:.2f}\n",
                           second.telemetry_offset_s);
  }
  RunSummary again = RunFlight(second, OpenFrameSource(config.input, so), cb, stop);
  again.warnings.insert(again.warnings.begin(),
                        fmt::format("telemetry_auto_offset: the offset estimated from the motion, "
                                    "{:+.2f} s (correlation {:.2f}), is applied",
                                    s.telemetry_offset_estimate_s, s.telemetry_offset_correlation));
  WriteJsonFileAtomic(std::filesystem::path(config.out) / RunFileNames::kSummaryJson,
                      ToJson(again));
  return again;
}

namespace {

// Decoding on its own thread (config.frame_queue > 0): `source` wrapped in a PrefetchSource,
// returned (else null); a live source keeps only the newest frame (bounded latency).
PrefetchSource* Prefetch(const RunConfig& config, std::unique_ptr<FrameSource>& source) {
  if (config.frame_queue <= 0) return nullptr;
  const bool live = source->IsLive();
  PrefetchOptions po;
  po.capacity = live ? 1 : config.frame_queue;
  po.policy = live ? QueuePolicy::kDropOldest : QueuePolicy::kWait;
  auto wrapped = std::make_unique<PrefetchSource>(std::move(source), po);
  PrefetchSource* prefetch = wrapped.get();
  source = std::move(wrapped);
  return prefetch;
}

// The frames still queued written (FrameLoop::Finish); its error is the run's failure (an
// output one over any other).
void Finish(run_steps::FrameLoop& loop, run_steps::LoopEnd* end) {
  try {
    loop.Finish();
  } catch (const OutputError& e) {  // the files stay valid; the summary says what failed
    end->failure = run_steps::RunFailure{run_steps::RunFailureKind::kOutput, -1, "", e.what()};
  } catch (const InputError& e) {  // a queued frame's position is not on Earth
    if (!end->failure) {
      end->failure = run_steps::RunFailure{run_steps::RunFailureKind::kInput, -1, "", e.what()};
    }
  }
}

// summary.json counts what frames.csv holds, on every exit path: frames processed but never
// written (queued for the heading when a write failed) are counted apart and said.
void CountWritten(const run_steps::FrameLoop& loop, const run_steps::LoopEnd& end,
                  RunSummary* summary_out) {
  RunSummary& summary = *summary_out;
  if (const int written = loop.frames_written(); written != summary.frames_processed) {
    summary.frames_not_written = std::max(0, summary.frames_processed - written);
    if (summary.frames_not_written > 0) {
      summary.warnings.push_back(fmt::format(
          "{} of the {} frames processed are not in frames.csv nor the tracks: writing them "
          "failed ({}); frames_processed counts the {} written",
          summary.frames_not_written, summary.frames_processed,
          end.failure ? end.failure->Text() : std::string("see the error"), written));
    }
    summary.frames_processed = written;
  }
}

// summary.json "mavlink": the link's counts.
nlohmann::json LinkStats(const mavlink::AutopilotLink& link, const RunConfig& config) {
  const mavlink::LinkStats st = link.stats();
  return {{"url", config.mavlink},
          {"message", ToString(config.mavlink_message)},
          {"sent", st.sent},
          {"send_failed", st.send_failed},
          {"heartbeats", st.heartbeats},
          {"timesync_answers", st.timesync_answers},
          {"distance_samples", st.distance_samples},
          {"relative_alt_samples", st.relative_alt_samples},
          {"attitude_samples", st.attitude_samples},
          {"autopilot_heartbeats", st.autopilot_heartbeats},
          {"crc_errors", st.parser.crc_errors},
          {"v1_packets", st.parser.v1_packets},
          {"signing", st.signing},
          {"signed_accepted", st.signed_accepted},
          {"rejected_unsigned", st.rejected_unsigned},
          {"rejected_bad_signature", st.rejected_bad_signature},
          {"rejected_replayed", st.rejected_replayed},
          {"signing_timestamp_saves", st.signing_timestamp_saves},
          {"signing_timestamp_save_failed", st.signing_timestamp_save_failed}};
}

// RunConfig::map opened and checked against the telemetry's fixes the run may use (those of
// its first gps_denied_after_s seconds under GPS denial): InputError naming the map when it
// cannot be read or covers none of them, a warning when it covers part (map/reference_map.h).
std::optional<map::ReferenceMaps> OpenMap(const RunConfig& config,
                                          const run_steps::RunTelemetry& telemetry,
                                          RunSummary* summary) {
  if (config.map.empty()) return std::nullopt;
  map::ReferenceMaps maps(std::vector<std::filesystem::path>(config.map.begin(), config.map.end()));
  summary->map = RunSummary::MapCover{};
  summary->map->path = config.map.front();
  summary->map->paths = config.map;
  std::vector<GeoPoint> fixes;
  const double t0 = telemetry.telemetry().start_time_s();
  for (const TelemetrySample& s : telemetry.telemetry().samples()) {
    if (!s.has_fix) continue;
    if (config.gps_denied_after_s >= 0.0 && s.time_s - t0 >= config.gps_denied_after_s) continue;
    fixes.push_back({s.lat_deg, s.lon_deg, 0.0});
  }
  if (fixes.empty()) {
    summary->warnings.push_back(fmt::format(
        "'{}': the map's cover of the flight is not checked before the run: no telemetry "
        "position the run may use", fmt::join(config.map, "', '")));
    return maps;
  }
  const std::string partial = map::CheckCover(maps, fixes);
  if (!partial.empty()) summary->warnings.push_back(partial + " (the telemetry's)");
  return maps;
}

// summary->map's cover of the geo-referenced track (at most 1000 positions, evenly spread).
void MapCoverOfTrack(const map::ReferenceMaps& maps, const GeoReferencer& georef,
                     const run_steps::RunTotals& totals, RunSummary* summary) {
  RunSummary::MapCover& m = *summary->map;
  if (!georef.ready() || totals.local_track.empty()) {
    m.note = "the track is not geo-referenced";
    return;
  }
  const std::size_t n = totals.local_track.size(), step = std::max<std::size_t>(1, n / 1000);
  std::vector<GeoPoint> track;
  for (std::size_t i = 0; i < n; i += step) {
    track.push_back(georef.Wgs84FromLocal({totals.local_track[i].x, totals.local_track[i].y}));
  }
  const map::MapCover c = maps.CoverOf(track);
  m.track_points = c.points;
  m.covered = c.covered;
  if (c.covered < c.points) {
    summary->warnings.push_back(fmt::format(
        "'{}': the map{} cover{} {} of the {} track positions checked",
        fmt::join(m.paths, "', '"), m.paths.size() > 1 ? "s" : "", m.paths.size() > 1 ? "" : "s",
        c.covered, c.points));
  }
}

// The samples of `telemetry` before the GPS denial of the run (`t.denied_at_s`; all of them
// without one): by frame index when the telemetry is matched by index, else by time (telemetry
// time = frame time + the offset applied).
Telemetry TelemetryBeforeDenial(const run_steps::RunTelemetry& telemetry,
                                const run_steps::RunTotals& t, const RunConfig& config) {
  if (!t.denied_at_s) return telemetry.telemetry();
  const bool by_index = telemetry.by_frame_index() && config.telemetry_offset_s == 0.0;
  std::vector<TelemetrySample> kept;
  for (const TelemetrySample& s : telemetry.telemetry().samples()) {
    const bool before = by_index && s.frame_index
                            ? *s.frame_index < t.denied_from_frame
                            : s.time_s < *t.denied_at_s + config.telemetry_offset_s;
    if (before) kept.push_back(s);
  }
  return Telemetry(std::move(kept), telemetry.telemetry().source());
}

// The telemetry's clock against the frames' (`t`): a warning in `summary` when its span does not
// cover them, and the offset seen in the motion (VO speed against GPS speed) in the summary, the
// log, and a warning when it differs from the applied offset by more than 0.2 s.
void CheckTelemetryTiming(const RunConfig& config, const run_steps::RunTelemetry& telemetry,
                          const run_steps::RunTotals& t, std::ostream* log, RunSummary* summary) {
  if (!telemetry.by_frame_index() || config.telemetry_offset_s != 0.0) {
    const std::string w = CheckTelemetryClock(telemetry.telemetry(), telemetry.origin(),
                                              t.first_time_s, t.last_time_s,
                                              config.telemetry_offset_s);
    if (!w.empty()) summary->warnings.push_back(w);
  }
  // GPS denial: the positions from the denial on are not the run's to use (RunConfig::
  // gps_denied_after_s), neither the frames' nor the telemetry's.
  std::vector<PlanarTrackPoint> vo_track;
  vo_track.reserve(t.local_track.size());
  for (const TrajectoryPoint2D& p : t.local_track) {
    if (!t.denied_at_s || p.t < *t.denied_at_s) vo_track.push_back({p.t, p.x, p.y});
  }
  const OffsetEstimate e =
      EstimateTelemetryOffset(vo_track, TelemetryBeforeDenial(telemetry, t, config));
  summary->telemetry_offset_estimate_valid = e.valid;
  summary->telemetry_offset_estimate_s = e.offset_s;
  summary->telemetry_offset_correlation = e.correlation;
  summary->telemetry_offset_clear = e.clear;
  if (e.valid && log) {
    *log << fmt::format(
        "telemetry offset from the motion: {:+.2f} s (VO/GPS speed correlation {:.2f}{}), "
        "applied {:+.2f} s\n",
        e.offset_s, e.correlation, e.clear ? "" : ", not clear", config.telemetry_offset_s);
  }
  if (e.valid && e.clear && std::abs(e.offset_s - config.telemetry_offset_s) > 0.2) {
    summary->warnings.push_back(fmt::format(
        "{}: the telemetry's clock seems {:+.2f} s off the video's (VO speed against GPS "
        "speed, correlation {:.2f}; applied {:+.2f} s): --telemetry-offset-s {:.2f}, or "
        "--telemetry-auto-offset",
        telemetry.origin(), e.offset_s, e.correlation, config.telemetry_offset_s, e.offset_s));
  }
}

// Steps 2-6 of RunFlight in its prepared folder `out_dir`: the source, the telemetry, the frames
// and the summary (not written yet). A failure of the frame loop ends it and is in the summary
// (LoopEnd::failure, a RunFailure); one before it (telemetry that does not parse, a link that
// cannot open) escapes.
void RunInFolder(const run_steps::RunInputs& inputs, std::unique_ptr<FrameSource> source,
                 const RunCallbacks& cb, const std::atomic<bool>* stop, const Stopwatch& wall,
                 std::ostream* log, const std::filesystem::path& out_dir, RunSummary& summary) {
  const RunConfig& config = inputs.config;
  DescribeSource(*source, config.max_frames, log, &summary);
  const auto* folder = dynamic_cast<const ImageFolderSource*>(source.get());
  // Before the source is wrapped (the duration needs the video source itself).
  const std::string source_duration = DurationOf(*source);
  const bool live = source->IsLive();
  PrefetchSource* prefetch = Prefetch(config, source);
  // "none": no telemetry file, and a photo folder's EXIF/XMP not read as telemetry.
  const bool no_telemetry = config.telemetry == kNoTelemetry;
  run_steps::RunTelemetry telemetry;
  try {
    telemetry = run_steps::RunTelemetry::Load(
        no_telemetry ? std::string() : config.telemetry, config.lenient_telemetry,
        no_telemetry ? nullptr : folder, &summary.warnings, config.telemetry_offset_s != 0.0);
  } catch (const InputError& e) {
    // A file found beside the video was not asked for: one that cannot be read is flagged and
    // the run goes on without it. A given file stays an error.
    if (!inputs.telemetry_beside && !inputs.telemetry_in_video) throw;
    summary.warnings.push_back(fmt::format(
        "the telemetry found {} could not be read, the run goes on without telemetry (give it "
        "with --telemetry to make this an error): {}",
        inputs.telemetry_beside ? "beside the video" : "in the video's subtitle track", e.what()));
  }
  telemetry.set_offset_s(config.telemetry_offset_s);
  summary.telemetry_offset_s = config.telemetry_offset_s;
  if (config.gps_denied_after_s >= 0.0) {
    summary.gps_denied = RunSummary::GpsDenied{};
    summary.gps_denied->after_s = config.gps_denied_after_s;
  }
  if (log) {
    *log << "telemetry: " << telemetry.Describe()
         << (telemetry.empty()         ? ""
             : inputs.telemetry_beside ? " (found beside the video: the same name; --telemetry "
                                         "names another, --telemetry none runs without)"
             : inputs.telemetry_in_video
                 ? " (the video's subtitle track: its captions; --telemetry names a file, "
                   "--telemetry none runs without)"
                 : "")
         << "\n";
  }
  summary.telemetry_beside = inputs.telemetry_beside;
  summary.telemetry_in_video = inputs.telemetry_in_video;
  summary.telemetry_camera_triggers = telemetry.from_camera_triggers();
  const std::optional<map::ReferenceMaps> maps = OpenMap(config, telemetry, &summary);

  // 2-5. The frames: camera, height, outputs, odometry.
  run_steps::FrameLoop loop(inputs, telemetry, folder, config.odometry, out_dir, cb, log);
  loop.set_source_live(live);
  if (maps) loop.set_maps(&*maps);
  run_steps::LoopEnd end = loop.Run(*source, stop, wall, &summary);
  if (summary.frames_processed == 0 && !end.stopped && !end.failure) {
    // Not a silent empty run: a window past the end, an empty window, an empty source.
    end.failure = run_steps::RunFailure();
    end.failure->message = fmt::format(
        "no frame to process in '{}' (start_s {} s, end_s {}, step {}): the window selects no "
        "frame of {}{}",
        config.input, config.start_s,
        config.end_s >= 0.0 ? fmt::format("{} s", config.end_s) : std::string("the end"),
        config.step, source->Describe(), source_duration);
  }
  if (!end.output_failed()) Finish(loop, &end);
  CountWritten(loop, end, &summary);
  if (mavlink::AutopilotLink* link = loop.link()) {
    link->SaveSigningTimestamp();  // the timestamp of the run's last packet, before the stats
    // The link's counts, beside the MAVLink sink's own (GPS_INPUT's, written when the loop ended).
    nlohmann::json sink_counts = std::move(summary.mavlink);
    summary.mavlink = LinkStats(*link, config);
    if (sink_counts.is_object()) summary.mavlink.update(sink_counts);
  }

  // The telemetry's clock against the frames': its span, and the offset seen in the motion.
  if (!telemetry.empty() && loop.totals().frames > 0) {
    CheckTelemetryTiming(config, telemetry, loop.totals(), log, &summary);
  }

  // 6. Summary (wall time and fps: the frames'), then 7. the offline whole-flight optimisation
  // (backend.enable) on a copy of the causal totals.
  if (prefetch != nullptr) summary.frames_dropped = prefetch->dropped();
  const bool optimize = config.backend.enable && !end.stopped && !end.output_failed();
  std::optional<run_steps::RunTotals> causal;
  if (optimize) causal = loop.totals();
  if (maps) MapCoverOfTrack(*maps, loop.georef(), loop.totals(), &summary);
  run_steps::Summarize(source->warnings(), !telemetry.empty(), end, loop.vo_stats(), loop.georef(),
                       loop.TakeTotals(), inputs.truth ? &*inputs.truth : nullptr,
                       wall.elapsed_ms() / 1000.0, &summary);
  if (optimize) {
    const CpuStopwatch cpu;
    run_steps::OptimizeFlight(config, loop.flight(), loop.georef(), *causal,
                              inputs.truth ? &*inputs.truth : nullptr, out_dir, &summary);
    if (summary.optimized) summary.optimized->cpu_s = cpu.elapsed_s();
  }
}

}  // namespace

// The steps are in run_steps.h.
RunSummary RunFlight(const RunConfig& given, std::unique_ptr<FrameSource> source,
                     const RunCallbacks& cb, const std::atomic<bool>* stop) {
  Validate(given);
  if (!source) throw InvalidArgument("RunFlight: the frame source is null");
  Stopwatch wall;
  const CpuStopwatch cpu;
  RunSummary summary;
  // 1. Inputs: what sim.json fills in (a simulated flight), the truth; then the output folder,
  // the source and the telemetry (a file, or the photos' own EXIF/XMP).
  const run_steps::RunInputs inputs = run_steps::ResolveInputs(given, &summary.warnings);
  const RunConfig& config = inputs.config;
  summary.sim_manifest = inputs.sim_manifest;
  summary.telemetry = config.telemetry == kNoTelemetry ? std::string() : config.telemetry;
  summary.truth = config.truth;
  summary.input = config.input;
  summary.out_dir = config.out;
  std::ostream* log = config.quiet ? nullptr : cb.log;
  // One run at a time in a folder (outputs/run_folder.h); the space for summary.json is held from
  // here on, so the summary is written even if the disk fills up during the run.
  const RunFolderLock lock(config.out);
  const std::filesystem::path out_dir = PrepareRunFolder(config, cb.log_config, log);
  SpaceReserve reserve(out_dir / RunFolderFiles::kReserve, kSummaryReserveBytes);
  // Whatever fails from here on, the folder ends with summary.json saying what happened: the
  // frame loop's failures are in the summary RunInFolder makes; one before the frames gets a
  // summary with the error alone.
  const auto release_reserve = [&] {
    reserve.Release();
    std::error_code ec;
    std::filesystem::remove(out_dir / RunFolderFiles::kReserve, ec);
  };
  try {
    RunInFolder(inputs, std::move(source), cb, stop, wall, log, out_dir, summary);
  } catch (const std::exception& e) {
    if (summary.error.empty()) summary.error = e.what();
    release_reserve();
    try {
      WriteJsonFileAtomic(out_dir / RunFileNames::kSummaryJson, ToJson(summary));
    } catch (const std::exception&) {  // the original error is the one to report
    }
    throw;
  }
  release_reserve();
  // The frames' CPU time: the offline optimisation's is its own (optimized.cpu_s).
  summary.cpu_s = cpu.elapsed_s() - (summary.optimized ? summary.optimized->cpu_s : 0.0);
  summary.cpu_ms_per_frame = 1000.0 * summary.cpu_s / std::max(1, summary.frames_processed);
  run_steps::WriteSummary(out_dir, summary);
  return summary;
}

}  // namespace aerovo
