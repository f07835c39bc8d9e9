// Reference (ground-truth) track reading: TUM and CSV with named columns, and bad input.
#include "aerovo/telemetry/reference_track.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "aerovo/core/error.h"
#include "aerovo/telemetry/io_test_util.h"

namespace aerovo::reference_track_test {
namespace {

void Write(const std::filesystem::path& p, const std::string& text) { std::ofstream(p) << text; }

TEST(ReferenceTrack, ReadsTum) {
  io_test::TempDir dir("aerovo_reftrack");
  Write(dir / "gt.tum",
        "# t x y z qx qy qz qw\n0.0 0 0 100 0 0 0 1\n0.2 2.5 -1 100 0 0 0 1\n\n0.4 5 -2 100\n");
  const ReferenceTrack t = ReadReferenceTrack(dir / "gt.tum");
  EXPECT_EQ(t.format, "tum");
  EXPECT_FALSE(t.geographic);
  ASSERT_EQ(t.points.size(), 3u);
  EXPECT_DOUBLE_EQ(t.points[1].time_s, 0.2);
  EXPECT_DOUBLE_EQ(t.points[1].x_m, 2.5);
  EXPECT_DOUBLE_EQ(t.points[2].y_m, -2.0);
  EXPECT_FALSE(t.points[0].geo.has_value());
  EXPECT_FALSE(t.points[0].frame_index.has_value());
}

TEST(ReferenceTrack, ReadsSimulatorCsv) {
  io_test::TempDir dir("aerovo_reftrack");
  Write(dir / "ground_truth.csv",
        "frame,time_s,east_m,north_m,up_m,lat_deg,lon_deg,alt_m,yaw_deg,pitch_deg,roll_deg,"
        "nodata_fraction\n"
        "0,0.000000,0,0,100,43.537348735,6.555255181,400.0,90,0,0,0\n"
        "1,0.200000,2.0,0,100,43.537348734,6.555279924,400.0,90,0,0,0\n");
  const ReferenceTrack t = ReadReferenceTrack(dir / "ground_truth.csv");
  EXPECT_EQ(t.format, "csv");
  EXPECT_TRUE(t.geographic);
  ASSERT_EQ(t.points.size(), 2u);
  ASSERT_TRUE(t.points[1].geo.has_value());
  EXPECT_DOUBLE_EQ(t.points[1].geo->lon_deg, 6.555279924);
  EXPECT_DOUBLE_EQ(t.points[1].time_s, 0.2);
  EXPECT_EQ(t.points[1].frame_index, 1);
}

TEST(ReferenceTrack, BadInputNamesFileAndLine) {
  io_test::TempDir dir("aerovo_reftrack");
  Write(dir / "bad.tum", "0 0 0 0\n0.1 x 0 0\n");
  try {
    ReadReferenceTrack(dir / "bad.tum");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.tum:2"), std::string::npos) << e.what();
  }
  Write(dir / "back.tum", "1 0 0\n0.5 1 1\n");
  EXPECT_THROW(ReadReferenceTrack(dir / "back.tum"), InputError);
  Write(dir / "one.tum", "1 0 0\n");
  EXPECT_THROW(ReadReferenceTrack(dir / "one.tum"), InputError);
  EXPECT_THROW(ReadReferenceTrack(dir / "missing.tum"), InputError);
}

// A run's own TUM file (vo_optimized.tum) may end in part of a pose when the run was killed
// mid-line: "2 3.5 -1" is the start of "2 3.5 -1.25 ...". It is dropped only when the caller says
// the file may be cut; a truth file given by the user is read whole.
TEST(ReferenceTrack, TumPointsDropALastLineWithoutItsLineEndOnlyWhenAsked) {
  io_test::TempDir dir("aerovo_reftrack");
  Write(dir / "cut.tum", "0 0 0 0 0 0 0 1\n1 1.5 -0.5 0 0 0 0 1\n2 3.5 -1");
  const std::vector<ReferencePoint> cut = ReadTumPoints(dir / "cut.tum", true);
  ASSERT_EQ(cut.size(), 2u);
  EXPECT_DOUBLE_EQ(cut[1].time_s, 1.0);
  EXPECT_DOUBLE_EQ(cut[1].x_m, 1.5);
  EXPECT_DOUBLE_EQ(cut[1].y_m, -0.5);
  const std::vector<ReferencePoint> whole = ReadTumPoints(dir / "cut.tum");
  ASSERT_EQ(whole.size(), 3u);
  EXPECT_DOUBLE_EQ(whole[2].y_m, -1.0);
  // With its line end the last pose is read in both modes.
  Write(dir / "whole.tum", "0 0 0\n1 1.5 -0.5\n2 3.5 -1.25\n");
  ASSERT_EQ(ReadTumPoints(dir / "whole.tum", true).size(), 3u);
  EXPECT_DOUBLE_EQ(ReadTumPoints(dir / "whole.tum", true)[2].y_m, -1.25);
  // A damaged line before the last is an error either way.
  Write(dir / "bad.tum", "0 0 0\n1 1.5\n2 3.5 -1.25\n");
  EXPECT_THROW(ReadTumPoints(dir / "bad.tum", true), InputError);
  // A file of comments only has no pose, which is not an error here (ReadReferenceTrack needs 2).
  Write(dir / "comments.tum", "# t x y z qx qy qz qw\n\n");
  EXPECT_TRUE(ReadTumPoints(dir / "comments.tum").empty());
  EXPECT_THROW(ReadTumPoints(dir / "missing.tum"), InputError);
}

// Numbers are ParseDecimal's: "nan", "inf" and hexadecimal are not positions; the token is quoted
// printable (an escape sequence in a file does not reach the terminal).
TEST(ReferenceTrack, TumNumbersAreStrictAndQuotedPrintable) {
  io_test::TempDir dir("aerovo_reftrack");
  for (const char* bad : {"nan", "inf", "0x10", "1e400", "1,5"}) {
    Write(dir / "bad.tum", std::string("0 0 0\n1 ") + bad + " 0\n");
    try {
      ReadReferenceTrack(dir / "bad.tum");
      ADD_FAILURE() << bad << " read as a number";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.tum:2: '"), std::string::npos) << e.what();
    }
  }
  Write(dir / "esc.tum", "0 0 0\n1 \x1b[31mred 0\n");
  try {
    ReadReferenceTrack(dir / "esc.tum");
    ADD_FAILURE() << "an escape sequence read as a number";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find('\x1b'), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\\x1B[31mred"), std::string::npos) << e.what();
  }
}

TEST(ReferenceTrack, ReadsSimulatorGroundTruthInItsOwnFrame) {
  io_test::TempDir dir("aerovo_reftrack");
  Write(dir / "ground_truth.csv",
        "frame,time_s,east_m,north_m,up_m,lat_deg,lon_deg,alt_m,yaw_deg,pitch_deg,roll_deg,"
        "nodata_fraction\r\n"
        "0,0.000000,0,0,100,43.537348735,6.555255181,400.0,90,0,0,0\r\n"
        "\r\n"
        "2,0.400000,5.5,-1.25,100,43.537348734,6.555279924,400.0,90,0,0,0\r\n");
  const ReferenceTrack t = ReadGroundTruthCsv(dir / "ground_truth.csv");
  EXPECT_EQ(t.format, "ground_truth_csv");
  EXPECT_FALSE(t.geographic);
  EXPECT_EQ(t.path, (dir / "ground_truth.csv").string());
  ASSERT_EQ(t.points.size(), 2u);
  EXPECT_EQ(t.points[1].frame_index, 2);
  EXPECT_DOUBLE_EQ(t.points[1].time_s, 0.4);
  EXPECT_DOUBLE_EQ(t.points[1].x_m, 5.5);
  EXPECT_DOUBLE_EQ(t.points[1].y_m, -1.25);
  EXPECT_FALSE(t.points[1].geo.has_value());
  // Only the first four columns are needed; one row is enough.
  Write(dir / "short.csv", "frame,time_s,east_m,north_m\n7,1.5,2,3\n");
  const ReferenceTrack s = ReadGroundTruthCsv(dir / "short.csv");
  ASSERT_EQ(s.points.size(), 1u);
  EXPECT_EQ(s.points[0].frame_index, 7);
}

TEST(ReferenceTrack, GroundTruthCsvErrorsNameFileAndLine) {
  io_test::TempDir dir("aerovo_reftrack");
  const auto expect_error = [&](const std::string& text, const std::string& where,
                                const std::string& what) {
    Write(dir / "gt.csv", text);
    SCOPED_TRACE(text);
    io_test::ExpectInputError([&] { ReadGroundTruthCsv(dir / "gt.csv"); },
                              {("gt.csv:" + where + ": ").c_str(), what.c_str()});
  };
  expect_error("a,b,c\n1,2,3\n", "1", "frame,time_s,east_m,north_m");
  expect_error("frame,time_s,east_m,north_m,up_m\n0,0,0,0,100\n1,0.5,x,0,100\n", "3",
               "east_m 'x' is not a number");
  expect_error("frame,time_s,east_m,north_m\n0,0,0,0\n1,0.5,0\n", "3", "fewer than 4 columns");
  expect_error("frame,time_s,east_m,north_m\n1.5,0,0,0\n", "2", "frame 1.5 is not an integer");
  expect_error("frame,time_s,east_m,north_m\n-1,0,0,0\n", "2", "is not an integer >= 0");
  expect_error("frame,time_s,east_m,north_m\n0,1,0,0\n1,0.5,0,0\n", "3", "before the previous");
  expect_error("frame,time_s,east_m,north_m\n", "1", "no frames");
  EXPECT_THROW(ReadGroundTruthCsv(dir / "missing.csv"), InputError);
  Write(dir / "empty.csv", "");
  EXPECT_THROW(ReadGroundTruthCsv(dir / "empty.csv"), InputError);
}

}  // namespace
}  // namespace aerovo::reference_track_test
