#include "aerovo/camera_files/calibration.h"

#include <fstream>
#include <iterator>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::calibration_test {
namespace {

using io_test::TempDir;
using ::testing::HasSubstr;

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string ReadTextFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string ErrorOf(const std::filesystem::path& path) {
  try {
    ReadCalibration(path.string());
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

CameraIntrinsics Pinhole5() {
  CameraIntrinsics k;
  k.width_px = 4000;
  k.height_px = 3000;
  k.fx_px = 2345.678;
  k.fy_px = 2351.25;
  k.cx_px = 2003.5;
  k.cy_px = 1490.25;
  k.distortion = {-0.123, 0.045, 0.0012, -0.0007, -0.011};
  return k;
}

CameraIntrinsics Fisheye4() {
  CameraIntrinsics k;
  k.width_px = 1920;
  k.height_px = 1080;
  k.fx_px = 905.5;
  k.fy_px = 904.0;
  k.cx_px = 961.0;
  k.cy_px = 538.75;
  k.model = LensModel::kFisheye;
  k.distortion = {-0.04, 0.012, -0.003, 0.0004};
  return k;
}

void ExpectSame(const CameraIntrinsics& got, const CameraIntrinsics& want) {
  EXPECT_EQ(got.width_px, want.width_px);
  EXPECT_EQ(got.height_px, want.height_px);
  EXPECT_NEAR(got.fx_px, want.fx_px, 1e-9 * want.fx_px);
  EXPECT_NEAR(got.fy_px, want.fy_px, 1e-9 * want.fy_px);
  EXPECT_NEAR(got.cx_px, want.cx_px, 1e-9 * want.width_px);
  EXPECT_NEAR(got.cy_px, want.cy_px, 1e-9 * want.height_px);
  EXPECT_EQ(got.model, want.model);
  std::vector<double> g = got.distortion, w = want.distortion;
  g.resize(std::max(g.size(), w.size()), 0.0);
  w.resize(g.size(), 0.0);
  for (std::size_t i = 0; i < g.size(); ++i) EXPECT_NEAR(g[i], w[i], 1e-12) << "coefficient " << i;
}

TEST(Calibration, EveryFormatRoundTripsPinholeAndFisheye) {
  TempDir dir("aerovo_calib_rt");
  struct Case {
    const char* file;
    CalibrationFormat format;
  };
  const Case cases[] = {{"cam.yaml", CalibrationFormat::kOpenCv},
                        {"cam.xml", CalibrationFormat::kOpenCv},
                        {"cameras.json", CalibrationFormat::kOdmJson},
                        {"cameras.txt", CalibrationFormat::kColmapTxt}};
  for (const Case& c : cases) {
    for (const CameraIntrinsics& k : {Pinhole5(), Fisheye4()}) {
      SCOPED_TRACE(std::string(c.file) + " " + LensModelName(k.model));
      const std::string path = (dir / c.file).string();
      WriteCalibration(path, k, c.format);
      EXPECT_EQ(DetectCalibrationFormat(path), c.format);
      const Calibration got = ReadCalibration(path);
      EXPECT_EQ(got.format, c.format);
      ExpectSame(got.intrinsics, k);
    }
  }
  // Without an extension the content decides.
  for (const Case& c : cases) {
    const std::string path = (dir / "noext").string();
    WriteCalibration((dir / c.file).string(), Fisheye4(), c.format);
    std::filesystem::copy_file(dir / c.file, path, std::filesystem::copy_options::overwrite_existing);
    EXPECT_EQ(DetectCalibrationFormat(path), c.format) << c.file;
    ExpectSame(ReadCalibration(path).intrinsics, Fisheye4());
  }
  // OpenCV's XML without its declaration line, and without an extension, is still OpenCV's.
  const std::string xml = ReadTextFile(dir / "cam.xml");
  WriteText(dir / "nodecl", xml.substr(xml.find("<opencv_storage>")));
  EXPECT_EQ(DetectCalibrationFormat((dir / "nodecl").string()), CalibrationFormat::kOpenCv);
  ExpectSame(ReadCalibration((dir / "nodecl").string()).intrinsics, Fisheye4());
}

// Files as the tools write them.
TEST(Calibration, ReadsTheToolsOwnFiles) {
  TempDir dir("aerovo_calib_tools");
  // OpenCV's camera_calibration sample (saveCameraParams).
  WriteText(dir / "out_camera_data.yml", R"(%YAML:1.0
---
calibration_time: "Tue 01 Dec 2026"
nr_of_frames: 25
image_width: 1280
image_height: 720
flags: 0
fisheye_model: 0
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1.0042e+03, 0., 6.395e+02, 0., 1.0031e+03, 3.601e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -0.31, 0.12, 1.0e-03, -2.0e-04, -0.02 ]
avg_reprojection_error: 0.31
)");
  const CameraIntrinsics cv = ReadCalibration((dir / "out_camera_data.yml").string()).intrinsics;
  // The same file saved by an editor with a byte order mark and YAML 1.2's directive.
  const std::string yml = ReadTextFile(dir / "out_camera_data.yml");
  WriteText(dir / "bom.yml", "\xEF\xBB\xBF%YAML 1.2" + yml.substr(yml.find('\n')));
  EXPECT_EQ(ReadCalibration((dir / "bom.yml").string()).intrinsics.distortion,
            (std::vector<double>{-0.31, 0.12, 1.0e-03, -2.0e-04, -0.02}));
  EXPECT_EQ(cv.width_px, 1280);
  EXPECT_DOUBLE_EQ(cv.fx_px, 1004.2);
  EXPECT_DOUBLE_EQ(cv.cy_px, 360.1);
  EXPECT_EQ(cv.model, LensModel::kPinhole);
  EXPECT_EQ(cv.distortion, (std::vector<double>{-0.31, 0.12, 1.0e-03, -2.0e-04, -0.02}));

  // OpenDroneMap (OpenSfM "perspective": one focal, k1 k2, principal point at the centre).
  WriteText(dir / "cameras.json", R"({
    "v2 dji fc300s 4000 3000 perspective 0.5555": {
        "projection_type": "perspective", "width": 4000, "height": 3000,
        "focal": 0.5555, "k1": -0.01, "k2": 0.002 }
})");
  const Calibration odm = ReadCalibration((dir / "cameras.json").string());
  EXPECT_EQ(odm.camera_id, "v2 dji fc300s 4000 3000 perspective 0.5555");
  EXPECT_DOUBLE_EQ(odm.intrinsics.fx_px, 0.5555 * 4000);
  EXPECT_DOUBLE_EQ(odm.intrinsics.cx_px, 1999.5);
  EXPECT_DOUBLE_EQ(odm.intrinsics.cy_px, 1499.5);
  EXPECT_EQ(odm.intrinsics.distortion, (std::vector<double>{-0.01, 0.002, 0.0, 0.0}));
  // ODM brown: c_x, c_y offsets normalised by the larger side.
  WriteText(dir / "brown.json", R"({"v2 dji fc6310r 5472 3648 brown 0.6666": {
      "projection_type": "brown", "width": 1368, "height": 912, "focal_x": 0.6664, "focal_y": 0.6665,
      "c_x": -0.0015, "c_y": 0.0047, "k1": -0.264, "k2": 0.1018, "p1": 0.00073, "p2": 0.00026,
      "k3": -0.0258}})");
  const CameraIntrinsics brown = ReadCalibration((dir / "brown.json").string()).intrinsics;
  EXPECT_DOUBLE_EQ(brown.fy_px, 0.6665 * 1368);
  EXPECT_DOUBLE_EQ(brown.cx_px, 683.5 - 0.0015 * 1368);
  EXPECT_DOUBLE_EQ(brown.cy_px, 455.5 + 0.0047 * 1368);
  EXPECT_EQ(brown.distortion, (std::vector<double>{-0.264, 0.1018, 0.00073, 0.00026, -0.0258}));

  // COLMAP: comments, SIMPLE_RADIAL f cx cy k, pixel centres at half-integers.
  WriteText(dir / "cameras.txt",
            "# Camera list with one line of data per camera:\n"
            "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
            "# Number of cameras: 1\n"
            "1 SIMPLE_RADIAL 3072 2304 2559.81 1536 1152 -0.0204\n");
  const CameraIntrinsics colmap = ReadCalibration((dir / "cameras.txt").string()).intrinsics;
  EXPECT_DOUBLE_EQ(colmap.fx_px, 2559.81);
  EXPECT_DOUBLE_EQ(colmap.fy_px, 2559.81);
  EXPECT_DOUBLE_EQ(colmap.cx_px, 1535.5);
  EXPECT_DOUBLE_EQ(colmap.cy_px, 1151.5);
  EXPECT_EQ(colmap.distortion, (std::vector<double>{-0.0204, 0, 0, 0}));
  WriteText(dir / "fish.txt", "7 RADIAL_FISHEYE 640 480 300 320 240 0.1 -0.01\n");
  const CameraIntrinsics fish = ReadCalibration((dir / "fish.txt").string()).intrinsics;
  EXPECT_EQ(fish.model, LensModel::kFisheye);
  EXPECT_EQ(fish.distortion, (std::vector<double>{0.1, -0.01, 0, 0}));
}

TEST(Calibration, ErrorsNameTheFileAndTheLineOrKey) {
  TempDir dir("aerovo_calib_err");
  EXPECT_THAT(ErrorOf(dir / "missing.yaml"), HasSubstr("no such file"));
  WriteText(dir / "nokey.yaml", "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n");
  EXPECT_THAT(ErrorOf(dir / "nokey.yaml"), HasSubstr("no key 'camera_matrix'"));
  EXPECT_THAT(ErrorOf(dir / "nokey.yaml"), HasSubstr("nokey.yaml"));
  WriteText(dir / "broken.yaml", "%YAML:1.0\n---\nimage_width: [1, \n");
  EXPECT_THAT(ErrorOf(dir / "broken.yaml"), HasSubstr("broken.yaml"));
  // A matrix whose stated size is not the data's is refused before OpenCV allocates it (3 x 2^31
  // doubles would be 48 GiB; fuzz_calibration found it in the XML form).
  const auto matrix = [](const std::string& rows, const std::string& cols, const std::string& dt,
                         const std::string& extra = "") {
    return "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n"
           "camera_matrix: !!opencv-matrix\n   rows: " +
           rows + "\n   cols: " + cols + "\n   dt: " + dt + "\n" + extra +
           "   data: [ 500., 0., 319.5, 0., 500., 239.5, 0., 0., 1. ]\n";
  };
  // Files on which OpenCV 4.6's own reader threw std::length_error (key.yaml) or never returned
  // (hang.yaml, 64 bytes): errors naming the line (fuzz_calibration found both).
  WriteText(dir / "key.yaml", "%YAML:1.0\n   dt: d\n   :1.0");
  EXPECT_THAT(ErrorOf(dir / "key.yaml"), HasSubstr("key.yaml': line 4: could not find expected"));
  WriteText(dir / "hang.yaml",
            "%YAML:1.1\n---image_width:0.1\n--\xaa-image_width:WWW\xaa\xa8\xd2\x9a"
            "e:WWW\xaa\xa8\xd2\x9a"
            "e-\n");
  EXPECT_THAT(ErrorOf(dir / "hang.yaml"), HasSubstr("hang.yaml': line "));
  // A video named by mistake is refused by its size before it is read (a sparse 17 MiB file).
  WriteText(dir / "flight.mp4", "");
  std::filesystem::resize_file(dir / "flight.mp4", std::uintmax_t{17} << 20);
  EXPECT_THAT(ErrorOf(dir / "flight.mp4"),
              HasSubstr("flight.mp4': 17825792 bytes, not a calibration file"));
  WriteText(dir / "seq.yaml", "%YAML:1.0\n--- [1, 2]\n");
  EXPECT_THAT(ErrorOf(dir / "seq.yaml"),
              HasSubstr("seq.yaml': line 2: not a map of keys at the top (an OpenCV calibration"));
  WriteText(dir / "root.xml", "<?xml version=\"1.0\"?>\n<svg><rows>3</rows></svg>\n");
  EXPECT_THAT(ErrorOf(dir / "root.xml"),
              HasSubstr("root.xml': the XML's top element is <svg>, not <opencv_storage>"));
  WriteText(dir / "cut.xml", "<?xml version=\"1.0\"?>\n<opencv_storage><image_width>640");
  EXPECT_THAT(ErrorOf(dir / "cut.xml"), HasSubstr("cut.xml' at byte "));
  EXPECT_THAT(ErrorOf(dir / "cut.xml"), HasSubstr("not valid XML"));
  WriteText(dir / "alias.yaml", "%YAML:1.0\n---\na: &x 640\nimage_width: *x\n");
  EXPECT_THAT(ErrorOf(dir / "alias.yaml"), HasSubstr("alias.yaml': line 4: an alias"));
  WriteText(dir / "deep.yaml", "%YAML:1.0\n---\na: " + std::string(100000, '[') + "\n");
  EXPECT_THAT(ErrorOf(dir / "deep.yaml"), HasSubstr("deep.yaml': line 3: nested deeper than 16"));
  WriteText(dir / "huge.yaml", matrix("3", "2147483647", "d"));
  EXPECT_THAT(ErrorOf(dir / "huge.yaml"),
              HasSubstr("huge.yaml': key 'camera_matrix' is not a matrix of 1 to 64 rows and "
                        "columns (cols is '2147483647')"));
  WriteText(dir / "colon.yaml", matrix("3", "':'", "d"));
  EXPECT_THAT(ErrorOf(dir / "colon.yaml"), HasSubstr("(cols is ':')"));
  WriteText(dir / "norows.yaml", matrix("3", "3", "d", "   sizes: [ 3, 3000000000 ]\n"));
  EXPECT_THAT(ErrorOf(dir / "norows.yaml"),
              HasSubstr("key 'camera_matrix' is not a matrix (a map of rows, cols, dt and data)"));
  WriteText(dir / "channels.yaml", matrix("1", "3", "\"3d\""));
  EXPECT_THAT(ErrorOf(dir / "channels.yaml"),
              HasSubstr("key 'camera_matrix' is a matrix of 3 channels, not 1"));
  WriteText(dir / "short.yaml", matrix("3", "4", "d"));
  EXPECT_THAT(ErrorOf(dir / "short.yaml"), HasSubstr("key 'camera_matrix' is not a matrix ("));
  WriteText(dir / "huge.xml",
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n"
            "<image_height>480</image_height>\n<camera_matrix type_id=\"opencv-matrix\">\n"
            "<rows>3</rows><cols>:</cols><dt>d</dt>\n<data>500. 0. 319.5 0. 500. 239.5 0. 0. 1."
            "</data></camera_matrix>\n</opencv_storage>\n");
  EXPECT_THAT(ErrorOf(dir / "huge.xml"),
              HasSubstr("key 'camera_matrix' is not a matrix of 1 to 64 rows and columns (cols"));

  WriteText(dir / "bad.txt", "# cameras\n1 PINHOLE 640 480 500 500 320 240\n2 PINHOLE 640 480 1 1 1 1\n");
  EXPECT_THAT(ErrorOf(dir / "bad.txt"), HasSubstr("line 3: a second camera (the first is on line 2)"));
  WriteText(dir / "fov.txt", "1 FOV 640 480 500 500 320 240 0.9\n");
  EXPECT_THAT(ErrorOf(dir / "fov.txt"), HasSubstr("line 1: camera model 'FOV' is not supported"));
  WriteText(dir / "count.txt", "\n\n1 OPENCV 640 480 500 500 320 240 0.1\n");
  EXPECT_THAT(ErrorOf(dir / "count.txt"), HasSubstr("line 3: model OPENCV has 8 parameters, not 5"));
  WriteText(dir / "nan.txt", "1 PINHOLE 640 480 500 abc 320 240\n");
  EXPECT_THAT(ErrorOf(dir / "nan.txt"), HasSubstr("line 1: parameter 'abc' is not a number"));
  // Numbers as ParseDecimal reads them (core/text.h): std::stod took "nan", "inf" and hexadecimal.
  WriteText(dir / "nank.txt", "1 OPENCV 640 480 500 500 320 240 nan 0 0 0\n");
  EXPECT_THAT(ErrorOf(dir / "nank.txt"), HasSubstr("line 1: parameter 'nan' is not a number"));
  WriteText(dir / "hex.txt", "1 PINHOLE 0x280 480 500 500 320 240\n");
  EXPECT_THAT(ErrorOf(dir / "hex.txt"), HasSubstr("line 1: WIDTH '0x280' is not a number"));
  WriteText(dir / "inf.txt", "1 PINHOLE 640 inf 500 500 320 240\n");
  EXPECT_THAT(ErrorOf(dir / "inf.txt"), HasSubstr("line 1: HEIGHT 'inf' is not a number"));
  WriteText(dir / "outside.txt", "1 PINHOLE 640 480 500 500 900 240\n");
  EXPECT_THAT(ErrorOf(dir / "outside.txt"), HasSubstr("line 1: CameraIntrinsics principal point"));

  WriteText(dir / "two.json", R"({"a": {"projection_type": "brown"}, "b": {}})");
  EXPECT_THAT(ErrorOf(dir / "two.json"), HasSubstr("has 2 cameras ('a', 'b')"));
  WriteText(dir / "nofocal.json", R"({"cam": {"projection_type": "brown", "width": 10, "height": 10}})");
  EXPECT_THAT(ErrorOf(dir / "nofocal.json"), HasSubstr("camera 'cam' has no key 'focal_x'"));
  WriteText(dir / "sph.json", R"({"cam": {"projection_type": "spherical", "width": 10, "height": 5}})");
  EXPECT_THAT(ErrorOf(dir / "sph.json"), HasSubstr("projection_type 'spherical' is not supported"));
  WriteText(dir / "overflow.json", R"({"cam": {"projection_type": "brown", "width": 912e666}})");
  EXPECT_THAT(ErrorOf(dir / "overflow.json"), HasSubstr("overflow.json': not valid JSON ("));
  WriteText(dir / "notjson.json", "{ nope");
  EXPECT_THAT(ErrorOf(dir / "notjson.json"), HasSubstr("not valid JSON"));
}

// An OpenCV calibrateCamera YAML file of a 320x240 camera (the layout of OpenCV's
// cv::FileStorage: "%YAML:1.0", !!opencv-matrix with rows, cols, dt, data).
std::string OpenCvYaml(const std::string& size, const std::string& focal,
                       const std::string& distortion) {
  return "%YAML:1.0\n---\n" + size +
         "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ " + focal +
         ", 0., 160., 0., " + focal +
         ", 120., 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: "
         "5\n   dt: d\n   data: [ " +
         distortion + " ]\n";
}

TEST(Calibration, HostileValuesAreErrorsNamingTheKeyAtFault) {
  TempDir dir("aerovo_calib_hostile");
  const std::string size = "image_width: 320\nimage_height: 240\n";
  // A focal length that is not a number, zero or negative: camera_matrix, not (as before) the
  // distortion_coefficients, is named.
  for (const char* focal : {"0.", "-300."}) {
    WriteText(dir / "focal.yaml", OpenCvYaml(size, focal, "0., 0., 0., 0., 0."));
    EXPECT_THAT(ErrorOf(dir / "focal.yaml"),
                HasSubstr("focal.yaml' (key 'camera_matrix'): CameraIntrinsics focal"))
        << focal;
  }
  // YAML's .nan (which OpenCV reads as NaN) is not a number a calibration may hold.
  WriteText(dir / "focal.yaml", OpenCvYaml(size, ".nan", "0., 0., 0., 0., 0."));
  EXPECT_THAT(ErrorOf(dir / "focal.yaml"),
              HasSubstr("focal.yaml': key 'camera_matrix' holds '.nan', not a number"));
  WriteText(dir / "size0.yaml",
            OpenCvYaml("image_width: 0\nimage_height: 240\n", "300.", "0., 0., 0., 0., 0."));
  EXPECT_THAT(ErrorOf(dir / "size0.yaml"),
              HasSubstr("size0.yaml': key 'image_width' 0 is not an image size in pixels (1 .. "
                        "1000000)"));
  // Sizes beyond an int: before, 99999999999 wrapped around to 1215752191.
  WriteText(dir / "wide.txt", "1 PINHOLE 99999999999 240 300 300 160 120\n");
  EXPECT_THAT(ErrorOf(dir / "wide.txt"),
              HasSubstr("wide.txt' line 1: WIDTH 99999999999 is not an image size in pixels"));
  WriteText(dir / "tall.json",
            R"({"cam": {"projection_type": "perspective", "width": 320, "height": -240, )"
            R"("focal": 0.9}})");
  EXPECT_THAT(ErrorOf(dir / "tall.json"),
              HasSubstr("tall.json' camera 'cam': key 'height' -240 is not an image size"));
}

TEST(Calibration, ADistortionThatTurnsBackInsideTheImageIsAnError) {
  TempDir dir("aerovo_calib_fold");
  const std::string size = "image_width: 320\nimage_height: 240\n";
  // k1 = -3 at f = 300 px: r_d = r (1 - 3 r^2) peaks at r_d = 0.222 (r = 1/3), the corner of the
  // image is at r_d = 200 / 300 = 0.667: no ray reaches it. Before: a completed run, frames
  // folded by the undistortion.
  WriteText(dir / "k1.yaml", OpenCvYaml(size, "300.", "-3., 0., 0., 0., 0."));
  EXPECT_THAT(ErrorOf(dir / "k1.yaml"),
              HasSubstr("k1.yaml' (key 'distortion_coefficients'): the distortion (-3 0 0 0 0) has "
                        "no ray for pixel (30, 0) of its 320x240 image"));
  // k1 = 0.5, k2 = -2: r_d peaks at 0.555 (r = 0.63), below the corner's 0.667.
  WriteText(dir / "k2.yaml", OpenCvYaml(size, "300.", "0.5, -2., 0., 0., 0."));
  EXPECT_THAT(ErrorOf(dir / "k2.yaml"), HasSubstr("the model turns back before the image's edge"));
  WriteText(dir / "k1.txt", "# c\n1 SIMPLE_RADIAL 320 240 300 160 120 -5\n");
  EXPECT_THAT(ErrorOf(dir / "k1.txt"), HasSubstr("k1.txt' line 2: the distortion (-5 0 0 0)"));
  // A strong barrel lens that stays monotonic over its image is read: k1 = -0.3, r_d peaks at
  // 0.703 (r = 1.054), beyond the corner's 0.667.
  WriteText(dir / "barrel.yaml", OpenCvYaml(size, "300.", "-0.3, 0., 0., 0., 0."));
  EXPECT_NEAR(ReadCalibration((dir / "barrel.yaml").string()).intrinsics.distortion[0], -0.3, 0);
  // A fit that turns back in the outer corners only is read (the check stops at 90 % of the
  // corner's distance, 180 px): k1 = -0.385, r_d peaks at 0.62 (186 px, r = 0.93).
  WriteText(dir / "corners.yaml", OpenCvYaml(size, "300.", "-0.385, 0., 0., 0., 0."));
  EXPECT_NEAR(ReadCalibration((dir / "corners.yaml").string()).intrinsics.distortion[0], -0.385, 0);
}

}  // namespace
}  // namespace aerovo::calibration_test
