// Stage 4: simplified Hough transform by column sums (paper section II-C).
#ifndef LANE_LINE_DETECTION_H_
#define LANE_LINE_DETECTION_H_

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"

namespace lane {

struct HoughOptions {
  // Gaussian smoothing of the column sums, IPM pixels (sigma).
  double smooth_sigma_px = 1.0;
  // A peak must reach this mean response per IPM row (column sum / height).
  // The unit is that of the thresholded filter response (IPM intensities in
  // [0, 1]). Tuned on synthetic frames; see README.
  double min_peak = 0.004;
  // Peaks closer than this are grouped into one line, metres across the road
  // (reference: 10 IPM px at 8.9 px/m).
  double group_distance_m = 1.1;

  absl::Status Validate() const;
};

struct ColumnPeak {
  double x = 0;      // sub-pixel column, IPM pixels
  double value = 0;  // smoothed column sum / IPM height
};

// Smoothed column sums of a CV_32F image, divided by its height.
std::vector<double> ColumnProfile(const cv::Mat& thresholded, double smooth_sigma_px);

// Local maxima (strictly above both neighbours, >= min_peak) with parabola
// sub-pixel refinement, then grouping: of peaks closer than group_px, the
// stronger survives. If no local maximum passes, the global maximum is used
// when it passes. Sorted by x.
std::vector<ColumnPeak> FindColumnPeaks(const std::vector<double>& profile, double min_peak,
                                        double group_px);

}  // namespace lane

#endif  // LANE_LINE_DETECTION_H_
