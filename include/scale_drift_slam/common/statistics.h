#pragma once
// Small order statistics shared by the modules.

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace scale_drift_slam::common {

/// The element in the middle of the sorted values: values[n / 2], the upper of the two middle
/// ones for an even count (no averaging: the result is always one of the values). Linear time.
/// Throws std::invalid_argument for no values.
inline double upperMedian(std::vector<double> values) {
  if (values.empty()) throw std::invalid_argument("the median of no values");
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace scale_drift_slam::common
