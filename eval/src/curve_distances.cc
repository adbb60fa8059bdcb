#include "lane/eval/curve_distances.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lane::eval {
namespace {

// Median and mean over the points of `from` of the distance to the nearest
// point of `to`.
std::pair<double, double> Directed(const std::vector<Eigen::Vector2d>& from,
                                   const std::vector<Eigen::Vector2d>& to) {
  std::vector<double> d = NearestPointDistances(from, to);
  double mean = 0;
  for (double v : d) mean += v;
  mean /= d.size();
  const size_t mid = d.size() / 2;
  std::nth_element(d.begin(), d.begin() + mid, d.end());
  double median = d[mid];
  if (d.size() % 2 == 0) median = 0.5 * (median + *std::max_element(d.begin(), d.begin() + mid));
  return {median, mean};
}

}  // namespace

MatchDistances CurveMatchDistances(const std::vector<Eigen::Vector2d>& a,
                                   const std::vector<Eigen::Vector2d>& b) {
  if (a.empty() || b.empty()) {
    return {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  }
  const auto ab = Directed(a, b);
  const auto ba = Directed(b, a);
  return {std::min(ab.first, ba.first), std::min(ab.second, ba.second)};
}

bool PaperMatch(const Bezier& detected, const Bezier& label, int image_width) {
  const double scale = image_width / 640.0;
  const MatchDistances d = CurveMatchDistances(detected.Sample(101), label.Sample(101));
  return d.median <= 20.0 * scale && d.mean <= 15.0 * scale;
}

}  // namespace lane::eval
