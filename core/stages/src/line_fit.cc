#include "lane/stages/line_fit.h"

#include <cmath>
#include <cstdint>

#include "absl/strings/str_cat.h"
#include "lane/base/double_pair.h"
#include "lane/geometry/bezier.h"
#include "lane/stages/ransac.h"

namespace lane {

std::optional<IpmLine> MakeIpmLine(const Eigen::Vector2d& point, const Eigen::Vector2d& dir,
                                   int rows) {
  if (std::abs(dir.y()) < 1e-9) return std::nullopt;  // horizontal
  const double dxdy = dir.x() / dir.y();
  IpmLine line;
  line.top = {point.x() + (0 - point.y()) * dxdy, 0.0};
  line.bottom = {point.x() + (rows - 1 - point.y()) * dxdy, rows - 1.0};
  return line;
}

namespace {

double AngleFromVerticalDeg(const IpmLine& line) {
  return lane::AngleFromVerticalDeg(line.bottom - line.top);
}

// The line through `top` with unit normal n: distance |n . p - n . top|.
struct NormalForm {
  explicit NormalForm(const IpmLine& line) {
    const Eigen::Vector2d d = (line.bottom - line.top).normalized();
    n = Eigen::Vector2d(d.y(), -d.x());
    offset = n.dot(line.top);
  }
  double Distance(const Eigen::Vector2d& p) const { return std::abs(n.dot(p) - offset); }
  Eigen::Vector2d n;
  double offset = 0;
};

// RANSAC estimator: 4 weighted samples, total least squares, scored by the
// sum of the responses of the pixels within the inlier distance.
class LineEstimator {
 public:
  using Model = IpmLine;
  static constexpr int kSampleSize = 4;

  LineEstimator(const WeightedPoints& pts, int rows, const LineRansacOptions& options)
      : pts_(pts), rows_(rows), options_(options) {
    xs_.reserve(pts.points.size());
    ys_.reserve(pts.points.size());
    for (const Eigen::Vector2d& p : pts.points) {
      xs_.push_back(p.x());
      ys_.push_back(p.y());
    }
    for (double w : pts.weights) total_weight_ += w;
  }

  std::optional<IpmLine> Estimate(const std::vector<Eigen::Vector2d>& sample) const {
    const auto fit = FitLineTls(sample, {});
    if (!fit) return std::nullopt;
    auto line = MakeIpmLine(fit->first, fit->second, rows_);
    if (!line || AngleFromVerticalDeg(*line) > options_.max_angle_from_vertical_deg) {
      return std::nullopt;
    }
    return line;
  }

  // Branch-free over the points' coordinates as separate arrays (whether a
  // point is an inlier is a coin toss for the branch predictor), adding an
  // exact 0 for outliers, in four partial sums (four_sums.h: the weights
  // are thresholded float pixels, so the order does not change the score;
  // the lanes of cordova1 and driver161 are byte-identical to the one-sum
  // loop's). Two points at a time in vector pairs (double_pair.h):
  // the pairs (s0, s1) and (s2, s3) hold the four sums exactly as
  // SumInFourParts adds them, term k into sum k % 4, the tail into s0.
  double Score(const IpmLine& line) const {
    const NormalForm normal(line);
    const double tol = options_.inlier_distance_px;
    const double nx = normal.n.x(), ny = normal.n.y(), offset = normal.offset;
    const double* x = xs_.data();
    const double* y = ys_.data();
    const double* w = pts_.weights.data();
    const auto term = [&](size_t i) {
      return std::abs(nx * x[i] + ny * y[i] - offset) <= tol ? w[i] : 0.0;
    };
    using internal::DoublePair;
    using internal::LoadPair;
    using internal::MaskPair;
    const DoublePair vnx = {nx, nx}, vny = {ny, ny}, voff = {offset, offset}, vtol = {tol, tol};
    const MaskPair no_sign = {INT64_MAX, INT64_MAX};
    const auto terms = [&](size_t i) {  // term(i), term(i + 1)
      const DoublePair d = vnx * LoadPair(x + i) + vny * LoadPair(y + i) - voff;
      const DoublePair dist = reinterpret_cast<DoublePair>(reinterpret_cast<MaskPair>(d) & no_sign);
      return reinterpret_cast<DoublePair>(reinterpret_cast<MaskPair>(LoadPair(w + i)) &
                                          (dist <= vtol));
    };
    const size_t n = xs_.size();
    DoublePair s01 = {0, 0}, s23 = {0, 0};
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
      s01 += terms(i);
      s23 += terms(i + 2);
    }
    double s0 = s01[0];
    for (; i < n; ++i) s0 += term(i);
    return (s0 + s01[1]) + (s23[0] + s23[1]);
  }

  // The inliers the refit uses. The same test as Score's, computed as
  // IpmLine::Distance: the two forms differ only in rounding, for points
  // exactly at the tolerance (which pixel centres often are, for lines fitted
  // through pixel centres). Kept as the refit always had it, so that moving
  // the mask into the RANSAC report left the output byte-identical (one form
  // for both changes 1-6 % of frames, at such ties).
  bool IsInlier(const IpmLine& line, size_t i) const {
    return line.Distance(pts_.points[i]) <= options_.inlier_distance_px;
  }

  // The adaptive stop's support: the score is the inliers' weight.
  double SupportFraction(const IpmLine& line) const {
    return total_weight_ > 0 ? Score(line) / total_weight_ : 0.0;
  }

 private:
  const WeightedPoints& pts_;
  int rows_;
  const LineRansacOptions& options_;
  std::vector<double> xs_, ys_;
  double total_weight_ = 0;
};

}  // namespace

absl::Status LineRansacOptions::Validate() const {
  if (!(window_half_width_m > 0 && window_half_width_m < 20)) {
    return absl::InvalidArgumentError("line_ransac.window_half_width_m must lie in (0, 20) metres");
  }
  if (absl::Status s = ransac.Validate("line_ransac"); !s.ok()) return s;
  if (ransac.iterations < 1) {
    return absl::InvalidArgumentError("line_ransac.iterations must be at least 1");
  }
  if (!(inlier_distance_px > 0 && inlier_distance_px < 20)) {
    return absl::InvalidArgumentError("line_ransac.inlier_distance_px must lie in (0, 20)");
  }
  if (min_inliers < 2) return absl::InvalidArgumentError("line_ransac.min_inliers must be >= 2");
  if (!(max_angle_from_vertical_deg > 0 && max_angle_from_vertical_deg <= 90)) {
    return absl::InvalidArgumentError(
        "line_ransac.max_angle_from_vertical_deg must lie in (0, 90]");
  }
  return absl::OkStatus();
}

double IpmLine::Distance(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d d = (bottom - top).normalized();
  const Eigen::Vector2d v = p - top;
  return std::abs(v.x() * d.y() - v.y() * d.x());
}

double IpmLine::XAt(double y) const {
  const double dy = bottom.y() - top.y();
  if (std::abs(dy) < 1e-12) return top.x();
  return top.x() + (y - top.y()) * (bottom.x() - top.x()) / dy;
}

std::optional<std::pair<Eigen::Vector2d, Eigen::Vector2d>> FitLineTls(
    const std::vector<Eigen::Vector2d>& points, const std::vector<double>& weights) {
  if (points.size() < 2) return std::nullopt;
  double wsum = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < points.size(); ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    mean += w * points[i];
    wsum += w;
  }
  if (!(wsum > 0)) return std::nullopt;
  mean /= wsum;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < points.size(); ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    const Eigen::Vector2d d = points[i] - mean;
    cov += w * d * d.transpose();
  }
  // Principal axis of the 2x2 scatter matrix in closed form.
  const double cxx = cov(0, 0), cyy = cov(1, 1), cxy = cov(0, 1);
  const double spread = std::hypot(cxx - cyy, 2 * cxy);
  if (!(cxx + cyy + spread > 1e-12)) return std::nullopt;  // all points equal
  const double angle = 0.5 * std::atan2(2 * cxy, cxx - cyy);
  Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
  if (dir.y() < 0) dir = -dir;
  return std::make_pair(mean, dir);
}

namespace {

// RANSAC line among the points of a window, refitted on its inliers.
std::optional<IpmLine> FitLineAmong(const cv::Mat& thresholded, const WeightedPoints& pts,
                                    const LineRansacOptions& options, std::mt19937_64& rng) {
  if (static_cast<int>(pts.points.size()) < options.min_inliers) return std::nullopt;
  const LineEstimator estimator(pts, thresholded.rows, options);
  const auto report = Ransac(estimator, pts.points, pts.weights, options.ransac, rng);
  if (!report.model) return std::nullopt;

  // Refit on the inliers the score counted, weighted by their response.
  WeightedPoints inliers;
  for (size_t i = 0; i < pts.points.size(); ++i) {
    if (report.inlier_mask[i]) {
      inliers.points.push_back(pts.points[i]);
      inliers.weights.push_back(pts.weights[i]);
    }
  }
  if (static_cast<int>(inliers.points.size()) < options.min_inliers) return std::nullopt;
  IpmLine line = *report.model;
  if (const auto fit = FitLineTls(inliers.points, inliers.weights)) {
    if (auto refined = MakeIpmLine(fit->first, fit->second, thresholded.rows)) line = *refined;
  }
  if (AngleFromVerticalDeg(line) > options.max_angle_from_vertical_deg) return std::nullopt;
  line.score = estimator.Score(line);
  return line;
}

}  // namespace

std::optional<IpmLine> FitLineInWindow(const cv::Mat& thresholded, double x_center,
                                       double half_width_px, const LineRansacOptions& options,
                                       std::mt19937_64& rng) {
  const WeightedPoints pts = CollectWindow(
      thresholded, [x_center](double) { return x_center; }, half_width_px);
  return FitLineAmong(thresholded, pts, options, rng);
}

std::optional<IpmLine> FitLineAlong(const cv::Mat& thresholded, const IpmLine& center,
                                    double half_width_px, const LineRansacOptions& options,
                                    std::mt19937_64& rng) {
  const WeightedPoints pts = CollectWindow(
      thresholded, [&center](double y) { return center.XAt(y); }, half_width_px);
  return FitLineAmong(thresholded, pts, options, rng);
}

}  // namespace lane
