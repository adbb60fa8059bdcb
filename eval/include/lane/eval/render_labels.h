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
#include "lane/synthetic.h"

namespace lane::eval {

// One LabelledFrame per line (name = the "frame" key, image_path empty,
// width/height from the file, type "dashed white", "solid yellow", ...).
// INVALID_ARGUMENT "SOURCE:LINE: ..." for a malformed line.
absl::StatusOr<std::vector<LabelledFrame>> ParseRenderLabels(absl::string_view text,
                                                             absl::string_view source);
absl::StatusOr<std::vector<LabelledFrame>> ReadRenderLabels(const std::string& path);

// The writer of the same format: one line for a rendered frame (what `lane
// render` writes; ParseRenderLabels reads it back).
// Labels file: one JSON object per line,
// {"frame":"000000.png","width":W,"height":H,"boundaries":[{"points":[[x,y]x4],
//  "dashed":b,"color":"white|yellow","ego":"left|right|none"}]}
std::string RenderLabelsJson(const std::string& frame_name, const SyntheticFrame& frame);

}  // namespace lane::eval

#endif  // LANE_EVAL_RENDER_LABELS_H_
