#include "lane/eval/results_jsonl.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "json_lines.h"
#include "lane/eval/text_file.h"

namespace lane::eval {

absl::StatusOr<std::vector<FrameResult>> ParseResultsJsonl(absl::string_view text,
                                                           absl::string_view source) {
  using Json = nlohmann::json;
  std::vector<FrameResult> out;
  const absl::Status status = ForEachJsonObjectLine(
      text, source, [&](const Json& j, const LineError& error) -> absl::Status {
        // `lane backfill`'s outputs end with a trailer (docs/results-format.md):
        // not a frame.
        if (!j.contains("schema") && j.contains("trailer") && j["trailer"].is_object()) {
          return absl::OkStatus();
        }
        if (!j.contains("schema") || !j["schema"].is_number_integer()) {
          return error("no \"schema\": not a lane detect results record");
        }
        if (j["schema"].get<int>() != 1) {
          return error(absl::StrCat("schema ", j["schema"].get<int>(), " is not supported (1 is)"));
        }
        FrameResult r;
        if (!j.contains("frame") || !j["frame"].is_string())
          return error("\"frame\" must be a string");
        r.frame = j["frame"].get<std::string>();
        if (j.contains("width") || j.contains("height")) {
          if (!j.contains("width") || !j.contains("height") || !j["width"].is_number_integer() ||
              !j["height"].is_number_integer()) {
            return error("\"width\" and \"height\" must both be integers");
          }
          r.width = j["width"].get<int>();
          r.height = j["height"].get<int>();
        }
        if (j.contains("mode")) {
          if (!j["mode"].is_string()) return error("\"mode\" must be a string");
          r.mode = j["mode"].get<std::string>();
        }
        if (j.contains("error")) {
          r.error = j["error"].is_string() ? j["error"].get<std::string>() : j["error"].dump();
          if (r.error.empty()) r.error = "error";
          out.push_back(std::move(r));
          return absl::OkStatus();
        }
        if (!j.contains("lanes") || !j["lanes"].is_array()) {
          return error("\"lanes\" must be an array (or the record must have \"error\")");
        }
        const Json& lanes = j["lanes"];
        for (size_t k = 0; k < lanes.size(); ++k) {
          const Json& lane = lanes[k];
          const Json* image = lane.is_object() && lane.contains("image") ? &lane["image"] : nullptr;
          if (image == nullptr || !image->is_array() || image->size() != 4) {
            return error(absl::StrCat("lanes[", k, "].image must hold 4 [x, y] points"));
          }
          std::array<Eigen::Vector2d, 4> control;
          for (size_t i = 0; i < 4; ++i) {
            const Json& p = (*image)[i];
            if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() ||
                !std::isfinite(p[0].get<double>()) || !std::isfinite(p[1].get<double>())) {
              return error(absl::StrCat("lanes[", k, "].image[", i, "] must be [x, y]"));
            }
            control[i] = {p[0].get<double>(), p[1].get<double>()};
          }
          DetectedLane detected{Curve::FromBezier(control), 0.0};
          if (lane.contains("score") && lane["score"].is_number()) {
            detected.score = lane["score"].get<double>();
          }
          r.lanes.push_back(std::move(detected));
        }
        out.push_back(std::move(r));
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  return out;
}

absl::StatusOr<std::vector<FrameResult>> ReadResultsJsonl(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseResultsJsonl(*text, path);
}

}  // namespace lane::eval
