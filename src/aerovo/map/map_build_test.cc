// map/map_build.h TiltedFramesWarning: a run whose frames were corrected with a per-frame camera
// attitude (not recorded in the run folder, so drawn as read) is warned about with the lever
// h tan(tilt); a run with the flight's own estimate (drawn nadir) or a near-nadir camera is not.
#include "aerovo/map/map_build.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "aerovo/core/error.h"
#include "aerovo/core/testing.h"

namespace aerovo::map::map_build_test {
namespace {

TEST(MapBuildTiltWarning, PerFrameAttitudeIsWarnedAboutWithItsLever) {
  const nlohmann::json summary = {{"attitude_sources", {{"gimbal", 120}, {"none", 3}}},
                                  {"max_tilt_deg", 15.0}};
  const std::string w = TiltedFramesWarning(summary, {{"altitude_m", 57.0}});
  EXPECT_NE(w.find("120 frames"), std::string::npos) << w;
  EXPECT_NE(w.find("(gimbal; up to 15.0 deg"), std::string::npos) << w;
  EXPECT_NE(w.find("15.3 m at 57 m"), std::string::npos) << w;  // 57 x tan(15 deg) = 15.27
  // Without a height given: the formula.
  EXPECT_NE(TiltedFramesWarning(summary, nlohmann::json::object()).find("h tan(tilt)"),
            std::string::npos);
}

TEST(MapBuildTiltWarning, EstimatedOrNadirOrUnknownIsNotWarned) {
  EXPECT_EQ(TiltedFramesWarning({{"attitude_sources", {{"estimated", 81}}}, {"max_tilt_deg", 14.7}},
                                {{"altitude_m", 57.0}}),
            "");
  EXPECT_EQ(TiltedFramesWarning({{"attitude_sources", {{"gimbal", 81}}}, {"max_tilt_deg", 0.4}},
                                {}),
            "");
  EXPECT_EQ(TiltedFramesWarning(nullptr, nullptr), "");
}

// summary.json is outside data once written: counts that are not frame counts (1e300, 2^40,
// negative, a string) are not counted, and a source's name is quoted printable. Before, get<int>()
// cast 1e300 into an int (undefined behaviour) and 2^40 wrapped around.
TEST(MapBuildTiltWarning, CountsThatAreNotFrameCountsAreNotCounted) {
  const nlohmann::json summary = {{"attitude_sources",
                                   {{"gimbal", 120},
                                    {"huge", 1e300},
                                    {"wrap", 1LL << 40},
                                    {"neg", -5},
                                    {"text", "12"},
                                    {"esc\x1b[2J", 3}}},
                                  {"max_tilt_deg", 15.0}};
  const std::string w = TiltedFramesWarning(summary, {{"altitude_m", 57.0}});
  EXPECT_NE(w.find("123 frames"), std::string::npos) << w;
  EXPECT_NE(w.find("(esc\\x1B[2J, gimbal; up to"), std::string::npos) << w;
}

// A run folder that records each frame's camera attitude (frames.csv camera_roll_deg,
// camera_pitch_deg) is drawn nadir frame by frame: nothing to warn about.
TEST(MapBuildTiltWarning, ARunFolderRecordingTheAttitudeIsNotWarned) {
  const nlohmann::json summary = {{"attitude_sources", {{"gimbal", 120}}}, {"max_tilt_deg", 15.0}};
  EXPECT_NE(TiltedFramesWarning(summary, {{"altitude_m", 57.0}}, false), "");
  EXPECT_EQ(TiltedFramesWarning(summary, {{"altitude_m", 57.0}}, true), "");
}

// The map `map build` writes: a .tif or .tiff name, and over an existing file only when that is a
// GeoTIFF (an earlier map); a run's frames.csv, a photo or a folder are never replaced.
TEST(MapBuildOutput, OnlyATiffNameAndOnlyAnEarlierMapIsReplaced) {
  namespace fs = std::filesystem;
  const fs::path dir = aerovo::testing::FreshTempDir("aerovo_map_build", "out");
  EXPECT_NO_THROW(CheckMapOutput(dir / "new.tif"));
  EXPECT_NO_THROW(CheckMapOutput(dir / "NEW.TIFF"));
  EXPECT_THROW(CheckMapOutput(dir / "map.png"), InvalidArgument);
  EXPECT_THROW(CheckMapOutput(dir / "map"), InvalidArgument);
  std::ofstream(dir / "frames.tif") << "frame,time_s\n0,0.0\n";  // not a raster
  EXPECT_THROW(CheckMapOutput(dir / "frames.tif"), InputError);
  fs::create_directories(dir / "folder.tif");
  EXPECT_THROW(CheckMapOutput(dir / "folder.tif"), InputError);
  GDALAllRegister();
  GDALDataset* ds = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
      (dir / "earlier.tif").c_str(), 8, 8, 1, GDT_Byte, nullptr);
  ASSERT_NE(ds, nullptr);
  GDALClose(ds);
  EXPECT_NO_THROW(CheckMapOutput(dir / "earlier.tif"));
  try {
    CheckMapOutput(dir / "frames.tif");
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("exists and is not a GeoTIFF map"), std::string::npos);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace aerovo::map::map_build_test
