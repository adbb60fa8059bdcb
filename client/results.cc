#include "results.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "cli/tracking_json.h"
#include "wire/detection_proto.h"

namespace lane_client {
namespace {

using Json = nlohmann::ordered_json;
namespace v1 = lane::v1;

double Round(double v, double scale) {
  if (!std::isfinite(v)) return v;
  const double r = std::round(v * scale) / scale;
  return r == 0 ? 0.0 : r;
}

Json Points(const v1::Bezier& bezier, double scale) {
  Json out = Json::array();
  for (const v1::Point2& p : bezier.control_points()) {
    out.push_back(Json::array({Round(p.x(), scale), Round(p.y(), scale)}));
  }
  return out;
}

std::string Dump(const Json& j) { return j.dump(-1, ' ', false, Json::error_handler_t::replace); }

std::array<Eigen::Vector2d, 4> ToPoints(const v1::Bezier& bezier) {
  std::array<Eigen::Vector2d, 4> out{};
  for (int i = 0; i < 4 && i < bezier.control_points_size(); ++i) {
    out[static_cast<size_t>(i)] = {bezier.control_points(i).x(), bezier.control_points(i).y()};
  }
  return out;
}

}  // namespace

std::string FrameCodeName(v1::FrameCode code) {
  if (!v1::FrameCode_IsValid(code)) return absl::StrCat("UNKNOWN_", static_cast<int>(code));
  std::string name = v1::FrameCode_Name(code);
  constexpr absl::string_view kPrefix = "FRAME_CODE_";
  if (absl::StartsWith(name, kPrefix)) name.erase(0, kPrefix.size());
  return name;
}

std::string ResponseJsonLine(const std::string& frame_name, const v1::FrameResponse& response,
                             double latency_ms, int attempts, uint64_t connection) {
  Json out = Json::object();
  out["schema"] = kStreamResultsSchema;
  out["frame"] = frame_name;
  out["camera_id"] = response.camera_id();
  out["frame_id"] = response.frame_id();
  out["capture_time_unix_ns"] = response.capture_time_unix_ns();
  out["server_receive_time_unix_ns"] = response.server_receive_time_unix_ns();
  out["server_send_time_unix_ns"] = response.server_send_time_unix_ns();
  out["status"] = FrameCodeName(response.status().code());
  if (response.status().code() != v1::FRAME_CODE_OK) out["error"] = response.status().message();
  out["calibration_version"] = response.calibration_version();
  // Tracked (a streamed session tracks unless told not to): every lane has
  // an id, and the tracking fields are written as `lane detect --track`
  // writes them (docs/results-format.md).
  bool tracked = response.has_ego();
  for (const v1::Lane& lane : response.lanes()) tracked = tracked || lane.id() > 0;
  const std::vector<lane::Lane> decoded = lane::wire::LanesFromProto(response);
  Json lanes = Json::array();
  for (int i = 0; i < response.lanes_size(); ++i) {
    const v1::Lane& lane = response.lanes(i);
    Json l = Json::object();
    l["image"] = Points(lane.image(), 1e3);
    l["ipm"] = Points(lane.ipm(), 1e3);
    l["ground"] = Points(lane.ground(), 1e4);
    l["score"] = Round(lane.score(), 1e4);
    if (tracked) lane_tools::AddLaneTrackingFields(decoded[static_cast<size_t>(i)], l);
    lanes.push_back(std::move(l));
  }
  out["lanes"] = std::move(lanes);
  if (tracked) out["ego"] = lane_tools::EgoJson(lane::wire::EgoFromProto(response));
  const v1::StageTimings& t = response.timings();
  Json timing = Json::object();
  timing["queue_wait"] = Round(t.queue_wait_ms(), 1e3);
  timing["decode"] = Round(t.decode_ms(), 1e3);
  const lane::StageTimings stages = lane::wire::TimingsFromProto(t);
  for (size_t i = 0; i < lane::DetectorStageCount(); ++i) {
    timing[lane::DetectorStageName(i)] = Round(stages.stage_ms[i], 1e3);
  }
  timing["detect"] = Round(t.detect_ms(), 1e3);
  out["timing_ms"] = std::move(timing);
  out["latency_ms"] = Round(latency_ms, 1e3);
  out["attempts"] = attempts;
  if (connection > 0) out["connection"] = connection;
  return Dump(out);
}

std::string ClientErrorJsonLine(const std::string& frame_name, const std::string& camera_id,
                                uint64_t frame_id, const std::string& error) {
  Json out = Json::object();
  out["schema"] = kStreamResultsSchema;
  out["frame"] = frame_name;
  out["camera_id"] = camera_id;
  out["frame_id"] = frame_id;
  out["status"] = "CLIENT_ERROR";
  out["error"] = error;
  out["attempts"] = 0;
  return Dump(out);
}

lane::Detection DetectionFromResponse(const v1::FrameResponse& response) {
  lane::Detection detection;
  for (const v1::Lane& l : response.lanes()) {
    lane::Lane lane;
    lane.image = ToPoints(l.image());
    lane.ipm = ToPoints(l.ipm());
    lane.ground = ToPoints(l.ground());
    lane.score = l.score();
    detection.lanes.push_back(lane);
  }
  const v1::StageTimings& t = response.timings();
  detection.timings = lane::wire::TimingsFromProto(t);
  return detection;
}

}  // namespace lane_client
