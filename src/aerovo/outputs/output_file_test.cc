// Output files under write failures: the AEROVO_TEST_FAIL_WRITE_AFTER_BYTES budget (set through
// output_file_testing, the same counter) and a real per-process file size limit (RLIMIT_FSIZE in
// a child process, SIGXFSZ ignored so that write() fails with EFBIG). Every file left must be
// valid with everything written before the failure, and the error must name the file.
#include "aerovo/outputs/output_file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "aerovo/core/testing.h"
#include "aerovo/outputs/track_writers.h"

namespace aerovo::output_file_test {
namespace {

namespace fs = std::filesystem;

using ::aerovo::testing::ReadText;

fs::path TempDir(const std::string& name) {
  return ::aerovo::testing::FreshTempDir("aerovo_output_file", name);
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

GeoTrackPoint Point(int i) { return {0.1 * i, {45.0 + 1e-5 * i, 7.0 + 1e-5 * i, 300.0}}; }

// Restores "no budget" whatever the test does.
struct BudgetGuard {
  explicit BudgetGuard(long long bytes) { output_file_testing::SetBudget(bytes); }
  ~BudgetGuard() { output_file_testing::SetBudget(-1); }
};

TEST(OutputFile, FailedAppendsLeaveEveryTrackFileValidAndNameTheFile) {
  const fs::path dir = TempDir("budget");
  // The budget runs out part-way through an append: each writer must roll it back.
  for (long long budget : {1500LL, 2345LL, 4000LL}) {
    BudgetGuard guard(budget);
    GeoJsonTrackWriter geojson(dir / "t.geojson", "t");
    GpxTrackWriter gpx(dir / "t.gpx", "t");
    KmlTrackWriter kml(dir / "t.kml", "t");
    GeoJsonPointsWriter points(dir / "p.geojson");
    int n_geojson = 0, n_gpx = 0, n_kml = 0, n_points = 0;
    std::string message;
    bool geojson_ok = true, gpx_ok = true, kml_ok = true, points_ok = true;
    for (int i = 0; i < 200; ++i) {
      const auto step = [&](bool& ok, int& n, auto&& append) {
        if (!ok) return;
        try {
          append();
          ++n;
        } catch (const OutputError& e) {
          ok = false;
          message = e.what();
        }
      };
      step(geojson_ok, n_geojson, [&] { geojson.Append(Point(i)); });
      step(gpx_ok, n_gpx, [&] { gpx.Append(Point(i)); });
      step(kml_ok, n_kml, [&] { kml.Append(Point(i)); });
      step(points_ok, n_points, [&] { points.Append(Point(i).geo, nlohmann::json{{"frame", i}}); });
    }
    // The budget is shared: once it ran out, every writer's next append failed, so each
    // format's roll-back is exercised (a format never written would not prove anything).
    EXPECT_FALSE(geojson_ok || gpx_ok || kml_ok || points_ok) << "budget " << budget;
    EXPECT_NE(message.find(dir.string()), std::string::npos) << message;
    EXPECT_NE(message.find("No space left on device"), std::string::npos) << message;
    // GeoJSON: parses, with exactly the points appended successfully.
    // Every writer started (its constructor would have thrown), so every file must be there.
    for (const char* name : {"t.geojson", "p.geojson", "t.gpx", "t.kml"}) {
      ASSERT_TRUE(fs::exists(dir / name)) << name << ", budget " << budget;
    }
    {
      const nlohmann::json j = nlohmann::json::parse(ReadText(dir / "t.geojson"));
      ASSERT_EQ(j["type"], "FeatureCollection");
      if (n_geojson >= 2) {
        EXPECT_EQ(j["features"][0]["geometry"]["coordinates"].size(), size_t(n_geojson));
      }
    }
    {
      const nlohmann::json j = nlohmann::json::parse(ReadText(dir / "p.geojson"));
      EXPECT_EQ(j["features"].size(), size_t(n_points)) << "budget " << budget;
    }
    // GPX and KML: the closing tail is there once, after exactly the points appended.
    {
      const std::string gpx_text = ReadText(dir / "t.gpx");
      EXPECT_EQ(Count(gpx_text, "<trkpt "), n_gpx);
      ASSERT_GE(gpx_text.size(), 24u);
      EXPECT_EQ(gpx_text.substr(gpx_text.size() - 24), "\n</trkseg></trk>\n</gpx>\n");
    }
    {
      const std::string kml_text = ReadText(dir / "t.kml");
      EXPECT_EQ(Count(kml_text, "</kml>"), 1);
      ASSERT_GE(kml_text.size(), 7u);
      EXPECT_EQ(kml_text.substr(kml_text.size() - 7), "</kml>\n");
    }
  }
  fs::remove_all(dir);
}

TEST(OutputFile, AFileThatCannotBeStartedIsRemovedNotLeftEmpty) {
  const fs::path dir = TempDir("start");
  BudgetGuard guard(10);
  EXPECT_THROW(GpxTrackWriter(dir / "t.gpx", "t"), OutputError);
  EXPECT_FALSE(fs::exists(dir / "t.gpx"));
  fs::remove_all(dir);
}

TEST(OutputFile, AtomicWriteKeepsTheOldFileOnFailureAndLeavesNoTemporary) {
  const fs::path dir = TempDir("atomic");
  WriteFileAtomic(dir / "s.json", "{\"old\": true}\n");
  {
    BudgetGuard guard(5);
    try {
      WriteFileAtomic(dir / "s.json", std::string(100, 'x'));
      FAIL() << "no error";
    } catch (const OutputError& e) {
      EXPECT_NE(std::string(e.what()).find((dir / "s.json").string()), std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(ReadText(dir / "s.json"), "{\"old\": true}\n");
  EXPECT_FALSE(fs::exists(dir / "s.json.tmp"));
  fs::remove_all(dir);
}

TEST(OutputFile, SpaceReserveHoldsAndGivesBackItsBytes) {
  const fs::path dir = TempDir("reserve");
  BudgetGuard guard(10000);
  SpaceReserve reserve(dir / ".reserve", 8000);
  ASSERT_TRUE(reserve.ok());
  EXPECT_EQ(fs::file_size(dir / ".reserve"), 8000u);
  EXPECT_EQ(output_file_testing::RemainingBudget(), 2000);
  // The rest of the "disk" fills up; the summary still fits once the reserve is released.
  EXPECT_THROW(WriteFileAtomic(dir / "big", std::string(5000, 'x')), OutputError);
  reserve.Release();
  EXPECT_EQ(fs::file_size(dir / ".reserve"), 0u);
  EXPECT_EQ(output_file_testing::RemainingBudget(), 10000);
  WriteFileAtomic(dir / "summary.json", std::string(5000, 'x'));
  EXPECT_EQ(fs::file_size(dir / "summary.json"), 5000u);
  // Too big a reserve is simply absent.
  SpaceReserve too_big(dir / ".reserve2", 1 << 20);
  EXPECT_FALSE(too_big.ok());
  fs::remove_all(dir);
}

// A real limit: RLIMIT_FSIZE in a child (the kernel's EFBIG). The child writes frames.csv and
// vo.gpx through a TrackWriterSet until a write fails, then exits 0 if the error named the
// file (its message on stderr).
TEST(OutputFile, FileSizeLimitOfTheKernelLeavesValidFiles) {
  const fs::path dir = TempDir("rlimit");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    struct rlimit lim {};
    lim.rlim_cur = lim.rlim_max = 6000;
    ::setrlimit(RLIMIT_FSIZE, &lim);
    try {
      TrackWriterSet set(dir);
      for (int i = 0; i < 1000; ++i) {
        FrameRecord r;
        r.frame = i;
        r.time_s = 0.1 * i;
        r.x_m = i;
        r.geo = Point(i).geo;
        r.status = "ok";
        set.Append(r, Point(i).geo);
      }
    } catch (const OutputError& e) {
      const std::string m = e.what();
      ::_exit(m.find("File too large") != std::string::npos ? 0 : 3);
    } catch (...) {
      ::_exit(4);
    }
    ::_exit(5);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  for (const char* name :
       {RunFileNames::kVoGeoJson, RunFileNames::kGpsGeoJson, RunFileNames::kVoFramesGeoJson}) {
    // TrackWriterSet starts every file in its constructor: each must exist and parse.
    ASSERT_TRUE(fs::exists(dir / name)) << name;
    EXPECT_TRUE(nlohmann::json::accept(ReadText(dir / name))) << name;
  }
  const std::string gpx = ReadText(dir / RunFileNames::kVoGpx);
  EXPECT_EQ(gpx.substr(gpx.size() - 24), "\n</trkseg></trk>\n</gpx>\n");
  const std::string csv = ReadText(dir / RunFileNames::kFramesCsv);
  ASSERT_FALSE(csv.empty());
  EXPECT_EQ(csv.back(), '\n');  // whole rows only
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::output_file_test
