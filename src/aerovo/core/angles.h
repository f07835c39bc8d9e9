// Angle constants and the plane rotation, shared by the modules (one definition, so that a unity
// build, which compiles several sources of a module as one, never sees two).
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace aerovo {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;  // radians per degree
inline constexpr double kRadToDeg = 180.0 / kPi;  // degrees per radian

/// The counter-clockwise rotation of the plane by `angle_rad` (radians):
/// [cos -sin; sin cos], x to y for a positive angle.
inline Eigen::Matrix2d RotationMatrix2d(double angle_rad) {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  return (Eigen::Matrix2d() << c, -s, s, c).finished();
}

}  // namespace aerovo
