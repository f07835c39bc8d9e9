// The one place where aerovo writes bytes of its output files (outputs/track_writers.h, the SRT
// writer, config.json, summary.json), so that a full disk (ENOSPC), a file size limit (EFBIG)
// or any other write error is handled the same way everywhere:
//   * a write error throws OutputError naming the file and the errno text;
//   * WriteAllAt writes every byte or fails (short writes and EINTR are retried);
//   * the files written whole (config.json, summary.json, report pages) go through
//     WriteFileAtomic: `name.tmp`, fsync, rename, so a reader sees the old or the new file;
//   * the progressive files (track_writers.cc) roll a failed append back to their last valid
//     content, so they stay valid whatever fails;
//   * SpaceReserve holds disk space from the start of a run (posix_fallocate) and gives it back
//     just before summary.json is written, so the summary of what happened fits even when the
//     disk filled up during the run.
//
// Test-only failure injection: when the environment variable AEROVO_TEST_FAIL_WRITE_AFTER_BYTES
// is set to N, the process behaves as if its file system had N free bytes when first used:
// every byte that grows an output file counts, SpaceReserve takes and gives back its bytes,
// and a write past the budget writes what still fits, then fails with ENOSPC. Overwriting
// bytes inside a file's current size is free (as on a real file system). Unset in normal use.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {

/// Throws OutputError "`what` `path`: strerror(errno_value)".
[[noreturn]] void ThrowOutputError(const char* what, const std::filesystem::path& path,
                                   int errno_value);

/// Writes `size` bytes of `data` at byte `offset` of the open descriptor `fd` (pwrite; retried
/// on EINTR and short writes). Throws OutputError naming `path` when a write fails; bytes
/// before the failure may have been written (callers roll back, see track_writers.cc).
void WriteAllAt(int fd, const void* data, size_t size, off_t offset,
                const std::filesystem::path& path);

/// ftruncate(fd, size) that also gives the freed bytes back to the test budget. False (errno
/// set) when it fails.
bool TruncateOutput(int fd, off_t size);

/// Writes `text` to `path` atomically: `path`.tmp in the same folder, fsync, rename over
/// `path`. On failure the temporary file is removed, `path` is left as it was and OutputError
/// names the file and the errno text.
void WriteFileAtomic(const std::filesystem::path& path, const std::string& text);

/// Disk space held for the end of a run: a file of `bytes` bytes allocated with
/// posix_fallocate (blocks really taken from the file system), truncated to 0 by Release()
/// (the blocks are free again) right before the final files are written. Never throws: a
/// reserve that cannot be made is simply absent (ok() false).
class SpaceReserve {
 public:
  SpaceReserve() = default;
  /// Holds `bytes` bytes in `path` (created or reused; left as an empty file by Release).
  SpaceReserve(const std::filesystem::path& path, size_t bytes);
  ~SpaceReserve();
  SpaceReserve(const SpaceReserve&) = delete;
  SpaceReserve& operator=(const SpaceReserve&) = delete;
  bool ok() const { return held_ > 0; }
  size_t bytes() const { return held_; }
  /// Frees the space (idempotent).
  void Release();

 private:
  int fd_ = -1;
  size_t held_ = 0;
};

namespace output_file_testing {
/// Bytes left of the AEROVO_TEST_FAIL_WRITE_AFTER_BYTES budget; -1 when there is none.
long long RemainingBudget();
/// Sets the budget (tests of this module; -1 = no budget).
void SetBudget(long long bytes);
}  // namespace output_file_testing

}  // namespace aerovo
