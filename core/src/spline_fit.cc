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

  SplineEstimator(const cv::Mat& image, const SplineRansacOptions& options)
      : image_(image), options_(options) {}

  std::optional<Bezier> Estimate(std::vector<Eigen::Vector2d> sample) const {
    std::sort(sample.begin(), sample.end(),
              [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.y() < b.y(); });
    return FitBezier(sample);
  }

  double Score(const Bezier& spline) const { return SplineScore(spline, image_, options_); }

 private:
  const cv::Mat& image_;
  const SplineRansacOptions& options_;
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

double SplineScore(const Bezier& spline, const cv::Mat& image, const SplineRansacOptions& options) {
  for (const auto& p : spline.p) {
    if (!InsideImage(p, image)) return 0.0;
  }
  // Raster the curve at dt = 0.01; each pixel counts once, with the jitter
  // columns either side.
  double raw = 0;
  int last_x = -1, last_y = -1;
  std::vector<Eigen::Vector2d> samples;
  samples.reserve(101);
  for (int i = 0; i <= 100; ++i) {
    const Eigen::Vector2d q = spline.Eval(i / 100.0);
    samples.push_back(q);
    const int x = static_cast<int>(std::lround(q.x()));
    const int y = static_cast<int>(std::lround(q.y()));
    if (x == last_x && y == last_y) continue;
    last_x = x;
    last_y = y;
    if (y < 0 || y >= image.rows) continue;
    const float* row = image.ptr<float>(y);
    for (int j = -options.jitter_px; j <= options.jitter_px; ++j) {
      const int xx = x + j;
      if (xx >= 0 && xx < image.cols) raw += row[xx];
    }
  }
  double length = 0;
  for (size_t i = 1; i < samples.size(); ++i) length += (samples[i] - samples[i - 1]).norm();
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
  cv::Mat window = cv::Mat::zeros(thresholded.size(), CV_32F);
  for (size_t i = 0; i < pts.points.size(); ++i) {
    window.at<float>(static_cast<int>(pts.points[i].y()), static_cast<int>(pts.points[i].x())) =
        static_cast<float>(pts.weights[i]);
  }
  const SplineEstimator estimator(window, options);
  const Bezier initial = Bezier::Line(line.top, line.bottom);
  const auto report = Ransac(estimator, pts.points, pts.weights, options.iterations, rng, initial);
  if (!report.model || !(report.score > 0)) return std::nullopt;
  return SplineFit{*report.model, report.score};
}

}  // namespace lane
