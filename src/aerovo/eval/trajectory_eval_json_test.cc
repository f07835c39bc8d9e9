#include <gtest/gtest.h>

#include "aerovo/eval/trajectory_eval.h"
#include "aerovo/eval/trajectory_eval_json.h"

namespace aerovo::trajectory_eval_json_test {
namespace {

// Straight 200 m line east, VO 1 % long: figures known in closed form (see
// EvaluateTrajectory.ScaleDriftOnStraightLine).
TrajectoryComparison LineComparison() {
  std::vector<TrajectoryPoint2D> enu, vo;
  for (int i = 0; i <= 200; ++i) {
    enu.push_back({i * 0.1, static_cast<double>(i), 0.0});
    vo.push_back({i * 0.1, 1.01 * i, 0.0});
  }
  return CompareTrajectories(vo, enu, {AlignmentModel::kSE2, {10.0, 500.0}});
}

TEST(TrajectoryEvalJson, CarriesTheFigures) {
  const TrajectoryComparison c = LineComparison();
  const nlohmann::json j = ToJson(c);
  EXPECT_EQ(j["se2"]["alignment"]["model"], "SE2");
  EXPECT_EQ(j["sim2"]["alignment"]["model"], "Sim2");
  EXPECT_DOUBLE_EQ(j["se2"]["alignment"]["scale"].get<double>(), 1.0);
  EXPECT_NEAR(j["sim2"]["alignment"]["scale"].get<double>(), 1.0 / 1.01, 1e-12);
  EXPECT_NEAR(j["se2"]["alignment"]["translation_m"][0].get<double>(), -1.0, 1e-9);
  EXPECT_NEAR(j["se2"]["distance_flown_m"].get<double>(), 200.0, 1e-9);
  EXPECT_NEAR(j["se2"]["end_point_error_m"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["se2"]["end_point_error_unaligned_percent"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["se2"]["ate_m"]["max"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["se2"]["ate_rmse_percent"].get<double>(), 100.0 * c.se2.ate_m.rmse / 200.0, 1e-12);
  ASSERT_EQ(j["se2"]["segments"].size(), 2u);
  EXPECT_EQ(j["se2"]["segments"][0]["length_m"].get<double>(), 10.0);
  EXPECT_EQ(j["se2"]["segments"][0]["drift_percent"]["count"].get<int>(), 191);
  EXPECT_NEAR(j["se2"]["segments"][0]["drift_percent"]["mean"].get<double>(), 1.0, 1e-9);
  EXPECT_FALSE(j["se2"].contains("ate_per_point_m"));
  EXPECT_EQ(ToJson(c.se2, true)["ate_per_point_m"].size(), 201u);
  // Round trip through text keeps the numbers.
  EXPECT_EQ(nlohmann::json::parse(j.dump()), j);
}

TEST(TrajectoryEvalJson, TableHasBothColumns) {
  const std::string t = FormatTrajectoryTable(LineComparison());
  EXPECT_NE(t.find("SE(2)"), std::string::npos);
  EXPECT_NE(t.find("Sim(2)"), std::string::npos);
  EXPECT_NE(t.find("end-point error, unaligned (%)"), std::string::npos);
  // SE(2) aligned end-point error 1.000 m, Sim(2) 0.000 m, on the same line.
  const size_t row = t.find("end-point error, aligned (m)");
  ASSERT_NE(row, std::string::npos);
  const std::string line = t.substr(row, t.find('\n', row) - row);
  EXPECT_NE(line.find("1.000"), std::string::npos) << line;
  EXPECT_NE(line.find("0.000"), std::string::npos) << line;
  EXPECT_NE(t.find("drift over 10 m (mean %)"), std::string::npos);
  EXPECT_NE(t.find("drift over 500 m (mean %)"), std::string::npos);  // shown as "-"
  std::cout << t;
}

}  // namespace
}  // namespace aerovo::trajectory_eval_json_test
