#include "cli/results_json.h"

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>

#include "cli/tracking_json.h"

namespace lane_tools {
namespace {

using Json = nlohmann::ordered_json;

double Round(double v, double scale) {
  const double r = std::round(v * scale) / scale;
  return r == 0 ? 0.0 : r;  // no "-0.0"
}

Json Points(const std::array<Eigen::Vector2d, 4>& points, double scale) {
  Json out = Json::array();
  for (const Eigen::Vector2d& p : points) {
    out.push_back(Json::array({Round(p.x(), scale), Round(p.y(), scale)}));
  }
  return out;
}

Json Header(const std::string& frame, int width, int height, lane::Mode mode) {
  Json out = Json::object();
  out["schema"] = kResultsSchema;
  out["frame"] = frame;
  if (width > 0 && height > 0) {
    out["width"] = width;
    out["height"] = height;
  }
  out["mode"] = lane::ModeName(mode);
  return out;
}

// Invalid UTF-8 (file names) would make dump() throw: replace it.
std::string Dump(const Json& j) { return j.dump(-1, ' ', false, Json::error_handler_t::replace); }

}  // namespace

void AddLaneTrackingFields(const lane::Lane& lane, Json& l) {
  l["id"] = lane.id;
  l["confirmed"] = lane.confirmed;
  l["predicted"] = lane.predicted;
  l["color"] = lane::MarkingColorName(lane.color);
  l["type"] = lane::MarkingTypeName(lane.type);
  l["refit"] = lane.refit;
}

Json EgoJson(const std::optional<lane::EgoLane>& ego) {
  if (!ego) return nullptr;
  Json e = Json::object();
  e["offset_m"] = Round(ego->offset_m, 1e3);
  e["width_m"] = Round(ego->width_m, 1e3);
  e["heading_deg"] = Round(ego->heading_deg, 1e3);
  e["curvature_per_m"] = Round(ego->curvature_per_m, 1e6);
  e["left_id"] = ego->left_id;
  e["right_id"] = ego->right_id;
  e["left_distance_m"] = Round(ego->left_distance_m, 1e3);
  e["right_distance_m"] = Round(ego->right_distance_m, 1e3);
  e["offset_rate_mps"] = Round(ego->offset_rate_mps, 1e3);
  e["departing"] = ego->departing;
  return e;
}

std::string DetectionJsonLine(const std::string& frame, int width, int height, lane::Mode mode,
                              const lane::Detection& detection, double decode_ms, bool tracked) {
  Json out = Header(frame, width, height, mode);
  Json lanes = Json::array();
  for (const lane::Lane& lane : detection.lanes) {
    Json l = Json::object();
    l["image"] = Points(lane.image, 1e3);
    l["ipm"] = Points(lane.ipm, 1e3);
    l["ground"] = Points(lane.ground, 1e4);
    l["score"] = Round(lane.score, 1e4);
    l["inferred"] = lane.inferred;
    if (tracked) AddLaneTrackingFields(lane, l);
    lanes.push_back(std::move(l));
  }
  out["lanes"] = std::move(lanes);
  if (tracked) out["ego"] = EgoJson(detection.ego);
  const lane::StageTimings& t = detection.timings;
  Json timing = Json::object();
  timing["decode"] = Round(decode_ms, 1e3);
  for (size_t i = 0; i < lane::DetectorStageCount(); ++i) {
    timing[lane::DetectorStageName(i)] = Round(t.stage_ms[i], 1e3);
  }
  timing["total"] = Round(t.total_ms, 1e3);
  out["timing_ms"] = std::move(timing);
  return Dump(out);
}

std::string ErrorJsonLine(const std::string& frame, int width, int height, lane::Mode mode,
                          const std::string& error) {
  Json out = Header(frame, width, height, mode);
  out["error"] = error;
  return Dump(out);
}

}  // namespace lane_tools
