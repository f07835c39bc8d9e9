// Helpers shared by the end-to-end tests that fly over generated terrain (bad_input_test,
// frame_input_test, telemetry_trust_test): a fresh scratch folder and the grey terrain.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/sim/terrain.h"

namespace aerovo::e2e {

/// An empty folder temp/<prefix>_<name>_<pid> (removed first if it exists).
inline std::filesystem::path FreshTempDir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    (prefix + "_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// Grey procedural terrain of size_px x size_px at metres_per_px (sim::GenerateTerrain, seed).
inline cv::Mat GreyTerrain(double metres_per_px, unsigned seed, int size_px = 1600) {
  sim::TerrainOptions t;
  t.width_px = size_px;
  t.height_px = size_px;
  t.metres_per_px = metres_per_px;
  t.seed = seed;
  cv::Mat grey;
  cv::cvtColor(sim::GenerateTerrain(t), grey, cv::COLOR_BGR2GRAY);
  return grey;
}

}  // namespace aerovo::e2e
