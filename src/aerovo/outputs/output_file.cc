#include "aerovo/outputs/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <system_error>

namespace aerovo {
namespace fs = std::filesystem;

namespace {

// The AEROVO_TEST_FAIL_WRITE_AFTER_BYTES budget (see the header); -1: none.
std::atomic<long long> g_budget{-1};
std::once_flag g_budget_once;

void InitBudget() {
  std::call_once(g_budget_once, [] {
    const char* env = std::getenv("AEROVO_TEST_FAIL_WRITE_AFTER_BYTES");
    if (env == nullptr || *env == '\0') return;
    char* end = nullptr;
    const long long v = std::strtoll(env, &end, 10);
    if (end != env && *end == '\0' && v >= 0) g_budget.store(v);
  });
}

// How many of `size` bytes at `offset` may be written under the budget (all without one).
size_t AllowedBytes(int fd, size_t size, off_t offset) {
  InitBudget();
  const long long budget = g_budget.load();
  if (budget < 0) return size;
  struct stat st {};
  if (::fstat(fd, &st) != 0) return size;
  const long long file_size = st.st_size;
  const long long end = static_cast<long long>(offset) + static_cast<long long>(size);
  const long long growth = end > file_size ? end - std::max<long long>(file_size, offset) : 0;
  const long long before_growth = static_cast<long long>(size) - growth;
  if (growth <= budget) return size;
  return static_cast<size_t>(before_growth + budget);
}

void Spend(size_t size, off_t offset, long long file_size_before) {
  if (g_budget.load() < 0) return;
  const long long end = static_cast<long long>(offset) + static_cast<long long>(size);
  if (end > file_size_before)
    g_budget.fetch_sub(end - std::max<long long>(file_size_before, offset));
}

long long FileSize(int fd) {
  struct stat st {};
  return ::fstat(fd, &st) == 0 ? static_cast<long long>(st.st_size) : 0;
}

}  // namespace

void ThrowOutputError(const char* what, const fs::path& path, int errno_value) {
  throw OutputError(std::string(what) + " " + path.string() + ": " + std::strerror(errno_value));
}

void WriteAllAt(int fd, const void* data, size_t size, off_t offset, const fs::path& path) {
  const char* p = static_cast<const char*>(data);
  size_t done = 0;
  while (done < size) {
    const off_t at = offset + static_cast<off_t>(done);
    size_t want = size - done;
    const size_t allowed = AllowedBytes(fd, want, at);
    const bool budget_short = allowed < want;
    want = allowed;
    if (want == 0) ThrowOutputError("cannot write", path, ENOSPC);
    const long long before = g_budget.load() >= 0 ? FileSize(fd) : 0;
    const ssize_t n = ::pwrite(fd, p + done, want, at);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) ThrowOutputError("cannot write", path, errno);
    if (n == 0) ThrowOutputError("cannot write", path, ENOSPC);
    Spend(static_cast<size_t>(n), at, before);
    done += static_cast<size_t>(n);
    if (budget_short && static_cast<size_t>(n) == want && done < size) {
      ThrowOutputError("cannot write", path, ENOSPC);
    }
  }
}

bool TruncateOutput(int fd, off_t size) {
  const long long before = g_budget.load() >= 0 ? FileSize(fd) : 0;
  if (::ftruncate(fd, size) != 0) return false;
  if (g_budget.load() >= 0 && before > size) g_budget.fetch_add(before - size);
  return true;
}

void WriteFileAtomic(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) ThrowOutputError("cannot create", tmp, errno);
  // Any failure: the temporary file goes, `path` stays as it was.
  const auto fail = [&](const char* what, int err) {
    (void)TruncateOutput(fd, 0);
    ::close(fd);
    ::unlink(tmp.c_str());
    ThrowOutputError(what, path, err);
  };
  try {
    WriteAllAt(fd, text.data(), text.size(), 0, path);
  } catch (const OutputError&) {
    (void)TruncateOutput(fd, 0);
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  // fsync before rename: after a crash the new name never points at unwritten blocks.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) fail("cannot sync", errno);
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    ThrowOutputError("cannot write", path, err);
  }
  std::error_code ec;
  const auto replaced = g_budget.load() >= 0 ? fs::file_size(path, ec) : 0;
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    ThrowOutputError("cannot rename the temporary file onto", path, err);
  }
  if (!ec && replaced > 0 && g_budget.load() >= 0) {  // the old file's blocks are free
    g_budget.fetch_add(static_cast<long long>(replaced));
  }
}

SpaceReserve::SpaceReserve(const fs::path& path, size_t bytes) {
  InitBudget();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) return;
  const long long budget = g_budget.load();
  if (budget >= 0) {
    if (budget < static_cast<long long>(bytes)) return;
    g_budget.fetch_sub(static_cast<long long>(bytes));
  }
  if (::posix_fallocate(fd_, 0, static_cast<off_t>(bytes)) != 0) {
    if (budget >= 0) g_budget.fetch_add(static_cast<long long>(bytes));
    (void)::ftruncate(fd_, 0);
    return;
  }
  held_ = bytes;
}

SpaceReserve::~SpaceReserve() {
  Release();
  if (fd_ >= 0) ::close(fd_);
}

void SpaceReserve::Release() {
  if (held_ == 0 || fd_ < 0) return;
  if (::ftruncate(fd_, 0) == 0 && g_budget.load() >= 0) {
    g_budget.fetch_add(static_cast<long long>(held_));
  }
  held_ = 0;
}

namespace output_file_testing {
long long RemainingBudget() {
  InitBudget();
  return g_budget.load();
}
void SetBudget(long long bytes) {
  InitBudget();
  g_budget.store(bytes);
}
}  // namespace output_file_testing

}  // namespace aerovo
