// The synthetic set-up of bad_input_test.cc and frame_input_test.cc: the simulator's procedural
// terrain seen by a nadir camera of 320x240 px with focal 400 px at 100 m (1 px = 0.25 m), and
// the run configuration of such frames (focal and altitude given, quiet).
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

#include "aerovo/pipeline/run_config.h"
#include "e2e_testing.h"

namespace aerovo::e2e::nadir {

constexpr int kW = 320, kH = 240;
constexpr double kFocalPx = 400.0, kHeightM = 100.0, kGsd = kHeightM / kFocalPx;  // 0.25 m/px

/// The grey terrain the frames are cut from: 1600 x 1600 px = 400 m x 400 m (seed 7),
/// generated once.
inline const cv::Mat& Ground() {
  static const cv::Mat ground = GreyTerrain(kGsd, 7);
  return ground;
}

/// The run of the frames at `input` into `out`: focal kFocalPx, altitude kHeightM, quiet.
inline RunConfig Config(const std::filesystem::path& input, const std::filesystem::path& out) {
  RunConfig c;
  c.input = input.string();
  c.out = out.string();
  c.focal_px = kFocalPx;
  c.altitude_m = kHeightM;
  c.quiet = true;
  return c;
}

}  // namespace aerovo::e2e::nadir
