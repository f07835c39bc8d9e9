#include "aerovo/camera_files/calibration.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <system_error>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "aerovo/camera/lens.h"
#include "aerovo/camera_files/opencv_storage.h"
#include "aerovo/core/error.h"
#include "aerovo/core/text.h"
#include "aerovo/outputs/output_file.h"

namespace aerovo {
namespace {

namespace fs = std::filesystem;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// The largest calibration file read, bytes. The three formats hold one camera in a few KB; a
// video or an image named by mistake (`--calibration flight.mp4`) would otherwise be read whole
// into memory before it is refused.
constexpr std::uintmax_t kMaxCalibrationBytes = std::uintmax_t{16} << 20;

// The whole file; InputError when it cannot be read or is larger than kMaxCalibrationBytes.
std::string ReadText(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > kMaxCalibrationBytes) {
    throw InputError(fmt::format(
        "calibration '{}': {} bytes, not a calibration file (one camera's OpenCV, ODM or COLMAP "
        "file is a few KB; at most {} MiB are read)",
        path, size, kMaxCalibrationBytes >> 20));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("calibration '{}': cannot be read", path));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The largest image side a calibration may give, px: ours, far beyond any camera's, small
// enough for an int (a side of 99999999999 would wrap around).
constexpr double kMaxImageSidePx = 1e6;

// `v` (a file's image width or height) as a whole number of pixels; InputError naming the file,
// `where` and `what` when it is not a number in 1 .. kMaxImageSidePx.
int PixelCount(const std::string& path, const std::string& where, const char* what, double v) {
  if (!(v >= 1.0 && v <= kMaxImageSidePx)) {
    throw InputError(
        fmt::format("calibration '{}'{}: {} {:.15g} is not an image size in pixels (1 .. "
                    "{:.0f})",
                    path, where, what, v, kMaxImageSidePx));
  }
  return static_cast<int>(std::lround(v));
}

// A pinhole lens model whose distortion turns back inside its image (camera/lens.h
// FirstFoldedPixel): InputError naming the file and the first such pixel.
void CheckMonotonic(const std::string& path, const std::string& where, const CameraIntrinsics& k) {
  const std::optional<std::array<double, 2>> pixel = FirstFoldedPixel(k);
  if (!pixel) return;
  std::string coefficients;
  for (double d : k.distortion) {
    coefficients += fmt::format("{}{:g}", coefficients.empty() ? "" : " ", d);
  }
  throw InputError(fmt::format(
      "calibration '{}'{}: the distortion ({}) has no ray for pixel ({:.0f}, {:.0f}) of its "
      "{}x{} image: the model turns back before the image's edge (a fit without points "
      "near the edges?), so it does not describe this lens there",
      path, where, coefficients, (*pixel)[0], (*pixel)[1], k.width_px, k.height_px));
}

// Validates the result and names the file when it is not a camera (or its lens model folds its
// image, CheckMonotonic).
CameraIntrinsics Checked(const std::string& path, const std::string& where, CameraIntrinsics k) {
  try {
    Validate(k);
  } catch (const InvalidArgument& e) {
    throw InputError(fmt::format("calibration '{}'{}: {}", path, where, e.what()));
  }
  CheckMonotonic(path, where, k);
  return k;
}

// ---- OpenCV cv::FileStorage -------------------------------------------------------------------

// The most rows or columns a calibration matrix may have: a camera matrix is 3x3, OpenCV's
// longest distortion vector 14 (calibrateCamera with the rational, thin-prism and tilt models).
constexpr int kMaxMatrixSide = 64;

// A value as text for a message: a number, or a string as Printable quotes it (core/text.h: at
// most 40 bytes, control and invalid bytes as \xNN).
std::string ValueText(const nlohmann::json& n) {
  if (n.is_number()) {
    const double v = n.get<double>();
    return std::fabs(v) < 1e15 && v == std::floor(v) ? fmt::format("{:.0f}", v)
                                                     : fmt::format("{:g}", v);
  }
  if (n.is_string()) return Printable(n.get_ref<const std::string&>(), 40);
  return n.is_object() ? "a map" : n.is_array() ? "a sequence" : "not a value";
}

// The channels a cv::FileStorage `dt` names for a matrix's elements (e.g. "d": 1, "3d": 3);
// 0 when it is not one element type of OpenCV's ("u c w s i f d h", after an optional count).
int MatrixChannels(const std::string& dt) {
  std::size_t i = 0;
  int count = 0;
  while (i < dt.size() && i < 3 && std::isdigit(static_cast<unsigned char>(dt[i]))) {
    count = count * 10 + (dt[i++] - '0');
  }
  if (i + 1 != dt.size() || std::strchr("ucwsifdh", dt[i]) == nullptr || dt[i] == '\0') return 0;
  return i == 0 ? 1 : count;
}

// A matrix of a calibration file: rows x cols values, row-major.
struct Matrix {
  int rows = 0, cols = 0;
  std::vector<double> values;
  double at(int r, int c) const { return values[static_cast<std::size_t>(r * cols + c)]; }
};

// The keys of an OpenCV file (camera_files_detail::ParseOpenCvStorage); each getter throws
// InputError naming the file and the key.
struct OpenCvKeys {
  const std::string& path;
  const nlohmann::json& root;

  bool Has(const char* key) const { return root.contains(key); }
  // The value of `key`; InputError when it is missing.
  const nlohmann::json& Need(const char* key) const {
    if (!Has(key)) throw InputError(fmt::format("calibration '{}': no key '{}'", path, key));
    return root.at(key);
  }
  // The number of `key`; InputError when missing or not a number.
  double NeedNumber(const char* key) const {
    const nlohmann::json& n = Need(key);
    if (!n.is_number()) {
      throw InputError(fmt::format("calibration '{}': key '{}' is not a number", path, key));
    }
    return n.get<double>();
  }
  // The matrix of `key`; InputError when missing, not a one-channel matrix of 1 to
  // kMaxMatrixSide rows and columns, or when its data are not rows x cols numbers.
  Matrix NeedMat(const char* key) const {
    const nlohmann::json& node = Need(key);
    if (!node.is_object() || node.contains("sizes") || !node.contains("data")) {
      throw InputError(
          fmt::format("calibration '{}': key '{}' is not a matrix (a map of rows, "
                      "cols, dt and data)",
                      path, key));
    }
    Matrix m;
    const auto side = [&](const char* name) {
      const nlohmann::json n = node.value(name, nlohmann::json());
      const double v = n.is_number() ? n.get<double>() : 0.0;
      if (!(v >= 1.0 && v <= kMaxMatrixSide && v == std::floor(v))) {
        throw InputError(fmt::format(
            "calibration '{}': key '{}' is not a matrix of 1 to {} rows and columns ({} is {})",
            path, key, kMaxMatrixSide, name,
            n.is_null() ? std::string("missing") : "'" + ValueText(n) + "'"));
      }
      return static_cast<int>(v);
    };
    m.rows = side("rows");
    m.cols = side("cols");
    const nlohmann::json dt = node.value("dt", nlohmann::json("d"));
    const int channels = dt.is_string() ? MatrixChannels(dt.get<std::string>()) : 0;
    if (channels == 0) {
      throw InputError(fmt::format(
          "calibration '{}': key '{}' has the element type dt '{}', not one of OpenCV's (d, f, "
          "i, ...)",
          path, key, ValueText(dt)));
    }
    if (channels != 1) {
      throw InputError(fmt::format("calibration '{}': key '{}' is a matrix of {} channels, not 1",
                                   path, key, channels));
    }
    const nlohmann::json& data = node.at("data");
    const std::size_t want = static_cast<std::size_t>(m.rows * m.cols);
    if (!data.is_array() || data.size() != want) {
      throw InputError(fmt::format(
          "calibration '{}': key '{}' is not a matrix ({} x {} needs {} values, its data has {})",
          path, key, m.rows, m.cols, want, data.is_array() ? data.size() : std::size_t{1}));
    }
    for (const nlohmann::json& v : data) {
      if (!v.is_number()) {
        throw InputError(fmt::format("calibration '{}': key '{}' holds '{}', not a number", path,
                                     key, ValueText(v)));
      }
      m.values.push_back(v.get<double>());
    }
    return m;
  }
};

// Sets fx, fy, cx, cy (pixels) of `k` from camera_matrix; InputError when it is not 3x3 or has
// a skew.
void ReadOpenCvCameraMatrix(const OpenCvKeys& keys, CameraIntrinsics& k) {
  const Matrix km = keys.NeedMat("camera_matrix");
  if (km.rows != 3 || km.cols != 3) {
    throw InputError(fmt::format("calibration '{}': key 'camera_matrix' is {}x{}, not 3x3",
                                 keys.path, km.rows, km.cols));
  }
  k.fx_px = km.at(0, 0);
  k.fy_px = km.at(1, 1);
  k.cx_px = km.at(0, 2);
  k.cy_px = km.at(1, 2);
  if (km.at(0, 1) != 0.0) {
    throw InputError(
        fmt::format("calibration '{}': key 'camera_matrix' has a skew {} (not "
                    "supported: pixels must be rectangular)",
                    keys.path, km.at(0, 1)));
  }
}

// The distortion_coefficients as written (empty when the key is absent); InputError when they
// are not a vector.
std::vector<double> ReadOpenCvDistortion(const OpenCvKeys& keys) {
  if (!keys.Has("distortion_coefficients")) return {};
  Matrix d = keys.NeedMat("distortion_coefficients");
  if (d.rows != 1 && d.cols != 1) {
    throw InputError(
        fmt::format("calibration '{}': key 'distortion_coefficients' is {}x{}, not a vector",
                    keys.path, d.rows, d.cols));
  }
  return std::move(d.values);
}

// Whether the file names a fisheye lens (distortion_model fisheye or equidistant, or a non-zero
// fisheye_model); InputError for a distortion_model that is not one we know.
bool OpenCvIsFisheye(const OpenCvKeys& keys) {
  bool fisheye = false;
  if (keys.Has("distortion_model")) {
    const nlohmann::json& model = keys.root.at("distortion_model");
    const std::string m = model.is_string() ? Lower(model.get<std::string>()) : ValueText(model);
    if (m == "fisheye" || m == "equidistant") {
      fisheye = true;
    } else if (!(m == "pinhole" || m == "plumb_bob" || m == "radtan" ||
                 m == "rational_polynomial")) {
      throw InputError(
          fmt::format("calibration '{}': key 'distortion_model' '{}' is not one of "
                      "pinhole, plumb_bob, rational_polynomial, fisheye, equidistant",
                      keys.path, Printable(m, 40)));
    }
  }
  if (keys.Has("fisheye_model")) {
    const nlohmann::json& fisheye_model = keys.root.at("fisheye_model");
    if (fisheye_model.is_number() && fisheye_model.get<double>() != 0.0) fisheye = true;
  }
  return fisheye;
}

// Brings OpenCV's coefficient counts to the ones CameraIntrinsics takes (camera/pinhole.h):
// trailing zeros past 8 dropped, a pinhole's 1-3 padded to 4 or 5 and 6-7 to 8 with zeros.
void NormaliseOpenCvDistortion(bool fisheye, std::vector<double>& d) {
  // calibrateCamera with CALIB_RATIONAL_MODEL etc. writes 12 or 14 coefficients; the thin-prism
  // and tilt terms are beyond our model, but trailing zeros are harmless.
  while (d.size() > 8 && d.back() == 0.0) d.pop_back();
  if (!fisheye && (d.size() == 6 || d.size() == 7)) d.resize(8, 0.0);
  if (!fisheye && (d.size() == 1 || d.size() == 2 || d.size() == 3)) {
    d.resize(d.size() == 3 ? 5 : 4, 0.0);
  }
}

// Reads an OpenCV calibrateCamera YAML/XML file (CalibrationFormat::kOpenCv) with libyaml or
// pugixml (opencv_storage.h says why not with OpenCV's reader); InputError naming the file and
// key for every problem.
Calibration ReadOpenCv(const std::string& path) {
  const nlohmann::json root = camera_files_detail::ParseOpenCvStorage(ReadText(path), path);
  const OpenCvKeys keys{path, root};
  Calibration c;
  c.format = CalibrationFormat::kOpenCv;
  CameraIntrinsics& k = c.intrinsics;
  k.width_px = PixelCount(path, "", "key 'image_width'", keys.NeedNumber("image_width"));
  k.height_px = PixelCount(path, "", "key 'image_height'", keys.NeedNumber("image_height"));
  ReadOpenCvCameraMatrix(keys, k);
  k.distortion = ReadOpenCvDistortion(keys);
  const bool fisheye = OpenCvIsFisheye(keys);
  if (fisheye) k.model = LensModel::kFisheye;
  NormaliseOpenCvDistortion(fisheye, k.distortion);
  // The size and camera_matrix first, so that an error names the key at fault.
  CameraIntrinsics geometry = k;
  geometry.model = LensModel::kPinhole;
  geometry.distortion.clear();
  Checked(path, " (key 'camera_matrix')", geometry);
  c.intrinsics = Checked(path, " (key 'distortion_coefficients')", k);
  return c;
}

void WriteOpenCv(const std::string& path, const CameraIntrinsics& k) {
  // Written to memory in the format of the path's extension (.xml or YAML), then to the file
  // atomically (outputs/output_file.h), so a failed write leaves the old file or none.
  const std::string ext = std::filesystem::path(path).extension().string();
  const bool xml = ext == ".xml" || ext == ".XML";
  cv::FileStorage out;
  std::string text;
  try {
    if (!out.open(xml ? ".xml" : ".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY)) {
      throw InputError(fmt::format("calibration '{}': cannot be written", path));
    }
    out << "image_width" << k.width_px;
    out << "image_height" << k.height_px;
    out << "distortion_model" << LensModelName(k.model);
    const cv::Mat km = (cv::Mat_<double>(3, 3) << k.fx_px, 0, k.cx_px, 0, k.fy_px, k.cy_px, 0, 0, 1);
    out << "camera_matrix" << km;
    std::vector<double> d = k.distortion;
    if (d.empty()) d.assign(k.model == LensModel::kFisheye ? 4 : 5, 0.0);
    out << "distortion_coefficients" << cv::Mat(d, true).reshape(1, 1);
    text = out.releaseAndGetString();
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("calibration '{}': cannot be written ({})", path, e.msg));
  }
  WriteFileAtomic(path, text);
}

// ---- OpenDroneMap / OpenSfM cameras.json -----------------------------------------------------
// OpenSfM's camera models (opensfm docs, "Camera models"; ODM writes cameras.json with them):
// normalised image coordinates put the image centre at 0 with the larger side spanning
// [-0.5, 0.5], so a pixel (integer centres) is u = x max(w, h) + (w - 1) / 2; focal, focal_x,
// focal_y and c_x, c_y are in those units.
//   perspective:     focal, k1, k2                 radial (1 + k1 r^2 + k2 r^4)
//   simple_radial:   focal_x, focal_y, c_x, c_y, k1
//   radial:          focal_x, focal_y, c_x, c_y, k1, k2
//   brown:           focal_x, focal_y, c_x, c_y, k1, k2, k3, p1, p2 (OpenCV's pinhole model)
//   fisheye:         focal, k1, k2                 theta_d = theta (1 + k1 theta^2 + k2 theta^4)
//   fisheye_opencv:  focal_x, focal_y, c_x, c_y, k1, k2, k3, k4 (OpenCV's fisheye model)

// The parsed cameras.json of `path`: an object holding exactly one camera; InputError when the
// file is not JSON, not an object of cameras, or holds several cameras (named in the message).
nlohmann::json ReadOdmCameras(const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ReadText(path));
  } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for 1e400
    throw InputError(fmt::format("calibration '{}': not valid JSON ({})", path, e.what()));
  }
  if (!j.is_object() || j.empty()) {
    throw InputError(fmt::format(
        "calibration '{}': expected an OpenDroneMap cameras.json object of cameras", path));
  }
  if (j.size() > 1) {
    std::string names;
    for (auto it = j.begin(); it != j.end(); ++it) {
      names += (names.empty() ? "'" : ", '") + it.key() + "'";
    }
    throw InputError(
        fmt::format("calibration '{}' has {} cameras ({}): keep the one of this flight", path,
                    j.size(), names));
  }
  return j;
}

// One camera of a cameras.json; Num throws InputError naming the file, camera and key.
struct OdmCamera {
  const std::string& path;
  const std::string& id;
  const nlohmann::json& cam;

  // The number of `key`, or `fallback` when the key is absent (InputError without a fallback, or
  // when the value is not a number).
  double Num(const char* key, std::optional<double> fallback = std::nullopt) const {
    if (!cam.contains(key)) {
      if (fallback) return *fallback;
      throw InputError(fmt::format("calibration '{}': camera '{}' has no key '{}'", path, id, key));
    }
    if (!cam[key].is_number()) {
      throw InputError(
          fmt::format("calibration '{}': camera '{}' key '{}' is not a number", path, id, key));
    }
    return cam[key].get<double>();
  }
};

// The camera's projection_type; InputError when it is missing, not a string or not one of the
// models above.
std::string ReadOdmProjectionType(const OdmCamera& odm) {
  const nlohmann::json& cam = odm.cam;
  if (!cam.is_object() || !cam.contains("projection_type") || !cam["projection_type"].is_string()) {
    throw InputError(fmt::format(
        "calibration '{}': camera '{}' has no string key 'projection_type'", odm.path, odm.id));
  }
  const std::string type = cam["projection_type"].get<std::string>();
  static const char* const kTypes[] = {"perspective", "simple_radial", "radial",
                                       "brown",       "fisheye",       "fisheye_opencv"};
  if (std::find(std::begin(kTypes), std::end(kTypes), type) == std::end(kTypes)) {
    throw InputError(fmt::format(
        "calibration '{}': camera '{}' projection_type '{}' is not supported (perspective, "
        "simple_radial, radial, brown, fisheye, fisheye_opencv)",
        odm.path, odm.id, type));
  }
  return type;
}

// Sets the lens model and the OpenCV-order distortion coefficients of `k` from the camera's k1..
// (absent ones 0) for projection `type` (one of the models above).
void ReadOdmDistortion(const OdmCamera& odm, const std::string& type, CameraIntrinsics& k) {
  if (type == "perspective") {
    k.distortion = {odm.Num("k1", 0.0), odm.Num("k2", 0.0), 0.0, 0.0};
  } else if (type == "simple_radial") {
    k.distortion = {odm.Num("k1", 0.0), 0.0, 0.0, 0.0};
  } else if (type == "radial") {
    k.distortion = {odm.Num("k1", 0.0), odm.Num("k2", 0.0), 0.0, 0.0};
  } else if (type == "brown") {
    k.distortion = {odm.Num("k1", 0.0), odm.Num("k2", 0.0), odm.Num("p1", 0.0), odm.Num("p2", 0.0),
                    odm.Num("k3", 0.0)};
  } else if (type == "fisheye") {
    k.model = LensModel::kFisheye;
    k.distortion = {odm.Num("k1", 0.0), odm.Num("k2", 0.0), 0.0, 0.0};
  } else if (type == "fisheye_opencv") {
    k.model = LensModel::kFisheye;
    k.distortion = {odm.Num("k1", 0.0), odm.Num("k2", 0.0), odm.Num("k3", 0.0), odm.Num("k4", 0.0)};
  }
}

// Reads an OpenDroneMap / OpenSfM cameras.json (CalibrationFormat::kOdmJson): size in pixels,
// focal and principal point from normalised units to pixels; InputError naming file, camera, key.
Calibration ReadOdm(const std::string& path) {
  const nlohmann::json j = ReadOdmCameras(path);
  const std::string id = j.begin().key();
  const OdmCamera odm{path, id, j.begin().value()};
  const std::string type = ReadOdmProjectionType(odm);
  Calibration c;
  c.format = CalibrationFormat::kOdmJson;
  c.camera_id = id;
  CameraIntrinsics& k = c.intrinsics;
  const std::string where = fmt::format(" camera '{}'", id);
  k.width_px = PixelCount(path, where, "key 'width'", odm.Num("width"));
  k.height_px = PixelCount(path, where, "key 'height'", odm.Num("height"));
  const double size = std::max(k.width_px, k.height_px);
  double fx = 0, fy = 0, cx = 0, cy = 0;
  const bool single_focal = type == "perspective" || type == "fisheye";
  if (single_focal) {
    fx = fy = odm.Num("focal");
  } else {
    fx = odm.Num("focal_x");
    fy = odm.Num("focal_y", fx);
    cx = odm.Num("c_x", 0.0);
    cy = odm.Num("c_y", 0.0);
  }
  k.fx_px = fx * size;
  k.fy_px = fy * size;
  k.cx_px = cx * size + 0.5 * (k.width_px - 1);
  k.cy_px = cy * size + 0.5 * (k.height_px - 1);
  ReadOdmDistortion(odm, type, k);
  c.intrinsics = Checked(path, where, k);
  return c;
}

void WriteOdm(const std::string& path, const CameraIntrinsics& k, const std::string& id) {
  const double size = std::max(k.width_px, k.height_px);
  nlohmann::json cam = {{"width", k.width_px},
                        {"height", k.height_px},
                        {"focal_x", k.fx_px / size},
                        {"focal_y", k.fy_px / size},
                        {"c_x", (k.cx_px - 0.5 * (k.width_px - 1)) / size},
                        {"c_y", (k.cy_px - 0.5 * (k.height_px - 1)) / size}};
  std::vector<double> d = k.distortion;
  if (k.model == LensModel::kFisheye) {
    d.resize(4, 0.0);
    cam["projection_type"] = "fisheye_opencv";
    cam["k1"] = d[0];
    cam["k2"] = d[1];
    cam["k3"] = d[2];
    cam["k4"] = d[3];
  } else {
    if (d.size() > 5 && std::any_of(d.begin() + 5, d.end(), [](double v) { return v != 0.0; })) {
      throw InvalidArgument(fmt::format(
          "calibration '{}': OpenDroneMap's brown model has no k4 k5 k6 (rational model)", path));
    }
    d.resize(5, 0.0);
    cam["projection_type"] = "brown";
    cam["k1"] = d[0];
    cam["k2"] = d[1];
    cam["p1"] = d[2];
    cam["p2"] = d[3];
    cam["k3"] = d[4];
  }
  WriteFileAtomic(path, nlohmann::json{{id, cam}}.dump(2) + "\n");
}

// ---- COLMAP cameras.txt ------------------------------------------------------------------------
// COLMAP's camera models (colmap.github.io/cameras.html and src/colmap/sensor/models.h): the
// parameter order of each model below. COLMAP's image coordinates put the upper-left corner of
// the image at (0, 0), so the first pixel's centre is (0.5, 0.5) (colmap.github.io/format.html):
// cx_px = cx - 0.5. The *_FISHEYE models are OpenCV's fisheye with fewer coefficients.

struct ColmapModel {
  const char* name;
  int params;
};

constexpr ColmapModel kColmapModels[] = {
    {"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4},
    {"SIMPLE_RADIAL", 4},  {"RADIAL", 5},
    {"OPENCV", 8},         {"OPENCV_FISHEYE", 8},
    {"FULL_OPENCV", 12},   {"SIMPLE_RADIAL_FISHEYE", 4},
    {"RADIAL_FISHEYE", 5},
};

// One camera line of cameras.txt as written: CAMERA_ID MODEL WIDTH HEIGHT PARAMS...
struct ColmapLine {
  std::string id, model;
  double width = 0, height = 0;
  std::vector<double> params;
};

// Splits camera line `line_no` of `path` into its fields; InputError naming the file and line
// when the first four are missing or a parameter is not a number.
ColmapLine ParseColmapLine(const std::string& path, int line_no, const std::string& line) {
  std::istringstream fields(line);
  ColmapLine l;
  std::string width, height;
  if (!(fields >> l.id >> l.model >> width >> height)) {
    throw InputError(
        fmt::format("calibration '{}' line {}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...",
                    path, line_no));
  }
  const auto number = [&](const std::string& tok, const char* what) {
    const std::optional<double> v = ParseDecimal(tok);
    if (!v) {
      throw InputError(fmt::format("calibration '{}' line {}: {} '{}' is not a number", path,
                                   line_no, what, tok));
    }
    return *v;
  };
  l.width = number(width, "WIDTH");
  l.height = number(height, "HEIGHT");
  std::string tok;
  while (fields >> tok) l.params.push_back(number(tok, "parameter"));
  return l;
}

// Checks that the line's model is one of kColmapModels and has its number of parameters;
// InputError naming the file and line otherwise.
void CheckColmapModel(const std::string& path, int line_no, const ColmapLine& l) {
  const ColmapModel* m = nullptr;
  for (const ColmapModel& candidate : kColmapModels) {
    if (l.model == candidate.name) m = &candidate;
  }
  if (m == nullptr) {
    throw InputError(fmt::format(
        "calibration '{}' line {}: camera model '{}' is not supported (SIMPLE_PINHOLE, PINHOLE, "
        "SIMPLE_RADIAL, RADIAL, OPENCV, OPENCV_FISHEYE, FULL_OPENCV, SIMPLE_RADIAL_FISHEYE, "
        "RADIAL_FISHEYE)",
        path, line_no, l.model));
  }
  if (static_cast<int>(l.params.size()) != m->params) {
    throw InputError(fmt::format("calibration '{}' line {}: model {} has {} parameters, not {}",
                                 path, line_no, l.model, m->params, l.params.size()));
  }
}

// The intrinsics of a checked camera line (not yet validated; InputError naming the file and line
// for a size that is not pixels): size rounded to pixels, the
// principal point moved from COLMAP's half-integer pixel centres to ours, the coefficients in
// OpenCV's order.
CameraIntrinsics ColmapIntrinsics(const std::string& path, int line_no, const ColmapLine& l) {
  const std::string& model = l.model;
  const std::vector<double>& p = l.params;
  CameraIntrinsics k;
  const std::string where = fmt::format(" line {}", line_no);
  k.width_px = PixelCount(path, where, "WIDTH", l.width);
  k.height_px = PixelCount(path, where, "HEIGHT", l.height);
  const bool one_focal = p.size() == 3 || model == "SIMPLE_RADIAL" || model == "RADIAL" ||
                         model == "SIMPLE_RADIAL_FISHEYE" || model == "RADIAL_FISHEYE";
  std::size_t i = 0;
  k.fx_px = p[i++];
  k.fy_px = one_focal ? k.fx_px : p[i++];
  k.cx_px = p[i++] - 0.5;
  k.cy_px = p[i++] - 0.5;
  const std::vector<double> rest(p.begin() + static_cast<long>(i), p.end());
  if (model == "SIMPLE_RADIAL") {
    k.distortion = {rest[0], 0, 0, 0};
  } else if (model == "RADIAL") {
    k.distortion = {rest[0], rest[1], 0, 0};
  } else if (model == "OPENCV") {
    k.distortion = rest;
  } else if (model == "FULL_OPENCV") {
    // COLMAP: k1 k2 p1 p2 k3 k4 k5 k6, OpenCV's order.
    k.distortion = rest;
  } else if (model == "OPENCV_FISHEYE") {
    k.model = LensModel::kFisheye;
    k.distortion = rest;
  } else if (model == "SIMPLE_RADIAL_FISHEYE") {
    k.model = LensModel::kFisheye;
    k.distortion = {rest[0], 0, 0, 0};
  } else if (model == "RADIAL_FISHEYE") {
    k.model = LensModel::kFisheye;
    k.distortion = {rest[0], rest[1], 0, 0};
  }
  return k;
}

// Reads a COLMAP cameras.txt (CalibrationFormat::kColmapTxt) holding one camera line ('#'
// comments and blank lines skipped); InputError naming the file and line for every problem.
Calibration ReadColmap(const std::string& path) {
  std::istringstream text(ReadText(path));
  std::string line;
  int line_no = 0;
  Calibration c;
  c.format = CalibrationFormat::kColmapTxt;
  int cameras = 0, first_line = 0;
  while (std::getline(text, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    ++cameras;
    if (cameras > 1) {
      throw InputError(fmt::format(
          "calibration '{}' line {}: a second camera (the first is on line {}): keep the one of "
          "this flight",
          path, line_no, first_line));
    }
    first_line = line_no;
    const ColmapLine l = ParseColmapLine(path, line_no, line);
    CheckColmapModel(path, line_no, l);
    c.camera_id = l.id;
    c.intrinsics =
        Checked(path, fmt::format(" line {}", line_no), ColmapIntrinsics(path, line_no, l));
  }
  if (cameras == 0) {
    throw InputError(fmt::format("calibration '{}': no camera line (CAMERA_ID MODEL WIDTH HEIGHT "
                                 "PARAMS...)",
                                 path));
  }
  return c;
}

void WriteColmap(const std::string& path, const CameraIntrinsics& k, const std::string& id) {
  std::vector<double> d = k.distortion;
  std::string model;
  std::vector<double> p = {k.fx_px, k.fy_px, k.cx_px + 0.5, k.cy_px + 0.5};
  if (k.model == LensModel::kFisheye) {
    model = "OPENCV_FISHEYE";
    d.resize(4, 0.0);
  } else if (d.empty()) {
    model = "PINHOLE";
  } else if (d.size() == 4) {
    model = "OPENCV";
  } else {
    model = "FULL_OPENCV";
    d.resize(8, 0.0);
  }
  p.insert(p.end(), d.begin(), d.end());
  std::string text =
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      "# Number of cameras: 1\n";
  text += fmt::format("{} {} {} {}", id.empty() ? std::string("1") : id, model, k.width_px,
                      k.height_px);
  for (double v : p) text += fmt::format(" {:.17g}", v);
  WriteFileAtomic(path, text + "\n");
}

}  // namespace

const char* CalibrationFormatName(CalibrationFormat format) {
  switch (format) {
    case CalibrationFormat::kOpenCv: return "OpenCV YAML/XML";
    case CalibrationFormat::kOdmJson: return "OpenDroneMap cameras.json";
    case CalibrationFormat::kColmapTxt: return "COLMAP cameras.txt";
  }
  return "?";
}

CalibrationFormat DetectCalibrationFormat(const std::string& path) {
  const std::string ext = Lower(fs::path(path).extension().string());
  if (ext == ".yaml" || ext == ".yml" || ext == ".xml") return CalibrationFormat::kOpenCv;
  if (ext == ".json") return CalibrationFormat::kOdmJson;
  if (ext == ".txt") return CalibrationFormat::kColmapTxt;
  const std::string text = ReadText(path);
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) throw InputError(fmt::format("calibration '{}' is empty", path));
  // OpenCV's YAML ("%YAML:1.0") or XML ("<?xml", or its <opencv_storage> without a
  // declaration: opencv_storage.h reads any text starting with '<' as XML).
  if (text.compare(first, 5, "%YAML") == 0 || text[first] == '<') {
    return CalibrationFormat::kOpenCv;
  }
  if (text[first] == '{') return CalibrationFormat::kOdmJson;
  return CalibrationFormat::kColmapTxt;
}

Calibration ReadCalibration(const std::string& path) {
  if (!fs::is_regular_file(path)) {
    throw InputError(fmt::format("calibration '{}': no such file", path));
  }
  switch (DetectCalibrationFormat(path)) {
    case CalibrationFormat::kOpenCv: return ReadOpenCv(path);
    case CalibrationFormat::kOdmJson: return ReadOdm(path);
    case CalibrationFormat::kColmapTxt: return ReadColmap(path);
  }
  throw InputError(fmt::format("calibration '{}': unknown format", path));
}

void WriteCalibration(const std::string& path, const CameraIntrinsics& intrinsics,
                      CalibrationFormat format, const std::string& camera_id) {
  Validate(intrinsics);
  switch (format) {
    case CalibrationFormat::kOpenCv: WriteOpenCv(path, intrinsics); return;
    case CalibrationFormat::kOdmJson: WriteOdm(path, intrinsics, camera_id); return;
    case CalibrationFormat::kColmapTxt: WriteColmap(path, intrinsics, camera_id); return;
  }
}

}  // namespace aerovo
