#include "lane/postprocess/spline_walk.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "lane/postprocess/profile.h"

namespace lane {

std::optional<LocalizedSpline> LocalizeSpline(const Bezier& spline, const ChannelView& image, int n,
                                              double search_px, double sigma_px, double min_cos) {
  std::vector<Eigen::Vector2d> pts;
  double contrast_sum = 0;
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d tangent = spline.Derivative(t);
    if (tangent.norm() < 1e-9 || !image.Inside(p.x(), p.y())) continue;
    tangent.normalize();
    const Eigen::Vector2d normal = Normal(tangent);
    thread_local std::vector<float> profile;
    SampleProfile(image, p, normal, search_px, profile);
    const auto peak = FindProfilePeak(profile, sigma_px);
    if (!peak) continue;
    const Eigen::Vector2d q = p + peak->offset * normal;
    if (!pts.empty()) {
      // Reject a point that makes the localised curve turn away from the
      // spline's own direction.
      const Eigen::Vector2d step = q - pts.back();
      if (step.norm() < 1e-9 || step.normalized().dot(tangent) < min_cos) continue;
    }
    pts.push_back(q);
    contrast_sum += peak->contrast;
  }
  if (pts.size() < 4) return std::nullopt;
  std::optional<Bezier> fit = FitBezier(pts);
  if (!fit) return std::nullopt;
  return LocalizedSpline{*fit, contrast_sum / pts.size()};
}

double BarContrast(const Bezier& spline, const ChannelView& image, double side_offset_px,
                   double bar_fraction, int samples) {
  std::vector<double> values;
  values.reserve(samples);
  for (int i = 0; i < samples; ++i) {
    const double t = (i + 0.5) / samples;
    const Eigen::Vector2d p = spline.Eval(t);
    Eigen::Vector2d tangent = spline.Derivative(t);
    if (tangent.norm() < 1e-9 || !image.Inside(p.x(), p.y())) continue;
    const Eigen::Vector2d normal = Normal(tangent.normalized());
    double centre = -1e30;
    for (double o : {-1.0, 0.0, 1.0}) {
      const Eigen::Vector2d q = p + o * normal;
      centre = std::max(centre, static_cast<double>(image.Bilinear(q.x(), q.y())));
    }
    const Eigen::Vector2d l = p - side_offset_px * normal;
    const Eigen::Vector2d r = p + side_offset_px * normal;
    if (!image.Inside(l.x(), l.y()) || !image.Inside(r.x(), r.y())) continue;
    values.push_back(
        std::min(centre - image.Bilinear(l.x(), l.y()), centre - image.Bilinear(r.x(), r.y())));
  }
  if (values.empty()) return 0.0;
  // A high quantile: a dashed marking is a bar along a fifth to a quarter of
  // its length or more, while a step (curb, asphalt edge) is never one.
  const size_t k =
      std::min(values.size() - 1, static_cast<size_t>(values.size() * (1.0 - bar_fraction)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

Bezier ExtendSpline(const Bezier& spline, const ChannelView& image, const ExtendOptions& options) {
  auto walk = [&](const Eigen::Vector2d& start, Eigen::Vector2d dir, double min_cos) {
    std::vector<Eigen::Vector2d> added;
    if (dir.norm() < 1e-9) return added;
    dir.normalize();
    const Eigen::Vector2d main_dir = dir;
    Eigen::Vector2d cur = start;
    for (int step = 0; step < options.max_steps; ++step) {
      const Eigen::Vector2d guess = cur + options.step_px * dir;
      if (!image.Inside(guess.x(), guess.y()) || guess.y() < options.min_row ||
          guess.y() > options.max_row) {
        break;
      }
      const Eigen::Vector2d normal = Normal(dir);
      thread_local std::vector<float> profile;
      SampleProfile(image, guess, normal, options.search_px, profile);
      const auto peak = FindProfilePeak(profile, options.sigma_px);
      if (!peak || peak->contrast < options.min_contrast) break;
      const Eigen::Vector2d q = guess + peak->offset * normal;
      const Eigen::Vector2d d = (q - cur).normalized();
      if (d.dot(main_dir) < min_cos) break;
      if (!image.Inside(q.x(), q.y()) || q.y() < options.min_row || q.y() > options.max_row) break;
      added.push_back(q);
      cur = q;
      dir = d;
    }
    return added;
  };
  const auto before = walk(spline.p[0], -spline.Derivative(0), options.min_cos_start);
  const auto after = walk(spline.p[3], spline.Derivative(1), options.min_cos_end);
  if (before.empty() && after.empty()) return spline;
  std::vector<Eigen::Vector2d> pts(before.rbegin(), before.rend());
  for (const auto& p : spline.Sample(20)) pts.push_back(p);
  pts.insert(pts.end(), after.begin(), after.end());
  if (auto fit = FitBezier(pts)) return *fit;
  return spline;
}

}  // namespace lane
