// TuSimple lane labels: JSON Lines, one object per frame,
//   {"lanes": [[x, x, ...], ...], "h_samples": [y, y, ...], "raw_file": "clips/.../20.jpg"}
// Lane k has a point (lanes[k][i], h_samples[i]) for every i where
// lanes[k][i] >= 0; TuSimple writes x = -2 for "no point".
#ifndef LANE_EVAL_TUSIMPLE_H_
#define LANE_EVAL_TUSIMPLE_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/curve.h"

namespace lane::eval {

struct TusimpleFrame {
  std::string raw_file;  // image path relative to the dataset folder
  // One polyline per lane with at least 2 points, in file order (lanes with
  // fewer points are dropped).
  std::vector<Curve> lanes;
};

// Parses a whole file. Blank lines are skipped. INVALID_ARGUMENT
// "SOURCE:LINE: ..." for a line that is not a JSON object, a missing or
// mistyped key, or a lane whose length differs from h_samples'.
absl::StatusOr<std::vector<TusimpleFrame>> ParseTusimpleLabels(absl::string_view text,
                                                               absl::string_view source);
absl::StatusOr<std::vector<TusimpleFrame>> ReadTusimpleLabels(const std::string& path);

// True when the first non-blank line of `text` is a JSON object with
// "lanes", "h_samples" and "raw_file" (used to recognise the format).
bool LooksLikeTusimple(absl::string_view text);

}  // namespace lane::eval

#endif  // LANE_EVAL_TUSIMPLE_H_
