// Procedural terrain: a synthetic nadir orthophoto (fields with crop rows, roads, villages with
// shaded roofs and shadows, trees, multi-scale texture) for simulated flights without any file.
//
// The image is north-up: column x grows to the east, row y to the south. It is built to give a
// blob (Hessian) detector such as SURF many well-spread, distinctive interest points at every
// place and at the scales a camera 50-300 m above it sees: no large uniform area, and no exactly
// repeating pattern (crop rows bend and fade with low-frequency noise, object placement is
// jittered), so that descriptor matching is not ambiguous.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace aerovo::sim {

/// Options of GenerateTerrain. Plain aggregate; check with Validate(). Sizes in metres are
/// converted with metres_per_px, so the same seed gives the same landscape at another
/// resolution (up to rasterisation and the pixel-scale noise).
struct TerrainOptions {
  /// Image size in pixels. Default 4096 x 4096 px, i.e. 1024 m x 1024 m at 0.25 m/px: room
  /// for a 1 km flight leg at 100 m height.
  int width_px = 4096;
  int height_px = 4096;
  /// Ground sampling distance of the generated image (m/px). 0.25 m/px is finer than what a
  /// 1280 px camera with a 70 deg field of view sees from 100 m (about 0.11 m/px needs
  /// upsampling; from 200 m it is 0.22 m/px).
  double metres_per_px = 0.25;
  /// Seed of every random choice: the same options give a bit-identical image.
  std::uint64_t seed = 1;
  /// Mean side of a field (m). European farmland parcels are typically 50-200 m across.
  double field_size_m = 90.0;
  /// Fraction of the parcels that are villages (buildings), forests and orchards; the rest are
  /// crop fields, meadows and ploughed soil. Each in [0, 1], sum <= 1.
  double village_fraction = 0.12;
  double forest_fraction = 0.08;
  double orchard_fraction = 0.06;
  /// Every n-th line of the parcel grid (on average) carries a paved road; others may carry dirt
  /// tracks or hedgerows. Range [1, 100].
  int road_every_n_lines = 4;
  /// Strength of the multi-scale brightness texture laid over everything (relative contrast,
  /// 0 = none). 0.18 keeps every 16 m x 16 m patch textured without hiding the structure.
  double texture_contrast = 0.18;
  /// Sun azimuth (deg clockwise from north, the direction the light comes FROM) and the ratio
  /// shadow length / object height. Defaults: morning sun from the south-east, 35 deg above
  /// the horizon (cot 35 deg = 1.43).
  double sun_azimuth_deg = 135.0;
  double shadow_length_per_height = 1.43;
  /// Final anti-aliasing blur sigma (px); 0 disables it. 0.6 px removes the staircase edges of
  /// the rasterised polygons, which would otherwise make unstable tiny-scale responses.
  double blur_sigma_px = 0.6;
};

/// Throws aerovo::InvalidArgument naming the first bad field.
void Validate(const TerrainOptions& options);

/// Generates the terrain: CV_8UC3 BGR image of options.height_px rows x options.width_px columns.
/// Deterministic: same options (including seed), same pixels. Runs in about 1-2 s for
/// 4096 x 4096 px on one core (OpenCV parallelises some steps).
cv::Mat GenerateTerrain(const TerrainOptions& options);

}  // namespace aerovo::sim
