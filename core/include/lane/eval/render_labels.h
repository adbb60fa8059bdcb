// The labels `lane render` writes beside its frames (`labels.jsonl`, see
// docs/results-format.md): one JSON object per frame with exact Bezier
// control points of every painted boundary.
#ifndef LANE_EVAL_RENDER_LABELS_H_
#define LANE_EVAL_RENDER_LABELS_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/labels.h"

namespace lane::eval {

// One LabelledFrame per line (name = the "frame" key, image_path empty,
// width/height from the file, type "dashed white", "solid yellow", ...).
// INVALID_ARGUMENT "SOURCE:LINE: ..." for a malformed line.
absl::StatusOr<std::vector<LabelledFrame>> ParseRenderLabels(absl::string_view text,
                                                             absl::string_view source);
absl::StatusOr<std::vector<LabelledFrame>> ReadRenderLabels(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_RENDER_LABELS_H_
