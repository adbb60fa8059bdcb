// What the tracking tests share (tracking_test.cc, tracker_prior_test.cc).
#ifndef LANE_TESTS_CORE_TRACKING_TEST_UTIL_H_
#define LANE_TESTS_CORE_TRACKING_TEST_UTIL_H_

#include <Eigen/Core>

#include "lane/detector/detector.h"

namespace lane {

// A lane on the ground along x(y) = c0 + c1 y + c2 y^2 / 2 over [y0, y1],
// as the exact cubic Bezier of that parabola (only ground points are set).
inline Lane GroundLane(double c0, double c1, double c2, double y0 = 4.0, double y1 = 24.0) {
  auto x = [&](double y) { return c0 + c1 * y + 0.5 * c2 * y * y; };
  const Eigen::Vector2d q0(x(y0), y0), q2(x(y1), y1);
  const Eigen::Vector2d q1(x(y0) + (c1 + c2 * y0) * (y1 - y0) / 2, (y0 + y1) / 2);
  Lane lane;
  lane.ground = {q0, q0 + 2.0 / 3.0 * (q1 - q0), q2 + 2.0 / 3.0 * (q1 - q2), q2};
  return lane;
}

}  // namespace lane

#endif  // LANE_TESTS_CORE_TRACKING_TEST_UTIL_H_
