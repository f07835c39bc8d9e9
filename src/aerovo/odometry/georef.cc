#include "aerovo/odometry/georef.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "aerovo/core/angles.h"
#include "aerovo/core/error.h"
#include "aerovo/geo/geodesic.h"

namespace aerovo {

const char* ToString(HeadingSource source) {
  switch (source) {
    case HeadingSource::kAuto:
      return "auto";
    case HeadingSource::kTelemetryYaw:
      return "yaw";
    case HeadingSource::kGpsSegment:
      return "gps";
  }
  return "?";
}

HeadingSource ParseHeadingSource(const std::string& text) {
  if (text == "auto") return HeadingSource::kAuto;
  if (text == "yaw") return HeadingSource::kTelemetryYaw;
  if (text == "gps") return HeadingSource::kGpsSegment;
  throw InvalidArgument("heading source must be 'auto', 'yaw' or 'gps', got '" + text + "'");
}

void Validate(const GeoRefOptions& options) {
  if (!(options.min_segment_m > 0.0) || !std::isfinite(options.min_segment_m)) {
    throw InvalidArgument("GeoRefOptions.min_segment_m must be > 0 m, got " +
                          std::to_string(options.min_segment_m));
  }
  if (!(options.outlier_m >= 0.0) || !std::isfinite(options.outlier_m)) {
    throw InvalidArgument("GeoRefOptions.outlier_m must be >= 0 m, got " +
                          std::to_string(options.outlier_m));
  }
  if (options.yaw_fixes < 1) {
    throw InvalidArgument("GeoRefOptions.yaw_fixes must be >= 1, got " +
                          std::to_string(options.yaw_fixes));
  }
}

GeoReferencer::GeoReferencer(const GeoRefOptions& options, bool fix_altitudes_above_sea_level)
    : options_(options), fix_altitudes_above_sea_level_(fix_altitudes_above_sea_level) {
  Validate(options_);
}

const LocalEnu& GeoReferencer::enu() const {
  if (!enu_) throw InvalidArgument("GeoReferencer::enu: no GPS fix observed yet");
  return *enu_;
}

bool GeoReferencer::Observe(const Eigen::Vector2d& local_m, const std::optional<GeoPoint>& gps,
                            std::optional<double> camera_yaw_deg) {
  if (!first_frame_seen_) {
    first_frame_seen_ = true;
    first_yaw_deg_ = camera_yaw_deg;
  }
  if (ready_ || !gps) return ready_;
  if (!enu_) {
    enu_.emplace(*gps);
    altitude_known_ = fix_altitudes_above_sea_level_;
  }
  const Eigen::Vector3d enu3 = enu_->Forward(*gps);
  const Eigen::Vector2d enu(enu3.x(), enu3.y());
  if (!local_m.allFinite() || !enu.allFinite()) return ready_;  // never into the sums
  if (!have_pair0_) {
    have_pair0_ = true;
    local0_ = local_m;
    enu0_ = enu;
  }

  const bool use_yaw = options_.heading_source == HeadingSource::kTelemetryYaw ||
                       (options_.heading_source == HeadingSource::kAuto && first_yaw_deg_);
  if (use_yaw && !first_yaw_deg_) {
    throw InputError("heading source 'yaw' requested but the first frame has no camera yaw");
  }
  pairs_.emplace_back(local_m, enu);
  if (use_yaw) {
    if (static_cast<int>(pairs_.size()) >= options_.yaw_fixes) FixFromYaw();
    return ready_;
  }
  // Closed-form 2-D rotation (Kabsch) about the centroids, from running sums of positions
  // relative to the first pair (keeps the sums small); centring removes the bias a noisy first
  // fix would put on every displacement.
  const Eigen::Vector2d dl = local_m - local0_, dg = enu - enu0_;
  sum_dot_ += dl.dot(dg);
  sum_cross_ += dl.x() * dg.y() - dl.y() * dg.x();
  sum_local_ += dl;
  sum_enu_ += dg;
  ++num_pairs_;
  if (dl.norm() >= options_.min_segment_m && dg.norm() >= options_.min_segment_m) FixFromSegment();
  return ready_;
}

void GeoReferencer::Restart() {
  if (ready_) throw InvalidArgument("GeoReferencer::Restart after the frame is known");
  enu_.reset();
  altitude_known_ = false;
  have_pair0_ = false;
  sum_dot_ = sum_cross_ = 0.0;
  sum_local_.setZero();
  sum_enu_.setZero();
  num_pairs_ = 0;
  pairs_.clear();
}

void GeoReferencer::SeedFromFix(const Eigen::Vector2d& local_m, double local_heading_rad,
                                const GeoPoint& at, double enu_heading_rad) {
  if (ready_) throw InvalidArgument("GeoReferencer::SeedFromFix after the frame is known");
  if (!local_m.allFinite() || !std::isfinite(local_heading_rad) ||
      !std::isfinite(enu_heading_rad)) {
    throw InvalidArgument("GeoReferencer::SeedFromFix: a position or heading is not finite");
  }
  if (!enu_) {
    enu_.emplace(at);
    altitude_known_ = false;
  }
  rotation_rad_ = std::remainder(enu_heading_rad - local_heading_rad, 2.0 * M_PI);
  translation_m_ = enu_->Forward(at).head<2>() - RotationMatrix2d(rotation_rad_) * local_m;
  source_used_ = "map";
  ready_ = true;
  pairs_.clear();
  pairs_.shrink_to_fit();
}

void GeoReferencer::FixFromYaw() {
  // Local +y (first image up) points along the compass bearing yaw0, whose ENU angle is
  // 90 deg - yaw0; +y itself is at 90 deg, hence a rotation of -yaw0.
  rotation_rad_ = EnuAngleRadFromBearingDeg(*first_yaw_deg_) - M_PI / 2.0;
  const Eigen::Matrix2d r = RotationMatrix2d(rotation_rad_);
  std::vector<double> tx, ty;
  for (const auto& [local, enu] : pairs_) {
    const Eigen::Vector2d t = enu - r * local;
    tx.push_back(t.x());
    ty.push_back(t.y());
  }
  const auto median = [](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  // The first fix's translation (as with yaw_fixes = 1) unless one of the others disagrees with
  // it by more than outlier_m: then the median, which one bad fix cannot move.
  const Eigen::Vector2d first(tx.front(), ty.front());
  bool agree = true;
  for (std::size_t i = 1; i < tx.size(); ++i) {
    agree = agree && (Eigen::Vector2d(tx[i], ty[i]) - first).norm() <= options_.outlier_m;
  }
  translation_m_ = agree ? first : Eigen::Vector2d(median(tx), median(ty));
  source_used_ = "telemetry-yaw";
  ready_ = true;
  pairs_.clear();
  pairs_.shrink_to_fit();
}

bool GeoReferencer::FixWithAvailable() {
  if (ready_ || pairs_.empty()) return ready_;
  const bool use_yaw = options_.heading_source == HeadingSource::kTelemetryYaw ||
                       (options_.heading_source == HeadingSource::kAuto && first_yaw_deg_);
  if (use_yaw) {
    FixFromYaw();
    return ready_;
  }
  if (num_pairs_ < 2) return ready_;
  const double n = num_pairs_;
  const double dot = sum_dot_ - sum_local_.dot(sum_enu_) / n;
  const double cross =
      sum_cross_ - (sum_local_.x() * sum_enu_.y() - sum_local_.y() * sum_enu_.x()) / n;
  if (std::hypot(dot, cross) < 1e-9) return false;  // no spread: the rotation is undefined
  FixFromSegment();
  return ready_;
}

void GeoReferencer::FixFromSegment() {
  double n = num_pairs_;
  double dot = sum_dot_ - sum_local_.dot(sum_enu_) / n;
  double cross = sum_cross_ - (sum_local_.x() * sum_enu_.y() - sum_local_.y() * sum_enu_.x()) / n;
  rotation_rad_ = std::atan2(cross, dot);
  // Translation through the centroids: every fix of the segment votes, not only the first.
  Eigen::Vector2d local_mean = local0_ + sum_local_ / n, enu_mean = enu0_ + sum_enu_ / n;
  translation_m_ = enu_mean - RotationMatrix2d(rotation_rad_) * local_mean;
  if (options_.outlier_m > 0.0 && pairs_.size() >= 3) {
    // Robust pass: residuals of the fit; the fixes beyond max(outlier_m, 5 sigma) are dropped
    // and the same closed form is solved again over the others.
    std::vector<double> res;
    res.reserve(pairs_.size());
    for (const auto& [local, enu] : pairs_) {
      res.push_back((enu - (RotationMatrix2d(rotation_rad_) * local + translation_m_)).norm());
    }
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double sigma = 1.4826 * sorted[sorted.size() / 2];
    const double limit = std::max(options_.outlier_m, 5.0 * sigma);
    double sd = 0.0, sc = 0.0;
    Eigen::Vector2d sl = Eigen::Vector2d::Zero(), se = Eigen::Vector2d::Zero();
    int kept = 0;
    for (std::size_t i = 0; i < pairs_.size(); ++i) {
      if (res[i] > limit) continue;
      const Eigen::Vector2d dl = pairs_[i].first - local0_, dg = pairs_[i].second - enu0_;
      sd += dl.dot(dg);
      sc += dl.x() * dg.y() - dl.y() * dg.x();
      sl += dl;
      se += dg;
      ++kept;
    }
    if (kept >= 2 && kept < static_cast<int>(pairs_.size())) {
      n = kept;
      dot = sd - sl.dot(se) / n;
      cross = sc - (sl.x() * se.y() - sl.y() * se.x()) / n;
      if (std::hypot(dot, cross) >= 1e-9) {
        outliers_ = static_cast<int>(pairs_.size()) - kept;
        rotation_rad_ = std::atan2(cross, dot);
        local_mean = local0_ + sl / n;
        enu_mean = enu0_ + se / n;
        translation_m_ = enu_mean - RotationMatrix2d(rotation_rad_) * local_mean;
      }
    }
  }
  source_used_ = "gps-segment";
  ready_ = true;
  pairs_.clear();
  pairs_.shrink_to_fit();
}

Eigen::Vector2d GeoReferencer::EnuFromLocal(const Eigen::Vector2d& local_m) const {
  if (!ready_) throw InvalidArgument("GeoReferencer::EnuFromLocal before the frame is known");
  return RotationMatrix2d(rotation_rad_) * local_m + translation_m_;
}

GeoPoint GeoReferencer::Wgs84FromLocal(const Eigen::Vector2d& local_m) const {
  const Eigen::Vector2d enu = EnuFromLocal(local_m);
  return enu_->Reverse(enu.x(), enu.y(), 0.0);
}

GeoPoint GeoReferencer::TrackWgs84FromLocal(const Eigen::Vector2d& local_m) const {
  GeoPoint p = Wgs84FromLocal(local_m);
  if (!altitude_known_) p.alt_m = std::numeric_limits<double>::quiet_NaN();
  return p;
}

}  // namespace aerovo
