// The text of a run's end (runner.h RunHeadline, FormatRunSummary): one place for the CLI, the
// tests and any caller of RunFlight.
#include <algorithm>
#include <filesystem>
#include <string>

#include <fmt/format.h>

#include "aerovo/eval/trajectory_eval_json.h"
#include "aerovo/pipeline/runner.h"

namespace aerovo {

std::string RunHeadline(const RunSummary& s) {
  const int tracked = std::max(0, s.frames_processed - s.frames_bridged);
  std::string line = s.interrupted ? "Interrupted: tracked " : "Tracked ";
  line += fmt::format("{} of {} frames", tracked, s.frames_processed);
  if (s.evaluation) {
    const TrajectoryErrors& e = s.evaluation->se2;
    const double end_m = e.end_point_error_unaligned_m;  // centimetres when under 10 m
    line += fmt::format(" over {:.0f} m; the track ends {:.{}f} m ({:.2f} %) from GPS.",
                        e.distance_flown_m, end_m, end_m < 10.0 ? 2 : 1,
                        e.end_point_error_unaligned_percent);
  } else {
    line += fmt::format(" over {:.0f} m (VO); no GPS to compare with.", s.vo_path_length_m);
  }
  return line;
}

namespace {

// The offline optimisation's section: what it did, then its track beside the causal one.
std::string FormatOptimized(const RunSummary& s) {
  const RunSummary::Optimized& o = *s.optimized;
  std::string t = fmt::format(
      "\nOffline optimisation (vo_optimized.*): {} keyframes, {} pairs tried\n"
      "  {} verified, {} rejected ({} by the gate), {} down-weighted; {:.2f} s CPU\n",
      o.keyframes, o.pairs_tried, o.pairs_verified, o.pairs_rejected, o.pairs_gated, o.outliers,
      o.cpu_s);
  if (o.closures_tried > 0) {
    t += fmt::format("  loop closures by appearance: {} tried, {} verified, {} rejected by the gate\n",
                     o.closures_tried, o.closures_verified, o.closures_gated);
  }
  if (o.gps_factors > 0) {
    t += fmt::format("  GPS fixes as position factors: {} ({} down-weighted)\n", o.gps_factors,
                     o.gps_outliers);
  }
  const auto rows = [&](const char* what, const std::optional<TrajectoryComparison>& causal,
                        const std::optional<TrajectoryComparison>& optimised) {
    if (!causal || !optimised) return;
    t += fmt::format("{:<42}{:>10}{:>11}\n", std::string("vs ") + what + " (m)", "causal",
                     "optimised");
    const auto row = [&](const char* name, double a, double b) {
      t += fmt::format("  {:<40}{:>10.3f}{:>11.3f}\n", name, a, b);
    };
    row("ATE RMSE Sim(2)", causal->sim2.ate_m.rmse, optimised->sim2.ate_m.rmse);
    row("ATE RMSE SE(2)", causal->se2.ate_m.rmse, optimised->se2.ate_m.rmse);
    row("end-point error, SE(2)-aligned", causal->se2.end_point_error_m,
        optimised->se2.end_point_error_m);
    row("end-point error, unaligned", causal->se2.end_point_error_unaligned_m,
        optimised->se2.end_point_error_unaligned_m);
  };
  rows("GPS", s.evaluation, o.evaluation);
  rows("truth", s.truth_evaluation, o.truth_evaluation);
  return t;
}

// The GPS denial's section: when it began, the error against the withheld fixes over time.
std::string FormatDenial(const RunSummary::GpsDenied& d) {
  if (d.from_frame < 0 || !d.error) {
    return fmt::format("\nGPS denied after {} s: no error against the withheld GPS ({}).\n",
                       d.after_s, d.note);
  }
  const DeniedError& e = *d.error;
  std::string t = fmt::format(
      "\nGPS denied from frame {} ({:.1f} s), {} fixes withheld: the geo-referenced track "
      "against them, unaligned\n",
      d.from_frame, d.from_time_s, d.fixes_withheld);
  t += fmt::format("  {:<40}{:.2f} m\n", "at the denial", e.first_error_m);
  for (const DeniedErrorAt& a : e.at) {
    t += fmt::format("  {:<40}{:.2f} m ({:.0f} m flown)\n",
                     fmt::format("after {:.0f} min", a.after_s / 60.0), a.error_m, a.distance_m);
  }
  t += fmt::format("  {:<40}{:.2f} m ({:.0f} m flown in {:.0f} s)\n", "at the end", e.end_error_m,
                   e.distance_m, e.duration_s);
  t += fmt::format("  {:<40}{:.2f} m RMSE, {:.2f} m max\n", "over the denial", e.rmse_m,
                   e.max_error_m);
  if (e.end_error_per_km_m) {
    t += fmt::format("  {:<40}{:.2f} m per km\n", "end error per km without GPS",
                     *e.end_error_per_km_m);
  }
  return t;
}

// The map fixes' section (--map): the attempts, what became of them, the errors against GPS.
std::string FormatMapFixes(const RunSummary::MapFixes& m) {
  std::string failed;
  for (const auto& [status, n] : m.by_status) {
    if (status != "fix" && n > 0)
      failed += fmt::format("{}{} {}", failed.empty() ? "" : ", ", status, n);
  }
  std::string t = fmt::format(
      "\nMap fixes (every {} frames, {}): {} of {} attempts{}{}\n", m.every_n_frames,
      m.applied + m.gated_by_graph > 0
          ? fmt::format("{} fused into the track, {} rejected by the pose graph's gate",
                        m.fused, m.gated_by_graph)
          : std::string("not applied to the track"),
      m.fixes, m.attempted, failed.empty() ? "" : "; " + failed,
      m.no_prediction > 0 ? fmt::format("; {} before the geo-reference", m.no_prediction)
                          : std::string());
  if (m.searches > 0) {
    t += fmt::format("  {:<40}{} of {} found a fix, {:.0f} ms each\n", "wide searches", m.found,
                     m.searches, m.search_ms);
  }
  if (m.time_to_first_fix_s) {
    t += fmt::format("  {:<40}{:.1f} s after the first attempt\n", "first fix",
                     *m.time_to_first_fix_s);
  }
  if (m.by_map.size() > 1) {  // several maps: each one's share, in the order given
    for (std::size_t i = 0; i < m.by_map.size(); ++i) {
      const RunSummary::MapFixes::ByMap& b = m.by_map[i];
      t += fmt::format("  {:<40}{} fixes of {} attempts, {} fused\n",
                       fmt::format("map {}: {}", i,
                                   std::filesystem::path(b.path).filename().string()),
                       b.fixes, b.attempted, b.fused);
    }
  }
  if (m.georef_seed) {
    t += fmt::format("  {:<40}from the map: frame {} ({:.1f} s), found by a whole-map search "
                     "at frame {} ({:.1f} s)\n",
                     "geo-reference", m.georef_seed->frame, m.georef_seed->time_s,
                     m.georef_seed->candidate_frame, m.georef_seed->candidate_time_s);
  } else if (!m.georef_note.empty()) {
    t += fmt::format("  {:<40}none from the map: {}\n", "geo-reference", m.georef_note);
  }
  if (m.with_gps > 0) {
    t += fmt::format(
        "  {:<40}median {:.2f} m, RMSE {:.2f} m, max {:.2f} m (the track: {:.2f}, {:.2f}, "
        "{:.2f} m)\n",
        "against GPS", m.median_m, m.rmse_m, m.max_m, m.track_median_m, m.track_rmse_m,
        m.track_max_m);
  }
  return t;
}

}  // namespace

std::string FormatRunSummary(const RunSummary& s) {
  std::string t = RunHeadline(s) + "\n\n";
  t += fmt::format("{:<20}{}\n", "Input", s.input);
  t += fmt::format("{:<20}{} processed{}: ok {}, re-acquired {}, bridged {}\n", "Frames",
                   s.frames_processed, s.interrupted ? " (interrupted)" : "", s.frames_ok,
                   s.frames_reacquired, s.frames_bridged);
  if (const RunSummary::PoseResets& r = s.pose_resets; r.frames > 0) {
    std::string causes;
    const std::pair<const char*, int> counts[] = {{"re-acquired", r.reacquired},
                                                  {"lens switch", r.lens_switch},
                                                  {"loop closure", r.loop_closure},
                                                  {"map fix", r.map_fix}};
    for (const auto& [cause, n] : counts) {
      if (n > 0) causes += fmt::format("{}{} {}", causes.empty() ? "" : ", ", cause, n);
    }
    t += fmt::format("{:<20}{} frames ({}{})\n", "Pose resets", r.frames, causes,
                     r.heading_only > 0 ? fmt::format("; {} by the heading alone", r.heading_only)
                                        : std::string());
  }
  if (!s.frames_flagged.empty()) {
    std::string flags;
    for (const auto& [flag, n] : s.frames_flagged) {
      flags += fmt::format("{}{} {}", flags.empty() ? "" : ", ", flag, n);
    }
    t += fmt::format("{:<20}flagged by the input: {}\n", "", flags);
  }
  t += fmt::format("{:<20}{} with a GPS fix{}\n", "", s.frames_with_gps,
                   s.gps_rejected > 0 ? fmt::format(", {} rejected as implausible", s.gps_rejected)
                                      : std::string());
  t += fmt::format("{:<20}{:.1f} m\n", "VO path length", s.vo_path_length_m);
  t += fmt::format("{:<20}{:.1f} px ({}); heading from {}\n", "Focal length", s.focal_px,
                   s.focal_source, s.heading_source.empty() ? "-" : s.heading_source);
  if (s.evaluation) {
    t += "\nComparison with GPS (ENU, after alignment):\n" + FormatTrajectoryTable(*s.evaluation);
  } else {
    t += fmt::format("\nNo comparison with GPS ({}).\n", s.gps_comparison_note.empty()
                                                             ? "no frame has a GPS fix"
                                                             : s.gps_comparison_note);
  }
  if (s.truth_evaluation) {
    t += fmt::format("\nComparison with the ground truth ({} frames):\n  {}\n", s.frames_with_truth,
                     s.truth);
    t += FormatTrajectoryTable(*s.truth_evaluation, "truth");
  }
  if (s.gps_denied) t += FormatDenial(*s.gps_denied);
  if (s.map_fixes) t += FormatMapFixes(*s.map_fixes);
  if (s.optimized) t += FormatOptimized(s);
  t += fmt::format("\n{:<20}detect {:.1f}, describe {:.1f}, correspond {:.1f}\n",
                   "Stage times (ms)", s.mean.detect_ms, s.mean.describe_ms, s.mean.correspond_ms);
  t +=
      fmt::format("{:<20}estimate {:.1f}, total {:.1f}\n", "", s.mean.estimate_ms, s.mean.total_ms);
  t += fmt::format("{:<20}{:.2f} fps ({:.1f} s); CPU {:.1f} ms per frame\n", "Throughput", s.fps,
                   s.wall_s, s.cpu_ms_per_frame);
  if (s.latency.frames > 0) {
    t += fmt::format("{:<20}capture to pose: median {:.1f}, p95 {:.1f}, max {:.1f}\n",
                     "Latency (ms)", s.latency.median_ms, s.latency.p95_ms, s.latency.max_ms);
  }
  if (s.frames_dropped > 0) {
    t += fmt::format("{:<20}{} (a live source faster than the processing)\n", "Frames dropped",
                     s.frames_dropped);
  }
  return t;
}

}  // namespace aerovo
