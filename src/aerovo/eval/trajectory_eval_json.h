// JSON and text-table views of trajectory evaluation results (for the run summary JSON and the
// table printed at the end of a run). Units follow the field names: _m metres, _deg degrees,
// _percent per cent of the reference path length.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "aerovo/eval/denied_error.h"
#include "aerovo/eval/trajectory_eval.h"

namespace aerovo {

/// {"count", "rmse", "mean", "median", "max"}.
nlohmann::json ToJson(const TrajectoryErrorStats& stats);
/// {"model": "SE2"|"Sim2", "num_points", "rotation_deg", "scale", "translation_m": [x, y],
///  "rmse_m"} (enu_from_vo).
nlohmann::json ToJson(const AlignmentResult& alignment);
/// {"alignment", "ate_m", "distance_flown_m", "ate_rmse_percent", "end_point_error_m",
///  "end_point_error_percent", "end_point_error_unaligned_m",
///  "end_point_error_unaligned_percent", "segments": [{"length_m", "error_m",
///  "drift_percent"}...]} plus "ate_per_point_m" when include_per_point.
nlohmann::json ToJson(const TrajectoryErrors& errors, bool include_per_point = false);
/// {"se2": ..., "sim2": ...}.
nlohmann::json ToJson(const TrajectoryComparison& comparison, bool include_per_point = false);

/// {"denied_at_s", "pairs", "duration_s", "distance_m", "first_error_m", "end_error_m",
///  "max_error_m", "rmse_m", "end_error_per_km_m" (null under 1 m flown), "at": [{"after_s",
///  "time_s", "error_m", "distance_m"}...]}.
nlohmann::json ToJson(const DeniedError& denied);

const char* ToString(AlignmentModel model);  ///< "SE2" or "Sim2".

/// A fixed-width text table, one column per alignment (SE(2), Sim(2)), one row per figure;
/// lines end with '\n'. `reference` names what the trajectory is compared with (header).
std::string FormatTrajectoryTable(const TrajectoryComparison& comparison,
                                  const std::string& reference = "GPS");

}  // namespace aerovo
