// The CULane metric: every lane is drawn as a 30 px wide polyline on a
// 1640x590 canvas; a detection and a label match when the intersection over
// union of their drawings is >= 0.5, with a one-to-one (Hungarian)
// assignment. Frames of another size are drawn on a canvas scaled to the
// reference width (uniform scale), which is the same as drawing them
// 30 * width / 1640 px wide at their own size.
#ifndef LANE_EVAL_CULANE_METRIC_H_
#define LANE_EVAL_CULANE_METRIC_H_

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"
#include "lane/eval/curve.h"
#include "lane/eval/matching.h"

namespace lane::eval {

struct CulaneOptions {
  // Width of a drawn lane, pixels at reference_width (CULane: 30 px).
  double line_width_px = 30.0;
  // CULane frames are 1640x590; other frames are scaled to this width.
  int reference_width = 1640;
  // Minimum IoU of a match (CULane: 0.5).
  double iou_threshold = 0.5;

  absl::Status Validate() const;
};

// Size of the canvas frames of image_width x image_height are drawn on.
cv::Size CulaneCanvasSize(int image_width, int image_height, const CulaneOptions& options = {});

// CV_8U canvas (CulaneCanvasSize), 255 under the lane: the curve's draw
// points (lane::eval::Curve::DrawPoints) scaled to the canvas, joined by
// line_width_px wide segments with round joins and ends.
cv::Mat DrawLaneMask(const Curve& lane, int image_width, int image_height,
                     const CulaneOptions& options = {});

// |a and b| / |a or b| of two CV_8U masks of one size (non-zero = set); 0
// when both are empty.
double MaskIoU(const cv::Mat& a, const cv::Mat& b);

// IoU of every detection (rows) with every label (columns).
std::vector<std::vector<double>> LaneIoUs(const std::vector<Curve>& detections,
                                          const std::vector<Curve>& labels, int image_width,
                                          int image_height, const CulaneOptions& options = {});

// One-to-one assignment maximising the summed IoU over the pairs with
// IoU >= iou_threshold (pairs below it cannot match).
Matching MatchCulane(const std::vector<Curve>& detections, const std::vector<Curve>& labels,
                     int image_width, int image_height, const CulaneOptions& options = {});

}  // namespace lane::eval

#endif  // LANE_EVAL_CULANE_METRIC_H_
