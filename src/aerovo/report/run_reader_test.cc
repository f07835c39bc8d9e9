// Reading a run folder back (run_reader.h) from files written here, without a run: the cut
// last line of a progressive CSV file (frames.csv, transforms.csv). The whole-run cases are
// tests/e2e/html_report_test.cc (HtmlReport.RunReaderDropsOnlyABrokenLastRecord).
#include "aerovo/report/run_reader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "aerovo/core/error.h"

namespace aerovo {
namespace {

namespace fs = std::filesystem;

// frames.csv's columns that ReadRunDir requires, and a row of them for frame `i`.
const char* const kFramesHeader =
    "frame,time_s,x_m,y_m,lat_deg,lon_deg,alt_m,n_surf,n_matched,n_inliers,cluster,detect_ms,"
    "describe_ms,correspond_ms,estimate_ms,total_ms,status,gps_lat_deg,gps_lon_deg,gps_alt_m\n";
std::string FrameRow(int i) {
  return std::to_string(i) + "," + std::to_string(0.5 * i) + "," + std::to_string(2 * i) +
         ",0,,,,500,400,300,4,1,1,1,1,4," + (i == 0 ? "first" : "ok") + ",,,\n";
}

class RunReaderCut : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("aerovo_run_reader_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// A last line cut inside its last value still has every field: before, its value was read cut
// short (ty -34.132989 as -34.1; x_m 6.5 as 6). aerovo ends every record with a line end, so a
// last line without one is a cut record and is dropped, as one with fewer fields is.
TEST_F(RunReaderCut, ALastLineWithoutItsLineEndIsDroppedEvenWithEveryField) {
  const std::string rows = FrameRow(0) + FrameRow(1) + FrameRow(2);
  std::string cut = FrameRow(3);
  cut = cut.substr(0, cut.size() - 1);  // every field, no line end
  // frames.csv: a row whose end was not written (its last cells are empty anyway).
  std::ofstream(dir_ / "frames.csv") << kFramesHeader << rows << cut;
  const std::string transforms_header = "frame,a11,a12,tx,a21,a22,ty\n";
  std::ofstream(dir_ / "transforms.csv") << transforms_header << "1,1,0,-20.000000,0,1,-34.132989\n"
                                         << "2,1,0,-20.000000,0,1,-34.1";
  const RunData run = ReadRunDir(dir_);
  ASSERT_EQ(run.frames.size(), 3u);
  EXPECT_EQ(run.frames.back().frame, 2);
  ASSERT_EQ(run.transforms.size(), 1u);
  EXPECT_DOUBLE_EQ(run.transforms[0].a[5], -34.132989);
  // With its line end the same row is read.
  std::ofstream(dir_ / "frames.csv") << kFramesHeader << rows << cut << "\n";
  std::ofstream(dir_ / "transforms.csv") << transforms_header << "1,1,0,-20.000000,0,1,-34.132989\n"
                                         << "2,1,0,-20.000000,0,1,-34.1\n";
  const RunData whole = ReadRunDir(dir_);
  EXPECT_EQ(whole.frames.size(), 4u);
  ASSERT_EQ(whole.transforms.size(), 2u);
  EXPECT_DOUBLE_EQ(whole.transforms[1].a[5], -34.1);
  // A broken record before the last is still an error naming the file and line.
  std::ofstream(dir_ / "transforms.csv") << transforms_header << "1,1,0\n"
                                         << "2,1,0,-20.000000,0,1,-34.1\n";
  try {
    ReadRunDir(dir_);
    ADD_FAILURE() << "a short record before the last accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("transforms.csv' line 2: 3 fields, the header has 7"),
              std::string::npos)
        << e.what();
  }
}

// vo_optimized.tum, written pose by pose at the end of a run, is read as ReadTumPoints reads a
// file that may be cut (telemetry/reference_track.h): a last pose without its line end is dropped
// ("1.0 2.5 -3" may be the start of "1.0 2.5 -3.75 ..."), and its numbers are strict.
TEST_F(RunReaderCut, ACutLastPoseOfTheOptimisedTrackIsDropped) {
  std::ofstream(dir_ / "frames.csv") << kFramesHeader << FrameRow(0) << FrameRow(1) << FrameRow(2);
  std::ofstream(dir_ / "vo_optimized.tum")
      << "0.0 0 0 0 0 0 0 1\n0.5 2.5 -3.75 0 0 0 0 1\n1.0 5 -7";
  const RunData run = ReadRunDir(dir_);
  ASSERT_EQ(run.optimized.size(), 2u);
  EXPECT_DOUBLE_EQ(run.optimized[1].t, 0.5);
  EXPECT_DOUBLE_EQ(run.optimized[1].x, 2.5);
  EXPECT_DOUBLE_EQ(run.optimized[1].y, -3.75);
  std::ofstream(dir_ / "vo_optimized.tum") << "0.0 0 0 0 0 0 0 1\n0.5 nan -3.75 0 0 0 0 1\n";
  try {
    ReadRunDir(dir_);
    ADD_FAILURE() << "nan read as a position";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("vo_optimized.tum:2: 'nan' is not a number"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace aerovo
