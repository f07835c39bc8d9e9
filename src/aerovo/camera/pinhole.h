// The camera model shared by every module: pinhole intrinsics with optional lens distortion
// coefficients, and the conversions between a focal length in pixels, a 35 mm-equivalent focal
// length and a horizontal field of view. No OpenCV here (sim/ uses it); undistorting frames is
// frames/camera.h Undistorter, resolving a run's camera from options and metadata frames/camera.h
// ResolveCamera.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aerovo {

/// Diagonal of the 36 x 24 mm full frame: sqrt(36^2 + 24^2) = 43.2666 mm.
inline constexpr double kFullFrameDiagonalMm = 43.266615305567875;

/// Focal length in pixels from a 35 mm-equivalent focal length. The equivalent focal length
/// (EXIF FocalLengthIn35mmFilm, CIPA DC-008) gives the same angle of view as on a 36 x 24 mm
/// frame; the angle matched is the DIAGONAL one, because sensors differ in aspect ratio:
///   f_px = f35_mm / 43.27 mm * sqrt(width_px^2 + height_px^2).
/// Example (tampa-phantom3, FC300S): 20 mm at 800x600 -> 20 / 43.27 * 1000 = 462.2 px.
/// (Using the 36 mm width instead would give 444.4 px, 4 % short for a 4:3 sensor.)
/// Throws InvalidArgument for f35 <= 0 or an empty size.
double FocalPxFrom35mm(double focal_35mm_mm, int width_px, int height_px);

/// The same for an image that is a crop of a sensor whose full frame has the aspect ratio
/// `sensor_aspect` (long side / short side, >= 1; e.g. 4/3). A 35 mm equivalent belongs to the
/// sensor's full frame, not to a cropped photo mode: DJI's specifications give one equivalent
/// focal length per camera (Phantom 3 Professional: 20 mm, FOV 94 deg, the diagonal FOV of the
/// 4:3 frame) for its 4:3 and 16:9 photo sizes alike, and its 16:9 photos (4000x2250) keep the
/// sensor's full width. So the diagonal used is that of the full frame that contains the image
/// with one side in common: when the image is wider than the sensor (16:9 from 4:3), its long
/// side is the sensor's; when it is narrower (1:1 from 4:3), its short side is.
///   f_px = f35_mm / 43.27 mm * diag,  diag = L sqrt(1 + 1/A^2) if L/S >= A, else S sqrt(1 + A^2)
/// (L, S the image's long and short sides, A = sensor_aspect). With A = L/S it is
/// FocalPxFrom35mm. Example: Phantom 3, 20 mm at 4000x2250 with A = 4/3: 2311 px (the 16:9
/// diagonal would give 2121 px, 8 % short). Throws InvalidArgument for f35 <= 0, an empty size
/// or sensor_aspect < 1.
double FocalPxFrom35mmOfSensor(double focal_35mm_mm, int width_px, int height_px,
                               double sensor_aspect);

/// The inverse of FocalPxFrom35mm: f35_mm = f_px * 43.27 mm / sqrt(width_px^2 + height_px^2).
/// Throws InvalidArgument for f_px <= 0 or an empty size.
double Focal35mmFromPx(double focal_px, int width_px, int height_px);

/// Focal length in pixels from the horizontal field of view: f = (w / 2) / tan(hfov / 2).
/// Throws InvalidArgument unless 0 < hfov_deg < 180 and width_px > 0.
double FocalPxFromHorizontalFov(double hfov_deg, int width_px);

/// Horizontal field of view (degrees) of a focal length in pixels: 2 atan(w / (2 f)).
double HorizontalFovDeg(double focal_px, int width_px);

/// The lens model of CameraIntrinsics::distortion (OpenCV's two models, docs/lenses.md).
enum class LensModel {
  /// Pinhole with Brown-Conrady distortion (cv::undistort / calibrateCamera): for normalised
  /// x = X/Z, y = Y/Z and r^2 = x^2 + y^2, x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) /
  /// (1 + k4 r^2 + k5 r^4 + k6 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2), y_d likewise; coefficients
  /// k1 k2 p1 p2 [k3 [k4 k5 k6]].
  kPinhole,
  /// Equidistant fisheye (cv::fisheye): theta = atan(r), theta_d = theta (1 + k1 theta^2 +
  /// k2 theta^4 + k3 theta^6 + k4 theta^8), x_d = (theta_d / r) x; coefficients k1 k2 k3 k4.
  /// Covers fields of view beyond 180 degrees' tangent limit of the pinhole model.
  kFisheye,
};

/// "pinhole" / "fisheye"; ParseLensModel throws InvalidArgument for another name.
const char* LensModelName(LensModel model);
LensModel ParseLensModel(const std::string& name);

/// Camera with optional distortion (`model`: OpenCV's pinhole or fisheye model and their
/// coefficient orders, see LensModel), all in pixels of the frames as delivered. Camera frame:
/// x to the image right, y to the image bottom, z along the optical axis. Pixel centres at
/// integer coordinates, so the centre of a W x H image is ((W - 1) / 2, (H - 1) / 2).
struct CameraIntrinsics {
  int width_px = 0;
  int height_px = 0;
  double fx_px = 0.0;
  double fy_px = 0.0;
  double cx_px = 0.0;
  double cy_px = 0.0;
  std::vector<double> distortion;  ///< Empty or all zero = no distortion.
  LensModel model = LensModel::kPinhole;

  bool HasDistortion() const;
  /// K = [fx 0 cx; 0 fy cy; 0 0 1]: pixel (u, v, 1) ~ K * (x, y, z) of a camera-frame point.
  Eigen::Matrix3d K() const;
};

/// Square pixels, principal point at the image centre ((w - 1) / 2, (h - 1) / 2), no
/// distortion. Throws InvalidArgument as Validate does.
CameraIntrinsics IntrinsicsFromFocalPx(double focal_px, int width_px, int height_px);

/// The same camera for frames of another size with the same aspect ratio (a calibration made at
/// full resolution used on reduced frames, or the reverse): focal lengths scale by
/// new_width / width and new_height / height, the principal point keeps its place relative to
/// the pixel-centre grid (c' = (c + 0.5) s - 0.5), the distortion coefficients (on normalised
/// coordinates) are unchanged. Throws InvalidArgument naming both sizes when the aspect ratios
/// differ by more than 1 % (a crop, not a scaling: the calibration does not apply).
CameraIntrinsics ScaledTo(const CameraIntrinsics& intrinsics, int width_px, int height_px);

/// Throws InvalidArgument naming the field: size <= 0, focal <= 0 or not finite, principal
/// point outside the image, distortion with a count other than 0, 4, 5, 8 (pinhole) or 0, 4
/// (fisheye).
void Validate(const CameraIntrinsics& intrinsics);

}  // namespace aerovo
