#include "aerovo/sim/terrain.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"

namespace aerovo::sim::terrain_test {
namespace {

TerrainOptions SmallTerrain(std::uint64_t seed) {
  TerrainOptions o;
  o.width_px = 1024;
  o.height_px = 768;
  o.seed = seed;
  return o;
}

cv::Mat Gray(const cv::Mat& bgr) {
  cv::Mat g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

TEST(Terrain, SizeAndTypeFollowOptions) {
  const cv::Mat t = GenerateTerrain(SmallTerrain(3));
  EXPECT_EQ(t.cols, 1024);
  EXPECT_EQ(t.rows, 768);
  EXPECT_EQ(t.type(), CV_8UC3);
}

TEST(Terrain, SameSeedSameImageOtherSeedOtherImage) {
  const cv::Mat a = GenerateTerrain(SmallTerrain(7));
  const cv::Mat b = GenerateTerrain(SmallTerrain(7));
  const cv::Mat c = GenerateTerrain(SmallTerrain(8));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  // Another seed changes the landscape, not just a few pixels.
  cv::Mat diff;
  cv::absdiff(Gray(a), Gray(c), diff);
  EXPECT_GT(cv::mean(diff)[0], 10.0);
}

// Every 64 x 64 px tile (16 m x 16 m) must be textured: grey-level standard deviation above
// 6 DN in more than 95 % of the tiles (no large uniform areas).
TEST(Terrain, TexturedEverywhere) {
  for (std::uint64_t seed : {1u, 2u}) {
    const cv::Mat g = Gray(GenerateTerrain(SmallTerrain(seed)));
    int tiles = 0, textured = 0;
    for (int y = 0; y + 64 <= g.rows; y += 64) {
      for (int x = 0; x + 64 <= g.cols; x += 64) {
        cv::Scalar mean, sd;
        cv::meanStdDev(g(cv::Rect(x, y, 64, 64)), mean, sd);
        ++tiles;
        textured += sd[0] > 6.0;
      }
    }
    EXPECT_GT(textured, 0.95 * tiles) << "seed " << seed << ": " << textured << "/" << tiles;
  }
}

// Blob-like interest points (local maxima of the determinant of the Hessian at sigma 2 px, the
// quantity SURF approximates) are found in nearly every 128 x 128 px tile.
TEST(Terrain, HessianBlobsAreWellSpread) {
  const cv::Mat g = Gray(GenerateTerrain(SmallTerrain(5)));
  cv::Mat f, dxx, dyy, dxy;
  g.convertTo(f, CV_32F);
  cv::GaussianBlur(f, f, cv::Size(0, 0), 2.0);
  cv::Sobel(f, dxx, CV_32F, 2, 0, 3);
  cv::Sobel(f, dyy, CV_32F, 0, 2, 3);
  cv::Sobel(f, dxy, CV_32F, 1, 1, 3);
  cv::Mat det = dxx.mul(dyy) - dxy.mul(dxy);
  cv::Mat dil;
  cv::dilate(det, dil, cv::Mat());
  const float thr = 4.0f;  // (DN/px^2)^2: clearly above the response of smooth shading
  int tiles = 0, good = 0, total = 0;
  for (int ty = 0; ty + 128 <= g.rows; ty += 128) {
    for (int tx = 0; tx + 128 <= g.cols; tx += 128) {
      int n = 0;
      for (int y = std::max(ty, 2); y < std::min(ty + 128, g.rows - 2); ++y) {
        for (int x = std::max(tx, 2); x < std::min(tx + 128, g.cols - 2); ++x) {
          const float v = det.at<float>(y, x);
          n += v > thr && v >= dil.at<float>(y, x);
        }
      }
      ++tiles;
      good += n >= 20;
      total += n;
    }
  }
  EXPECT_GT(good, 0.95 * tiles) << good << "/" << tiles << " tiles with >= 20 blobs";
  EXPECT_GT(total, 100 * tiles);
}

TEST(Terrain, ValidateRejectsBadOptions) {
  TerrainOptions o;
  o.metres_per_px = 0;
  EXPECT_THROW(Validate(o), InvalidArgument);
  o = TerrainOptions{};
  o.width_px = 10;
  EXPECT_THROW(GenerateTerrain(o), InvalidArgument);
  o = TerrainOptions{};
  o.village_fraction = 0.6;
  o.forest_fraction = 0.6;
  EXPECT_THROW(Validate(o), InvalidArgument);
  EXPECT_NO_THROW(Validate(TerrainOptions{}));
}

}  // namespace
}  // namespace aerovo::sim::terrain_test
