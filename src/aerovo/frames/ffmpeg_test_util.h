// Test and benchmark helper (used by *_test.cc and bench/bench_video_decode.cc only): runs the
// writer cannot (MPEG-TS clips of different sizes, rotation metadata). No shell: the arguments
// go to posix_spawnp as they are.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

namespace aerovo::io_test {

/// Runs `ffmpeg -nostdin -loglevel error -y ARGS...` from PATH, its output to /dev/null; true
/// when it exits 0.
inline bool RunFfmpeg(std::vector<std::string> args) {
  args.insert(args.begin(), {"ffmpeg", "-nostdin", "-loglevel", "error", "-y"});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "ffmpeg", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return false;
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return false;
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

/// ffmpeg can be run (tests that need it skip with a message otherwise).
inline bool HaveFfmpeg() {
  static const bool have = RunFfmpeg({"-version"});
  return have;
}

}  // namespace aerovo::io_test
