// Stage 2: separable Gaussian filtering of the top view (paper section II-B).
#ifndef LANE_FILTER_H_
#define LANE_FILTER_H_

#include <opencv2/core.hpp>

#include "absl/status/status.h"

namespace lane {

struct FilterOptions {
  // sigma_x of the second-derivative-of-Gaussian across the lane, metres. The
  // paper sets it to the expected marking width: 3 inches.
  double marking_width_m = 0.0762;
  // sigma_y of the smoothing Gaussian along the lane, metres. The paper sets
  // it to the height of the lane segment to detect: 1 m.
  double segment_length_m = 1.0;
  // Lower bounds on the sigmas in IPM pixels. A sigma below ~0.7 px samples
  // the kernel so coarsely that it stops being a second derivative.
  double min_sigma_x_px = 0.8;
  double min_sigma_y_px = 1.0;
  // Kernel half width in sigmas.
  double kernel_extent_sigmas = 3.0;
  // After filtering, responses this close to the left/right edges and to the
  // bottom of the top view are zeroed (reference: 10 and 2 IPM px): the edges
  // of the ROI produce strong spurious responses.
  int zero_border_x_px = 10;
  int zero_border_bottom_px = 2;

  absl::Status Validate() const;
};

// Kernels for cv::sepFilter2D, CV_32F column vectors.
struct FilterKernels {
  cv::Mat kx;  // across the lane: negated 2nd derivative, zero mean, positive taps sum to 1
  cv::Mat ky;  // along the lane: Gaussian, sums to 1
  double sigma_x_px = 0;
  double sigma_y_px = 0;
};

// Sigmas come from metres through the IPM scale (metres per IPM pixel).
FilterKernels MakeFilterKernels(const FilterOptions& options, double metres_per_px_x,
                                double metres_per_px_y);

// Filters a CV_32F top view whose mean has been removed (IpmMapping::Apply
// output minus its mean). Bright vertical bars of the marking width give
// positive responses. Borders are replicated, then zeroed as in the options.
cv::Mat FilterTopView(const cv::Mat& ipm, const FilterKernels& kernels,
                      const FilterOptions& options);

}  // namespace lane

#endif  // LANE_FILTER_H_
