// Interrupted runs at the CLI level: the built `aerovo` binary is run as a child process on a
// simulated flight and stopped mid-run with SIGINT or SIGTERM. Each must leave every output
// valid (frames.csv complete to its last row, GeoJSON parsed by nlohmann-json, KML and GPX by
// pugixml, summary.json saying interrupted), say how far it got and where the outputs are, and
// exit with 128 + the signal (130, 143).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <pugixml.hpp>

#include "e2e_testing.h"

namespace aerovo::cli_signal_test {
namespace {

namespace fs = std::filesystem;

#ifdef AEROVO_CLI_PATH

using e2e::ReadText;
using e2e::CountLines;

class CliSignal : public ::testing::Test {
 protected:
  // One simulated flight for both signals: 301 frames of 640x480 video with DJI SRT (large
  // enough frames that the run lasts several seconds, so the signal lands mid-run).
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("aerovo_cli_signal_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    const std::string cmd = std::string(AEROVO_CLI_PATH) +
                            " simulate --pattern line --length-m 300 --legs 1 --width 640 "
                            "--height 480 --fps 10 --hfov-deg 73.7 --out " +
                            (dir_ / "sim").string() + " > /dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  struct Outcome {
    int exit_code = -1;
    std::string output;  // stdout + stderr
    fs::path out;
  };

  // Runs `aerovo run` on the flight, sends `sig` once frames.csv has 10 rows, waits for exit.
  static Outcome RunAndSignal(int sig, const std::string& name) {
    Outcome o;
    o.out = dir_ / name;
    const fs::path log = dir_ / (name + ".log");
    const std::string video = (dir_ / "sim" / "video.mp4").string();
    const std::string srt = (dir_ / "sim" / "telemetry.srt").string();
    const pid_t pid = ::fork();
    if (pid < 0) return o;
    if (pid == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::execl(AEROVO_CLI_PATH, AEROVO_CLI_PATH, "run", video.c_str(), "--telemetry", srt.c_str(),
              "--hfov-deg", "73.7", "--threads", "1", "-o", o.out.c_str(),
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const auto start = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (fs::exists(o.out / "frames.csv") && CountLines(o.out / "frames.csv") > 10) break;
    }
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    o.output = ReadText(log);
    return o;
  }

  // Every output of the run folder is valid and holds `frames` frames.
  static void CheckOutputs(const fs::path& out, int frames) {
    // frames.csv: header + one complete row per frame (as many fields as the header).
    std::ifstream csv(out / "frames.csv");
    std::string header, line;
    ASSERT_TRUE(static_cast<bool>(std::getline(csv, header)));
    const auto fields = [](const std::string& l) { return std::count(l.begin(), l.end(), ','); };
    int rows = 0;
    while (std::getline(csv, line)) {
      EXPECT_EQ(fields(line), fields(header)) << "row " << rows << ": " << line;
      EXPECT_EQ(line.rfind(std::to_string(rows) + ",", 0), 0u) << line;  // frames 0, 1, 2...
      ++rows;
    }
    EXPECT_EQ(rows, frames);
    // GeoJSON: a FeatureCollection whose track has one position per frame.
    for (const char* f : {"vo.geojson", "gps.geojson", "vo_frames.geojson"}) {
      nlohmann::json j;
      ASSERT_NO_THROW(j = nlohmann::json::parse(ReadText(out / f))) << f;
      EXPECT_EQ(j["type"], "FeatureCollection") << f;
    }
    const nlohmann::json vo = nlohmann::json::parse(ReadText(out / "vo.geojson"));
    ASSERT_EQ(vo["features"].size(), 1u);
    EXPECT_EQ(vo["features"][0]["geometry"]["coordinates"].size(), static_cast<size_t>(frames));
    // KML and GPX: well-formed XML with one coordinate / trkpt per frame.
    for (const char* f : {"vo.kml", "gps.kml", "run.kml", "vo.gpx", "gps.gpx"}) {
      pugi::xml_document doc;
      const pugi::xml_parse_result r = doc.load_file((out / f).c_str());
      EXPECT_TRUE(r) << f << ": " << r.description() << " at offset " << r.offset;
    }
    pugi::xml_document kml;
    ASSERT_TRUE(kml.load_file((out / "vo.kml").c_str()));
    std::istringstream coords(kml.select_node("//LineString/coordinates").node().child_value());
    int n_coords = 0;
    for (std::string c; coords >> c;) ++n_coords;
    EXPECT_EQ(n_coords, frames);
    pugi::xml_document gpx;
    ASSERT_TRUE(gpx.load_file((out / "vo.gpx").c_str()));
    EXPECT_EQ(static_cast<int>(gpx.select_nodes("//trkpt").size()), frames);
    // TUM: one pose per frame.
    EXPECT_EQ(CountLines(out / "vo.tum"), frames);
  }

  static void Check(int sig, int expected_exit, const char* sig_name) {
    const Outcome o = RunAndSignal(sig, sig_name);
    const nlohmann::json summary = nlohmann::json::parse(ReadText(o.out / "summary.json"));
    const int frames = summary["frames_processed"];
    EXPECT_GT(frames, 10);
    if (o.exit_code == 0) {
      // The run finished before the signal arrived (a heavily loaded machine): still valid.
      EXPECT_EQ(frames, 301);
      EXPECT_FALSE(summary["interrupted"].get<bool>());
    } else {
      EXPECT_EQ(o.exit_code, expected_exit) << o.output;
      EXPECT_TRUE(summary["interrupted"].get<bool>());
      EXPECT_LT(frames, 301);
      // How far it got and where the outputs are.
      const std::string says = std::string("interrupted by ") + sig_name + " after " +
                               std::to_string(frames) + " of 301 frames";
      EXPECT_NE(o.output.find(says), std::string::npos) << o.output;
      EXPECT_NE(o.output.find(o.out.string()), std::string::npos) << o.output;
    }
    CheckOutputs(o.out, frames);
  }

  static fs::path dir_;
};

fs::path CliSignal::dir_;

TEST_F(CliSignal, SigintFlushesEveryOutputAndExits130) { Check(SIGINT, 130, "SIGINT"); }

TEST_F(CliSignal, SigtermFlushesEveryOutputAndExits143) { Check(SIGTERM, 143, "SIGTERM"); }

// `aerovo experiment` stopped by SIGINT during its second run: exit 130, experiment.json lists
// the finished run only, and the interrupted run's folder is valid up to its last frame.
TEST_F(CliSignal, ExperimentKeepsItsFinishedRunsOnSigint) {
  const fs::path out = dir_ / "experiment";
  const fs::path log = dir_ / "experiment.log";
  const std::string video = (dir_ / "sim" / "video.mp4").string();
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execl(AEROVO_CLI_PATH, AEROVO_CLI_PATH, "experiment", "illumination", video.c_str(), "--k",
            "1,0.75", "--max-frames", "80", "--threads", "1", "--no-report", "-o", out.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Wait for the second run to be under way (the first is then listed), then interrupt.
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const fs::path csv = out / "k0.75" / "frames.csv";
    if (fs::exists(csv) && CountLines(csv) > 10) break;
  }
  ::kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << ReadText(log);
  const nlohmann::json j = nlohmann::json::parse(ReadText(out / "experiment.json"));
  EXPECT_EQ(j["kind"], "illumination");
  const nlohmann::json second = nlohmann::json::parse(ReadText(out / "k0.75" / "summary.json"));
  if (WEXITSTATUS(status) == 0) {  // finished before the signal (heavily loaded machine)
    EXPECT_EQ(j["runs"].size(), 2u);
    EXPECT_FALSE(second["interrupted"].get<bool>());
  } else {
    EXPECT_EQ(WEXITSTATUS(status), 130) << ReadText(log);
    ASSERT_EQ(j["runs"].size(), 1u);
    EXPECT_EQ(j["runs"][0]["dir"], "k1.00");
    EXPECT_EQ(j["tables"]["features"]["rows"].size(), 1u);
    EXPECT_TRUE(second["interrupted"].get<bool>());
    CheckOutputs(out / "k0.75", second["frames_processed"].get<int>());
  }
  const nlohmann::json first = nlohmann::json::parse(ReadText(out / "k1.00" / "summary.json"));
  EXPECT_EQ(first["frames_processed"], 80);
  EXPECT_FALSE(first["interrupted"].get<bool>());
  EXPECT_TRUE(fs::exists(out / "tables.md"));
}

// Bad input at the CLI: a message naming the file and the problem on stderr, exit status 1, no
// crash (a crash would be a signal, not an exit).
TEST(CliErrors, BadInputExitsWithOneAndAMessage) {
  const fs::path dir =
      fs::temp_directory_path() / ("aerovo_cli_errors_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "empty.mp4").close();
  std::ofstream(dir / "notes.mp4") << "not a video\n";
  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> cases = {
      {(dir / "empty.mp4").string(), "empty.mp4': the file is empty (0 bytes)"},
      {(dir / "notes.mp4").string(), "cannot open video '" + (dir / "notes.mp4").string()},
      {(dir / "missing.mp4").string(), "missing.mp4': no such file or directory"},
  };
  for (const Case& c : cases) {
    const std::string cmd = std::string(AEROVO_CLI_PATH) + " run " + c.args + " --hfov-deg 70 -o " +
                            (dir / "run").string() + " > " + (dir / "log").string() + " 2>&1";
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status)) << cmd;
    EXPECT_EQ(WEXITSTATUS(status), 1) << cmd;
    const std::string out = ReadText(dir / "log");
    EXPECT_NE(out.find("aerovo: error: "), std::string::npos) << out;
    EXPECT_NE(out.find(c.expected), std::string::npos) << out;
  }
  fs::remove_all(dir);
}

#endif  // AEROVO_CLI_PATH

}  // namespace
}  // namespace aerovo::cli_signal_test
