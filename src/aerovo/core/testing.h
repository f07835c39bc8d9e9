// Test helpers (not installed): locating ../shared and skipping cleanly when it is absent.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace aerovo::testing {

/// The shared data folder: $AEROVO_SHARED if set, else the path CMake recorded
/// (../shared beside the source tree). Returns an empty path when it does not exist.
inline std::filesystem::path SharedDir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("AEROVO_SHARED"); env != nullptr && *env != '\0') {
    if (fs::is_directory(env)) return fs::path(env);
  }
#ifdef AEROVO_SHARED_DIR_DEFAULT
  if (fs::is_directory(AEROVO_SHARED_DIR_DEFAULT)) return fs::path(AEROVO_SHARED_DIR_DEFAULT);
#endif
  return {};
}

}  // namespace aerovo::testing

/// Skips the current test with a clear message when ../shared (or a file in it) is missing.
/// Usage: AEROVO_REQUIRE_SHARED(path_var, "data/oxford/graf/img1.png");
#define AEROVO_REQUIRE_SHARED(var, rel)                                                        \
  const std::filesystem::path var = ::aerovo::testing::SharedDir() / (rel);                    \
  if (::aerovo::testing::SharedDir().empty() || !std::filesystem::exists(var)) {               \
    GTEST_SKIP() << "shared data not found: " << (rel)                                        \
                 << " (set AEROVO_SHARED or place ../shared beside the source tree)";         \
  }
