// Shared by the fuzz targets of readers that take a path (fuzz_calibration, fuzz_reference_track):
// a private temporary folder per process, and the input written to a file in it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include <unistd.h>

namespace aerovo::fuzz {

/// <$TMPDIR or /tmp>/aerovo-fuzz-<name>-XXXXXX/ (mkdtemp(3), ending in '/'), made at the first
/// call; aborts when it cannot be made. One folder per process: libFuzzer's -jobs run processes.
inline std::string MakeFolder(const char* name) {
  const char* tmp = std::getenv("TMPDIR");
  std::string dir = std::string(tmp && *tmp ? tmp : "/tmp") + "/aerovo-fuzz-" + name + "-XXXXXX";
  if (::mkdtemp(dir.data()) == nullptr) std::abort();
  return dir + "/";
}

/// Writes the fuzzer's input to `path`, replacing it; aborts on a write error.
inline void WriteInput(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) std::abort();
}

}  // namespace aerovo::fuzz
