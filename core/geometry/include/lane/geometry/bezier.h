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

// Mean distance from 21 samples of the shorter curve to the nearest of 101
// samples of the other: small when one lies along the other (the detector's
// duplicate test).
double MeanNearestDistance(const Bezier& a, const Bezier& b);
// MeanNearestDistance(a, b) < limit, without sampling when the curves' control
// polygons' bounding boxes lie `limit` or more apart (a curve lies inside its
// control points' convex hull, so every distance is at least that gap).
bool MeanNearestDistanceBelow(const Bezier& a, const Bezier& b, double limit);

// Angle of the direction `d` from the vertical (an image or top-view column),
// degrees in [0, 90]; the one angle every direction check uses.
double AngleFromVerticalDeg(const Eigen::Vector2d& d);
// The same for the chord P0 -> P3.
inline double ChordAngleFromVerticalDeg(const Bezier& s) {
  return AngleFromVerticalDeg(s.p[3] - s.p[0]);
}

// The control points reordered, if needed, so that P0 is the upper (in the
// top view: farther) end.
Bezier TopDown(Bezier s);

// Least-squares Bezier through `n` samples of `s` mapped by `f` (samples that
// map to non-finite points are dropped): a spline carried into another frame
// (top view, image, ground).
template <typename Fn>
std::optional<Bezier> MapSpline(const Bezier& s, int n, Fn f) {
  std::vector<Eigen::Vector2d> pts;
  pts.reserve(n);
  for (const auto& p : s.Sample(n)) {
    const Eigen::Vector2d q = f(p);
    if (q.allFinite()) pts.push_back(q);
  }
  return FitBezier(pts);
}

// Max over samples of one curve of the distance to the nearest sample of the
// other, both ways (symmetric Hausdorff on n samples each).
double CurveDistance(const Bezier& a, const Bezier& b, int n = 101);

}  // namespace lane

#endif  // LANE_BEZIER_H_
