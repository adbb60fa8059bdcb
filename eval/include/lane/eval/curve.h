// A lane boundary as the evaluation sees it: a cubic Bezier (our detections,
// Caltech Lanes and synthetic labels) or a polyline (CULane and TuSimple
// labels). Both are sampled the same way for the paper's rule and drawn the
// same way for the CULane metric.
#ifndef LANE_EVAL_CURVE_H_
#define LANE_EVAL_CURVE_H_

#include <Eigen/Core>
#include <array>
#include <optional>
#include <vector>

#include "lane/geometry/bezier.h"

namespace lane::eval {

// The paper samples splines at t = 0, 0.01, ..., 1: 101 points.
inline constexpr int kPaperSamples = 101;

struct Curve {
  enum class Kind { kBezier, kPolyline };

  Kind kind = Kind::kPolyline;
  // kBezier: the 4 control points. kPolyline: the vertices in order (>= 2).
  std::vector<Eigen::Vector2d> points;

  static Curve FromBezier(const std::array<Eigen::Vector2d, 4>& control);
  static Curve Polyline(std::vector<Eigen::Vector2d> vertices);

  // n >= 2 points. A Bezier is sampled at t = 0, 1/(n-1), ..., 1 (the
  // paper's sampling); a polyline is densified "the same way": n points
  // evenly spaced along its length, from its first to its last vertex. A
  // curve without points gives none; a polyline of zero length gives n
  // copies of its point.
  std::vector<Eigen::Vector2d> Sample(int n = kPaperSamples) const;

  // Points to draw it through: a polyline's own vertices, or n samples of a
  // Bezier.
  std::vector<Eigen::Vector2d> DrawPoints(int bezier_samples = kPaperSamples) const;
};

// Where a sampled curve crosses image row `y`: the x of the crossing nearest
// the curve's lower end (largest y) when it crosses the row several times.
// When the curve does not reach the row, it is extended along the straight
// line through its end nearest the row and the sample a tenth of the curve
// further in. nullopt for fewer than 2 distinct points or an end that runs
// horizontally (no crossing).
std::optional<double> XAtRow(const std::vector<Eigen::Vector2d>& samples, double y);

}  // namespace lane::eval

#endif  // LANE_EVAL_CURVE_H_
