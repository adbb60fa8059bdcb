// Pictures of a scored frame, like the paper's Fig. 12: what was labelled,
// what was found, what was wrong.
#ifndef LANE_TOOLS_EVAL_OVERLAY_H_
#define LANE_TOOLS_EVAL_OVERLAY_H_

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "lane/eval/evaluate.h"
#include "lane/geometry/ipm.h"

namespace lane::cli {

// A BGR copy of `frame` with, under the paper's rule:
//  * scored labels as thin green lines (matched) or thick blue lines
//    (missed);
//  * detections as thick green lines (correct) or thick red lines (false
//    positives);
//  * labels not scored (2-lanes mode: not the ego lane's) as thin grey
//    lines, with the row the ego boundaries were chosen at dashed grey;
//  * on a frame without labels, detections in orange;
//  * the detector's ROI as a thin grey rectangle when `roi` is given;
//  * a caption: frame name, paper-rule and CULane counts, and a legend.
// Line widths scale with the frame's width (1 at 640 px).
cv::Mat DrawEvaluation(const cv::Mat& frame, const lane::eval::FrameOutcome& outcome,
                       const lane::eval::EvalOptions& options, const std::optional<lane::Roi>& roi);

}  // namespace lane::cli

#endif  // LANE_TOOLS_EVAL_OVERLAY_H_
