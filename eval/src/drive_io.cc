#include "lane/eval/drive_io.h"

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "json_lines.h"
#include "lane/eval/text_file.h"

namespace lane::eval {
namespace {

using Json = nlohmann::json;

// Four [x, y] points of `j` (an array) into `out`; false if they are not.
bool ControlPoints(const Json& j, std::array<Eigen::Vector2d, 4>& out) {
  if (!j.is_array() || j.size() != 4) return false;
  for (size_t i = 0; i < 4; ++i) {
    const Json& p = j[i];
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number()) return false;
    out[i] = {p[0].get<double>(), p[1].get<double>()};
    if (!out[i].allFinite()) return false;
  }
  return true;
}

bool Number(const Json& object, const char* key, double& out) {
  if (!object.contains(key) || !object[key].is_number()) return false;
  out = object[key].get<double>();
  return std::isfinite(out);
}

// Optional keys: `out` keeps its default when the key is absent; false when
// it is there with another type (nlohmann's value() would throw).
bool OptionalBool(const Json& object, const char* key, bool& out) {
  if (!object.contains(key)) return true;
  if (!object[key].is_boolean()) return false;
  out = object[key].get<bool>();
  return true;
}
bool OptionalString(const Json& object, const char* key, std::string& out) {
  if (!object.contains(key)) return true;
  if (!object[key].is_string()) return false;
  out = object[key].get<std::string>();
  return true;
}
bool OptionalInt(const Json& object, const char* key, int& out) {
  if (!object.contains(key)) return true;
  if (!object[key].is_number_integer()) return false;
  out = object[key].get<int>();
  return true;
}

}  // namespace

absl::StatusOr<DriveLabels> ParseDriveLabels(absl::string_view text, absl::string_view source) {
  DriveLabels labels;
  const absl::Status status = ForEachJsonObjectLine(
      text, source, [&](const Json& j, const LineError& error) -> absl::Status {
        DriveTruthFrame t;
        if (!j.contains("frame") || !j["frame"].is_string()) {
          return error("\"frame\" must be a string");
        }
        if (!j.contains("width") || !j["width"].is_number_integer() || !j.contains("height") ||
            !j["height"].is_number_integer()) {
          return error("\"width\" and \"height\" must be integers");
        }
        t.width = j["width"].get<int>();
        t.height = j["height"].get<int>();
        if (!Number(j, "time_s", t.time_s)) {
          return error("no \"time_s\": not a drive's labels (lane render --sequence writes them)");
        }
        if (!j.contains("boundaries") || !j["boundaries"].is_array()) {
          return error("\"boundaries\" must be an array");
        }
        for (size_t b = 0; b < j["boundaries"].size(); ++b) {
          const Json& e = j["boundaries"][b];
          std::array<Eigen::Vector2d, 4> points;
          if (!e.is_object() || !e.contains("points") || !ControlPoints(e["points"], points)) {
            return error(absl::StrCat("boundaries[", b, "].points must hold 4 [x, y] points"));
          }
          if (!e.contains("id") || !e["id"].is_number_integer()) {
            return error(absl::StrCat("boundaries[", b, "].id must be an integer"));
          }
          DriveTruthBoundary boundary;
          boundary.curve = Curve::FromBezier(points);
          boundary.id = e["id"].get<int>();
          std::string colour = "white";
          if (!OptionalString(e, "color", colour) || !OptionalBool(e, "dashed", boundary.dashed) ||
              !OptionalBool(e, "type_changes", boundary.type_changes)) {
            return error(absl::StrCat("boundaries[", b,
                                      "]: color must be a string, dashed and type_changes "
                                      "booleans"));
          }
          boundary.yellow = colour == "yellow";
          t.boundaries.push_back(std::move(boundary));
        }
        if (j.contains("road_edges")) {
          if (!j["road_edges"].is_array()) return error("\"road_edges\" must be an array");
          for (size_t k = 0; k < j["road_edges"].size(); ++k) {
            std::array<Eigen::Vector2d, 4> points;
            if (!ControlPoints(j["road_edges"][k], points)) {
              return error(absl::StrCat("road_edges[", k, "] must hold 4 [x, y] points"));
            }
            t.road_edges.push_back(Curve::FromBezier(points));
          }
        }
        if (j.contains("ego") && !j["ego"].is_null()) {
          const Json& e = j["ego"];
          SyntheticEgo ego;
          if (!e.is_object() || !e.contains("lane") || !e["lane"].is_number_integer() ||
              !Number(e, "offset_m", ego.offset_m) || !Number(e, "width_m", ego.width_m) ||
              !Number(e, "heading_deg", ego.heading_deg) ||
              !Number(e, "curvature_per_m", ego.curvature_per_m)) {
            return error(
                "\"ego\" must hold lane, offset_m, width_m, heading_deg and curvature_per_m");
          }
          ego.lane = e["lane"].get<int>();
          Number(e, "offset_rate_mps", ego.offset_rate_mps);
          t.ego = ego;
        }
        labels.frames.push_back(j["frame"].get<std::string>());
        labels.truth.push_back(std::move(t));
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  return labels;
}

absl::StatusOr<DriveLabels> ReadDriveLabels(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseDriveLabels(*text, path);
}

absl::StatusOr<DriveResults> ParseDriveResults(absl::string_view text, absl::string_view source) {
  DriveResults results;
  const absl::Status status = ForEachJsonObjectLine(
      text, source, [&](const Json& j, const LineError& error) -> absl::Status {
        if (!j.contains("schema") || !j["schema"].is_number_integer() ||
            j["schema"].get<int>() != 1) {
          return error("not a schema 1 lane detect record");
        }
        if (!j.contains("frame") || !j["frame"].is_string()) {
          return error("\"frame\" must be a string");
        }
        DriveOutput out;
        if (!j.contains("error")) {
          if (!j.contains("lanes") || !j["lanes"].is_array()) {
            return error("\"lanes\" must be an array (or the record must have \"error\")");
          }
          for (size_t i = 0; i < j["lanes"].size(); ++i) {
            const Json& l = j["lanes"][i];
            TrackedLane lane;
            if (!l.is_object() || !l.contains("image") ||
                !ControlPoints(l["image"], lane.lane.image)) {
              return error(absl::StrCat("lanes[", i, "].image must hold 4 [x, y] points"));
            }
            if (l.contains("id") && l["id"].is_number_integer()) {
              lane.id = l["id"].get<int>();
              results.tracked = true;
            }
            std::string colour = "unknown", type = "unknown";
            if (!OptionalBool(l, "confirmed", lane.confirmed) ||
                !OptionalBool(l, "predicted", lane.predicted) ||
                !OptionalBool(l, "inferred", lane.lane.inferred) ||
                !OptionalString(l, "color", colour) || !OptionalString(l, "type", type)) {
              return error(
                  absl::StrCat("lanes[", i,
                               "]: confirmed, predicted and inferred must be booleans, color and "
                               "type strings"));
            }
            for (MarkingColor c : {MarkingColor::kWhite, MarkingColor::kYellow}) {
              if (colour == MarkingColorName(c)) lane.color = c;
            }
            for (MarkingType t : {MarkingType::kSolid, MarkingType::kDashed, MarkingType::kDouble,
                                  MarkingType::kRoadEdge}) {
              if (type == MarkingTypeName(t)) lane.type = t;
            }
            out.lanes.push_back(std::move(lane));
          }
          if (j.contains("ego") && j["ego"].is_object()) {
            results.tracked = true;
            const Json& e = j["ego"];
            EgoLane ego;
            if (!Number(e, "offset_m", ego.offset_m) || !Number(e, "width_m", ego.width_m) ||
                !Number(e, "heading_deg", ego.heading_deg) ||
                !Number(e, "curvature_per_m", ego.curvature_per_m)) {
              return error("\"ego\" must hold offset_m, width_m, heading_deg and curvature_per_m");
            }
            if (!OptionalInt(e, "left_id", ego.left_id) ||
                !OptionalInt(e, "right_id", ego.right_id) ||
                !OptionalBool(e, "departing", ego.departing)) {
              return error("\"ego\": left_id and right_id must be integers, departing a boolean");
            }
            Number(e, "left_distance_m", ego.left_distance_m);
            Number(e, "right_distance_m", ego.right_distance_m);
            Number(e, "offset_rate_mps", ego.offset_rate_mps);
            for (size_t k = 0; k < out.lanes.size(); ++k) {
              if (out.lanes[k].id < 0) continue;
              if (out.lanes[k].id == ego.left_id) ego.left_index = static_cast<int>(k);
              if (out.lanes[k].id == ego.right_id) ego.right_index = static_cast<int>(k);
            }
            out.ego = ego;
          }
        }
        results.frames.push_back(j["frame"].get<std::string>());
        results.outputs.push_back(std::move(out));
        return absl::OkStatus();
      });
  if (!status.ok()) return status;
  return results;
}

absl::StatusOr<DriveResults> ReadDriveResults(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  return ParseDriveResults(*text, path);
}

}  // namespace lane::eval
