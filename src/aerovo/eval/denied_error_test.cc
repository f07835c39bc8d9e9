// CompareSinceDenial (denied_error.h) on tracks with known errors: a reference flying east at
// 10 m/s, an estimate that drifts north at 0.1 m/s from the denial on (1 m per 100 m flown).
#include <gtest/gtest.h>

#include <cmath>

#include "aerovo/core/error.h"
#include "aerovo/eval/denied_error.h"
#include "aerovo/eval/trajectory_eval_json.h"

namespace aerovo::denied_error_test {
namespace {

struct Tracks {
  std::vector<TrajectoryPoint2D> estimate, reference;
};

// 1 Hz from t = 0 to t = last_s; the error is 0.5 m east before the denial at 30 s, then grows
// north by 0.1 m/s on top of it.
Tracks Drifting(double last_s) {
  Tracks t;
  for (double s = 0.0; s <= last_s; s += 1.0) {
    t.reference.push_back({s, 10.0 * s, 0.0});
    const double drift = s >= 30.0 ? 0.1 * (s - 30.0) : 0.0;
    t.estimate.push_back({s, 10.0 * s + 0.5, drift});
  }
  return t;
}

TEST(DeniedError, ErrorOverTimeAndPerKm) {
  const Tracks t = Drifting(30.0 + 400.0);  // 400 s after the denial: no 10-minute figure
  const auto d = CompareSinceDenial(t.estimate, t.reference, 30.0);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->pairs, 401);
  EXPECT_NEAR(d->duration_s, 400.0, 1e-12);
  EXPECT_NEAR(d->distance_m, 4000.0, 1e-9);
  EXPECT_NEAR(d->first_error_m, 0.5, 1e-12);
  EXPECT_NEAR(d->end_error_m, std::hypot(0.5, 40.0), 1e-9);
  EXPECT_NEAR(d->max_error_m, d->end_error_m, 1e-12);
  ASSERT_TRUE(d->end_error_per_km_m.has_value());
  EXPECT_NEAR(*d->end_error_per_km_m, std::hypot(0.5, 40.0) / 4.0, 1e-9);
  ASSERT_EQ(d->at.size(), 2u);  // 1 and 5 minutes
  EXPECT_EQ(d->at[0].after_s, 60.0);
  EXPECT_NEAR(d->at[0].error_m, std::hypot(0.5, 6.0), 1e-9);
  EXPECT_NEAR(d->at[0].distance_m, 600.0, 1e-9);
  EXPECT_NEAR(d->at[1].time_s, 330.0, 1e-12);
  EXPECT_NEAR(d->at[1].error_m, std::hypot(0.5, 30.0), 1e-9);
  // RMSE of hypot(0.5, 0.1 k), k = 0..400.
  double sum = 0.0;
  for (int k = 0; k <= 400; ++k) sum += 0.25 + 0.01 * k * k;
  EXPECT_NEAR(d->rmse_m, std::sqrt(sum / 401.0), 1e-9);
  const nlohmann::json j = ToJson(*d);
  EXPECT_EQ(j.at("at").size(), 2u);
  EXPECT_NEAR(j.at("end_error_per_km_m").get<double>(), *d->end_error_per_km_m, 1e-12);
}

TEST(DeniedError, FirstPairAtOrAfterTheAskedTime) {
  Tracks t = Drifting(200.0);
  // Every other second missing after the denial (a photo every 2 s): 60 s after 30 s is t = 90
  // (kept), 30.5 s asked -> the pair at 62 s.
  std::vector<TrajectoryPoint2D> e, r;
  for (std::size_t i = 0; i < t.estimate.size(); ++i) {
    if (t.estimate[i].t > 30.0 && static_cast<int>(t.estimate[i].t) % 2 == 1) continue;
    e.push_back(t.estimate[i]);
    r.push_back(t.reference[i]);
  }
  const auto d = CompareSinceDenial(e, r, 30.0, {31.5, 60.0});
  ASSERT_TRUE(d.has_value());
  ASSERT_EQ(d->at.size(), 2u);
  EXPECT_EQ(d->at[0].time_s, 62.0);
  EXPECT_EQ(d->at[1].time_s, 90.0);
}

TEST(DeniedError, NothingAfterTheDenialOrStillAndBadInput) {
  const Tracks t = Drifting(20.0);
  EXPECT_FALSE(CompareSinceDenial(t.estimate, t.reference, 30.0).has_value());
  // Denied from the start, hovering: no per-km figure (under 1 m flown).
  std::vector<TrajectoryPoint2D> still{{0, 0, 0}, {1, 0.1, 0}, {2, 0.2, 0}};
  const auto d = CompareSinceDenial(still, still, 0.0);
  ASSERT_TRUE(d.has_value());
  EXPECT_FALSE(d->end_error_per_km_m.has_value());
  EXPECT_EQ(d->end_error_m, 0.0);
  EXPECT_TRUE(d->at.empty());
  EXPECT_THROW(CompareSinceDenial(t.estimate, still, 0.0), InvalidArgument);
  std::vector<TrajectoryPoint2D> back{{0, 0, 0}, {2, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(CompareSinceDenial(back, back, 0.0), InvalidArgument);
}

}  // namespace
}  // namespace aerovo::denied_error_test
