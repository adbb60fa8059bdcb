#include "results.h"

#include <nlohmann/json.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "io/results_json.h"
#include "wire/config_proto.h"
#include "wire/detection_proto.h"

namespace lane::client {
namespace {

using Json = nlohmann::ordered_json;
namespace v1 = lane::v1;

// The record `lane detect` writes for the response's frame.
Json DetectRecord(const std::string& frame_name, const v1::FrameResponse& response,
                  const StreamSession& session) {
  const bool ok = response.status().code() == v1::FRAME_CODE_OK;
  // A failed frame's size is not known here (it may be the wrong one).
  const io::ResultsFrame frame{frame_name, ok ? session.width : 0, ok ? session.height : 0,
                               session.mode};
  const double decode_ms = response.timings().decode_ms();
  if (ok && session.tracked) {
    return io::DetectionJson(frame, lane::wire::TrackedFrameFromProto(response), decode_ms);
  }
  return io::DetectionJson(frame, lane::wire::DetectionFromProto(response), decode_ms);
}

}  // namespace

absl::StatusOr<StreamSession> StreamSessionOf(const v1::Session& session) {
  absl::StatusOr<lane::Config> config = lane::wire::ConfigFromProto(session.config());
  if (!config.ok()) return config.status();
  StreamSession out;
  out.width = config->camera.image_width;
  out.height = config->camera.image_height;
  out.mode = config->detector.mode;
  out.tracked = !session.config().tracking().disabled();
  return out;
}

std::string FrameCodeName(v1::FrameCode code) {
  if (!v1::FrameCode_IsValid(code)) return absl::StrCat("UNKNOWN_", static_cast<int>(code));
  std::string name = v1::FrameCode_Name(code);
  constexpr absl::string_view kPrefix = "FRAME_CODE_";
  if (absl::StartsWith(name, kPrefix)) name.erase(0, kPrefix.size());
  return name;
}

std::string ResponseJsonLine(const std::string& frame_name, const v1::FrameResponse& response,
                             const StreamSession& session, double latency_ms, int attempts,
                             uint64_t connection) {
  Json out = DetectRecord(frame_name, response, session);
  // The server's timings: its queue wait first, and the detector's total
  // also under the name this file has always used for it.
  Json timing = Json::object();
  timing["queue_wait"] = io::RoundTo(response.timings().queue_wait_ms(), 3);
  for (const auto& item : out["timing_ms"].items()) timing[item.key()] = item.value();
  timing["detect"] = timing["total"];
  out["timing_ms"] = std::move(timing);
  out["camera_id"] = response.camera_id();
  out["frame_id"] = response.frame_id();
  out["capture_time_unix_ns"] = response.capture_time_unix_ns();
  out["server_receive_time_unix_ns"] = response.server_receive_time_unix_ns();
  out["server_send_time_unix_ns"] = response.server_send_time_unix_ns();
  out["status"] = FrameCodeName(response.status().code());
  if (response.status().code() != v1::FRAME_CODE_OK) out["error"] = response.status().message();
  out["calibration_version"] = response.calibration_version();
  out["latency_ms"] = io::RoundTo(latency_ms, 3);
  out["attempts"] = attempts;
  if (connection > 0) out["connection"] = connection;
  return io::JsonLine(out);
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
  return io::JsonLine(out);
}

}  // namespace lane::client
