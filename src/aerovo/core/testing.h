// Test helpers (not installed): locating ../shared and skipping cleanly when it is absent;
// scratch folders named after the test and the process, reading a file back whole or by lines,
// and a shell command's standard output (for the tests of every module and
// tests/e2e/e2e_testing.h).
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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

/// The path temp/<prefix>_<name>_<pid>, removed if it exists and not created (for a command
/// that makes its output folder itself, or a test that creates it).
inline std::filesystem::path UnusedTempPath(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    (prefix + "_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

/// An empty folder temp/<prefix>_<name>_<pid> (removed first if it exists).
inline std::filesystem::path FreshTempDir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir = UnusedTempPath(prefix, name);
  std::filesystem::create_directories(dir);
  return dir;
}

/// The whole file as bytes ("" when it cannot be read).
inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The lines of `text`, without their '\n'.
inline std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

/// What a shell command wrote to its standard output, and how it ended.
struct CommandOutput {
  int status = -1;  ///< pclose's wait status (0 = exit 0); -1 when the command could not start.
  std::string out;
  /// The exit code; -1 when the command did not exit normally (a signal) or did not start.
  int ExitCode() const { return WIFEXITED(status) ? WEXITSTATUS(status) : -1; }
};

/// Runs `cmd` through /bin/sh (popen), its standard output captured; stderr as `cmd` redirects.
inline CommandOutput RunCommand(const std::string& cmd) {
  CommandOutput r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  r.status = ::pclose(p);
  return r;
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
