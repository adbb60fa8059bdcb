// Stage 3: quantile threshold (paper section II-B). Values are kept, not
// binarised.
#ifndef LANE_THRESHOLD_H_
#define LANE_THRESHOLD_H_

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"

namespace lane {

struct ThresholdOptions {
  // Quantile of the (non-negative) filter response below which everything is
  // zeroed. Paper: 97.5 %; reference 2-lanes mode: 98.5 %. Here 97 % in both
  // modes: the transverse rows below are zeroed after the threshold, and the
  // lower quantile gives their share back to the markings (camera-only
  // configs, 5 seeds: cordova1 CULane F1 0.748 -> 0.752, FP rate 4.5 -> 5.5 %
  // at 90.8 -> 92.5 % correct; 2-lanes 96.8 % / 2.2 % -> 97.5 % / 1.1 %;
  // driver161-a F1 0.447 -> 0.463; docs/accuracy-log.md).
  double quantile = 0.97;
  // Transverse structures (not in the paper): crosswalks, stop lines and the
  // horizontal edges of vehicles (bumpers, rear windows, the shadow under a
  // car) fill whole rows of the top view with kept pixels. Lane markings run
  // along the road, at most one per lane width: a 15 cm marking keeps about
  // 0.25 m of a row per 3.5 m lane, 7 %. Rows whose kept pixels exceed this
  // fraction of the searched width (the valid top view; in 2-lanes mode the
  // band searched) are zeroed, with `transverse_margin_m` of rows either
  // side along the road (the filter smooths over +-1 m). 0.1: above the
  // markings' 7 %, far below a crosswalk's 30-50 %. >= 1 disables it.
  double transverse_max_fraction = 0.1;
  double transverse_margin_m = 1.0;

  absl::Status Validate() const;
};

// Linearly interpolated q-quantile of `values` (reorders them). q in [0, 1].
float Quantile(std::vector<float>& values, double q);

// In place on a CV_32F image: negatives -> 0, then everything below the
// q-quantile of all pixels -> 0. Returns the threshold used.
float ApplyQuantileThreshold(cv::Mat& image, double q);
// The same into `out` (allocated as `in`, unless it is `in`), leaving `in`
// as it is: no copy of `in` first.
float ApplyQuantileThreshold(const cv::Mat& in, cv::Mat& out, double q);

// The transverse rows of ThresholdOptions::transverse_max_fraction: zeroes
// rows of the thresholded `image` (and `margin_rows` either side) where the
// fraction of non-zero pixels over the row's valid pixels (`valid`, CV_8U)
// exceeds `max_fraction`. Returns the number of rows found.
int SuppressTransverseRows(cv::Mat& image, const cv::Mat& valid, double max_fraction,
                           int margin_rows);

}  // namespace lane

#endif  // LANE_THRESHOLD_H_
