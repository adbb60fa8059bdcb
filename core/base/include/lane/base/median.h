// The median of a sample, the mean of the two middle values for an even
// count; NaN for an empty one.
#ifndef LANE_BASE_MEDIAN_H_
#define LANE_BASE_MEDIAN_H_

#include <algorithm>
#include <limits>
#include <vector>

namespace lane {

inline double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto h = static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), v.begin() + h, v.end());
  double m = v[static_cast<size_t>(h)];
  if (v.size() % 2 == 0) m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + h));
  return m;
}

}  // namespace lane

#endif  // LANE_BASE_MEDIAN_H_
