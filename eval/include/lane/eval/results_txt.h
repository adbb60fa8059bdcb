// The results file of the original tool (`<list>_results.txt`), so results
// can be scored with the scripts users already have, and theirs with ours:
//
//   frame#00000000 has 3 splines
//   	spline#1 has 4 points and score 12.3
//   		412.125, 350.5
//   		... (one "x, y" line per control point, image pixels)
//
// Frames are numbered from 0 in the order of the image list, splines from 1.
#ifndef LANE_EVAL_RESULTS_TXT_H_
#define LANE_EVAL_RESULTS_TXT_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/results.h"

namespace lane::eval {

// The block of one frame, ending in a newline. Coordinates with 3 decimals.
std::string ResultsTxtFrame(int index, const std::vector<DetectedLane>& lanes);

// One FrameResult per frame block, in file order, with `index` set and
// `frame` = "#index". A spline of 4 points is a Bezier, of other counts
// (>= 2) a polyline. INVALID_ARGUMENT "SOURCE:LINE: ..." for anything else,
// including a spline or point count that disagrees with its header and a
// frame number given twice.
absl::StatusOr<std::vector<FrameResult>> ParseResultsTxt(absl::string_view text,
                                                         absl::string_view source);
absl::StatusOr<std::vector<FrameResult>> ReadResultsTxt(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_RESULTS_TXT_H_
