#include "aerovo/cli/progress.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace aerovo::cli::progress_test {
namespace {

// Everything written to a temporary FILE*.
class Captured {
 public:
  Captured() : f_(std::tmpfile()) {}
  ~Captured() { std::fclose(f_); }
  std::FILE* file() const { return f_; }
  std::string text() const {
    std::fflush(f_);
    std::rewind(f_);
    std::string s;
    char buf[256];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f_)) > 0) s.append(buf, n);
    return s;
  }

 private:
  std::FILE* f_;
};

int Count(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

TEST(Progress, BarRedrawsOneLineAndEndsIt) {
  Captured c;
  {
    Progress p(ProgressStyle::kBar, c.file());
    p.Update(45, 172, 3.2, "run 1/2 ");
    p.Update(172, 172, 4.0, "run 1/2 ");
    p.Finish();
  }
  const std::string s = c.text();
  EXPECT_EQ(s,
            "\rrun 1/2 [#######.......................]    45/172     3.20 fps  ETA 0:39 "
            "\rrun 1/2 [##############################]   172/172     4.00 fps  ETA 0:00 \n");
}

TEST(Progress, BarClearErasesTheLine) {
  Captured c;
  Progress p(ProgressStyle::kBar, c.file());
  p.Clear();  // nothing shown: nothing written
  p.Update(3, 0, 1.5);
  p.Clear();
  EXPECT_EQ(c.text(), "\r     3 frames   1.50 fps \r\033[K");
}

TEST(Progress, LinesHaveNoCarriageReturnAndAreThrottled) {
  Captured c;
  {
    // A long interval: the first state, then nothing until Finish prints the last one.
    Progress p(ProgressStyle::kLines, c.file(), 3600.0);
    for (int i = 1; i <= 50; ++i) p.Update(i, 50, 2.0, "  rendering ");
    p.Finish();
    p.Finish();  // nothing more
  }
  const std::string s = c.text();
  EXPECT_EQ(s.find('\r'), std::string::npos) << s;
  EXPECT_EQ(s,
            "  rendering 1/50 frames, 2.00 fps, ETA 0:24\n"
            "  rendering 50/50 frames, 2.00 fps, ETA 0:00\n");
}

TEST(Progress, LinesEveryIntervalAndUnknownTotals) {
  Captured c;
  {
    Progress p(ProgressStyle::kLines, c.file(), 0.0);  // every update is due
    p.Update(1, 0, 0.0);
    p.Update(2, 0, 5.0);
    p.Finish();  // the last state was printed: not again
  }
  EXPECT_EQ(c.text(), "1 frames\n2 frames, 5.00 fps\n");
}

TEST(Progress, DestructorFinishesAndOffWritesNothing) {
  Captured c;
  {
    Progress p(ProgressStyle::kLines, c.file(), 3600.0);
    p.Update(1, 4, 1.0);
    p.Update(2, 4, 1.0);
  }
  EXPECT_EQ(Count(c.text(), "\n"), 2) << c.text();
  Captured off;
  {
    Progress p(ProgressStyle::kOff, off.file());
    EXPECT_FALSE(p.enabled());
    p.Update(1, 4, 1.0);
    p.Finish();
  }
  EXPECT_EQ(off.text(), "");
  EXPECT_EQ(DefaultProgressStyle(true), ProgressStyle::kOff);
}

TEST(Progress, MeasuredRateWithoutFps) {
  Captured c;
  Progress p(ProgressStyle::kLines, c.file(), 0.0);
  p.Update(0, 10, std::string("x "));
  const std::string s = c.text();
  EXPECT_EQ(s.rfind("x 0/10 frames", 0), 0u) << s;
}

#ifdef AEROVO_CLI_PATH
// `aerovo simulate` with stderr redirected to a file (as in a log or CI): plain progress lines.
TEST(Progress, SimulateToAFileWritesPlainLines) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "aerovo_progress_test";
  fs::remove_all(dir);
  const fs::path err = dir.string() + ".stderr";
  const std::string cmd = std::string(AEROVO_CLI_PATH) +
                          " simulate --pattern line --length-m 40 --legs 1 --width 160 "
                          "--height 120 --fps 5 --out " +
                          dir.string() + " > /dev/null 2> " + err.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(err);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string s = ss.str();
  EXPECT_EQ(s.find('\r'), std::string::npos) << s;
  // The first state, then (the interval is seconds long) the last one: every frame written.
  ASSERT_EQ(s.rfind("  rendering  ", 0), 0u) << s;
  ASSERT_GE(Count(s, "\n"), 2) << s;
  const std::size_t last = s.rfind("  rendering  ");
  int done = 0, total = 0;
  ASSERT_EQ(std::sscanf(s.c_str() + last, "  rendering  %d/%d frames", &done, &total), 2) << s;
  EXPECT_GT(total, 0);
  EXPECT_EQ(done, total) << s;
  fs::remove_all(dir);
  fs::remove(err);
}
#endif

}  // namespace
}  // namespace aerovo::cli::progress_test
