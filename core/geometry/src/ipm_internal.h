// Helpers shared by the IPM's sources (ipm.cc, ipm_options.cc).
#ifndef LANE_GEOMETRY_IPM_INTERNAL_H_
#define LANE_GEOMETRY_IPM_INTERNAL_H_

#include <cmath>

namespace lane::ipm_internal {

// Top-view size along one axis for a ground range and resolution.
inline int GroundPixels(double range_m, double metres_per_px) {
  const double n = range_m / metres_per_px;
  return n < 1e6 ? static_cast<int>(std::lround(n)) : 1000000;
}

}  // namespace lane::ipm_internal

#endif  // LANE_GEOMETRY_IPM_INTERNAL_H_
