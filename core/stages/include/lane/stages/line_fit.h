// Stage 5: RANSAC line fitting around each column peak (paper section II-C).
#ifndef LANE_LINE_FIT_H_
#define LANE_LINE_FIT_H_

#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "lane/stages/ransac.h"

namespace lane {

struct LineRansacOptions {
  // Half width of the window around each Hough line, metres across the road
  // (reference: 15 IPM px all-lanes, 8 px 2-lanes, at 8.9 px/m).
  double window_half_width_m = 1.7;
  // The trials and the adaptive stop (ransac.h): at most 40 trials, ending
  // after max(min_iterations, N), N = log(1 - confidence) / log(1 - e^4)
  // for the best line's inlier share e of the window's weight. Config keys
  // line_ransac.iterations, .confidence, .min_iterations.
  RansacOptions ransac{40, 0.999, 5};
  // Distance from the line within which a pixel is an inlier, IPM pixels.
  // The reference uses 0.2 px; on a pixel grid that only keeps pixels whose
  // centres the line crosses, so we use 0.5 px (one pixel-wide band).
  double inlier_distance_px = 0.5;
  // Fewer inliers than this and the window yields no line.
  int min_inliers = 10;
  // Lines further than this from vertical in the top view are dropped, deg.
  double max_angle_from_vertical_deg = 20.0;

  absl::Status Validate() const;
};

// A line in the top view through two points; `top` lies on row 0 and
// `bottom` on the last row of the IPM.
struct IpmLine {
  Eigen::Vector2d top;
  Eigen::Vector2d bottom;
  double score = 0;  // sum of inlier responses
  // Unit direction (top - bottom normalised) and distance of a point from it.
  double Distance(const Eigen::Vector2d& p) const;
  // x of the line at row y.
  double XAt(double y) const;
};

// The line through `point` along `dir` (any length), clipped to rows 0 and
// rows - 1 of a top view; none when it runs horizontally.
std::optional<IpmLine> MakeIpmLine(const Eigen::Vector2d& point, const Eigen::Vector2d& dir,
                                   int rows);

// Non-zero pixels of a CV_32F image within |x - center(y)| <= half_width,
// with their values as weights. center_at maps a row to a column.
struct WeightedPoints {
  std::vector<Eigen::Vector2d> points;
  std::vector<double> weights;
};
template <typename CenterFn>
WeightedPoints CollectWindow(const cv::Mat& image, CenterFn center_at, double half_width) {
  WeightedPoints out;
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    const double c = center_at(static_cast<double>(y));
    const int x0 = std::max(0, static_cast<int>(std::ceil(c - half_width)));
    const int x1 = std::min(image.cols - 1, static_cast<int>(std::floor(c + half_width)));
    const auto take = [&](int x) {
      if (row[x] > 0) {
        out.points.emplace_back(x, y);
        out.weights.push_back(row[x]);
      }
    };
    // A thresholded window is mostly +0 (all bits clear): four pixels at a
    // time are skipped when their bits are; the others are tested one by
    // one, as every pixel would be.
    int x = x0;
    for (; x + 3 <= x1; x += 4) {
      uint64_t a, b;
      std::memcpy(&a, row + x, sizeof a);
      std::memcpy(&b, row + x + 2, sizeof b);
      if ((a | b) == 0) continue;
      for (int k = x; k < x + 4; ++k) take(k);
    }
    for (; x <= x1; ++x) take(x);
  }
  return out;
}

// Weighted total-least-squares line through points (weights may be empty =
// all 1). Returns (centroid, unit direction), or nullopt if degenerate.
std::optional<std::pair<Eigen::Vector2d, Eigen::Vector2d>> FitLineTls(
    const std::vector<Eigen::Vector2d>& points, const std::vector<double>& weights);

// RANSAC line in the window around column `x_center`. nullopt when the window
// has too few inliers or the line is too far from vertical.
std::optional<IpmLine> FitLineInWindow(const cv::Mat& thresholded, double x_center,
                                       double half_width_px, const LineRansacOptions& options,
                                       std::mt19937_64& rng);
// The same in the window around a slanted line (a tracker's prediction,
// DetectionPrior): the window follows `center` row by row.
std::optional<IpmLine> FitLineAlong(const cv::Mat& thresholded, const IpmLine& center,
                                    double half_width_px, const LineRansacOptions& options,
                                    std::mt19937_64& rng);

}  // namespace lane

#endif  // LANE_LINE_FIT_H_
