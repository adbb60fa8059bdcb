// The tracker's lanes on the ground (lane/geometry/ground_curve.h): fitted
// to a lane, compared and drawn.
#ifndef LANE_TRACK_GROUND_CURVE_H_
#define LANE_TRACK_GROUND_CURVE_H_

#include <Eigen/Core>
#include <optional>

#include "lane/detector/detector.h"
#include "lane/geometry/ground_curve.h"

namespace lane {

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
