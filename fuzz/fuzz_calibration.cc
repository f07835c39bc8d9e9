// libFuzzer target: camera calibration files (aerovo::ReadCalibration): OpenCV calibrateCamera
// YAML / XML (read with libyaml and pugixml, camera_files/opencv_storage.h; Debian's
// uninstrumented builds: the coverage feedback comes from aerovo's code, ASan still sees the
// heap), OpenDroneMap cameras.json and
// COLMAP cameras.txt. ReadCalibration reads a path, so each input is written to one file of a
// private temporary folder; the file has no extension, and the format is recognised by content
// (calibration.h DetectCalibrationFormat), as for a file a user names without one. A read either
// throws InputError or returns a camera that passes Validate (camera/pinhole.h); anything else
// (another exception, a crash, a sanitizer report) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "aerovo/camera/pinhole.h"
#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/error.h"
#include "fuzz_files.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = aerovo::fuzz::MakeFolder("calibration") + "calibration";
  aerovo::fuzz::WriteInput(path, data, size);
  try {
    const aerovo::Calibration c = aerovo::ReadCalibration(path);
    aerovo::Validate(c.intrinsics);  // InvalidArgument (not an InputError) would escape: a bug
  } catch (const aerovo::InputError&) {
  }
  return 0;
}
