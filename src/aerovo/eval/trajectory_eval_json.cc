#include "aerovo/eval/trajectory_eval_json.h"

#include <cmath>
#include <functional>
#include <vector>

#include <fmt/format.h>
#include "aerovo/core/angles.h"

namespace aerovo {
namespace {

double AtePercent(const TrajectoryErrors& e) {
  return e.distance_flown_m > 0.0 ? 100.0 * e.ate_m.rmse / e.distance_flown_m : 0.0;
}
}  // namespace

const char* ToString(AlignmentModel model) {
  return model == AlignmentModel::kSim2 ? "Sim2" : "SE2";
}

nlohmann::json ToJson(const DeniedError& d) {
  nlohmann::json at = nlohmann::json::array();
  for (const DeniedErrorAt& a : d.at) {
    at.push_back({{"after_s", a.after_s},
                  {"time_s", a.time_s},
                  {"error_m", a.error_m},
                  {"distance_m", a.distance_m}});
  }
  return {{"denied_at_s", d.denied_at_s},
          {"pairs", d.pairs},
          {"duration_s", d.duration_s},
          {"distance_m", d.distance_m},
          {"first_error_m", d.first_error_m},
          {"end_error_m", d.end_error_m},
          {"max_error_m", d.max_error_m},
          {"rmse_m", d.rmse_m},
          {"end_error_per_km_m",
           d.end_error_per_km_m ? nlohmann::json(*d.end_error_per_km_m) : nlohmann::json()},
          {"at", at}};
}

nlohmann::json ToJson(const TrajectoryErrorStats& s) {
  return {
      {"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median}, {"max", s.max}};
}

nlohmann::json ToJson(const AlignmentResult& a) {
  const Similarity2D& t = a.enu_from_vo;
  return {{"model", ToString(a.model)},
          {"num_points", a.num_points},
          {"rotation_deg", t.angle_rad * kRadToDeg},
          {"scale", t.scale},
          {"translation_m", {t.translation_m.x(), t.translation_m.y()}},
          {"rmse_m", a.rmse_m}};
}

nlohmann::json ToJson(const TrajectoryErrors& e, bool include_per_point) {
  nlohmann::json segments = nlohmann::json::array();
  for (const SegmentErrors& s : e.segments) {
    segments.push_back({{"length_m", s.length_m},
                        {"error_m", ToJson(s.error_m)},
                        {"drift_percent", ToJson(s.drift_percent)}});
  }
  nlohmann::json j = {{"alignment", ToJson(e.alignment)},
                      {"ate_m", ToJson(e.ate_m)},
                      {"distance_flown_m", e.distance_flown_m},
                      {"ate_rmse_percent", AtePercent(e)},
                      {"end_point_error_m", e.end_point_error_m},
                      {"end_point_error_percent", e.end_point_error_percent},
                      {"end_point_error_unaligned_m", e.end_point_error_unaligned_m},
                      {"end_point_error_unaligned_percent", e.end_point_error_unaligned_percent},
                      {"segments", segments}};
  if (include_per_point) j["ate_per_point_m"] = e.ate_per_point_m;
  return j;
}

nlohmann::json ToJson(const TrajectoryComparison& c, bool include_per_point) {
  return {{"se2", ToJson(c.se2, include_per_point)}, {"sim2", ToJson(c.sim2, include_per_point)}};
}

std::string FormatTrajectoryTable(const TrajectoryComparison& c, const std::string& reference) {
  std::string out =
      fmt::format("{:<34}{:>14}{:>14}\n", "trajectory vs " + reference, "SE(2)", "Sim(2)");
  const auto row = [&](const std::string& label, const char* spec,
                       const std::function<double(const TrajectoryErrors&)>& get) {
    out += fmt::format("{:<34}", label);
    for (const TrajectoryErrors* e : {&c.se2, &c.sim2}) {
      out += fmt::format("{:>14}", fmt::format(spec, get(*e)));
    }
    out += '\n';
  };
  out += fmt::format("{:<34}{:>14}{:>14}\n", "pairs", c.se2.alignment.num_points,
                     c.sim2.alignment.num_points);
  row("distance flown (m)", "{:.2f}", [](const auto& e) { return e.distance_flown_m; });
  row("alignment rotation (deg)", "{:.3f}",
      [](const auto& e) { return e.alignment.enu_from_vo.angle_rad * kRadToDeg; });
  row("alignment scale", "{:.5f}", [](const auto& e) { return e.alignment.enu_from_vo.scale; });
  row("ATE RMSE (m)", "{:.3f}", [](const auto& e) { return e.ate_m.rmse; });
  row("ATE RMSE (% of distance)", "{:.3f}", [](const auto& e) { return AtePercent(e); });
  row("ATE mean (m)", "{:.3f}", [](const auto& e) { return e.ate_m.mean; });
  row("ATE median (m)", "{:.3f}", [](const auto& e) { return e.ate_m.median; });
  row("ATE max (m)", "{:.3f}", [](const auto& e) { return e.ate_m.max; });
  row("end-point error, aligned (m)", "{:.3f}", [](const auto& e) { return e.end_point_error_m; });
  row("end-point error, aligned (%)", "{:.3f}",
      [](const auto& e) { return e.end_point_error_percent; });
  row("end-point error, unaligned (m)", "{:.3f}",
      [](const auto& e) { return e.end_point_error_unaligned_m; });
  row("end-point error, unaligned (%)", "{:.3f}",
      [](const auto& e) { return e.end_point_error_unaligned_percent; });
  for (size_t k = 0; k < c.se2.segments.size() && k < c.sim2.segments.size(); ++k) {
    const std::string len = fmt::format("{:g} m", c.se2.segments[k].length_m);
    if (c.se2.segments[k].drift_percent.count == 0) {
      out += fmt::format("{:<34}{:>14}{:>14}\n", "drift over " + len + " (mean %)", "-", "-");
      continue;
    }
    row("drift over " + len + " (mean %)", "{:.3f}",
        [k](const auto& e) { return e.segments[k].drift_percent.mean; });
    row("drift over " + len + " (max %)", "{:.3f}",
        [k](const auto& e) { return e.segments[k].drift_percent.max; });
  }
  return out;
}

}  // namespace aerovo
