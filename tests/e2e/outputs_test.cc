// Outputs and messages at the CLI level (docs/reliability.md, "Outputs, the output folder,
// security, messages"), each case with inputs the test makes itself
// (one small simulated flight, generated photos): a disk that fills up mid-run (the test-only
// AEROVO_TEST_FAIL_WRITE_AFTER_BYTES budget, outputs/output_file.h), two runs into one folder, a
// re-run into a used folder (--force), SIGPIPE (`--print-poses | head`) and SIGHUP, SIGINT
// inside a huge frame, hostile folder names for `aerovo report --open`, warnings on stderr
// with -q, YAML anchors, and a time window that selects no frame.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <pugixml.hpp>

#include "aerovo/frames/ffmpeg_test_util.h"
#include "e2e_testing.h"

namespace aerovo::outputs_test {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

#ifdef AEROVO_CLI_PATH

using e2e::ReadText;
using e2e::CountLines;

struct Child {
  pid_t pid = -1;
  fs::path out_file, err_file;
};

struct Outcome {
  int exit_code = -1;  // exit status, or -signal
  std::string out, err;
  double seconds = 0.0;
};

// Starts the CLI with `args`; stdout and stderr into files under `log_dir` named after `tag`;
// `env` added to the environment; `stdout_fd` (>= 0) replaces the stdout file; a
// `file_size_limit_bytes` (> 0) is the child's RLIMIT_FSIZE, as `ulimit -f` sets it (SIGXFSZ
// left at its default action: aerovo must not die of it).
Child Start(const std::vector<std::string>& args, const fs::path& log_dir, const std::string& tag,
            const std::map<std::string, std::string>& env = {}, int stdout_fd = -1,
            rlim_t file_size_limit_bytes = 0) {
  Child c;
  c.out_file = log_dir / (tag + ".out");
  c.err_file = log_dir / (tag + ".err");
  c.pid = ::fork();
  if (c.pid == 0) {
    for (const auto& [k, v] : env) ::setenv(k.c_str(), v.c_str(), 1);
    const int out =
        stdout_fd >= 0 ? stdout_fd : ::open(c.out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = ::open(c.err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1);
    ::dup2(err, 2);
    if (file_size_limit_bytes > 0) {
      const rlimit lim{file_size_limit_bytes, file_size_limit_bytes};
      ::setrlimit(RLIMIT_FSIZE, &lim);
    }
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(AEROVO_CLI_PATH));
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(AEROVO_CLI_PATH, argv.data());
    ::_exit(127);
  }
  return c;
}

Outcome Wait(const Child& c, Clock::time_point since = Clock::now()) {
  Outcome o;
  int status = 0;
  ::waitpid(c.pid, &status, 0);
  o.seconds = std::chrono::duration<double>(Clock::now() - since).count();
  o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  o.out = ReadText(c.out_file);
  o.err = ReadText(c.err_file);
  return o;
}

Outcome RunCli(const std::vector<std::string>& args, const fs::path& log_dir,
               const std::string& tag, const std::map<std::string, std::string>& env = {}) {
  return Wait(Start(args, log_dir, tag, env));
}

bool WaitForRows(const fs::path& csv, int rows, double timeout_s) {
  const auto start = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - start).count() < timeout_s) {
    if (fs::exists(csv) && CountLines(csv) > rows) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

// Every file of a run folder that exists is valid: JSON parses, XML parses, CSV rows complete.
void ExpectValidFolder(const fs::path& out) {
  for (const fs::directory_entry& e : fs::directory_iterator(out)) {
    const fs::path p = e.path();
    const std::string ext = p.extension().string();
    SCOPED_TRACE(p.string());
    if (ext == ".geojson" || ext == ".json") {
      EXPECT_FALSE(nlohmann::json::parse(ReadText(p), nullptr, false).is_discarded());
    } else if (ext == ".gpx" || ext == ".kml") {
      pugi::xml_document doc;
      const pugi::xml_parse_result r = doc.load_file(p.c_str());
      EXPECT_TRUE(r) << r.description() << " at offset " << r.offset;
    } else if (ext == ".csv" || ext == ".tum") {
      const std::string text = ReadText(p);
      if (!text.empty()) {
        EXPECT_EQ(text.back(), '\n');
      }
      EXPECT_EQ(text.find('\0'), std::string::npos);
    } else if (ext == ".tmp") {
      ADD_FAILURE() << "temporary file left";
    }
  }
}

// A pipe for a child's stdout holding only 4 kB (F_SETPIPE_SZ): a run printing its poses into
// it blocks once it is full, until Drain() reads it.
struct PosePipe {
  PosePipe() {
    int fds[2] = {-1, -1};
    // O_CLOEXEC: the child must not keep the read end open (the pipe would never close).
    if (::pipe2(fds, O_CLOEXEC) == 0) {
      read_end = fds[0];
      write_end = fds[1];
      ::fcntl(write_end, F_SETPIPE_SZ, 4096);
    }
  }
  ~PosePipe() {
    CloseReadEnd();
    CloseWriteEnd();
  }
  void CloseWriteEnd() {
    if (write_end >= 0) ::close(write_end);
    write_end = -1;
  }
  void CloseReadEnd() {
    if (read_end >= 0) ::close(read_end);
    read_end = -1;
  }
  void Drain() const {
    char buf[4096];
    while (::read(read_end, buf, sizeof(buf)) > 0) {
    }
  }
  int read_end = -1;
  int write_end = -1;
};

// Frames of the simulated flight (120 m at 10 m/s, 10 fps).
constexpr int kFrames = 121;

class CliOutputs : public ::testing::Test {
 protected:
  // One small simulated flight (kFrames frames of 320x240 with a DJI SRT, sim.json beside it).
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("aerovo_cli_outputs_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const Outcome o = RunCli(
        {"simulate", "--pattern", "line", "--length-m", "120", "--legs", "1", "--width", "320",
         "--height", "240", "--fps", "10", "--hfov-deg", "73.7", "--out", (dir_ / "sim").string()},
        dir_, "simulate");
    ASSERT_EQ(o.exit_code, 0) << o.err;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::string Video() { return (dir_ / "sim" / "video.mp4").string(); }
  static std::vector<std::string> RunArgs(const fs::path& out) {
    return {"run", Video(), "--threads", "1", "--no-report", "-o", out.string()};
  }

  static fs::path dir_;
};
fs::path CliOutputs::dir_;

// A run stopped by a full disk: exit 1, the error names the file, every file valid, and
// summary.json says what failed (`cause`, the errno text) and counts exactly the rows of
// frames.csv.
void ExpectDiskFullRun(const fs::path& out, const Outcome& o,
                       const std::string& cause = "No space left on device") {
  EXPECT_EQ(o.exit_code, 1) << o.err;
  EXPECT_NE(o.err.find(cause), std::string::npos) << o.err;
  EXPECT_NE(o.err.find(out.string() + "/"), std::string::npos) << o.err;  // names the file
  ExpectValidFolder(out);
  const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_NE(s["error"].get<std::string>().find(cause), std::string::npos) << s.dump(2);
  EXPECT_GT(s["frames_processed"].get<int>(), 0);
  EXPECT_LT(s["frames_processed"].get<int>(), kFrames);
  // frames.csv holds exactly the frames summary.json counts as processed; those processed but
  // not written (queued for the heading when the disk filled up) are counted apart and said.
  EXPECT_EQ(CountLines(out / "frames.csv") - 1, s["frames_processed"].get<int>());
  if (s["frames_not_written"].get<int>() > 0) {
    EXPECT_NE(s.dump().find("are not in frames.csv"), std::string::npos) << s.dump(2);
  }
  std::cout << out.filename().string() << ": frames_processed " << s["frames_processed"]
            << " = frames.csv rows, frames_not_written " << s["frames_not_written"] << "\n";
  EXPECT_FALSE(fs::exists(out / ".aerovo.reserve"));
}

TEST_F(CliOutputs, DiskFullMidRunLeavesValidFilesAndASummaryThatSaysWhatFailed) {
  // 1 MiB for the run's summary reserve plus 40 kB: the disk fills up a few frames in, while
  // the first frames wait for the heading (30 m of GPS track: 30 frames) and are written at once.
  const fs::path out = dir_ / "full";
  const Outcome o =
      RunCli(RunArgs(out), dir_, "full",
             {{"AEROVO_TEST_FAIL_WRITE_AFTER_BYTES", std::to_string((1 << 20) + 40000)}});
  ExpectDiskFullRun(out, o);
}

// frames.csv and summary.json's frames_processed agree however far the run got: a budget that
// runs out while the queued frames are written (above), and one that runs out later, frame by
// frame.
TEST_F(CliOutputs, DiskFullLaterStillAgreesWithFramesCsv) {
  const fs::path out = dir_ / "full_later";
  const Outcome o =
      RunCli(RunArgs(out), dir_, "full_later",
             {{"AEROVO_TEST_FAIL_WRITE_AFTER_BYTES", std::to_string((1 << 20) + 160000)}});
  ExpectDiskFullRun(out, o);
}


// A file size limit (`ulimit -f`) is a full disk for each file: the first file that reaches it
// (run.kml or frames.csv, the largest that grow frame by frame) fails with EFBIG. Before,
// SIGXFSZ killed the run in the middle of that write: the file cut, no summary.json.
TEST_F(CliOutputs, FileSizeLimitEndsTheRunLikeAFullDisk) {
  const fs::path out = dir_ / "fsize";
  // Above summary.json's size (~13 kB for this flight, written whatever failed), below what the
  // files that grow frame by frame reach over the whole flight (run.kml ~50 kB, frames.csv ~21 kB).
  constexpr rlim_t kLimit = 18000;
  const Outcome o = Wait(Start(RunArgs(out), dir_, "fsize", {}, -1, kLimit));
  ASSERT_EQ(o.exit_code, 1) << "exit " << o.exit_code << " (negative: killed by that signal)\n"
                            << o.err;
  ExpectDiskFullRun(out, o, "File too large");
  EXPECT_NE(o.err.find("cannot write " + out.string() + "/"), std::string::npos) << o.err;
  for (const fs::directory_entry& e : fs::directory_iterator(out)) {
    EXPECT_LE(e.file_size(), kLimit) << e.path();
  }
}

// A pose stream on a stdout that cannot be written (a full disk behind `> poses.txt`; /dev/full
// here) stops the run as any output file that fails does: before, --print-poses went on
// printing into nothing and exited 0, so a consumer got no poses from a run that said success.
TEST_F(CliOutputs, APoseStreamThatCannotBeWrittenStopsTheRunNamingStdout) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this machine";
  const std::vector<std::pair<std::string, std::string>> streams = {
      {"--print-poses", "stdout (--print-poses)"}, {"--poses-jsonl=-", "stdout (--poses-jsonl -)"}};
  for (const auto& [flag, name] : streams) {
    SCOPED_TRACE(flag);
    const fs::path out = dir_ / ("devfull" + std::to_string(flag.size()));
    std::vector<std::string> args = RunArgs(out);
    args.push_back(flag);
    const int full = ::open("/dev/full", O_WRONLY);
    ASSERT_GE(full, 0);
    const Outcome o = Wait(Start(args, dir_, "devfull", {}, full));
    ::close(full);
    EXPECT_EQ(o.exit_code, 1) << o.err;
    EXPECT_NE(o.err.find("cannot write the pose stream to " + name + ": No space left on device"),
              std::string::npos)
        << o.err;
    ExpectValidFolder(out);
    const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
    EXPECT_NE(s["error"].get<std::string>().find("No space left on device"), std::string::npos)
        << s.dump(2);
    EXPECT_LT(s["frames_processed"].get<int>(), kFrames);
    EXPECT_EQ(CountLines(out / "frames.csv") - 1, s["frames_processed"].get<int>());
  }
}

// The run's text (configuration, summary table) on a stdout that cannot be written: the run's
// files are complete, but the exit status says the text was lost (before: exit 0).
TEST_F(CliOutputs, AStdoutThatCannotBeWrittenIsExitOne) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this machine";
  const fs::path out = dir_ / "devfull_text";
  const int full = ::open("/dev/full", O_WRONLY);
  ASSERT_GE(full, 0);
  const Outcome o = Wait(Start(RunArgs(out), dir_, "devfull_text", {}, full));
  ::close(full);
  EXPECT_EQ(o.exit_code, 1) << o.err;
  EXPECT_NE(o.err.find("cannot write to stdout"), std::string::npos) << o.err;
  ExpectValidFolder(out);
  const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ(s["frames_processed"].get<int>(), kFrames);
}

// A run that fails before or at its first frame (telemetry that does not parse; no height for
// frame 0) still leaves summary.json with the error, and no space reserve (before: config.json
// and empty tracks, no summary, the reserve file left).
TEST_F(CliOutputs, AFailureBeforeTheFirstFrameStillWritesTheSummary) {
  const fs::path bad = dir_ / "bad.srt";
  std::ofstream(bad) << "garbage\n1\n";
  // The flight's SRT without its first 40 records: frame 0 has no record, and the first is
  // further ahead than a missing first record explains (RunTelemetry::kMaxLeadFrames, 30), so
  // no height.
  const std::string srt = ReadText(dir_ / "sim" / "telemetry.srt");
  std::size_t cut = 0;
  for (int i = 0; i < 40; ++i) cut = srt.find("\n\n", cut) + 2;
  const fs::path late = dir_ / "late.srt";
  std::ofstream(late) << srt.substr(cut);
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--telemetry", bad.string(), "--focal-px", "213.5"}, "bad.srt:1: "},
      {{"--telemetry", late.string(), "--focal-px", "213.5"}, "#0: no height above ground"}};
  int k = 0;
  for (const auto& [extra, error] : cases) {
    SCOPED_TRACE(error);
    const fs::path out = dir_ / ("early" + std::to_string(k++));
    std::vector<std::string> args = RunArgs(out);
    args.insert(args.end(), extra.begin(), extra.end());
    const Outcome o = RunCli(args, dir_, "early");
    EXPECT_EQ(o.exit_code, 1) << o.err;
    EXPECT_NE(o.err.find(error), std::string::npos) << o.err;
    ASSERT_TRUE(fs::exists(out / "summary.json")) << o.err;
    const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
    EXPECT_NE(s["error"].get<std::string>().find(error), std::string::npos) << s.dump(2);
    EXPECT_EQ(s["frames_processed"].get<int>(), 0);
    EXPECT_FALSE(fs::exists(out / ".aerovo.reserve"));
    ExpectValidFolder(out);
  }
}

TEST_F(CliOutputs, ASecondRunIntoTheSameFolderFailsNamingTheFolderAndTheFirstRunsPid) {
  // The first run prints its poses into a small pipe nobody reads yet: it blocks mid-run,
  // holding its folder, whatever the machine's speed.
  const fs::path out = dir_ / "twice";
  PosePipe pipe;
  std::vector<std::string> args = RunArgs(out);
  args.push_back("--print-poses");
  const Child first = Start(args, dir_, "first", {}, pipe.write_end);
  pipe.CloseWriteEnd();
  ASSERT_TRUE(WaitForRows(out / "frames.csv", 1, 60));
  const Outcome second = RunCli(RunArgs(out), dir_, "second");
  std::thread drain([&] { pipe.Drain(); });
  const Outcome a = Wait(first);
  drain.join();
  EXPECT_EQ(a.exit_code, 0) << a.err;
  EXPECT_EQ(second.exit_code, 1);
  EXPECT_NE(
      second.err.find("output folder '" + out.string() + "' is in use by another aerovo run (pid " +
                      std::to_string(first.pid) + ")"),
      std::string::npos)
      << second.err;
  // The first run's files are its own: every frame, a summary that agrees.
  ExpectValidFolder(out);
  EXPECT_EQ(CountLines(out / "frames.csv"), kFrames + 1);
  const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ(s["frames_processed"], kFrames);
}

TEST_F(CliOutputs, ARerunIntoAUsedFolderIsRefusedUnlessForceWhichRemovesOnlyAerovosFiles) {
  const fs::path out = dir_ / "rerun";
  std::vector<std::string> args = RunArgs(out);
  args.insert(args.end(), {"--max-frames", "5"});
  ASSERT_EQ(RunCli(args, dir_, "rerun1").exit_code, 0);
  std::ofstream(out / "report.html") << "<html>earlier report</html>";
  std::ofstream(out / "my_notes.txt") << "not aerovo's\n";
  const Outcome refused = RunCli(args, dir_, "rerun2");
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("output folder '" + out.string() + "' is not empty"),
            std::string::npos)
      << refused.err;
  EXPECT_NE(refused.err.find("--force"), std::string::npos) << refused.err;
  args.push_back("--force");
  const Outcome forced = RunCli(args, dir_, "rerun3");
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_NE(forced.err.find("--force: removed"), std::string::npos) << forced.err;
  EXPECT_NE(forced.err.find("report.html"), std::string::npos) << forced.err;
  EXPECT_NE(forced.err.find("kept 1 file(s) aerovo did not write"), std::string::npos)
      << forced.err;
  EXPECT_FALSE(fs::exists(out / "report.html"));  // the earlier run's report is gone
  EXPECT_EQ(ReadText(out / "my_notes.txt"), "not aerovo's\n");
  EXPECT_EQ(CountLines(out / "frames.csv"), 6);
}

TEST_F(CliOutputs, PrintPosesIntoHeadEndsWithASummaryAndExitCode141) {
  // Both pose streams on stdout: the text one and the JSON one (`--poses-jsonl - | head`).
  for (const std::string flag : {"--print-poses", "--poses-jsonl=-"}) {
    SCOPED_TRACE(flag);
    const fs::path out = dir_ / ("pipe" + std::to_string(flag.size()));
    PosePipe pipe;
    std::vector<std::string> args = RunArgs(out);
    args.push_back(flag);
    const Child c = Start(args, dir_, "pipe", {}, pipe.write_end);
    pipe.CloseWriteEnd();
    // `head -3`: read three lines, then close the pipe (the run is still writing: the pipe
    // holds 4 kB, the poses of the flight about twice that).
    std::string got;
    char ch;
    int lines = 0;
    while (lines < 3 && ::read(pipe.read_end, &ch, 1) == 1) {
      got += ch;
      if (ch == '\n') ++lines;
    }
    pipe.CloseReadEnd();
    const Outcome o = Wait(c);
    EXPECT_EQ(lines, 3) << got;
    EXPECT_EQ(o.exit_code, 141) << o.err;
    EXPECT_NE(o.err.find("interrupted by SIGPIPE"), std::string::npos) << o.err;
    EXPECT_NE(o.err.find("exit code 141"), std::string::npos) << o.err;
    EXPECT_NE(o.err.find(" processed (interrupted): ok "), std::string::npos)
        << o.err;  // the final table
    ExpectValidFolder(out);
    const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
    EXPECT_EQ(s["interrupted"], true);
    EXPECT_LT(s["frames_processed"].get<int>(), kFrames);
    EXPECT_EQ(CountLines(out / "frames.csv") - 1, s["frames_processed"].get<int>());
  }
}

TEST_F(CliOutputs, SighupStopsLikeSigintWithASummary) {
  const fs::path out = dir_ / "hup";
  PosePipe pipe;  // blocks the run mid-flight until drained (see above)
  std::vector<std::string> args = RunArgs(out);
  args.push_back("--print-poses");
  const Child c = Start(args, dir_, "hup", {}, pipe.write_end);
  pipe.CloseWriteEnd();
  ASSERT_TRUE(WaitForRows(out / "frames.csv", 3, 60));
  ::kill(c.pid, SIGHUP);
  std::thread drain([&] { pipe.Drain(); });
  const Outcome o = Wait(c);
  drain.join();
  EXPECT_EQ(o.exit_code, 129) << o.err;
  EXPECT_NE(o.err.find("interrupted by SIGHUP"), std::string::npos) << o.err;
  ExpectValidFolder(out);
  const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ(s["interrupted"], true);
}

// SIGINT inside a huge frame (8000x8000 textured photo): the run stops within a second, with
// its summary, instead of waiting for the frame's SURF and matching, or for the next photo's
// decoding in progress on the reader thread (frames/prefetch_source.h join_timeout_ms). The budget
// is the required second (docs/reliability.md, "SIGINT inside a huge frame") for the optimised
// build; an instrumented build (ASan+UBSan at -O1, its LeakSanitizer scanning the heap at exit)
// runs the same path 2-3x slower and gets 2 s.
TEST_F(CliOutputs, SigintInsideAHugeFrameTakesEffectWithinASecond) {
  const fs::path photos = dir_ / "huge_photos";
  fs::create_directories(photos);
  cv::Mat img(8000, 8000, CV_8UC1);
  cv::RNG rng(7);
  cv::Mat small(500, 500, CV_8UC1);
  rng.fill(small, cv::RNG::UNIFORM, 0, 256);
  cv::resize(small, img, img.size(), 0, 0, cv::INTER_CUBIC);
  ASSERT_TRUE(cv::imwrite((photos / "a.jpg").string(), img, {cv::IMWRITE_JPEG_QUALITY, 80}));
  fs::copy_file(photos / "a.jpg", photos / "b.jpg");
  const fs::path out = dir_ / "huge";
  const Child c = Start({"run", photos.string(), "--altitude", "100", "--hfov-deg", "70",
                         "--threads", "1", "--no-report", "-o", out.string()},
                        dir_, "huge");
  // Wait until the first frame is being processed (config.json rewritten with the resolved
  // camera), then a little more: inside SURF.
  const auto start = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - start).count() < 60) {
    if (fs::exists(out / "transforms.csv")) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(fs::exists(out / "transforms.csv"));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto signalled = Clock::now();
  ::kill(c.pid, SIGINT);
  const Outcome o = Wait(c, signalled);
  EXPECT_EQ(o.exit_code, 130) << o.err;
#ifdef AEROVO_INSTRUMENTED_BUILD
  constexpr double kStopBudgetS = 2.0;
#else
  constexpr double kStopBudgetS = 1.0;
#endif
  EXPECT_LT(o.seconds, kStopBudgetS) << "the stop took " << o.seconds << " s";
  const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ(s["interrupted"], true);
  EXPECT_EQ(s["frames_processed"], 0);  // the cancelled frame is not counted
  fs::remove_all(photos);
}

// `aerovo report --open` on folders with hostile names: the name reaches the opener as one
// argument (a fake xdg-open on PATH records it), nothing runs through a shell.
TEST_F(CliOutputs, ReportOpenPassesHostileFolderNamesAsOneArgumentWithoutAShell) {
  const fs::path base = dir_ / "hostile";
  fs::create_directories(base / "bin");
  const fs::path record = base / "opened.txt";
  {
    std::ofstream s(base / "bin" / "xdg-open");
    s << "#!/bin/sh\nprintf '%s\\n' \"$#:$1\" >> '" << record.string() << "'\n";
  }
  fs::permissions(base / "bin" / "xdg-open", fs::perms::owner_all);
  const fs::path run = base / "run";
  std::vector<std::string> args = RunArgs(run);
  args.insert(args.end(), {"--max-frames", "4"});
  ASSERT_EQ(RunCli(args, base, "run").exit_code, 0);
  const std::string path = std::string("/usr/bin:/bin");
  const std::vector<std::string> names = {"x';touch PWNED;'", "a \"b\" c", "-dash", "`touch PWNED`",
                                          "$(touch PWNED)"};
  int expected_lines = 0;
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const fs::path dir = base / name;
    fs::rename(run, dir);
    const Child c = [&] {
      Child ch;
      ch.out_file = base / "report.out";
      ch.err_file = base / "report.err";
      ch.pid = ::fork();
      if (ch.pid == 0) {
        ::chdir(base.c_str());  // where a PWNED file would appear
        ::setenv("PATH", ((base / "bin").string() + ":" + path).c_str(), 1);
        const int out = ::open(ch.out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ::dup2(out, 1);
        ::dup2(out, 2);
        // A relative name as a user would type it (a leading dash as ./-dash).
        const std::string arg = name[0] == '-' ? "./" + name : name;
        ::execl(AEROVO_CLI_PATH, AEROVO_CLI_PATH, "report", arg.c_str(), "--open", "--no-mosaic",
                "--no-png", "-q", static_cast<char*>(nullptr));
        ::_exit(127);
      }
      return ch;
    }();
    const Outcome o = Wait(c);
    EXPECT_EQ(o.exit_code, 0) << o.out;
    ++expected_lines;
    // The opener runs detached: wait for its record.
    const auto start = Clock::now();
    while (CountLines(record) < expected_lines &&
           std::chrono::duration<double>(Clock::now() - start).count() < 10) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::vector<std::string> lines;
    std::ifstream in(record);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    ASSERT_EQ(static_cast<int>(lines.size()), expected_lines);
    EXPECT_EQ(lines.back(), "1:" + fs::absolute(dir / "report.html").lexically_normal().string());
    EXPECT_FALSE(fs::exists(base / "PWNED"));
    EXPECT_FALSE(fs::exists(dir / "PWNED"));
    fs::rename(dir, run);
  }
}

// A DJI video and its SRT as the aircraft records them (DJI_0001.MP4, DJI_0001.SRT, no sim.json):
// the run uses the SRT beside the video and says so; --telemetry none runs without it.
TEST_F(CliOutputs, TheSrtBesideADjiVideoIsUsedUnlessTelemetryIsNone) {
  const fs::path dji = dir_ / "dji";
  fs::create_directories(dji);
  fs::copy_file(Video(), dji / "DJI_0001.MP4", fs::copy_options::overwrite_existing);
  fs::copy_file(dir_ / "sim" / "telemetry.srt", dji / "DJI_0001.SRT",
                fs::copy_options::overwrite_existing);
  const std::vector<std::string> common = {"run",          (dji / "DJI_0001.MP4").string(),
                                           "--hfov-deg",   "73.7",
                                           "--max-frames", "6",
                                           "--threads",    "1",
                                           "--no-report"};
  std::vector<std::string> args = common;
  args.insert(args.end(), {"-o", (dji / "with").string()});
  const Outcome with = RunCli(args, dir_, "beside");
  ASSERT_EQ(with.exit_code, 0) << with.err;
  EXPECT_NE(with.out.find("from " + (dji / "DJI_0001.SRT").string() + " (found beside the video"),
            std::string::npos)
      << with.out;
  const nlohmann::json s = nlohmann::json::parse(ReadText(dji / "with" / "summary.json"));
  EXPECT_EQ(s["telemetry"], (dji / "DJI_0001.SRT").string());
  EXPECT_TRUE(s["telemetry_beside"].get<bool>());
  EXPECT_EQ(s["frames_with_gps"].get<int>(), 6);
  EXPECT_EQ(s["height_source"], "telemetry");
  // The saved configuration names the file, so that it reproduces the run.
  const nlohmann::json c = nlohmann::json::parse(ReadText(dji / "with" / "config.json"));
  EXPECT_EQ(c["telemetry"], (dji / "DJI_0001.SRT").string());

  args = common;
  args.insert(args.end(),
              {"--telemetry", "none", "--altitude", "60", "-o", (dji / "without").string()});
  const Outcome without = RunCli(args, dir_, "none");
  ASSERT_EQ(without.exit_code, 0) << without.err;
  const nlohmann::json n = nlohmann::json::parse(ReadText(dji / "without" / "summary.json"));
  EXPECT_EQ(n["telemetry"], "");
  EXPECT_FALSE(n["telemetry_beside"].get<bool>());
  EXPECT_EQ(n["frames_with_gps"].get<int>(), 0);

  // An SRT beside the video that cannot be read (not asked for) is flagged, not fatal.
  {
    std::ofstream(dji / "DJI_0001.SRT") << "1\n00:00:00,000 --> 00:00:00,100\n[latitude: 95.0] "
                                           "[longitude: 6.0]\n";
  }
  args = common;
  args.insert(args.end(), {"--altitude", "60", "-o", (dji / "broken").string()});
  const Outcome broken = RunCli(args, dir_, "broken_beside");
  ASSERT_EQ(broken.exit_code, 0) << broken.err;
  EXPECT_NE(broken.err.find("the telemetry found beside the video could not be read"),
            std::string::npos)
      << broken.err;
  EXPECT_NE(broken.err.find("latitude 95"), std::string::npos) << broken.err;
  const nlohmann::json b = nlohmann::json::parse(ReadText(dji / "broken" / "summary.json"));
  EXPECT_EQ(b["frames_with_gps"].get<int>(), 0);
  // Given with --telemetry, the same file is an error naming it.
  args = common;
  args.insert(args.end(), {"--telemetry", (dji / "DJI_0001.SRT").string(), "--altitude", "60", "-o",
                           (dji / "given").string()});
  const Outcome given = RunCli(args, dir_, "broken_given");
  EXPECT_EQ(given.exit_code, 1);
  EXPECT_NE(given.err.find("DJI_0001.SRT:3: latitude 95"), std::string::npos) << given.err;
}

// DJI aircraft that write no .SRT (Mini 2, Mini 4K, Mini 4 Pro) put the captions in the video's
// subtitle track (MP4 timed text, what ffmpeg -c:s mov_text writes): `aerovo run` reads them
// there, with the same result as from the .SRT.
TEST_F(CliOutputs, TheCaptionsInsideADjiVideoAreItsTelemetry) {
  if (!io_test::HaveFfmpeg()) GTEST_SKIP() << "ffmpeg not found on PATH";
  const fs::path dji = dir_ / "dji_track";
  fs::create_directories(dji);
  const fs::path srt = dir_ / "sim" / "telemetry.srt";
  ASSERT_TRUE(
      io_test::RunFfmpeg({"-i", Video(), "-i", srt.string(), "-map", "0:v", "-map", "1", "-c:v",
                          "copy", "-c:s", "mov_text", (dji / "DJI_0002.MP4").string()}));
  const auto run = [&](const fs::path& video, std::vector<std::string> extra,
                       const std::string& out) {
    std::vector<std::string> args = {"run",
                                     video.string(),
                                     "--hfov-deg",
                                     "73.7",
                                     "--max-frames",
                                     "6",
                                     "--threads",
                                     "1",
                                     "--no-report",
                                     "-o",
                                     (dji / out).string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunCli(args, dir_, out);
  };
  const Outcome inside = run(dji / "DJI_0002.MP4", {}, "inside");
  ASSERT_EQ(inside.exit_code, 0) << inside.err;
  EXPECT_NE(
      inside.out.find("from " + (dji / "DJI_0002.MP4").string() + " (the video's subtitle track"),
      std::string::npos)
      << inside.out;
  const nlohmann::json s = nlohmann::json::parse(ReadText(dji / "inside" / "summary.json"));
  EXPECT_EQ(s["telemetry"], (dji / "DJI_0002.MP4").string());
  EXPECT_TRUE(s["telemetry_in_video"].get<bool>());
  EXPECT_FALSE(s["telemetry_beside"].get<bool>());
  EXPECT_EQ(s["frames_with_gps"].get<int>(), 6);
  EXPECT_EQ(s["height_source"], "telemetry");
  const nlohmann::json c = nlohmann::json::parse(ReadText(dji / "inside" / "config.json"));
  EXPECT_EQ(c["telemetry"], (dji / "DJI_0002.MP4").string());
  // The same video with the .SRT given (which wins over the track): the same track, to the
  // digit.
  const Outcome given = run(dji / "DJI_0002.MP4", {"--telemetry", srt.string()}, "given_srt");
  ASSERT_EQ(given.exit_code, 0) << given.err;
  for (const char* file : {"vo.tum", "vo.geojson"}) {
    const std::string track = ReadText(dji / "inside" / file);
    EXPECT_NE(track.find("\n"), std::string::npos) << file;
    EXPECT_EQ(track, ReadText(dji / "given_srt" / file)) << file;
  }
  // The first caption damaged (its count beyond its bytes): an error naming the sample; with
  // --lenient-telemetry it is skipped, and the camera's focal length and the first frame's
  // height, which the first frame's record would have given, come from the first record that
  // has them, each with a warning.
  {
    std::string bytes = ReadText(dji / "DJI_0002.MP4");
    const std::size_t at = bytes.find("FrameCnt: 1,");
    ASSERT_NE(at, std::string::npos);
    bytes[at - 2] = '\xFF';
    bytes[at - 1] = '\xFF';
    bytes[at] = '\x01';
    std::ofstream(dji / "DJI_0003.MP4", std::ios::binary) << bytes;
  }
  const std::vector<std::string> no_fov = {
      "run", (dji / "DJI_0003.MP4").string(), "--max-frames", "6", "--threads", "1", "--no-report"};
  std::vector<std::string> args = no_fov;
  args.insert(args.end(),
              {"--hfov-deg", "73.7", "--altitude", "60", "-o", (dji / "damaged").string()});
  const Outcome damaged = RunCli(args, dir_, "damaged");
  ASSERT_EQ(damaged.exit_code, 0) << damaged.err;  // not asked for: flagged, the run goes on
  EXPECT_NE(damaged.err.find("(subtitle track, sample 1): the timed-text sample says its text is "
                             "65535 bytes"),
            std::string::npos)
      << damaged.err;
  EXPECT_NE(damaged.out.find("telemetry: none\n"), std::string::npos) << damaged.out;
  args = no_fov;
  args.insert(args.end(), {"--lenient-telemetry", "-o", (dji / "damaged_lenient").string()});
  const Outcome lenient = RunCli(args, dir_, "damaged_lenient");
  ASSERT_EQ(lenient.exit_code, 0) << lenient.err;
  const nlohmann::json l =
      nlohmann::json::parse(ReadText(dji / "damaged_lenient" / "summary.json"));
  EXPECT_EQ(l["frames_with_gps"].get<int>(), 5);
  EXPECT_EQ(l["focal_source"], "telemetry-35mm");
  EXPECT_NE(l["warnings"].dump().find("its telemetry record has no 35 mm focal length"),
            std::string::npos)
      << l["warnings"].dump(1);
  EXPECT_NE(l["warnings"].dump().find("its height is that of the first record ahead"),
            std::string::npos)
      << l["warnings"].dump(1);
  EXPECT_EQ(l["height_source"], "telemetry");
  {
    const auto rows = e2e::ReadFramesCsv(dji / "damaged_lenient");
    ASSERT_GE(rows.size(), 2u);
    EXPECT_EQ(rows[0].at("height_source"), "first_record");
    EXPECT_EQ(rows[1].at("height_source"), "telemetry");
  }
  // (An .SRT beside the video wins over its track and --telemetry none reads neither:
  // RunSteps.AVideosOwnCaptionsAreItsTelemetryWhenNoSrtIsBeside.)
  // A subtitle track that is not captions was not asked for: flagged, the run goes on; given
  // with --telemetry, the same video is an error naming its track.
  const fs::path words = dji / "words.srt";
  std::ofstream(words) << "1\n00:00:00,000 --> 00:00:01,000\nHello\n";
  ASSERT_TRUE(
      io_test::RunFfmpeg({"-i", Video(), "-i", words.string(), "-map", "0:v", "-map", "1", "-c:v",
                          "copy", "-c:s", "mov_text", (dji / "film.mp4").string()}));
  const Outcome film = run(dji / "film.mp4", {"--altitude", "60"}, "film");
  ASSERT_EQ(film.exit_code, 0) << film.err;
  EXPECT_NE(film.err.find("the telemetry found in the video's subtitle track could not be read"),
            std::string::npos)
      << film.err;
  const Outcome film_given =
      run(dji / "film.mp4", {"--telemetry", (dji / "film.mp4").string(), "--altitude", "60"},
          "film_given");
  EXPECT_EQ(film_given.exit_code, 1) << film_given.err;
  EXPECT_NE(film_given.err.find("film.mp4 (subtitle track 0 as SRT)"), std::string::npos)
      << film_given.err;
  // `aerovo telemetry` reads the track too.
  const Outcome t = RunCli({"telemetry", (dji / "DJI_0002.MP4").string()}, dir_, "telemetry");
  EXPECT_EQ(t.exit_code, 0) << t.err;
  EXPECT_NE(t.out.find("DJI_0002.MP4"), std::string::npos) << t.out;
}

TEST_F(CliOutputs, QuietHidesTheProgressNotTheWarningsWhichGoToStderr) {
  // A telemetry that covers only the first half of the flight: a warning about the frames
  // without a fix.
  const fs::path srt = dir_ / "half.srt";
  {
    const std::string full = ReadText(dir_ / "sim" / "telemetry.srt");
    // Keep the SRT entries of the first 30 frames (entries are separated by blank lines).
    std::string kept;
    size_t at = 0;
    for (int i = 0; i < 30; ++i) {
      const size_t end = full.find("\n\n", at);
      if (end == std::string::npos) break;
      kept += full.substr(at, end + 2 - at);
      at = end + 2;
    }
    std::ofstream(srt) << kept;
  }
  const fs::path out = dir_ / "quiet";
  std::vector<std::string> args = RunArgs(out);
  args.insert(args.end(), {"--telemetry", srt.string(), "-q"});
  const Outcome o = RunCli(args, dir_, "quiet");
  ASSERT_EQ(o.exit_code, 0) << o.err;
  EXPECT_NE(o.err.find("warning: "), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("have no telemetry fix"), std::string::npos) << o.err;
  EXPECT_EQ(o.out.find("warning"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find(" processed: ok "), std::string::npos) << o.out;  // the final table
}

TEST_F(CliOutputs, YamlConfigWithAnchorsAndAliases) {
  const fs::path cfg = dir_ / "anchors.yaml";
  std::ofstream(cfg) << ".common: &common {step: 2, threads: 1}\n"
                        "<<: *common\n"
                        "max_frames: &n 6\n"
                        "no_such_key_check: *n\n";
  // An alias as the value of an unknown key is reported as that key, not as the alias.
  const Outcome bad =
      RunCli({"run", Video(), "--config", cfg.string(), "--print-config"}, dir_, "yaml_bad");
  EXPECT_EQ(bad.exit_code, 2);  // a bad configuration is a usage error (cli/conventions.h)
  EXPECT_NE((bad.err + bad.out).find("no_such_key_check"), std::string::npos) << bad.err;
  std::ofstream(cfg) << ".common: &common {step: 2, threads: 1}\n"
                        "<<: *common\n"
                        "max_frames: &n 6\n";
  const Outcome ok =
      RunCli({"run", Video(), "--config", cfg.string(), "--print-config"}, dir_, "yaml_ok");
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  const nlohmann::json j = nlohmann::json::parse(ok.out);
  EXPECT_EQ(j["step"], 2);
  EXPECT_EQ(j["max_frames"], 6);
  EXPECT_EQ(j["surf.num_threads"], 1);
}

TEST_F(CliOutputs, ATimeWindowThatSelectsNoFrameIsAClearError) {
  struct Case {
    std::vector<std::string> flags;
    std::string expect;
    int exit_code;
  };
  // The flight lasts 12.1 s (kFrames frames at 10 fps).
  const std::vector<Case> cases = {
      {{"--start-s", "1000"}, "past the end", 1},
      {{"--start-s", "1.01", "--end-s", "1.05"}, "no frame to process", 1},
      // Options that contradict each other: a usage error (cli/conventions.h).
      {{"--start-s", "3", "--end-s", "2"}, "end_s must be >= start_s", 2},
  };
  int k = 0;
  for (const Case& c : cases) {
    const fs::path out = dir_ / ("window" + std::to_string(k++));
    std::vector<std::string> args = RunArgs(out);
    args.insert(args.end(), c.flags.begin(), c.flags.end());
    const Outcome o = RunCli(args, dir_, out.filename().string());
    EXPECT_EQ(o.exit_code, c.exit_code) << c.flags[1];
    EXPECT_NE(o.err.find(c.expect), std::string::npos) << o.err;
    if (c.expect == "no frame to process") {
      EXPECT_NE(o.err.find("lasting 12.100 s"), std::string::npos) << o.err;
      const nlohmann::json s = nlohmann::json::parse(ReadText(out / "summary.json"));
      EXPECT_NE(s["error"].get<std::string>().find("no frame to process"), std::string::npos);
    }
  }
}

#endif  // AEROVO_CLI_PATH

}  // namespace
}  // namespace aerovo::outputs_test
