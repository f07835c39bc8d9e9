// Reading a run folder back (run_reader.h) from files written here, without a run: the cells
// checked, and the cut last line of a progressive file (frames.csv, transforms.csv,
// vo_optimized.tum). The whole-run cases are tests/e2e/html_report_test.cc
// (HtmlReport.RunReaderDropsOnlyABrokenLastRecord).
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

class RunReaderFiles : public ::testing::Test {
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
TEST_F(RunReaderFiles, ALastLineWithoutItsLineEndIsDroppedEvenWithEveryField) {
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
TEST_F(RunReaderFiles, ACutLastPoseOfTheOptimisedTrackIsDropped) {
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

// Every cell is checked against what aerovo writes there, and a bad one is an error naming the
// file, line and column: before, a frame index of 1e300 was cast to int (undefined behaviour),
// -5 or a frame before the previous row's were taken, and a latitude of 1000 ended the report in
// "LocalEnu origin: latitude 1000.000000 deg is outside [-90, 90]" without naming any file.
TEST_F(RunReaderFiles, EveryCellIsCheckedAndABadOneIsNamedWithItsFileLineAndColumn) {
  const auto error_of = [&](const std::string& frames) -> std::string {
    std::ofstream(dir_ / "frames.csv") << kFramesHeader << frames;
    try {
      ReadRunDir(dir_);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string row0 = FrameRow(0), row1 = FrameRow(1), row2 = FrameRow(2);
  EXPECT_EQ(error_of(row0 + row1 + row2), "no error");
  const auto with = [](std::string row, const std::string& from, const std::string& to) {
    return row.replace(row.find(from), from.size(), to);
  };
  const struct {
    std::string frames, message;
  } kCases[] = {
      {row0 + with(row1, "1,0.5", "1e300,0.5") + row2,
       "frames.csv' line 3: column 'frame' is not a whole number in [0, 100000000]: '1e300'"},
      {row0 + with(row1, "1,0.5", "-5,0.5") + row2, "line 3: column 'frame' is not a whole number"},
      {row0 + with(row1, "1,0.5", "1.5,0.5") + row2,
       "line 3: column 'frame' is not a whole number"},
      {row0 + row2 + row1, "frames.csv' line 4: column 'frame' 1 comes after frame 2"},
      {row0 + row1 + row1, "frames.csv' line 4: column 'frame' 1 comes after frame 1"},
      {row0 + with(row1, ",500,400,300,4,", ",500,400,-3,4,") + row2,
       "line 3: column 'n_inliers' is not a whole number in [0, 2147483647]: '-3'"},
      {row0 + with(row1, ",500,400,300,4,", ",500,400,300,-2,") + row2,
       "line 3: column 'cluster' is not a whole number in [-1, 2147483647]: '-2'"},
      {row0 + with(row1, ",0,,,,500", ",0,1000,7,,500") + row2,
       "frames.csv' line 3: column 'lat_deg' is not a latitude: 1000"},
      {row0 + with(row1, ",0,,,,500", ",0,45,-700,,500") + row2,
       "frames.csv' line 3: column 'lon_deg' is not a longitude: -700"},
      {row0 + with(row1, ",ok,,,", ",ok,91,7,") + row2,
       "frames.csv' line 3: column 'gps_lat_deg' is not a latitude: 91"},
      // A cell is quoted printable: no escape sequence reaches the terminal.
      {row0 + with(row1, "1,0.5", "1,\x1b[2J") + row2,
       "line 3: column 'time_s' is not a number: '\\x1B[2J"},
  };
  for (const auto& c : kCases) {
    const std::string m = error_of(c.frames);
    EXPECT_NE(m.find(c.message), std::string::npos) << c.frames << "\n" << m;
  }
  // transforms.csv and map_fixes.csv alike.
  std::ofstream(dir_ / "frames.csv") << kFramesHeader << row0 << row1 << row2;
  std::ofstream(dir_ / "transforms.csv") << "frame,a11,a12,tx,a21,a22,ty\n"
                                         << "2,1,0,0,0,1,0\n1,1,0,0,0,1,0\n";
  try {
    ReadRunDir(dir_);
    ADD_FAILURE() << "transforms.csv out of order accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("transforms.csv' line 3: column 'frame' 1 comes after "
                                         "frame 2"),
              std::string::npos)
        << e.what();
  }
  fs::remove(dir_ / "transforms.csv");
  const std::string fixes_header = "frame,time_s,status,lat_deg,lon_deg,gps_error_m,applied,map\n";
  std::ofstream(dir_ / "map_fixes.csv") << fixes_header << "1,0.5,ok,45,7,1.5,1,0\n"
                                        << "1,0.5,ok,45,7,1.5,0,1\n";
  const RunData two_maps = ReadRunDir(dir_);  // two maps tried on one frame
  ASSERT_EQ(two_maps.map_fixes.size(), 2u);
  EXPECT_EQ(two_maps.map_fixes[1].map, 1);
  std::ofstream(dir_ / "map_fixes.csv") << fixes_header << "1,0.5,ok,45,7,1.5,1,-1\n";
  try {
    ReadRunDir(dir_);
    ADD_FAILURE() << "map -1 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("map_fixes.csv' line 2: column 'map' is not a whole "
                                         "number in [0, 2147483647]: '-1'"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace aerovo
