// 2-lanes mode (the ego lane's two boundaries): the band of top-view columns
// around the camera that can hold them, and the pair of column peaks whose
// spacing looks like one lane.
#ifndef LANE_TWO_LANES_H_
#define LANE_TWO_LANES_H_

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"
#include "lane/stages/line_detection.h"

namespace lane {

struct TwoLaneOptions {
  // Only columns within this lateral distance of the camera are searched for
  // the ego lane's boundaries, metres. The reference keeps IPM columns 59..100
  // of 160 (about +-2.3 m); we widen it so a car driving 0.7 m off its lane's
  // centre still has both boundaries inside, while the next boundaries out
  // (>= 4.3 m away) stay outside.
  double search_half_width_m = 2.9;
  // Expected ego-lane width and tolerance (Gaussian sigma), metres
  // (reference: 30 and 10 IPM px at 8.9 px/m).
  double lane_width_m = 3.4;
  double lane_width_sigma_m = 1.1;
  // A pair is accepted when its width score exp(-d^2/2s^2) reaches this;
  // otherwise only the strongest line is kept.
  double min_pair_score = 0.3;

  absl::Status Validate() const;
};

// Top-view columns [begin, end) within search_half_width_m of the camera's
// column `camera_col` (IPM pixels, metres_per_px_x across).
struct ColumnBand {
  int begin = 0;
  int end = 0;
};
ColumnBand EgoBand(double camera_col, double metres_per_px_x, int cols,
                   const TwoLaneOptions& options);

// Zeroes the columns of `image` outside `band`.
void KeepBand(const ColumnBand& band, cv::Mat& image);

// The best pair of peaks straddling the camera whose spacing scores as one
// lane (width score exp(-d^2 / 2 sigma^2) times the peaks' sum), else the
// strongest single peak. Fewer than 2 peaks come back unchanged.
std::vector<ColumnPeak> SelectEgoPair(const std::vector<ColumnPeak>& peaks, double camera_col,
                                      double metres_per_px_x, const TwoLaneOptions& options);

}  // namespace lane

#endif  // LANE_TWO_LANES_H_
