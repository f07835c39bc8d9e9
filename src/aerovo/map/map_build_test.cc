// map/map_build.h TiltedFramesWarning: a run whose frames were corrected with a per-frame camera
// attitude (not recorded in the run folder, so drawn as read) is warned about with the lever
// h tan(tilt); a run with the flight's own estimate (drawn nadir) or a near-nadir camera is not.
#include "aerovo/map/map_build.h"

#include <gtest/gtest.h>

#include <string>

namespace aerovo::map {
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

// A run folder that records each frame's camera attitude (frames.csv camera_roll_deg,
// camera_pitch_deg) is drawn nadir frame by frame: nothing to warn about.
TEST(MapBuildTiltWarning, ARunFolderRecordingTheAttitudeIsNotWarned) {
  const nlohmann::json summary = {{"attitude_sources", {{"gimbal", 120}}}, {"max_tilt_deg", 15.0}};
  EXPECT_NE(TiltedFramesWarning(summary, {{"altitude_m", 57.0}}, false), "");
  EXPECT_EQ(TiltedFramesWarning(summary, {{"altitude_m", 57.0}}, true), "");
}

}  // namespace
}  // namespace aerovo::map
