// A run owns its output folder: one run at a time (RunFolderLock), and a new run starts in an
// empty folder (ClaimOutputFolder) so that no earlier run's file is left beside the new ones.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace aerovo {

/// Hidden files of a run folder kept by RunFolderLock and the run's space reserve.
struct RunFolderFiles {
  /// flock()ed for the run; holds the pid of the run that holds it ("1234\n").
  static constexpr const char* kLock = ".aerovo.lock";
  /// Disk space held during a run (outputs/output_file.h SpaceReserve), removed at its end.
  static constexpr const char* kReserve = ".aerovo.reserve";
};

/// Exclusive lock on a folder for the life of the object: flock(LOCK_EX | LOCK_NB) on
/// DIR/.aerovo.lock, which then holds this process's pid. Locks of the same folder taken again
/// in the same process (e.g. the CLI, then RunFlight) share the first one. The lock file stays
/// (deleting it would let two runs lock two different files); the kernel drops the lock when
/// the process ends, however it ends.
class RunFolderLock {
 public:
  /// Creates `dir` (and parents) if needed and locks it. Throws InputError naming the folder
  /// when it cannot be created, or when another process holds it: "output folder 'DIR' is in
  /// use by another aerovo run (pid N)".
  explicit RunFolderLock(const std::filesystem::path& dir);
  ~RunFolderLock();
  RunFolderLock(const RunFolderLock&) = delete;
  RunFolderLock& operator=(const RunFolderLock&) = delete;

  struct Shared;

 private:
  std::shared_ptr<Shared> shared_;
};

/// What ClaimOutputFolder did.
struct ClaimResult {
  std::vector<std::string> removed;  ///< Entries removed (--force), names relative to the folder.
  std::vector<std::string> kept;     ///< Foreign entries left in place (--force).
};

/// Claims `dir` for a new run of a command that writes the entries named in `own` (files, or
/// folders such as "figures"; their `.tmp` twins are included). An absent or empty folder (the
/// hidden files of RunFolderFiles aside) is fine. Otherwise, without `force`: InputError naming
/// the folder, a few of its entries and --force. With `force`: removes the entries whose names
/// are in `own` (and their .tmp), never anything else; foreign entries are kept and listed.
/// `command` names the command in the message ("aerovo run").
ClaimResult ClaimOutputFolder(const std::filesystem::path& dir, bool force,
                              const std::vector<std::string>& own, const std::string& command);

/// True for a sub-folder aerovo wrote as a whole (a run, an experiment or a simulated flight:
/// it holds summary.json, config.json, experiment.json or sim.json), for commands whose folder
/// holds such sub-folders under names that vary (aerovo experiment, aerovo demo). `own` of
/// ClaimOutputFolder then also covers every such sub-folder of `dir` (OwnEntries).
bool IsAerovoFolder(const std::filesystem::path& dir);

/// `names` plus the sub-folders of `dir` for which IsAerovoFolder holds.
std::vector<std::string> OwnEntries(const std::filesystem::path& dir,
                                    std::vector<std::string> names);

}  // namespace aerovo
