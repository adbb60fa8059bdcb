#include "lane/track/ground_curve.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace lane {

Bezier GroundBezier(const Lane& lane) {
  Bezier b;
  for (int k = 0; k < 4; ++k) b.p[k] = lane.ground[k];
  return b;
}

// Mean |a(y) - b(y)| over the common extent (or b's when they barely meet).
double LateralDistance(const GroundCurve& a, const GroundCurve& b) {
  double lo = std::max(a.y_near, b.y_near), hi = std::min(a.y_far, b.y_far);
  if (hi - lo < 1.0) {
    lo = b.y_near;
    hi = b.y_far;
  }
  double sum = 0;
  constexpr int kSamples = 8;
  for (int i = 0; i < kSamples; ++i) {
    const double y = lo + (hi - lo) * i / (kSamples - 1);
    sum += std::abs(a.X(y) - b.X(y));
  }
  return sum / kSamples;
}

std::optional<GroundCurve> FitGroundCurve(const Lane& lane) {
  const std::vector<Eigen::Vector2d> pts = GroundBezier(lane).Sample(20);
  double lo = pts[0].y(), hi = pts[0].y();
  for (const Eigen::Vector2d& p : pts) {
    lo = std::min(lo, p.y());
    hi = std::max(hi, p.y());
  }
  if (!(hi - lo >= 1.0) || !std::isfinite(lo) || !std::isfinite(hi)) return std::nullopt;
  // Curvature only when the lane is long enough to show it.
  const int terms = hi - lo >= 6.0 ? 3 : 2;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(pts.size()), terms);
  Eigen::VectorXd x(static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) {
    const double y = pts[i].y();
    const auto r = static_cast<Eigen::Index>(i);
    a(r, 0) = 1.0;
    a(r, 1) = y;
    if (terms == 3) a(r, 2) = 0.5 * y * y;
    x(r) = pts[i].x();
  }
  const Eigen::VectorXd c = a.colPivHouseholderQr().solve(x);
  if (!c.allFinite()) return std::nullopt;
  GroundCurve g;
  g.coefficients.head(terms) = c;
  g.y_near = lo;
  g.y_far = hi;
  return g;
}

}  // namespace lane
