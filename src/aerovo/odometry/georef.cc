#include "aerovo/odometry/georef.h"

#include <cmath>

#include "aerovo/core/error.h"
#include "aerovo/geo/geodesic.h"

namespace aerovo {
namespace {
Eigen::Matrix2d Rotation(double angle_rad) {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  return (Eigen::Matrix2d() << c, -s, s, c).finished();
}
}  // namespace

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
}

GeoReferencer::GeoReferencer(const GeoRefOptions& options) : options_(options) {
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
    local0_ = local_m;
    enu0_.setZero();
  }
  const Eigen::Vector3d enu3 = enu_->Forward(*gps);
  const Eigen::Vector2d enu(enu3.x(), enu3.y());

  const bool use_yaw = options_.heading_source == HeadingSource::kTelemetryYaw ||
                       (options_.heading_source == HeadingSource::kAuto && first_yaw_deg_);
  if (use_yaw) {
    if (!first_yaw_deg_) {
      throw InputError("heading source 'yaw' requested but the first frame has no camera yaw");
    }
    // Local +y (first image up) points along the compass bearing yaw0, whose ENU angle is
    // 90 deg - yaw0; +y itself is at 90 deg, hence a rotation of -yaw0.
    rotation_rad_ = EnuAngleRadFromBearingDeg(*first_yaw_deg_) - M_PI / 2.0;
    translation_m_ = enu - Rotation(rotation_rad_) * local_m;
    source_used_ = "telemetry-yaw";
    ready_ = true;
    return true;
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

bool GeoReferencer::FixWithAvailable() {
  if (ready_ || num_pairs_ < 2) return ready_;
  const double n = num_pairs_;
  const double dot = sum_dot_ - sum_local_.dot(sum_enu_) / n;
  const double cross =
      sum_cross_ - (sum_local_.x() * sum_enu_.y() - sum_local_.y() * sum_enu_.x()) / n;
  if (std::hypot(dot, cross) < 1e-9) return false;  // no spread: the rotation is undefined
  FixFromSegment();
  return ready_;
}

void GeoReferencer::FixFromSegment() {
  const double n = num_pairs_;
  const double dot = sum_dot_ - sum_local_.dot(sum_enu_) / n;
  const double cross =
      sum_cross_ - (sum_local_.x() * sum_enu_.y() - sum_local_.y() * sum_enu_.x()) / n;
  rotation_rad_ = std::atan2(cross, dot);
  // Translation through the centroids: every fix of the segment votes, not only the first.
  const Eigen::Vector2d local_mean = local0_ + sum_local_ / n, enu_mean = enu0_ + sum_enu_ / n;
  translation_m_ = enu_mean - Rotation(rotation_rad_) * local_mean;
  source_used_ = "gps-segment";
  ready_ = true;
}

Eigen::Vector2d GeoReferencer::EnuFromLocal(const Eigen::Vector2d& local_m) const {
  if (!ready_) throw InvalidArgument("GeoReferencer::EnuFromLocal before the frame is known");
  return Rotation(rotation_rad_) * local_m + translation_m_;
}

GeoPoint GeoReferencer::Wgs84FromLocal(const Eigen::Vector2d& local_m) const {
  const Eigen::Vector2d enu = EnuFromLocal(local_m);
  return enu_->Reverse(enu.x(), enu.y(), 0.0);
}

}  // namespace aerovo
