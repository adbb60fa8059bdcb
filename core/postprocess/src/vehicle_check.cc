#include "lane/postprocess/vehicle_check.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "lane/geometry/channel_view.h"

namespace lane {

RayTest TestRay(const std::vector<Eigen::Vector2d>& pts) {
  RayTest out;
  if (pts.size() < 2) return out;
  // Least squares x = a + b y.
  double sy = 0, sx = 0, syy = 0, sxy = 0;
  for (const auto& p : pts) {
    sy += p.y();
    sx += p.x();
    syy += p.y() * p.y();
    sxy += p.x() * p.y();
  }
  const double n = static_cast<double>(pts.size());
  const double det = n * syy - sy * sy;
  if (!(std::abs(det) > 1e-9)) return out;
  const double b = (n * sxy - sy * sx) / det;
  const double a = (sx - b * sy) / n;
  const double y_m = sy / n;
  if (!(y_m > 0)) return out;
  const double x_m = a + b * y_m;
  constexpr double kDeg = 180.0 / M_PI;
  out.line_deg = std::atan(b) * kDeg;
  for (const auto& p : pts) out.bend_m = std::max(out.bend_m, std::abs(p.x() - (a + b * p.y())));
  out.ray_deg = std::atan(x_m / y_m) * kDeg;
  out.valid = true;
  return out;
}

RayTest TestRay(const Bezier& ipm_spline, const IpmMapping& ipm) {
  std::vector<Eigen::Vector2d> ground;
  for (const Eigen::Vector2d& p : ipm_spline.Sample(21)) ground.push_back(ipm.IpmToGround(p));
  return TestRay(ground);
}

double RoadDirectionDeg(const std::vector<Bezier>& ipm_splines, const IpmMapping& ipm) {
  std::vector<double> angles;
  for (const Bezier& s : ipm_splines) {
    const RayTest t = TestRay(s, ipm);
    if (t.valid) angles.push_back(t.line_deg);
  }
  if (angles.empty()) return 0.0;
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2];
}

float RoadLevel(const cv::Mat& top_view, const cv::Mat& valid_mask) {
  CV_Assert(top_view.type() == CV_32FC1 && valid_mask.type() == CV_8UC1);
  thread_local std::vector<float> values;
  values.clear();
  for (int r = 0; r < top_view.rows; r += 2) {
    const float* v = top_view.ptr<float>(r);
    const uint8_t* m = valid_mask.ptr<uint8_t>(r);
    for (int c = (r / 2) % 2; c < top_view.cols; c += 2) {
      if (m[c]) values.push_back(v[c]);
    }
  }
  if (values.empty()) return 0.f;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

double BrightSideFraction(const Bezier& spline, const cv::Mat& top_view, float road_level,
                          double side_px, int samples) {
  const ChannelView view(top_view);
  int counted = 0, bright = 0;
  for (int i = 0; i < samples; ++i) {
    const double t = (i + 0.5) / samples;
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d d = spline.Derivative(t);
    if (d.norm() < 1e-9) continue;
    const Eigen::Vector2d n(-d.y() / d.norm(), d.x() / d.norm());
    const Eigen::Vector2d l = p - side_px * n, r = p + side_px * n;
    const auto inside = [&](const Eigen::Vector2d& q) {
      return q.x() >= 0 && q.y() >= 0 && q.x() <= top_view.cols - 1 && q.y() <= top_view.rows - 1;
    };
    if (!inside(p) || !inside(l) || !inside(r)) continue;
    float centre = -1e30f;
    for (double o : {-1.0, 0.0, 1.0}) {
      const Eigen::Vector2d q = p + o * n;
      if (inside(q)) centre = std::max(centre, view.Bilinear(q.x(), q.y()));
    }
    const float contrast = centre - road_level;
    if (!(contrast > 0)) continue;  // not brighter than the road: a gap
    ++counted;
    const float side = std::max(view.Bilinear(l.x(), l.y()), view.Bilinear(r.x(), r.y()));
    if (side >= centre) ++bright;
  }
  return counted > 0 ? static_cast<double>(bright) / counted : 0.0;
}

}  // namespace lane
