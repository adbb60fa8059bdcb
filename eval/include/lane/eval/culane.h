// CULane label files (`NNNNN.lines.txt`): one lane a line, "x0 y0 x1 y1 ..."
// in image pixels (points every 10 rows from the bottom up). An empty file is
// a frame without lanes.
#ifndef LANE_EVAL_CULANE_H_
#define LANE_EVAL_CULANE_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/curve.h"

namespace lane::eval {

// The lanes of one file's text, as polylines in file order. Blank lines are
// skipped. INVALID_ARGUMENT "SOURCE:LINE: ..." for a token that is not a
// finite number, an odd number of values, or a lane of fewer than 2 points.
absl::StatusOr<std::vector<Curve>> ParseCulaneLines(absl::string_view text,
                                                    absl::string_view source);
// Reads and parses `path`; NOT_FOUND when it cannot be read.
absl::StatusOr<std::vector<Curve>> ReadCulaneLines(const std::string& path);

// The file name of the labels of image `image_name`: "00090.jpg" ->
// "00090.lines.txt".
std::string CulaneLabelName(const std::string& image_name);

}  // namespace lane::eval

#endif  // LANE_EVAL_CULANE_H_
