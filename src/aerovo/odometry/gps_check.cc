#include "aerovo/odometry/gps_check.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo {

void Validate(const GpsCheckOptions& o) { options::CheckRanges(o, "gps_check"); }

GpsFixChecker::GpsFixChecker(const GpsCheckOptions& options) : options_(options) {
  Validate(options_);
}

std::string GpsFixChecker::Compare(const Fix& a, const Fix& b, std::string* reason) const {
  const double dt = std::max(std::abs(b.time_s - a.time_s), 1e-3);
  const double dh = (b.enu.head<2>() - a.enu.head<2>()).norm();
  const double tol = options_.tolerance_m;
  if (dh > tol + options_.max_speed_mps * dt) {
    *reason = fmt::format("jumps {:.1f} m in {:.2f} s ({:.0f} m/s; limit {:g} m/s)", dh, dt,
                          dh / dt, options_.max_speed_mps);
    return "speed";
  }
  const auto vertical = [&](double za, double zb, const char* what) {
    const double dz = std::abs(zb - za);
    if (dz > tol + options_.max_vertical_speed_mps * dt) {
      *reason = fmt::format("{} changes by {:.1f} m in {:.2f} s ({:.0f} m/s; limit {:g} m/s)", what,
                            dz, dt, dz / dt, options_.max_vertical_speed_mps);
      return true;
    }
    return false;
  };
  if (vertical(a.enu.z(), b.enu.z(), "altitude")) return "altitude";
  if (a.rel_alt_m && b.rel_alt_m && vertical(*a.rel_alt_m, *b.rel_alt_m, "relative altitude")) {
    return "altitude";
  }
  if (options_.vo_ratio > 0.0 && a.unmeasured == b.unmeasured) {
    const double dvo = (b.local - a.local).norm();
    if (dh > tol + options_.vo_ratio * dvo) {
      *reason = fmt::format("jumps {:.1f} m while the camera moved {:.1f} m (visual odometry)", dh,
                            dvo);
      return "vo";
    }
  }
  return "";
}

GpsFixVerdict GpsFixChecker::Check(int frame_index, double time_s, const GeoPoint& gps,
                                   std::optional<double> rel_alt_m, const Eigen::Vector2d& local_m,
                                   int unmeasured_frames) {
  GpsFixVerdict v;
  if (!options_.enabled) return v;
  if (!enu_) enu_.emplace(gps);
  Fix f{frame_index, time_s, gps, enu_->Forward(gps), rel_alt_m, local_m, unmeasured_frames};
  if (!f.enu.allFinite()) {
    v.accepted = false;
    v.kind = "speed";
    v.reason = "its position is not finite in the run's ENU frame";
    return v;
  }
  if (!anchor_) {
    anchor_ = f;
    anchor_chain_.push_back(frame_index);
    return v;
  }
  std::string reason;
  const std::string kind = Compare(*anchor_, f, &reason);
  if (kind.empty()) {
    anchor_ = f;
    anchor_chain_.push_back(frame_index);
    challenger_.clear();
    return v;
  }
  std::string ignored;
  if (challenger_.empty() || !Compare(challenger_.back(), f, &ignored).empty()) challenger_.clear();
  challenger_.push_back(f);
  const int n = static_cast<int>(challenger_.size());
  if (n >= options_.min_chain && n > static_cast<int>(anchor_chain_.size())) {
    // The challengers outnumber the accepted fixes: those were the outliers.
    v.switched = true;
    v.superseded = std::move(anchor_chain_);
    anchor_chain_.clear();
    for (int i = 0; i + 1 < n; ++i) {
      const Fix& c = challenger_[static_cast<std::size_t>(i)];
      v.reinstated.push_back({c.frame, c.time_s, c.gps, c.local});
      anchor_chain_.push_back(c.frame);
    }
    anchor_chain_.push_back(frame_index);
    // The ENU frame was centred on a fix now superseded (possibly far away: a fix at 0,0, where
    // the horizontal plane is tilted against the flight's): centre it on the new chain's first fix.
    enu_.emplace(challenger_.front().gps);
    f.enu = enu_->Forward(f.gps);
    anchor_ = f;
    challenger_.clear();
    return v;
  }
  v.accepted = false;
  v.kind = kind;
  v.reason = reason;
  return v;
}

double GpsFixChecker::PlausibleRelAlt(double time_s, double rel_alt_m,
                                      std::optional<double> last_height_m) {
  if (options_.enabled && last_height_m && last_rel_alt_time_s_ &&
      std::abs(rel_alt_m - *last_height_m) >
          options_.tolerance_m +
              options_.max_vertical_speed_mps * std::max(time_s - *last_rel_alt_time_s_, 1e-3)) {
    return *last_height_m;
  }
  if (rel_alt_m > 0.0) last_rel_alt_time_s_ = time_s;
  return rel_alt_m;
}

}  // namespace aerovo
