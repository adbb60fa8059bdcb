// Cubic Bezier splines (paper section II-D): Q(t) = T(t) M P.
#ifndef LANE_BEZIER_H_
#define LANE_BEZIER_H_

#include <Eigen/Core>
#include <array>
#include <optional>
#include <vector>

namespace lane {

struct Bezier {
  std::array<Eigen::Vector2d, 4> p;

  Eigen::Vector2d Eval(double t) const;
  // dQ/dt.
  Eigen::Vector2d Derivative(double t) const;
  // n >= 2 points at t = 0, 1/(n-1), ..., 1.
  std::vector<Eigen::Vector2d> Sample(int n) const;
  // Length of the polyline through Sample(n).
  double Length(int n = 51) const;
  // Mean cosine of the two angles between consecutive legs of the control
  // polygon: 1 for a straight spline, lower when curved (paper's theta).
  double Straightness() const;
  // A straight spline from a to b with evenly spaced inner control points.
  static Bezier Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b);
};

// Chord-length parameters (paper's t_i): t_0 = 0, t_n-1 = 1, proportional to
// the cumulative distance along the points. nullopt if all points coincide.
std::optional<std::vector<double>> ChordLengthParams(const std::vector<Eigen::Vector2d>& pts);

// Least-squares Bezier through the points using chord-length t and the
// pseudo-inverse P = (T M)^+ Q. Needs >= 4 points that are not all equal.
std::optional<Bezier> FitBezier(const std::vector<Eigen::Vector2d>& pts);

// For each point of `from`, the distance to the nearest point of `to`: the
// one curve-distance loop of the project (Hausdorff distances, the paper's
// matching rule and the detector's duplicate test are all built on it).
// Infinity for every point when `to` is empty.
std::vector<double> NearestPointDistances(const std::vector<Eigen::Vector2d>& from,
                                          const std::vector<Eigen::Vector2d>& to);

// Max over samples of one curve of the distance to the nearest sample of the
// other, both ways (symmetric Hausdorff on n samples each).
double CurveDistance(const Bezier& a, const Bezier& b, int n = 101);

}  // namespace lane

#endif  // LANE_BEZIER_H_
