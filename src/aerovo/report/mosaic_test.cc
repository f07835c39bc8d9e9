// report/mosaic.h MosaicNadirFromFrame: the frames of a run that applied an attitude are drawn
// through the virtual nadir camera (odometry/attitude.h); a run without one as read.
#include "aerovo/report/mosaic.h"

#include "aerovo/core/angles.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Core>

namespace aerovo::mosaic_test {
namespace {

RunData TiltedRun(bool applied) {
  RunData run;
  run.config = {{"resolved", {{"focal_px", 462.0}, {"frame_width_px", 800},
                              {"frame_height_px", 600}}}};
  run.summary = {{"attitude_estimate",
                  {{"applied", applied}, {"roll_deg", 0.0}, {"pitch_deg", 15.0}}}};
  return run;
}

// A camera pitched 15 deg forward (towards the image top) looks at the ground 15 deg ahead of
// nadir with its image centre: in the virtual nadir camera that ray is f tan(15 deg) above the
// centre, and the nadir (the virtual camera's centre) is below the tilted image's centre.
TEST(MosaicNadir, TheTiltedImageCentreIsDrawnAheadOfTheNadir) {
  const Eigen::Matrix3d h = MosaicNadirFromFrame(TiltedRun(true), 800, 600, 0);
  const Eigen::Vector3d c = h * Eigen::Vector3d(399.5, 299.5, 1.0);
  EXPECT_NEAR(c.x() / c.z(), 399.5, 1e-9);
  EXPECT_NEAR(c.y() / c.z(), 299.5 - 462.0 * std::tan(15.0 * kDegToRad), 1e-6);
}

TEST(MosaicNadir, NoAppliedAttitudeDrawsTheFrameAsRead) {
  EXPECT_TRUE(MosaicNadirFromFrame(TiltedRun(false), 800, 600, 0).isIdentity());
  RunData no_summary = TiltedRun(true);
  no_summary.summary = nullptr;
  EXPECT_TRUE(MosaicNadirFromFrame(no_summary, 800, 600, 0).isIdentity());
}

// A run folder recording each frame's camera attitude (frames.csv camera_roll_deg,
// camera_pitch_deg) draws each frame through its own: a gimbal pitched 15 deg at frame 4, 10
// deg at frame 6, none recorded at frame 5 (drawn as read), and frame 7 not in frames.csv;
// the flight's estimate of summary.json is then not used.
TEST(MosaicNadir, EachFrameThroughItsOwnRecordedAttitude) {
  RunData run = TiltedRun(true);  // an estimate of 15 deg, applied
  run.records_camera_attitude = true;
  for (int i = 0; i < 7; ++i) {
    RunFrameRow f;
    f.frame = i;
    if (i == 4 || i == 6) {
      f.camera_roll_deg = 0.0;
      f.camera_pitch_deg = i == 4 ? 15.0 : 10.0;
    }
    run.frames.push_back(f);
  }
  ASSERT_TRUE(RecordsCameraAttitude(run));
  const auto centre_y = [&](int frame) {
    const Eigen::Vector3d c = MosaicNadirFromFrame(run, 800, 600, frame) *
                              Eigen::Vector3d(399.5, 299.5, 1.0);
    return c.y() / c.z();
  };
  EXPECT_NEAR(centre_y(4), 299.5 - 462.0 * std::tan(15.0 * kDegToRad), 1e-6);
  EXPECT_NEAR(centre_y(6), 299.5 - 462.0 * std::tan(10.0 * kDegToRad), 1e-6);
  EXPECT_TRUE(MosaicNadirFromFrame(run, 800, 600, 5).isIdentity());
  EXPECT_TRUE(MosaicNadirFromFrame(run, 800, 600, 7).isIdentity());
  EXPECT_TRUE(MosaicNadirFromFrame(run, 800, 600, 0).isIdentity());
  // The columns with no attitude on any frame (a nadir run of this build): none is applied,
  // and the summary's estimate is not used either.
  for (RunFrameRow& f : run.frames) f.camera_roll_deg = f.camera_pitch_deg = std::nullopt;
  EXPECT_TRUE(MosaicNadirFromFrame(run, 800, 600, 4).isIdentity());
}

}  // namespace
}  // namespace aerovo::mosaic_test
