#include "json_lines.h"

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace lane::eval {

absl::Status ForEachJsonObjectLine(
    absl::string_view text, absl::string_view source,
    const std::function<absl::Status(const nlohmann::json& object, const LineError& error)>&
        record) {
  int line_number = 0;
  const LineError error = [&](const std::string& message) {
    return absl::InvalidArgumentError(absl::StrCat(source, ":", line_number, ": ", message));
  };
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty()) continue;
    const nlohmann::json j =
        nlohmann::json::parse(line.begin(), line.end(), nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) return error("not a JSON object");
    if (absl::Status s = record(j, error); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace lane::eval
