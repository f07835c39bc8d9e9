// The camera's attitude and the virtual nadir camera (docs/attitude.md): a camera that is not
// looking straight down sees the ground point under its image centre h tan(tilt) away from the
// point under the aircraft, and its ground sampling distance varies across the frame. Mapping
// each keypoint through the frame's rotation to a virtual nadir camera with the same centre and
// focal length (the homography K R K^-1 of a pure rotation, Hartley & Zisserman 2004, 8.4.2)
// makes every step a step between nadir-equivalent images: over flat ground a similarity whose
// image-centre displacement times h / f is the aircraft's own displacement. No I/O.
//
// Frames:
// - camera frame: x image right, y image down, z optical axis (as pose_chain.h's pixels).
// - camera FRD frame: x = image up ("forward"), y = image right, z = optical axis ("down"): the
//   body frame of an aircraft carrying a nadir camera with the image top towards its nose.
// - level frame: the camera FRD frame with roll and pitch removed (x, y horizontal, z down;
//   x the horizontal direction of the image top).
// CameraAttitude's roll and pitch are the aerospace (Z-Y-X, yaw dropped) angles of the camera
// FRD frame in the level frame: level_from_camera_frd = Ry(pitch) * Rx(roll). So pitch > 0
// tilts the optical axis towards the image top (forward of nadir), roll > 0 towards the image
// left (the aircraft's right wing down); 0, 0 = nadir. Sources (converted in pipeline/run_steps):
// a DJI gimbal's pitch + 90 and roll (gimbal pitch -90 = nadir), the aircraft's own roll and
// pitch for a camera fixed nadir under it (with a mount angle), the simulator's pitch_deg and
// -roll_deg (sim/camera.h).
#pragma once

#include <Eigen/Core>

namespace aerovo {

/// Roll and pitch of the camera (degrees; see the file comment for the frames and signs).
struct CameraAttitude {
  double roll_deg = 0.0;
  double pitch_deg = 0.0;
};

/// level_from_camera_frd = Ry(pitch) * Rx(roll).
Eigen::Matrix3d LevelFromCameraFrd(const CameraAttitude& attitude);

/// The attitude (roll, pitch) of a rotation level_from_camera_frd: the Z-Y-X angles with the
/// yaw dropped (a rotation about the vertical only turns the virtual nadir image, which the
/// odometry's heading follows). Precondition: |pitch| < 90 deg.
CameraAttitude AttitudeOfRotation(const Eigen::Matrix3d& level_from_camera_frd);

/// Angle between the optical axis and the vertical, degrees.
double TiltFromNadirDeg(const CameraAttitude& attitude);

/// The smallest depression (angle below the horizon, degrees) of the rays through the four
/// corners of a `width_px` x `height_px` frame (pixel centres at the edges, focal length
/// `focal_px`, principal point (`cx_px`, `cy_px`)) of a camera at `attitude`: negative when a
/// corner looks above the horizon. A nadir view of the frame exists only where every ray meets
/// the ground (depression > 0); NadirFromCameraHomography sends rays near the horizon towards
/// infinity. 90 - the half diagonal field of view for a nadir camera. Precondition: focal_px > 0.
double LowestCornerDepressionDeg(const CameraAttitude& attitude, double focal_px, double cx_px,
                                 double cy_px, int width_px, int height_px);

/// Homography nadir_from_camera on pixels: a pixel of the tilted camera to the pixel of the same
/// ray in the virtual nadir camera with the same centre, focal length `focal_px` and principal
/// point (`cx_px`, `cy_px`) (K P^T R P K^-1, P the camera-to-FRD axis swap, R =
/// LevelFromCameraFrd). The virtual camera's principal point is the ground point under the
/// aircraft. Precondition: focal_px > 0.
Eigen::Matrix3d NadirFromCameraHomography(const CameraAttitude& attitude, double focal_px,
                                          double cx_px, double cy_px);

/// The ground point under the image centre relative to the point under the camera over flat
/// ground `height_m` below: (forward along the image top's horizontal direction, right), metres.
/// For a pitch alone this is (height tan(pitch), 0). Precondition: tilt < 90 deg.
Eigen::Vector2d ImageCentreGroundOffsetM(const CameraAttitude& attitude, double height_m);

}  // namespace aerovo
