// A lane on the ground as the tracker holds it: x(y) = offset + heading y +
// curvature y^2 / 2 (metres; x right, y ahead) over its extent in y.
#ifndef LANE_TRACK_GROUND_CURVE_H_
#define LANE_TRACK_GROUND_CURVE_H_

#include <Eigen/Core>
#include <optional>

#include "lane/detector.h"

namespace lane {

// x(y) = offset + heading * y + curvature * y^2 / 2 over [y_near, y_far].
struct GroundCurve {
  Eigen::Vector3d coefficients = Eigen::Vector3d::Zero();  // offset, heading, curvature
  double y_near = 0;
  double y_far = 0;

  double X(double y) const {
    return coefficients(0) + coefficients(1) * y + 0.5 * coefficients(2) * y * y;
  }
};

// Least-squares fit of a lane's ground Bezier (sampled); none when the lane
// does not advance along the road.
std::optional<GroundCurve> FitGroundCurve(const Lane& lane);

// Mean |a(y) - b(y)| over the common extent of a and b (or b's extent when
// they overlap by less than a metre), metres.
double LateralDistance(const GroundCurve& a, const GroundCurve& b);

// A lane's ground Bezier.
Bezier GroundBezier(const Lane& lane);

}  // namespace lane

#endif  // LANE_TRACK_GROUND_CURVE_H_
