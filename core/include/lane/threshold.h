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
  // zeroed. Paper: 97.5 %. Reference 2-lanes mode: 98.5 %.
  double quantile = 0.975;

  absl::Status Validate() const;
};

// Linearly interpolated q-quantile of `values` (reorders them). q in [0, 1].
float Quantile(std::vector<float>& values, double q);

// In place on a CV_32F image: negatives -> 0, then everything below the
// q-quantile of all pixels -> 0. Returns the threshold used.
float ApplyQuantileThreshold(cv::Mat& image, double q);

}  // namespace lane

#endif  // LANE_THRESHOLD_H_
