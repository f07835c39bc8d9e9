// Pinhole camera over flat ground: the geometry of the simulator.
//
// Frames (all right-handed):
// - map frame: East-North-Up metres; origin at the outer north-west corner of the ground image,
//   the ground is the plane z = 0 (flat), z is the height above it.
// - camera frame: x to the image right, y to the image bottom, z along the optical axis.
// - image: pixel (u, v) = column, row; pixel centres at integer coordinates, (0, 0) = top-left
//   pixel centre; the principal point is the image centre ((w - 1) / 2, (h - 1) / 2).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "aerovo/camera/pinhole.h"

namespace aerovo::sim {

/// The simulator's camera settings: square pixels, principal point at the image centre, an ideal
/// pinhole by default or a lens with known distortion (`lens`, `distortion`: OpenCV's pinhole or
/// fisheye model, camera/pinhole.h LensModel) so that undistortion can be checked against exact
/// truth. Its maths is camera/pinhole.h (Intrinsics below).
struct CameraModel {
  /// Image size (px). Default 1280 x 720 (720p video); 1920 x 1080 is the other common choice.
  int width_px = 1280;
  int height_px = 720;
  /// Horizontal field of view (deg). Default 73.7 deg: a 35 mm-equivalent 24 mm lens across the
  /// full 36 mm width (DJI Phantom 4 / Mavic class wide cameras).
  double hfov_deg = 73.7;
  /// Focal length (px); when > 0 it overrides hfov_deg. 0 = derive it from hfov_deg.
  double focal_px = 0.0;
  /// Lens model of `distortion`. Default pinhole.
  LensModel lens = LensModel::kPinhole;
  /// Distortion coefficients in OpenCV's order for `lens` (pinhole: k1 k2 p1 p2 [k3 ...];
  /// fisheye: k1 k2 k3 k4). Empty (default) = none. With a fisheye lens focal_px / hfov_deg
  /// are those of the pinhole the frames undistort to (the lens's own f in r_d = f theta_d).
  std::vector<double> distortion;
};

/// Throws aerovo::InvalidArgument naming the bad field.
void Validate(const CameraModel& camera);

/// Focal length in pixels: focal_px if set, else (width / 2) / tan(hfov / 2)
/// (FocalPxFromHorizontalFov).
double FocalPx(const CameraModel& camera);

/// Horizontal field of view (deg) implied by the model (hfov_deg, or the one focal_px gives).
double HorizontalFovDeg(const CameraModel& camera);

/// The model as intrinsics: f = FocalPx, cx = (w - 1) / 2, cy = (h - 1) / 2, the lens and
/// distortion of the model. Throws InvalidArgument for a non-positive size or focal length.
CameraIntrinsics Intrinsics(const CameraModel& camera);

/// K = [f 0 cx; 0 f cy; 0 0 1] of Intrinsics(camera).
Eigen::Matrix3d IntrinsicMatrix(const CameraModel& camera);

/// Pose of the camera at one frame.
struct CameraPose {
  double time_s = 0.0;  ///< Time since the first frame (s).
  /// Camera centre in the map frame (m): east, north, height above the flat ground.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  /// Compass heading of the image's top direction (deg, clockwise from north): with yaw 0 the
  /// image is north-up. A nadir drone camera's image top points forward, so following the track
  /// means yaw = track heading.
  double yaw_deg = 0.0;
  /// Tilt about the camera x axis (deg); positive tilts the optical axis towards the image top.
  double pitch_deg = 0.0;
  /// Tilt about the camera y axis (deg); positive tilts the optical axis towards the image right.
  double roll_deg = 0.0;
};

/// Rotation map_from_camera (columns: camera x, y, z axes in the map frame): nadir for
/// yaw = pitch = roll = 0, then R = R_nadir(yaw) * Rx(pitch) * Ry(roll).
Eigen::Matrix3d MapFromCameraRotation(const CameraPose& pose);

/// Homography image_from_map: (u, v, 1) ~ H * (east_m, north_m, 1) for points on the ground
/// plane z = 0, of the ideal pinhole (a distorted camera's undistorted image). Precondition: the
/// camera is above the ground (position z > 0).
Eigen::Matrix3d ImageFromGroundHomography(const CameraModel& camera, const CameraPose& pose);

/// The camera has lens distortion (CameraModel::distortion not all zero).
bool HasDistortion(const CameraModel& camera);

/// Pixel where the ground point (east_m, north_m, 0) appears, through the lens's distortion
/// (may be outside the image; NaN if the point is behind the camera).
Eigen::Vector2d ProjectGroundPoint(const CameraModel& camera, const CameraPose& pose,
                                   const Eigen::Vector2d& ground_en_m);

/// Ground point (east, north) seen at pixel (u, v): the inverse of ProjectGroundPoint (the
/// lens's distortion undone iteratively). NaN when the pixel's ray does not hit the ground
/// (horizon).
Eigen::Vector2d BackProjectPixel(const CameraModel& camera, const CameraPose& pose,
                                 const Eigen::Vector2d& pixel);

/// The lens's inverse on normalised coordinates: where the ideal pinhole has the ray that the
/// lens images at normalised (x_d, y_d) = ((u - cx) / f, (v - cy) / f). Identity without
/// distortion.
Eigen::Vector2d UndistortNormalised(const CameraModel& camera, const Eigen::Vector2d& distorted);

/// Nadir ground sampling distance h / f (metres per image pixel at the image centre).
double NadirGsdMetresPerPx(const CameraModel& camera, double height_m);

}  // namespace aerovo::sim
