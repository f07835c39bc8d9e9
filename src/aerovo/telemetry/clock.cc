#include "aerovo/telemetry/clock.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <utility>

#include <fmt/format.h>
#include <Eigen/Core>

#include "aerovo/geo/local_enu.h"

namespace aerovo {

std::string CheckTelemetryClock(const Telemetry& t, const std::string& source,
                                double frames_start_s, double frames_end_s, double offset_s) {
  if (t.size() < 3) return "";
  const double tel_span = t.end_time_s() - t.start_time_s();
  const double video_span = frames_end_s - frames_start_s;
  const double first_s = frames_start_s + offset_s, last_s = frames_end_s + offset_s;
  if (t.start_time_s() > last_s || t.end_time_s() < first_s) {
    // No frame can take a fix from it; a bare "N frames have no fix" would not say why.
    return fmt::format(
        "{}: no time overlap with the frames: the telemetry spans {:.3f} to {:.3f} s, the frames "
        "{:.3f} to {:.3f} s on its clock{}: another flight, or another clock (GPS-week or "
        "absolute seconds against the frames' from 0?); no frame takes a fix from it "
        "(--telemetry-offset-s shifts it)",
        source, t.start_time_s(), t.end_time_s(), first_s, last_s,
        offset_s != 0.0 ? fmt::format(" (offset {:+.3f} s applied)", offset_s) : std::string());
  }
  if (!(video_span >= 1.0) || !(tel_span > 0.0)) return "";  // too short to judge
  const double ratio = tel_span / video_span;
  std::string unit;
  if (ratio >= 5e5 && ratio <= 2e6) {
    unit = ": its times look like microseconds read as seconds (convert them to seconds)";
  } else if (ratio >= 500.0 && ratio <= 2000.0) {
    unit = ": its times look like milliseconds read as seconds (convert them to seconds)";
  } else if (ratio >= 40.0 && ratio <= 80.0) {
    unit =
        ": its times look like seconds while the video's are minutes, or the telemetry is "
        "of a longer flight";
  } else if (ratio <= 1.0 / 500.0 && ratio >= 1.0 / 2000.0) {
    unit = ": its times look like seconds written as kiloseconds or the video's as milliseconds";
  }
  if (ratio > 20.0) {
    return fmt::format(
        "{}: the telemetry spans {:.1f} s but the frames only {:.1f} s ({:.0f}x){}; every frame "
        "takes a fix from the first {:.1f}% of it",
        source, tel_span, video_span, ratio,
        unit.empty() ? ": another flight, or a clip of a longer recording (--telemetry-offset-s)"
                     : unit,
        100.0 / ratio);
  }
  if (ratio < 0.05) {
    return fmt::format(
        "{}: the telemetry spans {:.3f} s but the frames {:.1f} s ({:.4f}x){}; most frames have "
        "no fix",
        source, tel_span, video_span, ratio, unit.empty() ? ": another unit of time?" : unit);
  }
  return "";
}

namespace {

// Speed (m/s) over the window [t - 0.5 s, t + 0.5 s] of a track given as sorted (t, x, y),
// interpolated linearly; nullopt when the window leaves the track.
std::optional<double> TrackSpeed(const std::vector<PlanarTrackPoint>& track, double t) {
  constexpr double kHalf = 0.5;
  if (track.size() < 2 || t - kHalf < track.front().time_s || t + kHalf > track.back().time_s) {
    return std::nullopt;
  }
  const auto at = [&](double q) {
    auto it = std::lower_bound(track.begin(), track.end(), q,
                               [](const PlanarTrackPoint& p, double v) { return p.time_s < v; });
    if (it == track.begin()) return Eigen::Vector2d(it->x_m, it->y_m);
    const PlanarTrackPoint& b = *it;
    const PlanarTrackPoint& a = *(it - 1);
    const double w = b.time_s > a.time_s ? (q - a.time_s) / (b.time_s - a.time_s) : 0.0;
    return Eigen::Vector2d(a.x_m + w * (b.x_m - a.x_m), a.y_m + w * (b.y_m - a.y_m));
  };
  return (at(t + kHalf) - at(t - kHalf)).norm() / (2.0 * kHalf);
}

}  // namespace

OffsetEstimate EstimateTelemetryOffset(const std::vector<PlanarTrackPoint>& vo_track_m,
                                       const Telemetry& telemetry, double max_offset_s) {
  OffsetEstimate best;
  if (vo_track_m.size() < 20 || telemetry.size() < 3) return best;
  // The GPS track in metres (ENU at the first sample), on the telemetry's clock.
  // Samples without a fix (TelemetrySample::has_fix) have no position and are left out.
  const auto first_fix = std::find_if(telemetry.samples().begin(), telemetry.samples().end(),
                                      [](const TelemetrySample& s) { return s.has_fix; });
  if (first_fix == telemetry.samples().end()) return best;
  const LocalEnu enu(first_fix->lat_deg, first_fix->lon_deg, 0.0);
  std::vector<PlanarTrackPoint> gps;
  gps.reserve(telemetry.size());
  for (const TelemetrySample& s : telemetry.samples()) {
    if (!s.has_fix) continue;
    const Eigen::Vector3d e = enu.Forward(s.lat_deg, s.lon_deg, 0.0);
    if (!gps.empty() && s.time_s <= gps.back().time_s) continue;  // equal times: keep the first
    gps.push_back({s.time_s, e.x(), e.y()});
  }
  // At most ~2000 frames, evenly spread; their VO speeds once.
  const std::size_t stride = std::max<std::size_t>(1, vo_track_m.size() / 2000);
  std::vector<std::pair<double, double>> vo;  // (frame time, speed)
  for (std::size_t i = 0; i < vo_track_m.size(); i += stride) {
    const double t = vo_track_m[i].time_s;
    if (const auto v = TrackSpeed(vo_track_m, t)) vo.emplace_back(t, *v);
  }
  std::vector<std::pair<double, int>> scores;  // (correlation, candidate)
  const int n_candidates = static_cast<int>(std::floor(max_offset_s / 0.05));
  double best_corr = -2.0;
  for (int k = -n_candidates; k <= n_candidates; ++k) {
    const double d = 0.05 * k;
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    int n = 0;
    for (const auto& [t, v] : vo) {
      const auto g = TrackSpeed(gps, t + d);
      if (!g) continue;
      sx += v;
      sy += *g;
      sxx += v * v;
      syy += *g * *g;
      sxy += v * *g;
      ++n;
    }
    if (n < 20) continue;
    const double cov = sxy - sx * sy / n, vx = sxx - sx * sx / n, vy = syy - sy * sy / n;
    if (!(vx > 1e-9 * n) || !(vy > 1e-9 * n)) continue;  // no speed variation
    const double corr = cov / std::sqrt(vx * vy);
    scores.emplace_back(corr, k);
    if (corr > best_corr) {
      best_corr = corr;
      best.valid = true;
      best.offset_s = d;
      best.correlation = corr;
      best.frames = n;
    }
  }
  if (!best.valid) return best;
  double second = -2.0;
  for (const auto& [corr, k] : scores) {
    if (std::abs(0.05 * k - best.offset_s) >= 2.0) second = std::max(second, corr);
  }
  best.clear = best.correlation >= 0.8 && best.correlation - second >= 0.1;
  return best;
}

}  // namespace aerovo
