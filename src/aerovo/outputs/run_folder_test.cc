// A run owns its folder: the lock between processes (a forked child holds it), shared within
// one process, and the claim of a used folder with and without --force.
#include "aerovo/outputs/run_folder.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::run_folder_test {
namespace {

namespace fs = std::filesystem;

fs::path UnusedDir(const std::string& name) {
  return ::aerovo::testing::UnusedTempPath("aerovo_run_folder", name);
}

TEST(RunFolderLock, ASecondProcessIsRefusedWithTheHoldersPid) {
  const fs::path dir = UnusedDir("lock");
  int ready[2], done[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(done), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    int code = 0;
    try {
      const RunFolderLock lock(dir);
      (void)!::write(ready[1], "x", 1);
      char c;
      (void)!::read(done[0], &c, 1);  // hold until the parent has tried
    } catch (...) {
      code = 1;
    }
    ::_exit(code);
  }
  char c;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  try {
    const RunFolderLock lock(dir);
    ADD_FAILURE() << "the second lock was granted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'" + dir.string() + "'"), std::string::npos) << m;
    EXPECT_NE(m.find("in use by another aerovo run (pid " + std::to_string(pid) + ")"),
              std::string::npos)
        << m;
  }
  ASSERT_EQ(::write(done[1], "x", 1), 1);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  // The holder is gone: the folder can be locked again.
  EXPECT_NO_THROW(RunFolderLock{dir});
  for (int fd : {ready[0], ready[1], done[0], done[1]}) ::close(fd);
  fs::remove_all(dir);
}

TEST(RunFolderLock, NestedLocksInOneProcessShareTheLock) {
  const fs::path dir = UnusedDir("nested");
  const RunFolderLock outer(dir);
  { const RunFolderLock inner(dir / "."); }
  const RunFolderLock again(dir);
  EXPECT_TRUE(fs::exists(dir / RunFolderFiles::kLock));
  fs::remove_all(dir);
}

TEST(ClaimOutputFolder, RefusesAUsedFolderAndForceRemovesOnlyAerovosFiles) {
  const fs::path dir = UnusedDir("claim");
  const std::vector<std::string> own = {"frames.csv", "summary.json", "figures"};
  // Absent, then empty but for the lock: fine.
  EXPECT_TRUE(ClaimOutputFolder(dir, false, own, "aerovo run").removed.empty());
  { const RunFolderLock lock(dir); }
  EXPECT_NO_THROW(ClaimOutputFolder(dir, false, own, "aerovo run"));
  std::ofstream(dir / "frames.csv") << "old\n";
  std::ofstream(dir / "summary.json.tmp") << "{";
  fs::create_directories(dir / "figures");
  std::ofstream(dir / "figures" / "fig2.svg") << "<svg/>";
  std::ofstream(dir / "notes.txt") << "mine\n";
  try {
    ClaimOutputFolder(dir, false, own, "aerovo run");
    ADD_FAILURE() << "a used folder was accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'" + dir.string() + "' is not empty"), std::string::npos) << m;
    EXPECT_NE(m.find("frames.csv"), std::string::npos) << m;
    EXPECT_NE(m.find("--force"), std::string::npos) << m;
  }
  EXPECT_TRUE(fs::exists(dir / "frames.csv"));  // nothing removed without --force
  const ClaimResult r = ClaimOutputFolder(dir, true, own, "aerovo run");
  EXPECT_EQ(r.removed, (std::vector<std::string>{"figures", "frames.csv", "summary.json.tmp"}));
  EXPECT_EQ(r.kept, (std::vector<std::string>{"notes.txt"}));
  EXPECT_FALSE(fs::exists(dir / "frames.csv"));
  EXPECT_FALSE(fs::exists(dir / "figures"));
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
  EXPECT_TRUE(fs::exists(dir / RunFolderFiles::kLock));
  // A file where the folder should be.
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(ClaimOutputFolder(dir / "file", false, own, "aerovo run"), InputError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::run_folder_test
