#include "lane/spline_fit.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "lane/ransac.h"

namespace lane {
namespace {

bool InsideImage(const Eigen::Vector2d& p, const cv::Mat& image) {
  return p.x() >= 0 && p.y() >= 0 && p.x() <= image.cols - 1 && p.y() <= image.rows - 1;
}

// RANSAC estimator: 4 weighted samples sorted by row, least-squares Bezier
// with chord-length t, scored by the paper's rasterised score.
class SplineEstimator {
 public:
  using Model = Bezier;
  static constexpr int kSampleSize = 4;

  SplineEstimator(const cv::Mat& image, const SplineRansacOptions& options,
                  std::pair<const IpmLine*, double> window)
      : image_(image), options_(options), window_(window) {}

  std::optional<Bezier> Estimate(const std::vector<Eigen::Vector2d>& sample) const {
    sorted_ = sample;
    std::sort(sorted_.begin(), sorted_.end(),
              [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.y() < b.y(); });
    return FitBezier(sorted_);
  }

  double Score(const Bezier& spline) const {
    return SplineScore(spline, image_, options_, window_);
  }

 private:
  const cv::Mat& image_;
  const SplineRansacOptions& options_;
  std::pair<const IpmLine*, double> window_;
  mutable std::vector<Eigen::Vector2d> sorted_;  // scratch, reused across trials
};

}  // namespace

absl::Status SplineRansacOptions::Validate() const {
  if (!(window_half_width_m > 0 && window_half_width_m < 20)) {
    return absl::InvalidArgumentError(
        "spline_ransac.window_half_width_m must lie in (0, 20) metres");
  }
  if (iterations < 0 || iterations > 10000) {
    return absl::InvalidArgumentError("spline_ransac.iterations must lie in 0..10000");
  }
  if (!std::isfinite(k1) || !std::isfinite(k2) || k1 < 0 || k2 < 0) {
    return absl::InvalidArgumentError("spline_ransac.k1 and k2 must be finite and >= 0");
  }
  if (jitter_px < 0 || jitter_px > 10) {
    return absl::InvalidArgumentError("spline_ransac.jitter_px must lie in 0..10");
  }
  if (!(merge_distance_px >= 0 && merge_distance_px < 100)) {
    return absl::InvalidArgumentError("spline_ransac.merge_distance_px must lie in [0, 100)");
  }
  return absl::OkStatus();
}

double SplineScore(const Bezier& spline, const cv::Mat& image, const SplineRansacOptions& options,
                   const std::pair<const IpmLine*, double>& window) {
  for (const auto& p : spline.p) {
    if (!InsideImage(p, image)) return 0.0;
  }
  // The curve in power form, Q(t) = ((a t + b) t + c) t + d, for Horner
  // evaluation in the hot loop (this runs once per RANSAC trial).
  const Eigen::Vector2d a = -spline.p[0] + 3 * spline.p[1] - 3 * spline.p[2] + spline.p[3];
  const Eigen::Vector2d b = 3 * spline.p[0] - 6 * spline.p[1] + 3 * spline.p[2];
  const Eigen::Vector2d c = -3 * spline.p[0] + 3 * spline.p[1];
  const Eigen::Vector2d d = spline.p[0];
  // Window: columns within half of x = x0 + slope * y.
  double w_x0 = 0, w_slope = 0, w_half = 1e9;
  if (window.first) {
    w_x0 = window.first->XAt(0);
    w_slope = window.first->XAt(1) - w_x0;
    w_half = window.second;
  }
  // Raster the curve at dt = 0.01; each pixel counts once, with the jitter
  // columns either side. All control points are inside the image, so the
  // curve (inside their convex hull) is too and coordinates are >= 0.
  double raw = 0;
  int last_x = -1, last_y = -1;
  for (int i = 0; i <= 100; ++i) {
    const double t = i * 0.01;
    const double qx = ((a.x() * t + b.x()) * t + c.x()) * t + d.x();
    const double qy = ((a.y() * t + b.y()) * t + c.y()) * t + d.y();
    const int x = static_cast<int>(qx + 0.5);
    const int y = static_cast<int>(qy + 0.5);
    if ((x == last_x && y == last_y) || y >= image.rows || x >= image.cols) continue;
    last_x = x;
    last_y = y;
    const float* row = image.ptr<float>(y);
    int lo = std::max(0, x - options.jitter_px);
    int hi = std::min(image.cols - 1, x + options.jitter_px);
    if (window.first) {
      const double wc = w_x0 + w_slope * y;
      lo = std::max(lo, static_cast<int>(wc - w_half + 0.999999));   // ceil for wc - half > -1
      hi = std::min(hi, static_cast<int>(wc + w_half));                // floor, wc + half >= 0
    }
    for (int xx = lo; xx <= hi; ++xx) raw += row[xx];
  }
  if (raw <= 0) return 0.0;
  // Length from a 20-segment polyline (within 0.1 % for these curves).
  double length = 0;
  Eigen::Vector2d prev = d;
  for (int i = 1; i <= 20; ++i) {
    const double t = i * 0.05;
    const Eigen::Vector2d q = ((a * t + b) * t + c) * t + d;
    length += (q - prev).norm();
    prev = q;
  }
  const double l_norm = length / image.rows - 1.0;                // paper's l'
  const double theta_norm = (spline.Straightness() - 1.0) / 2.0;  // paper's theta'
  return raw * (1.0 + options.k1 * l_norm + options.k2 * theta_norm);
}

std::optional<SplineFit> FitSplineAroundLine(const cv::Mat& thresholded, const IpmLine& line,
                                             double half_width_px,
                                             const SplineRansacOptions& options,
                                             std::mt19937_64& rng) {
  const WeightedPoints pts = CollectWindow(
      thresholded, [&line](double y) { return line.XAt(y); }, half_width_px);
  // Only the window's pixels count towards the score.
  const SplineEstimator estimator(thresholded, options, {&line, half_width_px});
  const Bezier initial = Bezier::Line(line.top, line.bottom);
  const auto report = Ransac(estimator, pts.points, pts.weights, options.iterations, rng, initial);
  if (!report.model || !(report.score > 0)) return std::nullopt;
  return SplineFit{*report.model, report.score};
}

}  // namespace lane
