// libFuzzer target: camera calibration files (aerovo::ReadCalibration): OpenCV calibrateCamera
// YAML / XML (read by OpenCV's cv::FileStorage, Debian's uninstrumented build: the coverage
// feedback comes from aerovo's code, ASan still sees the heap), OpenDroneMap cameras.json and
// COLMAP cameras.txt. ReadCalibration reads a path, so each input is written to one file of a
// private temporary folder; the file has no extension, and the format is recognised by content
// (calibration.h DetectCalibrationFormat), as for a file a user names without one. A read either
// throws InputError or returns a camera that passes Validate (camera/pinhole.h); anything else
// (another exception, a crash, a sanitizer report) is a bug.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include <unistd.h>

#include "aerovo/camera/pinhole.h"
#include "aerovo/camera_files/calibration.h"
#include "aerovo/core/error.h"

namespace {

// <$TMPDIR or /tmp>/aerovo-fuzz-calibration-XXXXXX/calibration, made once per process.
const std::string& InputPath() {
  static const std::string path = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::string dir = std::string(tmp && *tmp ? tmp : "/tmp") + "/aerovo-fuzz-calibration-XXXXXX";
    if (::mkdtemp(dir.data()) == nullptr) std::abort();
    return dir + "/calibration";
  }();
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = InputPath();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) std::abort();
  }
  try {
    const aerovo::Calibration c = aerovo::ReadCalibration(path);
    aerovo::Validate(c.intrinsics);  // InvalidArgument (not an InputError) would escape: a bug
  } catch (const aerovo::InputError&) {
  }
  return 0;
}
