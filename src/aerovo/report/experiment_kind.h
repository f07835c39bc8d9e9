// The kinds of experiment (pipeline/experiment.h runs them, report/html_report.cc draws their
// figures): the "kind" of experiment.json, the subcommand of `aerovo experiment`.
//
// How to add an experiment (the compiler asks for the rest):
//   1. One entry X(kName, "name") in AEROVO_EXPERIMENT_KINDS below (the enumerator, the name in
//      experiment.json and on the command line).
//   2. Its entry in Experiments() (pipeline/experiment.cc): CLI help, the RunConfig keys it sets,
//      the runs it plans and the tables it computes; ExperimentRegistry.EveryKindOnce in
//      experiment_test.cc checks that every kind has one.
//   3. Its figures in the report's table (kExperimentFigures in report/html_report.cc; a
//      static_assert checks that every kind has an entry).
// The run, the tables and the figures live in the module that can compute them (the report
// module sits below pipeline and cannot call the runs; pipeline cannot be called by the report),
// so one kind has one entry in each, keyed by this enum.
#pragma once

#include <cstddef>
#include <iterator>
#include <optional>
#include <string>

#include "aerovo/core/options.h"

namespace aerovo {

/// THE list of experiments: X(enumerator, name), in the order of the enum (and of the
/// subcommands of `aerovo experiment`).
// clang-format off
#define AEROVO_EXPERIMENT_KINDS(X)                                                               \
  X(kIllumination, "illumination") /* paper Fig. 4-6: brightness f_k = k f */                    \
  X(kRansac, "ransac")             /* paper Fig. 7-8: standard vs clustered RANSAC */
// clang-format on

enum class ExperimentKind {
#define AEROVO_EXPERIMENT_KIND_ENUMERATOR(e, name) e,
  AEROVO_EXPERIMENT_KINDS(AEROVO_EXPERIMENT_KIND_ENUMERATOR)
#undef AEROVO_EXPERIMENT_KIND_ENUMERATOR
};

/// Every ExperimentKind, in enum order.
inline constexpr ExperimentKind kAllExperimentKinds[] = {
#define AEROVO_EXPERIMENT_KIND_VALUE(e, name) ExperimentKind::e,
    AEROVO_EXPERIMENT_KINDS(AEROVO_EXPERIMENT_KIND_VALUE)
#undef AEROVO_EXPERIMENT_KIND_VALUE
};
inline constexpr std::size_t kNumExperimentKinds = std::size(kAllExperimentKinds);

/// "illumination", "ransac".
inline const char* ToString(ExperimentKind kind) {
  switch (kind) {
#define AEROVO_EXPERIMENT_KIND_NAME(e, name) \
  case ExperimentKind::e:                    \
    return name;
    AEROVO_EXPERIMENT_KINDS(AEROVO_EXPERIMENT_KIND_NAME)
#undef AEROVO_EXPERIMENT_KIND_NAME
  }
  return "?";
}

template <>
struct options::EnumTraits<ExperimentKind> {
  static constexpr const auto& kValues = kAllExperimentKinds;
  static const char* Name(ExperimentKind kind) { return ToString(kind); }
};

/// The kind named `name` (experiment.json's "kind"); nullopt for another name (an experiment
/// folder of another version: the report draws its generic figures).
inline std::optional<ExperimentKind> ParseExperimentKind(const std::string& name) {
  return options::ParseEnum<ExperimentKind>(name);
}

}  // namespace aerovo
