// The live view's JSON (docs/service.md, "Live view"): a camera's summary,
// the list of sessions, and one camera's page data (calibration, the last
// response's lanes, the recent history). Part of LiveView (live_view.h).
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "live_draw.h"
#include "live_view.h"

namespace lane::server {
namespace {

using LiveViewJson = nlohmann::ordered_json;  // LiveView::Json

// "MARKING_TYPE_ROAD_EDGE" -> "road_edge".
std::string EnumWord(const std::string& name, absl::string_view prefix) {
  absl::string_view word = name;
  absl::ConsumePrefix(&word, prefix);
  return absl::AsciiStrToLower(word);
}

// The lateral offset of a lane at its end nearest the camera, metres.
double NearOffset(const v1::Lane& lane) {
  if (lane.ground().control_points_size() < 4) return 0;
  const v1::Point2& a = lane.ground().control_points(0);
  const v1::Point2& b = lane.ground().control_points(3);
  return a.y() <= b.y() ? a.x() : b.x();
}

LiveViewJson LanesJson(const v1::FrameResponse& response) {
  LiveViewJson lanes = LiveViewJson::array();
  const int left = response.has_ego() ? response.ego().left_lane_id() : 0;
  const int right = response.has_ego() ? response.ego().right_lane_id() : 0;
  const std::vector<int> slots = LiveLaneSlots(response);
  for (int i = 0; i < response.lanes_size(); ++i) {
    const v1::Lane& lane = response.lanes(i);
    LiveViewJson l;
    l["id"] = lane.id();
    l["color"] = EnumWord(v1::MarkingColor_Name(lane.color()), "MARKING_COLOR_");
    l["type"] = EnumWord(v1::MarkingType_Name(lane.type()), "MARKING_TYPE_");
    l["score"] = lane.score();
    l["offset_m"] = NearOffset(lane);
    l["confirmed"] = lane.confirmed();
    l["predicted"] = lane.predicted();
    l["inferred"] = lane.inferred();
    l["ego"] = lane.id() > 0 && lane.id() == left    ? "left"
               : lane.id() > 0 && lane.id() == right ? "right"
                                                     : "";
    l["draw_colour"] = LiveSlotHex(slots[static_cast<size_t>(i)]);
    lanes.push_back(std::move(l));
  }
  return lanes;
}

double Finite(double v) { return std::isfinite(v) ? v : 0.0; }

}  // namespace

LiveView::Json LiveView::SummaryJson(const Session& session, int64_t now_ns) const {
  const LiveSummary s = session.live->Summarize(now_ns, absl::ToInt64Nanoseconds(options_.window));
  const CalibrationSnapshot calibration = session.Calibration();
  Json j;
  j["camera_id"] = session.camera_id;
  j["version"] = session.version;
  j["fps"] = s.fps;
  j["p50_ms"] = s.p50_ms;
  j["p99_ms"] = s.p99_ms;
  j["lanes_per_frame"] = s.lanes_per_frame;
  j["frames_total"] = s.frames_total;
  j["last_frame_unix_ms"] = s.last_frame_unix_ns / 1000000;
  j["stale"] = s.last_frame_unix_ns > 0 &&
               now_ns - s.last_frame_unix_ns > absl::ToInt64Nanoseconds(options_.stale_after);
  j["zero_lanes"] = s.window_ok_frames > 0 && s.lanes_per_frame == 0;
  if (s.last_error_unix_ns > 0) {
    j["last_error"] = {{"code", s.last_error_code},
                       {"message", s.last_error},
                       {"unix_ms", s.last_error_unix_ns / 1000000}};
  } else {
    j["last_error"] = nullptr;
  }
  Json c;
  c["state"] = session.calibration.auto_calibrate ? "auto-calibrating" : "fixed";
  c["confidence"] = Finite(calibration.confidence);
  c["frames_used"] = calibration.frames_used;
  c["drift_pitch_deg"] = Finite(calibration.drift_pitch_deg);
  c["drift_yaw_deg"] = Finite(calibration.drift_yaw_deg);
  c["rederived"] = calibration.rederived;
  c["refused"] = calibration.refused;
  c["last_refusal"] = calibration.last_refusal;
  j["calibration"] = std::move(c);
  j["watched"] = session.live->Watched(now_ns);
  return j;
}

LiveView::Json LiveView::SessionsJson() const {
  const int64_t now_ns = absl::GetCurrentTimeNanos();
  Json sessions = Json::array();
  for (const SessionRegistry::Entry& entry : sessions_.List()) {
    if (entry.session->live != nullptr) sessions.push_back(SummaryJson(*entry.session, now_ns));
  }
  Json out;
  out["now_unix_ms"] = now_ns / 1000000;
  out["window_seconds"] = absl::ToDoubleSeconds(options_.window);
  out["sessions"] = std::move(sessions);
  return out;
}

LiveView::Json LiveView::CameraJson(const std::shared_ptr<Session>& session) const {
  const int64_t now_ns = absl::GetCurrentTimeNanos();
  Json j = SummaryJson(*session, now_ns);
  j["now_unix_ms"] = now_ns / 1000000;
  const std::shared_ptr<const lane::Detector> detector = session->CurrentDetector();
  const lane::CameraModel& camera = detector->ipm().camera();
  j["width"] = camera.image_width;
  j["height"] = camera.image_height;
  j["horizon_row"] = Finite(camera.HorizonRow());
  const Eigen::Vector2d vp = camera.VanishingPoint();
  j["vanishing_point"] = {Finite(vp.x()), Finite(vp.y())};
  const lane::FrameNeeds& needs = detector->Needs();
  if (session->decode.full_decode) {
    j["decoded_rows"] = {0, camera.image_height};
    j["decoded_pixels"] = "whole frames";
  } else {
    j["decoded_rows"] = {needs.top, needs.bottom};
    j["decoded_pixels"] = needs.pixels == lane::FrameNeeds::Pixels::kRed
                              ? "red channel, JPEG/PNG; raw frames whole"
                              : "colour, JPEG/PNG; raw frames whole";
  }
  j["draw_fps"] = options_.fps;
  const std::shared_ptr<const LivePictures> pictures = session->live->pictures();
  if (pictures != nullptr) {
    j["picture"] = {{"seq", pictures->seq},
                    {"frame_id", pictures->frame_id},
                    {"drawn_unix_ms", pictures->drawn_unix_ns / 1000000}};
  } else {
    j["picture"] = nullptr;
  }
  const std::optional<v1::FrameResponse> last = session->live->LastResponse();
  if (last.has_value()) {
    Json r;
    r["frame_id"] = last->frame_id();
    r["status"] = EnumWord(v1::FrameCode_Name(last->status().code()), "FRAME_CODE_");
    r["lanes"] = LanesJson(*last);
    if (last->has_ego()) {
      const v1::EgoLane& e = last->ego();
      r["ego"] = {{"offset_m", e.offset_m()},           {"width_m", e.width_m()},
                  {"heading_deg", e.heading_deg()},     {"left_lane_id", e.left_lane_id()},
                  {"right_lane_id", e.right_lane_id()}, {"departing", e.departing()}};
    } else {
      r["ego"] = nullptr;
    }
    j["last_response"] = std::move(r);
  } else {
    j["last_response"] = nullptr;
  }
  Json history = Json::array();
  for (const LiveSecond& s : session->live->History(now_ns)) {
    history.push_back({s.second, s.frames, s.ok_frames, s.lanes, s.zero_lane_frames,
                       s.frames > 0 ? s.latency_sum_ms / s.frames : 0.0f, s.latency_max_ms});
  }
  j["history"] = std::move(history);
  j["history_seconds"] = LiveFeed::kHistorySeconds;
  return j;
}

}  // namespace lane::server
