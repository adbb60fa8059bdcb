// A lane on the ground as a curve: x(y) = offset + heading y + curvature
// y^2 / 2 (metres; x right, y ahead of the camera's foot point) over its
// extent in y. The tracker holds its lanes so (lane/track/ground_curve.h),
// and the detector refits a tracked lane in this form (lane/detector/detector.h,
// DetectionPrior).
#ifndef LANE_GEOMETRY_GROUND_CURVE_H_
#define LANE_GEOMETRY_GROUND_CURVE_H_

#include <Eigen/Core>

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

}  // namespace lane

#endif  // LANE_GEOMETRY_GROUND_CURVE_H_
