#include "io/results_json.h"

#include <array>
#include <cmath>

namespace lane::io {
namespace {

using Json = nlohmann::ordered_json;

double Round(double v, double scale) {
  if (!std::isfinite(v)) return v;
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

Json Header(const ResultsFrame& frame) {
  Json out = Json::object();
  out["schema"] = kResultsSchema;
  out["frame"] = frame.name;
  if (frame.width > 0 && frame.height > 0) {
    out["width"] = frame.width;
    out["height"] = frame.height;
  }
  out["mode"] = lane::ModeName(frame.mode);
  return out;
}

// What the detector found of a lane.
Json LaneJson(const lane::Lane& lane) {
  Json l = Json::object();
  l["image"] = Points(lane.image, 1e3);
  l["ipm"] = Points(lane.ipm, 1e3);
  l["ground"] = Points(lane.ground, 1e4);
  l["score"] = Round(lane.score, 1e4);
  l["inferred"] = lane.inferred;
  return l;
}

Json TrackedLaneJson(const lane::TrackedLane& tracked) {
  Json l = LaneJson(tracked.lane);
  l["id"] = tracked.id;
  l["confirmed"] = tracked.confirmed;
  l["predicted"] = tracked.predicted;
  l["color"] = lane::MarkingColorName(tracked.color);
  l["type"] = lane::MarkingTypeName(tracked.type);
  l["refit"] = tracked.lane.refit;
  return l;
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

Json TimingJson(const lane::StageTimings& t, double decode_ms) {
  Json timing = Json::object();
  timing["decode"] = Round(decode_ms, 1e3);
  for (size_t i = 0; i < lane::DetectorStageCount(); ++i) {
    timing[lane::DetectorStageName(i)] = Round(t.stage_ms[i], 1e3);
  }
  timing["total"] = Round(t.total_ms, 1e3);
  return timing;
}

}  // namespace

Json DetectionJson(const ResultsFrame& frame, const lane::Detection& detection, double decode_ms) {
  Json out = Header(frame);
  Json lanes = Json::array();
  for (const lane::Lane& lane : detection.lanes) lanes.push_back(LaneJson(lane));
  out["lanes"] = std::move(lanes);
  out["timing_ms"] = TimingJson(detection.timings, decode_ms);
  return out;
}

Json DetectionJson(const ResultsFrame& frame, const lane::TrackedFrame& tracked, double decode_ms) {
  Json out = Header(frame);
  Json lanes = Json::array();
  for (const lane::TrackedLane& lane : tracked.lanes) lanes.push_back(TrackedLaneJson(lane));
  out["lanes"] = std::move(lanes);
  out["ego"] = EgoJson(tracked.ego);
  out["timing_ms"] = TimingJson(tracked.detection.timings, decode_ms);
  return out;
}

Json ErrorJson(const ResultsFrame& frame, const std::string& error) {
  Json out = Header(frame);
  out["error"] = error;
  return out;
}

std::string JsonLine(const Json& record) {
  return record.dump(-1, ' ', false, Json::error_handler_t::replace);
}

double RoundTo(double value, int decimals) { return Round(value, std::pow(10.0, decimals)); }

}  // namespace lane::io
