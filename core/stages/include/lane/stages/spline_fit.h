// Stage 6: RANSAC cubic Bezier fitting (paper section II-D, Algorithm 1).
#ifndef LANE_SPLINE_FIT_H_
#define LANE_SPLINE_FIT_H_

#include <opencv2/core.hpp>
#include <optional>
#include <random>

#include "absl/status/status.h"
#include "lane/geometry/bezier.h"
#include "lane/stages/line_fit.h"
#include "lane/stages/ransac.h"

namespace lane {

struct SplineRansacOptions {
  // Half width of the window around each RANSAC line, metres across the road
  // (reference: 10 IPM px all-lanes, 6 px 2-lanes, at 8.9 px/m).
  double window_half_width_m = 1.1;
  // The trials and the adaptive stop (ransac.h): at most 40 trials, ending
  // after max(min_iterations, N), as LineRansacOptions'; a window pixel
  // supports a spline when it lies within jitter_px columns of the
  // rasterised curve. 0 iterations: only the line's own spline is scored.
  RansacOptions ransac{40, 0.999, 5};
  // Score = raw * (1 + k1 * l' + k2 * theta') (paper). k1 weighs length,
  // k2 straightness.
  double k1 = 1.5;
  double k2 = 1.2;
  // The raw score also sums the pixels this many columns either side of the
  // rasterised curve (reference: 2), so a curve one pixel off still scores.
  int jitter_px = 2;
  // Two splines whose sampled curves stay within this distance everywhere are
  // duplicates: the straighter one is kept. IPM pixels.
  double merge_distance_px = 4.0;

  absl::Status Validate() const;
};

// The paper's spline score on a CV_32F thresholded top view. Returns 0 for a
// spline with a control point outside the image. When `window` is given,
// only pixels within window->second columns of the line window->first count.
double SplineScore(const Bezier& spline, const cv::Mat& thresholded,
                   const SplineRansacOptions& options,
                   const std::pair<const IpmLine*, double>& window = {nullptr, 0.0});

struct SplineFit {
  Bezier spline;
  double score = 0;
  int trials = 0;  // RANSAC trials run (fewer than `iterations` after an adaptive stop)
};

// RANSAC spline in the window around `line`, seeded with the line itself.
std::optional<SplineFit> FitSplineAroundLine(const cv::Mat& thresholded, const IpmLine& line,
                                             double half_width_px,
                                             const SplineRansacOptions& options,
                                             std::mt19937_64& rng);

}  // namespace lane

#endif  // LANE_SPLINE_FIT_H_
