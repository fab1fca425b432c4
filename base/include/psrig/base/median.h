#pragma once
// The median of a sample: for an even count the upper of the two middle
// values (no averaging: the answer is always one of the values); 0 for an
// empty sample.

#include <algorithm>
#include <cstddef>
#include <vector>

namespace psrig {

[[nodiscard]] inline double median(std::vector<double> values) {
  if (values.empty()) return 0;
  auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace psrig
