#include "lane/eval/render_labels.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "json_lines.h"
#include "lane/eval/text_file.h"

namespace lane::eval {

absl::StatusOr<std::vector<LabelledFrame>> ParseRenderLabels(absl::string_view text,
                                                             absl::string_view source) {
  using Json = nlohmann::json;
  std::vector<LabelledFrame> frames;
  const absl::Status status = ForEachJsonObjectLine(
      text, source, [&](const Json& j, const LineError& error) -> absl::Status {
        LabelledFrame frame;
        if (!j.contains("frame") || !j["frame"].is_string()) {
          return error("\"frame\" must be a string");
        }
        frame.name = j["frame"].get<std::string>();
        for (const char* key : {"width", "height"}) {
          if (!j.contains(key) || !j[key].is_number_integer() || j[key].get<int>() <= 0) {
            return error(absl::StrCat("\"", key, "\" must be a positive integer"));
          }
        }
        frame.width = j["width"].get<int>();
        frame.height = j["height"].get<int>();
        if (!j.contains("boundaries") || !j["boundaries"].is_array()) {
          return error("\"boundaries\" must be an array");
        }
        for (size_t b = 0; b < j["boundaries"].size(); ++b) {
          const Json& boundary = j["boundaries"][b];
          const Json* points =
              boundary.is_object() && boundary.contains("points") ? &boundary["points"] : nullptr;
          if (points == nullptr || !points->is_array() || points->size() != 4) {
            return error(absl::StrCat("boundaries[", b, "].points must hold 4 [x, y] points"));
          }
          std::array<Eigen::Vector2d, 4> control;
          for (size_t i = 0; i < 4; ++i) {
            const Json& p = (*points)[i];
            if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() ||
                !std::isfinite(p[0].get<double>()) || !std::isfinite(p[1].get<double>())) {
              return error(absl::StrCat("boundaries[", b, "].points[", i, "] must be [x, y]"));
            }
            control[i] = {p[0].get<double>(), p[1].get<double>()};
          }
          LabelledBoundary label{Curve::FromBezier(control), ""};
          const bool dashed = boundary.contains("dashed") && boundary["dashed"].is_boolean() &&
                              boundary["dashed"].get<bool>();
          const std::string colour = boundary.contains("color") && boundary["color"].is_string()
                                         ? boundary["color"].get<std::string>()
                                         : std::string("white");
          const bool twin = boundary.contains("double") && boundary["double"].is_boolean() &&
                            boundary["double"].get<bool>();
          const bool dots = boundary.contains("dots") && boundary["dots"].is_boolean() &&
                            boundary["dots"].get<bool>();
          label.type = absl::StrCat(
              dots ? "dots " : (twin ? "double " : (dashed ? "dashed " : "solid ")), colour);
          frame.boundaries.push_back(std::move(label));
        }
        frames.push_back(std::move(frame));
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  return frames;
}

absl::StatusOr<std::vector<LabelledFrame>> ReadRenderLabels(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseRenderLabels(*text, path);
}

std::string RenderLabelsJson(const std::string& frame_name, const SyntheticFrame& frame) {
  auto round2 = [](double v) { return std::round(v * 100.0) / 100.0; };
  nlohmann::ordered_json j;
  j["frame"] = frame_name;
  j["width"] = frame.bgr.cols;
  j["height"] = frame.bgr.rows;
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (int i = 0; i < static_cast<int>(frame.boundaries.size()); ++i) {
    const SyntheticBoundary& b = frame.boundaries[i];
    nlohmann::ordered_json pts = nlohmann::ordered_json::array();
    for (const auto& p : b.image) pts.push_back({round2(p.x()), round2(p.y())});
    nlohmann::ordered_json e;
    e["points"] = pts;
    e["dashed"] = b.dashed;
    e["color"] = b.yellow ? "yellow" : "white";
    if (b.double_line) e["double"] = true;
    if (b.dots) e["dots"] = true;
    e["ego"] = i == frame.ego_left ? "left" : (i == frame.ego_right ? "right" : "none");
    e["id"] = b.id;
    if (frame.ego) e["type_changes"] = b.type_changes;
    list.push_back(e);
  }
  j["boundaries"] = list;
  if (frame.ego) {
    auto round4 = [](double v) { return std::round(v * 1e4) / 1e4; };
    j["time_s"] = round4(frame.time_s);
    nlohmann::ordered_json ego;
    ego["lane"] = frame.ego->lane;
    ego["offset_m"] = round4(frame.ego->offset_m);
    ego["width_m"] = round4(frame.ego->width_m);
    ego["heading_deg"] = round4(frame.ego->heading_deg);
    ego["curvature_per_m"] = std::round(frame.ego->curvature_per_m * 1e7) / 1e7;
    ego["offset_rate_mps"] = round4(frame.ego->offset_rate_mps);
    j["ego"] = ego;
    // The asphalt's edges (no paint): a lane found on one is neither a hit
    // nor a false positive (lane eval --drive).
    nlohmann::ordered_json edges = nlohmann::ordered_json::array();
    for (const auto& edge : frame.road_edges) {
      nlohmann::ordered_json pts = nlohmann::ordered_json::array();
      for (const auto& p : edge) pts.push_back({round2(p.x()), round2(p.y())});
      edges.push_back(pts);
    }
    j["road_edges"] = edges;
  }
  return j.dump();
}

}  // namespace lane::eval
