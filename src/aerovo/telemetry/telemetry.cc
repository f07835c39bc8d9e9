#include "aerovo/telemetry/telemetry.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo {
namespace {

void CheckRange(const std::optional<double>& v, double lo, double hi, const char* name,
                const std::string& where) {
  if (!v) return;
  if (!std::isfinite(*v) || *v < lo || *v > hi) {
    throw InputError(fmt::format("{}: {} {} out of range [{}, {}]", where, name, *v, lo, hi));
  }
}

double Lerp(double a, double b, double w) { return a + (b - a) * w; }

// Shorter-arc interpolation: 350 deg -> 10 deg passes through 0, not through 180.
double LerpAngleDeg(double a, double b, double w) {
  double d = std::remainder(b - a, 360.0);
  double r = a + d * w;
  // Keep the result in the convention of the inputs' range ((-180, 180] or [0, 360)).
  if (a >= 0.0 && b >= 0.0) {
    r = std::fmod(r, 360.0);
    if (r < 0.0) r += 360.0;
  } else {
    r = std::remainder(r, 360.0);
  }
  return r;
}

std::optional<double> LerpOpt(const std::optional<double>& a, const std::optional<double>& b,
                              double w, bool angle) {
  if (a && b) return angle ? LerpAngleDeg(*a, *b, w) : Lerp(*a, *b, w);
  if (!a && !b) return std::nullopt;
  // Only one side known: hold that value (altitude, focal length and attitude vary slowly, and
  // a held value is better than dropping the field between two fixes).
  return a ? a : b;
}

}  // namespace

void ValidateSample(const TelemetrySample& s, const std::string& where) {
  if (!std::isfinite(s.time_s)) throw InputError(fmt::format("{}: time is not finite", where));
  CheckRange(s.lat_deg, -90.0, 90.0, "latitude", where);
  CheckRange(s.lon_deg, -180.0, 180.0, "longitude", where);
  CheckRange(s.abs_alt_m, -1e5, 1e5, "absolute altitude (m)", where);
  CheckRange(s.rel_alt_m, -1e5, 1e5, "relative altitude (m)", where);
  for (auto [v, name] : {std::pair{&s.yaw_deg, "yaw"},
                         {&s.pitch_deg, "pitch"},
                         {&s.roll_deg, "roll"},
                         {&s.gimbal_yaw_deg, "gimbal yaw"},
                         {&s.gimbal_pitch_deg, "gimbal pitch"},
                         {&s.gimbal_roll_deg, "gimbal roll"}}) {
    CheckRange(*v, -360.0, 360.0, name, where);
  }
  for (auto [v, name] : {std::pair{&s.focal_length_mm, "focal length (mm)"},
                         {&s.focal_length_35mm_mm, "35 mm equivalent focal length (mm)"}}) {
    if (*v && (!std::isfinite(**v) || **v <= 0.0 || **v > 1e4)) {
      throw InputError(fmt::format("{}: {} {} out of range (0, 10000]", where, name, **v));
    }
  }
  if (s.frame_index && *s.frame_index < 0) {
    throw InputError(fmt::format("{}: negative frame index {}", where, *s.frame_index));
  }
}

Telemetry::Telemetry(std::vector<TelemetrySample> samples, std::string source)
    : samples_(std::move(samples)), source_(std::move(source)) {
  std::stable_sort(
      samples_.begin(), samples_.end(),
      [](const TelemetrySample& a, const TelemetrySample& b) { return a.time_s < b.time_s; });
  for (std::size_t i = 0; i < samples_.size(); ++i) {
    if (samples_[i].frame_index) by_frame_.emplace_back(*samples_[i].frame_index, i);
  }
  // Equal frame indices keep time order, so a lookup finds the earliest fix of that frame.
  std::stable_sort(by_frame_.begin(), by_frame_.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
}

double Telemetry::start_time_s() const { return samples_.empty() ? 0.0 : samples_.front().time_s; }
double Telemetry::end_time_s() const { return samples_.empty() ? 0.0 : samples_.back().time_s; }

bool Telemetry::HasFrameIndices() const { return !by_frame_.empty(); }

TelemetrySample InterpolateSamples(const TelemetrySample& a, const TelemetrySample& b, double w) {
  const TelemetrySample& near = w <= 0.5 ? a : b;
  TelemetrySample r = near;
  r.time_s = Lerp(a.time_s, b.time_s, w);
  if (a.unix_time_s && b.unix_time_s) r.unix_time_s = Lerp(*a.unix_time_s, *b.unix_time_s, w);
  r.frame_index = (w == 0.0) ? a.frame_index : (w == 1.0 ? b.frame_index : std::nullopt);
  r.lat_deg = Lerp(a.lat_deg, b.lat_deg, w);
  // Longitude across the antimeridian: interpolate the short way and wrap back.
  double lon = a.lon_deg + std::remainder(b.lon_deg - a.lon_deg, 360.0) * w;
  r.lon_deg = std::remainder(lon, 360.0);
  if (r.lon_deg == -180.0 && a.lon_deg == 180.0) r.lon_deg = 180.0;
  r.abs_alt_m = LerpOpt(a.abs_alt_m, b.abs_alt_m, w, false);
  r.rel_alt_m = LerpOpt(a.rel_alt_m, b.rel_alt_m, w, false);
  r.yaw_deg = LerpOpt(a.yaw_deg, b.yaw_deg, w, true);
  r.pitch_deg = LerpOpt(a.pitch_deg, b.pitch_deg, w, true);
  r.roll_deg = LerpOpt(a.roll_deg, b.roll_deg, w, true);
  r.gimbal_yaw_deg = LerpOpt(a.gimbal_yaw_deg, b.gimbal_yaw_deg, w, true);
  r.gimbal_pitch_deg = LerpOpt(a.gimbal_pitch_deg, b.gimbal_pitch_deg, w, true);
  r.gimbal_roll_deg = LerpOpt(a.gimbal_roll_deg, b.gimbal_roll_deg, w, true);
  r.focal_length_mm = LerpOpt(a.focal_length_mm, b.focal_length_mm, w, false);
  r.focal_length_35mm_mm = LerpOpt(a.focal_length_35mm_mm, b.focal_length_35mm_mm, w, false);
  if (w == 0.0 || w == 1.0) return r;  // `near` itself: its fix (or none) and its origin.
  // Between a sample with a fix and one without there is no position to interpolate.
  r.has_fix = a.has_fix && b.has_fix;
  if (!r.has_fix) r.lat_deg = r.lon_deg = 0.0;
  r.origin = a.origin.empty() || b.origin.empty()
                 ? std::string()
                 : fmt::format("between {} and {}", a.origin, b.origin);
  return r;
}

std::optional<TelemetrySample> Telemetry::Lookup(double time_s, double tolerance_s) const {
  if (samples_.empty() || !std::isfinite(time_s)) return std::nullopt;
  const double t0 = samples_.front().time_s, t1 = samples_.back().time_s;
  if (time_s < t0 - tolerance_s || time_s > t1 + tolerance_s) return std::nullopt;
  if (time_s <= t0) {
    TelemetrySample s = samples_.front();
    if (time_s != t0) s.frame_index.reset();
    s.time_s = time_s;
    return s;
  }
  if (time_s >= t1) {
    TelemetrySample s = samples_.back();
    if (time_s != t1) s.frame_index.reset();
    s.time_s = time_s;
    return s;
  }
  auto it = std::upper_bound(samples_.begin(), samples_.end(), time_s,
                             [](double t, const TelemetrySample& s) { return t < s.time_s; });
  const TelemetrySample& b = *it;
  const TelemetrySample& a = *(it - 1);
  const double span = b.time_s - a.time_s;
  if (span <= 0.0) return a;
  return InterpolateSamples(a, b, (time_s - a.time_s) / span);
}

std::optional<TelemetrySample> Telemetry::AtFrame(int frame_index) const {
  auto it = std::lower_bound(by_frame_.begin(), by_frame_.end(), frame_index,
                             [](const auto& e, int f) { return e.first < f; });
  if (it != by_frame_.end() && it->first == frame_index) return samples_[it->second];
  if (it == by_frame_.end() || it == by_frame_.begin()) return std::nullopt;
  const auto& [fa, ia] = *(it - 1);
  const auto& [fb, ib] = *it;
  const double w = static_cast<double>(frame_index - fa) / static_cast<double>(fb - fa);
  TelemetrySample r = InterpolateSamples(samples_[ia], samples_[ib], w);
  r.frame_index = frame_index;
  return r;
}

std::optional<TelemetrySample> Telemetry::LookupUnix(double unix_time_s, double tolerance_s) const {
  for (const TelemetrySample& s : samples_) {
    if (s.unix_time_s) return Lookup(unix_time_s - (*s.unix_time_s - s.time_s), tolerance_s);
  }
  return std::nullopt;
}

std::optional<TelemetrySample> Telemetry::ForFrame(int frame_index, double frame_time_s, Match how,
                                                   double time_offset_s, double tolerance_s) const {
  if (how == Match::kByFrameIndex || (how == Match::kAuto && HasFrameIndices())) {
    return AtFrame(frame_index);
  }
  return Lookup(frame_time_s + time_offset_s, tolerance_s);
}

std::vector<RepeatedTimeRun> RepeatedTimeRuns(const std::vector<double>& times_s) {
  std::vector<RepeatedTimeRun> runs;
  std::vector<double> gaps;  // between consecutive distinct times
  for (std::size_t i = 0; i < times_s.size();) {
    std::size_t j = i + 1;
    while (j < times_s.size() && times_s[j] == times_s[i]) ++j;
    if (j < times_s.size() && times_s[j] > times_s[i]) gaps.push_back(times_s[j] - times_s[i]);
    if (j - i >= 2) runs.push_back({i, j - i, times_s[i], 0.0});
    i = j;
  }
  if (runs.empty() || gaps.empty()) return runs;
  std::vector<double> sorted = gaps;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double clock_step_s = sorted[sorted.size() / 2];
  for (RepeatedTimeRun& r : runs) {
    const std::size_t next = r.first + r.count;
    r.step_s = next < times_s.size() && times_s[next] > r.time_s
                   ? std::min(times_s[next] - r.time_s, clock_step_s)
                   : clock_step_s;
  }
  return runs;
}

}  // namespace aerovo
