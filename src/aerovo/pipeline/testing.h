// Test helpers of the run configuration (not installed): one valid non-default value for every
// option of the RunConfig schema, so that tests can iterate the schema (pipeline/run_config_test.cc
// by JSON and YAML, tests/e2e/run_cli_test.cc by flag).
#pragma once

#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "aerovo/core/options_json.h"
#include "aerovo/pipeline/run_config.h"

namespace aerovo::testing {

// One valid value different from the default for every field of the schema.
struct Sample {
  std::string key;
  std::string alias;
  nlohmann::json value;
  bool cli_switch = false;  ///< A flag without value (--quiet): the value is true.
};

class NonDefaultValues : public options::GroupingVisitor<NonDefaultValues> {
 public:
  template <class T>
  void Field(const T& v, const char* key, const char*, const options::Spec& spec) {
    T other = v;
    if constexpr (std::is_same_v<T, bool>) {
      other = !v;
    } else if constexpr (std::is_enum_v<T>) {
      for (const T e : options::EnumTraits<T>::kValues) {
        if (e != v) {
          other = e;
          break;
        }
      }
    } else if constexpr (std::is_same_v<T, std::string>) {
      // A string with a syntax (the --mavlink URL) gets a valid value of it.
      other = std::string(key) == "mavlink" ? "udp:127.0.0.1:14550"
              : v.empty()                   ? "given"
                                            : v + "-2";
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      other = T{"given"};
    } else if (v != v) {
      other = static_cast<T>(1.0);  // NaN = unknown (ground_elevation_m): a known value
    } else {
      for (const double c : {v + 1.0, v * 0.5, v + 0.25, v - 1.0}) {
        if (static_cast<T>(c) != v && (!spec.HasRange() || spec.Contains(c))) {
          other = static_cast<T>(c);
          break;
        }
      }
    }
    EXPECT_FALSE(other == v) << Key(key);
    samples.push_back(
        {Key(key), spec.alias ? spec.alias : "", options::ToJsonValue(other), spec.cli_switch});
  }
  std::vector<Sample> samples;
};

inline std::vector<Sample> Samples() {
  NonDefaultValues v;
  options::Visit(RunConfig{}, v);
  return v.samples;
}

}  // namespace aerovo::testing
