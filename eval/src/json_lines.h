// JSON Lines reading shared by the label and results readers.
#ifndef LANE_EVAL_JSON_LINES_H_
#define LANE_EVAL_JSON_LINES_H_

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace lane::eval {

// Makes the error for a problem with the current line: INVALID_ARGUMENT
// "SOURCE:LINE: message".
using LineError = std::function<absl::Status(const std::string& message)>;

// Calls `record` with each non-blank line of `text` parsed as a JSON object,
// in order. A line that is not a JSON object, or the first non-OK status that
// `record` returns, ends the reading with that error.
absl::Status ForEachJsonObjectLine(
    absl::string_view text, absl::string_view source,
    const std::function<absl::Status(const nlohmann::json& object, const LineError& error)>&
        record);

}  // namespace lane::eval

#endif  // LANE_EVAL_JSON_LINES_H_
