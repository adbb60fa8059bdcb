#include "lane/stages/spline_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "absl/strings/str_cat.h"
#include "lane/base/four_sums.h"
#include "lane/stages/ransac.h"

namespace lane {
namespace {

// The raw-score lookups of one window: per row, the columns inside the
// window (lo..hi) and their prefix sums, so that the sum over a sample's
// jitter columns is one subtraction. Built once per line, used by every
// RANSAC trial.
class WindowedRaster {
 public:
  WindowedRaster(const cv::Mat& image, const IpmLine* line, double half, int jitter)
      : cols_(image.cols), jitter_(jitter), rows_(image.rows) {
    size_t total = 0;
    for (int y = 0; y < image.rows; ++y) {
      int lo = 0, hi = image.cols - 1;
      if (line) {
        const double c = line->XAt(y);
        lo = std::max(lo, static_cast<int>(std::ceil(c - half)));
        hi = std::min(hi, static_cast<int>(std::floor(c + half)));
      }
      rows_[y] = {lo, hi, total};
      total += 1 + static_cast<size_t>(std::max(0, hi - lo + 1));
    }
    prefix_.reset(new double[total]);  // every element is written below
    for (int y = 0; y < image.rows; ++y) {
      const Row& r = rows_[y];
      const float* row = image.ptr<float>(y);
      double* p = prefix_.get() + r.start;
      double acc = 0;
      *p = 0;
      // Most of a thresholded window is 0, and acc + 0 == acc: adding only
      // the others keeps the sums and shortens the chain of dependent
      // additions to the non-zero pixels.
      for (int x = r.lo; x <= r.hi; ++x) {
        const float v = row[x];
        if (v != 0.f) acc += v;
        *++p = acc;
      }
    }
  }

  int rows() const { return static_cast<int>(rows_.size()); }
  int cols() const { return cols_; }

  // Sum of the window's pixels in columns x - jitter .. x + jitter of row y.
  double Sum(int x, int y) const {
    const Row& r = rows_[y];
    const int a = std::max(r.lo, x - jitter_);
    const int b = std::min(r.hi, x + jitter_);
    if (a > b) return 0.0;
    const double* p = prefix_.get() + r.start;
    return p[b - r.lo + 1] - p[a - r.lo];
  }

 private:
  struct Row {
    int lo, hi;    // the window's columns in this row
    size_t start;  // its prefix sums in prefix_
  };
  int cols_;
  int jitter_;
  std::vector<Row> rows_;
  std::unique_ptr<double[]> prefix_;
};

// The curve in power form, Q(t) = ((a t + b) t + c) t + d, for Horner
// evaluation in the hot loops (once per RANSAC trial).
struct PowerForm {
  explicit PowerForm(const Bezier& s)
      : a(-s.p[0] + 3 * s.p[1] - 3 * s.p[2] + s.p[3]),
        b(3 * s.p[0] - 6 * s.p[1] + 3 * s.p[2]),
        c(-3 * s.p[0] + 3 * s.p[1]),
        d(s.p[0]) {}
  Eigen::Vector2d a, b, c, d;
};

// The score's raster of the curve: its pixels at t = 0, 0.01, .., 1,
// rounded half up (coordinates >= 0; truncated towards 0 below), in a loop
// without dependencies (it vectorises).
constexpr int kRasterSteps = 101;
void RasterizeCurve(const PowerForm& f, int* xs, int* ys) {
  const double ax = f.a.x(), bx = f.b.x(), cx = f.c.x(), dx = f.d.x();
  const double ay = f.a.y(), by = f.b.y(), cy = f.c.y(), dy = f.d.y();
  for (int i = 0; i < kRasterSteps; ++i) {
    const double t = i * 0.01;
    xs[i] = static_cast<int>(((ax * t + bx) * t + cx) * t + dx + 0.5);
    ys[i] = static_cast<int>(((ay * t + by) * t + cy) * t + dy + 0.5);
  }
}

double ScoreOnRaster(const Bezier& spline, const WindowedRaster& raster,
                     const SplineRansacOptions& options) {
  for (const auto& p : spline.p) {
    if (!(p.x() >= 0 && p.y() >= 0 && p.x() <= raster.cols() - 1 && p.y() <= raster.rows() - 1)) {
      return 0.0;  // a control point outside the image disqualifies the spline
    }
  }
  const PowerForm f(spline);
  const Eigen::Vector2d &a = f.a, &b = f.b, &c = f.c, &d = f.d;
  // Each pixel counts once, with the jitter columns either side. All
  // control points are inside the image, so the curve (inside their convex
  // hull) is too and coordinates are >= 0. The pixels first, then the sum
  // in order.
  int xs[kRasterSteps], ys[kRasterSteps];
  RasterizeCurve(f, xs, ys);
  // The pixels' sums (0 for a pixel repeated or outside), then their total
  // in four partial sums (four_sums.h; thresholded float pixels, so the
  // order does not change the score).
  double values[kRasterSteps];
  int last_x = -1, last_y = -1;
  for (int i = 0; i < kRasterSteps; ++i) {
    const int x = xs[i], y = ys[i];
    values[i] = 0.0;
    if ((x == last_x && y == last_y) || y >= raster.rows() || x >= raster.cols()) continue;
    last_x = x;
    last_y = y;
    values[i] = raster.Sum(x, y);
  }
  const double raw =
      internal::SumInFourParts(kRasterSteps, [&values](size_t i) { return values[i]; });
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
  const double l_norm = length / raster.rows() - 1.0;             // paper's l'
  const double theta_norm = (spline.Straightness() - 1.0) / 2.0;  // paper's theta'
  return raw * (1.0 + options.k1 * l_norm + options.k2 * theta_norm);
}

// RANSAC estimator: 4 weighted samples sorted by row, least-squares Bezier
// with chord-length t, scored by the paper's rasterised score.
class SplineEstimator {
 public:
  using Model = Bezier;
  static constexpr int kSampleSize = 4;

  SplineEstimator(const WindowedRaster& raster, const WeightedPoints& pts,
                  const SplineRansacOptions& options)
      : raster_(raster), pts_(pts), options_(options) {
    for (double w : pts.weights) total_weight_ += w;
  }

  std::optional<Bezier> Estimate(const std::vector<Eigen::Vector2d>& sample) const {
    sorted_ = sample;
    std::sort(sorted_.begin(), sorted_.end(),
              [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.y() < b.y(); });
    return FitBezier(sorted_);
  }

  double Score(const Bezier& spline) const { return ScoreOnRaster(spline, raster_, options_); }

  // The adaptive stop's support: the weight of the window's pixels within
  // jitter_px columns of the curve rasterised as the score rasterises it
  // (per row, between the leftmost and rightmost curve pixel), over the
  // window's weight.
  double SupportFraction(const Bezier& spline) const {
    if (!(total_weight_ > 0)) return 0.0;
    const int rows = raster_.rows();
    row_lo_.assign(rows, std::numeric_limits<int>::max());
    row_hi_.assign(rows, std::numeric_limits<int>::min());
    int xs[kRasterSteps], ys[kRasterSteps];
    RasterizeCurve(PowerForm(spline), xs, ys);
    for (int i = 0; i < kRasterSteps; ++i) {
      const int x = xs[i], y = ys[i];
      if (y < 0 || y >= rows) continue;
      row_lo_[y] = std::min(row_lo_[y], x);
      row_hi_[y] = std::max(row_hi_[y], x);
    }
    const int j = options_.jitter_px;
    double support = 0;
    for (size_t i = 0; i < pts_.points.size(); ++i) {
      const int x = static_cast<int>(pts_.points[i].x());
      const int y = static_cast<int>(pts_.points[i].y());
      if (y >= 0 && y < rows && x >= row_lo_[y] - j && x <= row_hi_[y] + j) {
        support += pts_.weights[i];
      }
    }
    return support / total_weight_;
  }

 private:
  const WindowedRaster& raster_;
  const WeightedPoints& pts_;
  const SplineRansacOptions& options_;
  double total_weight_ = 0;
  mutable std::vector<int> row_lo_, row_hi_;     // scratch of SupportFraction
  mutable std::vector<Eigen::Vector2d> sorted_;  // scratch, reused across trials
};

}  // namespace

absl::Status SplineRansacOptions::Validate() const {
  if (!(window_half_width_m > 0 && window_half_width_m < 20)) {
    return absl::InvalidArgumentError(
        "spline_ransac.window_half_width_m must lie in (0, 20) metres");
  }
  if (absl::Status s = ransac.Validate("spline_ransac"); !s.ok()) return s;
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
  return ScoreOnRaster(
      spline, WindowedRaster(image, window.first, window.second, options.jitter_px), options);
}

std::optional<SplineFit> FitSplineAroundLine(const cv::Mat& thresholded, const IpmLine& line,
                                             double half_width_px,
                                             const SplineRansacOptions& options,
                                             std::mt19937_64& rng) {
  const WeightedPoints pts = CollectWindow(
      thresholded, [&line](double y) { return line.XAt(y); }, half_width_px);
  // Only the window's pixels count towards the score.
  const WindowedRaster raster(thresholded, &line, half_width_px, options.jitter_px);
  const SplineEstimator estimator(raster, pts, options);
  const Bezier initial = Bezier::Line(line.top, line.bottom);
  const auto report = Ransac(estimator, pts.points, pts.weights, options.ransac, rng, initial);
  if (!report.model || !(report.score > 0)) return std::nullopt;
  return SplineFit{*report.model, report.score, report.trials};
}

}  // namespace lane
