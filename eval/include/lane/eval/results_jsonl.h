// Reader of `lane detect` results: JSON Lines, schema 1
// (docs/results-format.md). The writer is io/results_json.h.
#ifndef LANE_EVAL_RESULTS_JSONL_H_
#define LANE_EVAL_RESULTS_JSONL_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lane/eval/results.h"

namespace lane::eval {

// One FrameResult per non-blank line: frame, width, height, mode, lanes
// (each lane's "image" Bezier and "score"; "ipm" and "ground" are not
// needed) or error. INVALID_ARGUMENT "SOURCE:LINE: ..." for a line that is
// not a schema 1 record. A trailer line ({"trailer": {...}}, the last line of
// a `lane backfill` output) is skipped.
absl::StatusOr<std::vector<FrameResult>> ParseResultsJsonl(absl::string_view text,
                                                           absl::string_view source);
absl::StatusOr<std::vector<FrameResult>> ReadResultsJsonl(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_RESULTS_JSONL_H_
