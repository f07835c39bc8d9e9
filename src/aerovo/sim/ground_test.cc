#include "aerovo/sim/ground.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "aerovo/core/error.h"
#include "aerovo/sim/terrain.h"

namespace aerovo::sim::ground_test {
namespace {

SimulationOptions ShortLine() {
  SimulationOptions o;
  o.camera.width_px = 160;
  o.camera.height_px = 120;
  o.camera.hfov_deg = 60;
  o.flight.pattern = FlightPattern::kLine;
  o.flight.leg_length_m = 20;
  o.flight.height_m = 30;
  o.fps = 2;
  return o;
}

bool SameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

TEST(Ground, DefaultIsTheTerrainFittedToTheFlight) {
  const SimulationOptions o = ShortLine();
  GroundOptions g;
  g.terrain_seed = 5;
  const GroundImage got = MakeGround(g, o);
  TerrainOptions t;
  t.seed = 5;
  const GroundImage want = MakeTerrainGround(FitTerrainToFlight(o, t));
  EXPECT_TRUE(SameImage(got.image, want.image));
  EXPECT_EQ(got.metres_per_px, want.metres_per_px);
  EXPECT_EQ(got.nw_corner.lat_deg, kDefaultTerrainLatDeg);
  EXPECT_EQ(got.nw_corner.lon_deg, kDefaultTerrainLonDeg);
  EXPECT_EQ(got.nw_corner.alt_m, kDefaultTerrainAltM);
}

TEST(Ground, TerrainSizeAndResolution) {
  const SimulationOptions o = ShortLine();
  GroundOptions g;
  g.terrain_size_px = 300;
  g.terrain_mpp = 0.2;
  g.nw_lat_deg = 43.5;
  g.nw_lon_deg = 6.5;
  g.ground_alt_m = 250.0;
  GroundImage got = MakeGround(g, o);
  EXPECT_EQ(got.image.cols, 300);
  EXPECT_EQ(got.image.rows, 300);
  EXPECT_EQ(got.metres_per_px, 0.2);
  EXPECT_EQ(got.nw_corner.lat_deg, 43.5);
  EXPECT_EQ(got.nw_corner.alt_m, 250.0);
  // The resolution alone keeps the fitted extent.
  g.terrain_size_px = 0;
  const TerrainOptions fitted = FitTerrainToFlight(o);
  got = MakeGround(g, o);
  EXPECT_EQ(got.metres_per_px, 0.2);
  EXPECT_NEAR(got.image.cols * 0.2, fitted.width_px * fitted.metres_per_px, 0.2 + 1e-9);
}

TEST(Ground, OrthophotoAndErrorsNamingTheField) {
  const SimulationOptions o = ShortLine();
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "aerovo_ground_test_ortho.png";
  cv::Mat img(400, 500, CV_8UC3, cv::Scalar(40, 120, 200));
  ASSERT_TRUE(cv::imwrite(file.string(), img));
  GroundOptions g;
  g.ortho = file.string();
  try {
    MakeGround(g, o);
    ADD_FAILURE() << "an orthophoto without its resolution was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("ortho_mpp"), std::string::npos) << e.what();
  }
  g.ortho_mpp = 0.5;
  try {
    MakeGround(g, o);
    ADD_FAILURE() << "an orthophoto without its corner was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("nw_lat_deg"), std::string::npos) << e.what();
  }
  g.nw_lat_deg = 43.0;
  g.nw_lon_deg = 400.0;
  EXPECT_THROW(MakeGround(g, o), InvalidArgument);
  g.nw_lon_deg = 6.0;
  const GroundImage got = MakeGround(g, o);
  EXPECT_EQ(got.source_kind, "orthophoto");
  EXPECT_EQ(got.image.cols, 500);
  EXPECT_EQ(got.metres_per_px, 0.5);
  EXPECT_EQ(got.nw_corner.lon_deg, 6.0);
  std::filesystem::remove(file);
  g.ortho = file.string();  // now missing
  EXPECT_THROW(MakeGround(g, o), InputError);
  GroundOptions bad;
  bad.terrain_size_px = -1;
  EXPECT_THROW(Validate(bad), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::sim::ground_test
