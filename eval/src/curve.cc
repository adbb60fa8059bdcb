#include "lane/eval/curve.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace lane::eval {

Curve Curve::FromBezier(const std::array<Eigen::Vector2d, 4>& control) {
  Curve c;
  c.kind = Kind::kBezier;
  c.points.assign(control.begin(), control.end());
  return c;
}

Curve Curve::Polyline(std::vector<Eigen::Vector2d> vertices) {
  Curve c;
  c.kind = Kind::kPolyline;
  c.points = std::move(vertices);
  return c;
}

std::vector<Eigen::Vector2d> Curve::Sample(int n) const {
  n = std::max(n, 2);
  std::vector<Eigen::Vector2d> out;
  if (points.empty()) return out;
  out.reserve(n);
  if (kind == Kind::kBezier && points.size() == 4) {
    const Bezier b{{points[0], points[1], points[2], points[3]}};
    return b.Sample(n);
  }
  // Polyline (or a malformed Bezier, treated as its control polygon):
  // cumulative length at each vertex, then n evenly spaced stations.
  std::vector<double> at(points.size(), 0.0);
  for (size_t i = 1; i < points.size(); ++i) {
    at[i] = at[i - 1] + (points[i] - points[i - 1]).norm();
  }
  const double length = at.back();
  if (!(length > 0)) return std::vector<Eigen::Vector2d>(n, points.front());
  size_t seg = 0;
  for (int k = 0; k < n; ++k) {
    const double s = length * k / (n - 1);
    while (seg + 2 < points.size() && at[seg + 1] < s) ++seg;
    const double span = at[seg + 1] - at[seg];
    const double f = span > 0 ? std::clamp((s - at[seg]) / span, 0.0, 1.0) : 0.0;
    out.push_back(points[seg] + f * (points[seg + 1] - points[seg]));
  }
  return out;
}

std::vector<Eigen::Vector2d> Curve::DrawPoints(int bezier_samples) const {
  if (kind == Kind::kBezier && points.size() == 4) return Sample(bezier_samples);
  return points;
}

std::optional<double> XAtRow(const std::vector<Eigen::Vector2d>& samples, double y) {
  if (samples.size() < 2) return std::nullopt;
  // Walk from the lower end (largest y) so the crossing nearest it wins.
  std::vector<Eigen::Vector2d> pts = samples;
  if (pts.front().y() < pts.back().y()) std::reverse(pts.begin(), pts.end());
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    const Eigen::Vector2d& a = pts[i];
    const Eigen::Vector2d& b = pts[i + 1];
    if ((a.y() - y) * (b.y() - y) > 0) continue;  // both on one side
    if (a.y() == b.y()) {
      if (a.y() == y) return a.x();
      continue;
    }
    return a.x() + (y - a.y()) / (b.y() - a.y()) * (b.x() - a.x());
  }
  // No crossing: extend the end nearest the row.
  const bool use_lower = std::abs(pts.front().y() - y) <= std::abs(pts.back().y() - y);
  if (!use_lower) std::reverse(pts.begin(), pts.end());
  const Eigen::Vector2d& end = pts.front();
  const size_t step = std::max<size_t>(1, pts.size() / 10);
  for (size_t k = step; k < pts.size(); ++k) {
    const Eigen::Vector2d d = pts[k] - end;
    if (d.norm() <= 1e-9) continue;
    if (std::abs(d.y()) < 1e-9) return std::nullopt;
    return end.x() + (y - end.y()) / d.y() * d.x();
  }
  return std::nullopt;
}

}  // namespace lane::eval
