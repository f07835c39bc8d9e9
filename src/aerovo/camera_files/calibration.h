// Camera calibration files users already have, read by one function (ReadCalibration) and
// written by one (WriteCalibration, for tests and for `aerovo simulate`): OpenCV's
// calibrateCamera YAML/XML, OpenDroneMap/OpenSfM cameras.json and COLMAP cameras.txt. Every
// format becomes a CameraIntrinsics (camera/pinhole.h: pixel centres at integer coordinates,
// pinhole or fisheye lens, OpenCV coefficient orders). The formats, their sources and their
// conversions: docs/lenses.md.
#pragma once

#include <string>

#include "aerovo/camera/pinhole.h"

namespace aerovo {

enum class CalibrationFormat {
  /// cv::FileStorage YAML or XML (by the file's extension) of calibrateCamera's results:
  /// image_width, image_height, camera_matrix (3x3), distortion_coefficients (1xN or Nx1), and
  /// for a fisheye lens `distortion_model: fisheye` (or "equidistant", or the OpenCV
  /// camera_calibration sample's `fisheye_model: 1`).
  kOpenCv,
  /// OpenDroneMap / OpenSfM cameras.json: {"<camera id>": {projection_type, width, height,
  /// focal / focal_x, focal_y, c_x, c_y, k1 ...}}; focal and c_x, c_y normalised by max(width,
  /// height), c_x, c_y relative to the image centre.
  kOdmJson,
  /// COLMAP cameras.txt: "CAMERA_ID MODEL WIDTH HEIGHT PARAMS..." lines, '#' comments; pixel
  /// centres at half-integers (COLMAP's convention), so cx = cx_colmap - 0.5.
  kColmapTxt,
};

const char* CalibrationFormatName(CalibrationFormat format);

struct Calibration {
  CameraIntrinsics intrinsics;
  CalibrationFormat format = CalibrationFormat::kOpenCv;
  /// The camera's name in the file (ODM camera id, COLMAP CAMERA_ID; empty for OpenCV).
  std::string camera_id;
};

/// The format of `path`: by extension (.yaml .yml .xml: OpenCV; .json: ODM; .txt: COLMAP), else
/// by content ("%YAML" or '<': OpenCV; '{': ODM; else COLMAP). InputError when the file
/// cannot be read.
CalibrationFormat DetectCalibrationFormat(const std::string& path);

/// Reads the one camera of a calibration file. Throws InputError naming the file and the line
/// (COLMAP), key (ODM, OpenCV) and problem: unreadable or malformed file, missing or
/// non-numeric key, unsupported lens model (e.g. COLMAP FOV, THIN_PRISM_FISHEYE; OpenSfM
/// spherical, dual), several cameras in one file, invalid values (CameraIntrinsics Validate).
Calibration ReadCalibration(const std::string& path);

/// Writes `intrinsics` as `format` (OpenCV: YAML, or XML when the path ends in .xml) so that
/// ReadCalibration gives them back (to 1e-9 relative). Formats that cannot hold the camera
/// throw InvalidArgument: ODM and COLMAP have no 5- or 8-coefficient pinhole of their own
/// besides brown (k1 k2 p1 p2 k3) / FULL_OPENCV (8 coefficients). OutputError when the file cannot
/// be written. The file is written atomically (outputs/output_file.h WriteFileAtomic): a failure
/// leaves the earlier file or none, never a part.
void WriteCalibration(const std::string& path, const CameraIntrinsics& intrinsics,
                      CalibrationFormat format, const std::string& camera_id = "aerovo");

}  // namespace aerovo
