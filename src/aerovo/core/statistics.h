// Small robust statistics of a sample, written once for the modules that need them.
// No I/O; the values are taken by value (the selection reorders them).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "aerovo/core/error.h"

namespace aerovo {

/// The sample median: the middle value, the mean of the two middle values for an even count.
/// O(n) expected (std::nth_element). Throws InvalidArgument for an empty sample or a value that
/// is not finite (no order to take a middle of).
inline double Median(std::vector<double> values) {
  if (values.empty()) throw InvalidArgument("Median: no values");
  for (double v : values) {
    if (!std::isfinite(v)) throw InvalidArgument("Median: a value is not finite");
  }
  const std::size_t mid = values.size() / 2;
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(mid);
  std::nth_element(values.begin(), at, values.end());
  double m = *at;
  if (values.size() % 2 == 0) m = 0.5 * (m + *std::max_element(values.begin(), at));
  return m;
}

/// The standard error of the median-type estimate of a sample's centre, from the median
/// absolute deviation: 1.4826 MAD / sqrt(n), where 1.4826 makes the MAD a consistent estimate
/// of a normal distribution's standard deviation (P. J. Rousseeuw, C. Croux, "Alternatives to
/// the median absolute deviation", J. Amer. Statist. Assoc. 88(424), 1993). Throws as Median.
inline double RobustStandardError(const std::vector<double>& values) {
  const double centre = Median(values);
  std::vector<double> deviation;
  deviation.reserve(values.size());
  for (double v : values) deviation.push_back(std::abs(v - centre));
  return 1.4826 * Median(std::move(deviation)) / std::sqrt(static_cast<double>(values.size()));
}

}  // namespace aerovo
