#include "aerovo/outputs/run_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <system_error>

#include <fmt/format.h>

#include "aerovo/core/error.h"

namespace aerovo {
namespace fs = std::filesystem;

struct RunFolderLock::Shared {
  fs::path key;
  int fd = -1;
  ~Shared();
};

namespace {

std::mutex g_locks_mutex;
// The folders this process holds, by canonical path.
std::map<fs::path, std::weak_ptr<RunFolderLock::Shared>>& Locks() {
  static std::map<fs::path, std::weak_ptr<RunFolderLock::Shared>> locks;
  return locks;
}

std::string ReadPid(int fd) {
  char buf[32] = {};
  const ssize_t n = ::pread(fd, buf, sizeof(buf) - 1, 0);
  if (n <= 0) return "unknown";
  std::string s(buf, static_cast<size_t>(n));
  s = s.substr(0, s.find_first_of("\n\r"));
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) return "unknown";
  return s;
}

}  // namespace

RunFolderLock::Shared::~Shared() {
  if (fd >= 0) ::close(fd);  // releases the flock
}

RunFolderLock::RunFolderLock(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw InputError("cannot create output folder '" + dir.string() +
                     "': " + (ec ? ec.message() : std::string("not a directory")));
  }
  const fs::path key = fs::weakly_canonical(dir, ec);
  std::lock_guard<std::mutex> guard(g_locks_mutex);
  auto& locks = Locks();
  if (auto it = locks.find(key); it != locks.end()) {
    if ((shared_ = it->second.lock())) return;
  }
  const fs::path lock_path = dir / RunFolderFiles::kLock;
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw InputError("cannot create the lock file " + lock_path.string() + ": " +
                     std::strerror(errno));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    const std::string pid = ReadPid(fd);
    ::close(fd);
    if (err == EWOULDBLOCK) {
      throw InputError(fmt::format(
          "output folder '{}' is in use by another aerovo run (pid {}); wait for it to end or "
          "choose another folder (-o)",
          dir.string(), pid));
    }
    throw InputError("cannot lock " + lock_path.string() + ": " + std::strerror(err));
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) != 0 ||
      ::pwrite(fd, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    // The lock holds without the pid; a second run then says "pid unknown".
  }
  shared_ = std::make_shared<Shared>();
  shared_->key = key;
  shared_->fd = fd;
  locks[key] = shared_;
}

RunFolderLock::~RunFolderLock() {
  std::lock_guard<std::mutex> guard(g_locks_mutex);
  if (shared_ && shared_.use_count() == 1) Locks().erase(shared_->key);
  shared_.reset();
}

ClaimResult ClaimOutputFolder(const fs::path& dir, bool force, const std::vector<std::string>& own,
                              const std::string& command) {
  ClaimResult r;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return r;
  if (!fs::is_directory(dir, ec)) {
    throw InputError("output folder '" + dir.string() + "' exists and is not a folder");
  }
  std::set<std::string> owned(own.begin(), own.end());
  for (const std::string& n : own) owned.insert(n + ".tmp");
  std::vector<std::string> entries;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name == RunFolderFiles::kLock || name == RunFolderFiles::kReserve) continue;
    entries.push_back(name);
  }
  if (ec) throw InputError("cannot list output folder '" + dir.string() + "': " + ec.message());
  if (entries.empty()) return r;
  std::sort(entries.begin(), entries.end());
  if (!force) {
    std::string some;
    for (size_t i = 0; i < entries.size() && i < 5; ++i) some += (i ? ", " : "") + entries[i];
    if (entries.size() > 5) some += fmt::format(", ... ({} entries)", entries.size());
    throw InputError(fmt::format(
        "output folder '{}' is not empty ({}): {} writes into a new or empty folder so that no "
        "earlier file is mistaken for this run's; choose another folder (-o) or add --force to "
        "remove aerovo's own files from it first (other files are kept)",
        dir.string(), some, command));
  }
  for (const std::string& name : entries) {
    if (owned.count(name) == 0) {
      r.kept.push_back(name);
      continue;
    }
    fs::remove_all(dir / name, ec);
    if (ec) {
      throw InputError("cannot remove " + (dir / name).string() + " (--force): " + ec.message());
    }
    r.removed.push_back(name);
  }
  return r;
}

bool IsAerovoFolder(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return false;
  for (const char* f : {"summary.json", "config.json", "experiment.json", "sim.json"}) {
    if (fs::is_regular_file(dir / f, ec)) return true;
  }
  return false;
}

std::vector<std::string> OwnEntries(const fs::path& dir, std::vector<std::string> names) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return names;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (IsAerovoFolder(e.path())) names.push_back(e.path().filename().string());
  }
  return names;
}

}  // namespace aerovo
