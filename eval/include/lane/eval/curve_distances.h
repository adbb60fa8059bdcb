// The distances between two curves that the paper's rule compares, and the
// rule itself on one pair of splines (Aly 2008, section III-A). Matching a
// frame's detections to its labels is in paper_rule.h.
#ifndef LANE_EVAL_CURVE_DISTANCES_H_
#define LANE_EVAL_CURVE_DISTANCES_H_

#include <Eigen/Core>
#include <vector>

#include "lane/geometry/bezier.h"

namespace lane::eval {

struct MatchDistances {
  double median = 0;  // d^ = min of the two directed median distances, pixels
  double mean = 0;    // d- = min of the two directed mean distances, pixels
};

// Nearest-point distances between two sampled curves in both directions.
MatchDistances CurveMatchDistances(const std::vector<Eigen::Vector2d>& a,
                                   const std::vector<Eigen::Vector2d>& b);

// Samples both splines at t = 0, 0.01, ..., 1 and applies the paper's rule:
// d^ <= 20 px AND d- <= 15 px, thresholds scaled by image_width / 640.
bool PaperMatch(const Bezier& detected, const Bezier& label, int image_width);

}  // namespace lane::eval

#endif  // LANE_EVAL_CURVE_DISTANCES_H_
