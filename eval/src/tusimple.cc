#include "lane/eval/tusimple.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "json_lines.h"
#include "lane/eval/text_file.h"

namespace lane::eval {
namespace {

using Json = nlohmann::json;

bool IsNumberArray(const Json& j) {
  if (!j.is_array()) return false;
  for (const Json& v : j) {
    if (!v.is_number()) return false;
  }
  return true;
}

}  // namespace

absl::StatusOr<std::vector<TusimpleFrame>> ParseTusimpleLabels(absl::string_view text,
                                                               absl::string_view source) {
  std::vector<TusimpleFrame> frames;
  const absl::Status status = ForEachJsonObjectLine(
      text, source, [&](const Json& j, const LineError& error) -> absl::Status {
        const auto raw_file = j.find("raw_file");
        if (raw_file == j.end() || !raw_file->is_string() || raw_file->get<std::string>().empty()) {
          return error("\"raw_file\" must be a non-empty string");
        }
        const auto h_samples = j.find("h_samples");
        if (h_samples == j.end() || !IsNumberArray(*h_samples)) {
          return error("\"h_samples\" must be an array of numbers");
        }
        const auto lanes = j.find("lanes");
        if (lanes == j.end() || !lanes->is_array()) {
          return error("\"lanes\" must be an array of arrays of numbers");
        }
        TusimpleFrame frame;
        frame.raw_file = raw_file->get<std::string>();
        for (size_t k = 0; k < lanes->size(); ++k) {
          const Json& lane = (*lanes)[k];
          if (!IsNumberArray(lane)) {
            return error(absl::StrCat("lanes[", k, "] must be an array of numbers"));
          }
          if (lane.size() != h_samples->size()) {
            return error(absl::StrCat("lanes[", k, "] has ", lane.size(),
                                      " values but h_samples has ", h_samples->size()));
          }
          std::vector<Eigen::Vector2d> points;
          for (size_t i = 0; i < lane.size(); ++i) {
            const double x = lane[i].get<double>();
            const double y = (*h_samples)[i].get<double>();
            if (!std::isfinite(x) || !std::isfinite(y)) {
              return error(absl::StrCat("lanes[", k, "][", i, "] is not finite"));
            }
            if (x >= 0) points.emplace_back(x, y);
          }
          if (points.size() >= 2) frame.lanes.push_back(Curve::Polyline(std::move(points)));
        }
        frames.push_back(std::move(frame));
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  return frames;
}

absl::StatusOr<std::vector<TusimpleFrame>> ReadTusimpleLabels(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseTusimpleLabels(*text, path);
}

bool LooksLikeTusimple(absl::string_view text) {
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    line = absl::StripAsciiWhitespace(line);
    if (line.empty()) continue;
    const Json j = Json::parse(line.begin(), line.end(), nullptr, /*allow_exceptions=*/false);
    return j.is_object() && j.contains("lanes") && j.contains("h_samples") &&
           j.contains("raw_file");
  }
  return false;
}

}  // namespace lane::eval
