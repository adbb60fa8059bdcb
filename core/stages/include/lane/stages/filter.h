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
  // Bar check (not in the paper): the second-derivative filter also answers
  // beside a step (a curb, the edge of a vehicle, a shadow's border), on its
  // bright side. A marking is a bar: brighter than the road on BOTH sides.
  // With a side distance > 0 (metres), a response is kept only where the top
  // view, averaged over +-segment_length_m along the road, is brighter at the
  // pixel than at +-side distance across on both sides. 0.15 m: one marking
  // width (10-15 cm) from its centre lies road on both sides of a marking
  // up to 30 cm wide (double lines are two bars). At least one pixel.
  double bar_side_m = 0.0;
  // Void: top-view pixels without image content, i.e. outside the image or
  // the ROI, or black (at most `void_level` of 255: outside a lens's image
  // circle, as in the Caltech Lanes frames). They are set to the mean of the
  // rest before filtering, and responses within the kernel's half width
  // (across) and `void_margin_y_px` rows (along) of them are zeroed: the
  // border between image and void is a step the filter answers. Negative
  // void_level (the default): no void handling, only responses outside the
  // ROI are zeroed, as in the reference. Measured on the two dev clips
  // (docs/accuracy-log.md), masking the border cost more markings near the
  // ROI's slanted sides than it removed false positives, so it is off.
  double void_level = -1.0;
  int void_margin_y_px = 2;

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

// The void of a top view (FilterOptions::void_level): CV_8U, 255 where
// `ipm` (values in [0, 1], before the mean is removed) has no image content.
cv::Mat VoidMask(const cv::Mat& ipm, const cv::Mat& invalid, double void_level);
// `void_mask` grown by `half_x` columns and `half_y` rows either way.
cv::Mat GrowMask(const cv::Mat& void_mask, int half_x, int half_y);

// The bar check of FilterOptions::bar_side_m on `response` (same size as
// `ipm`): zeroes responses where the top view is not brighter than both
// sides `side_px` away, after averaging `along_px` rows either way.
void SuppressSteps(const cv::Mat& ipm, cv::Mat& response, double side_px, int along_px);

}  // namespace lane

#endif  // LANE_FILTER_H_
