// Geodesy and trajectory evaluation on a real flight's GPS (the tampa-phantom3 photos in
// $AEROVO_SHARED/data/flights; skipped without them).
#include <algorithm>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "aerovo/core/testing.h"
#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/frames/image_metadata.h"
#include "aerovo/geo/geodesic.h"
#include "aerovo/geo/local_enu.h"

namespace aerovo::trajectory_eval_flight_test {
namespace {
namespace fs = std::filesystem;

TEST(TrajectoryEvalFlight, TampaGpsTrackInEnu) {
  AEROVO_REQUIRE_SHARED(dir, "data/flights/tampa-phantom3/DJI_0054.JPG");
  std::vector<fs::path> photos;
  for (const auto& e : fs::directory_iterator(dir.parent_path())) {
    if (e.path().extension() == ".JPG") photos.push_back(e.path());
  }
  std::sort(photos.begin(), photos.end());  // file-name order is the flight order (README)
  ASSERT_EQ(photos.size(), 172u);
  std::vector<GeoPoint> fixes;
  for (const fs::path& p : photos) {
    const ImageMetadata m = ReadImageMetadata(p);
    ASSERT_TRUE(m.HasGps()) << p;
    // EXIF altitude of this flight is invalid (README): keep the fixes on the ellipsoid.
    fixes.push_back({*m.lat_deg, *m.lon_deg, 0.0});
  }
  // docs/method.md, "Trajectory evaluation": first fix as ENU origin.
  const LocalEnu enu(fixes.front());
  std::vector<TrajectoryPoint2D> track;
  double geodesic_length = 0.0;
  for (size_t i = 0; i < fixes.size(); ++i) {
    const Eigen::Vector3d p = enu.Forward(fixes[i]);
    track.push_back({static_cast<double>(i), p.x(), p.y()});
    if (i > 0) geodesic_length += GeodesicDistance(fixes[i - 1], fixes[i]);
  }
  // Over a ~1 km area the tangent plane distorts horizontal distances by < 1e-7: the ENU path
  // length equals the sum of ellipsoidal geodesics to within 1 cm.
  const double enu_length = PathLength(track);
  EXPECT_NEAR(enu_length, geodesic_length, 0.01);
  // docs/method.md, "Pitfalls on real flights": this flight is 1.56 km long.
  EXPECT_NEAR(enu_length, 1560.0, 0.05 * 1560.0);

  // The real (noisy, lawnmower) shape under a known Sim(2): exact recovery and zero errors.
  const Similarity2D vo_from_enu{-0.6, 0.8, {12.0, -40.0}};
  std::vector<TrajectoryPoint2D> vo;
  for (const auto& p : track) {
    const Eigen::Vector2d q = vo_from_enu.Apply({p.x, p.y});
    vo.push_back({p.t, q.x(), q.y()});
  }
  const TrajectoryComparison c = CompareTrajectories(vo, track);
  EXPECT_NEAR(c.sim2.alignment.enu_from_vo.angle_rad, 0.6, 1e-9);
  EXPECT_NEAR(c.sim2.alignment.enu_from_vo.scale, 1.0 / 0.8, 1e-9);
  EXPECT_LT(c.sim2.ate_m.max, 1e-6);
  EXPECT_NEAR(c.sim2.distance_flown_m, enu_length, 1e-9);
  // SE(2) cannot undo the 0.8 scale: aligned VO displacements are 0.8x the GPS ones, so the
  // drift is 20 % on straight segments and at most 20 % on curved ones.
  EXPECT_GT(c.se2.ate_m.rmse, 10.0);
  EXPECT_NEAR(c.se2.segments[1].drift_percent.median, 20.0, 0.5);
  EXPECT_LE(c.se2.segments[1].drift_percent.max, 20.0 + 1e-9);
}

}  // namespace
}  // namespace aerovo::trajectory_eval_flight_test
