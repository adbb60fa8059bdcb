// Whole-file reads for the label and results readers.
#ifndef LANE_EVAL_TEXT_FILE_H_
#define LANE_EVAL_TEXT_FILE_H_

#include <string>

#include "absl/status/statusor.h"

namespace lane::eval {

// The bytes of `path`; NOT_FOUND "cannot read PATH" when it cannot be opened.
absl::StatusOr<std::string> ReadTextFile(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_TEXT_FILE_H_
