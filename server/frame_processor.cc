#include "frame_processor.h"

#include <algorithm>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "lane/track/frame_tracker.h"
#include "session_proto.h"
#include "wire/config_proto.h"
#include "wire/detection_proto.h"
#include "wire/frame_decoder.h"
#include "wire/status_map.h"
#include "wire/tracker_state_proto.h"

namespace lane::server {
namespace {

double MillisecondsBetween(SteadyTime a, SteadyTime b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

Arrival Arrival::Now() {
  return Arrival{std::chrono::steady_clock::now(), absl::GetCurrentTimeNanos()};
}

double SecondsSince(SteadyTime start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void StartResponse(const v1::FrameRequest& request, const std::string& camera_id,
                   const Arrival& arrival, v1::FrameResponse* response) {
  response->set_frame_id(request.frame_id());
  response->set_capture_time_unix_ns(request.capture_time_unix_ns());
  response->set_camera_id(camera_id);
  response->set_server_receive_time_unix_ns(arrival.unix_ns);
}

absl::Status ProcessFrame(const v1::FrameRequest& request, Session& session,
                          const FrameLimits& limits, const Arrival& arrival, Metrics& metrics,
                          v1::FrameResponse* response, std::optional<lane::Detection>* detection,
                          bool tracked, LiveFrame* live_sample) {
  const SteadyTime start = std::chrono::steady_clock::now();
  const double queue_wait_ms = MillisecondsBetween(arrival.steady, start);
  metrics.ObserveQueueWait(queue_wait_ms * 1e-3);
  metrics.ObserveFrameBytes(request.ByteSizeLong());
  response->set_calibration_version(session.version);
  v1::StageTimings* timings = response->mutable_timings();
  timings->set_queue_wait_ms(queue_wait_ms);

  wire::DecodeOptions decode;
  decode.width = session.config.camera.image_width;
  decode.height = session.config.camera.image_height;
  decode.max_pixels = limits.max_frame_pixels;
  decode.accept_damaged = session.decode.accept_damaged_frames;
  decode.cpu_budget = limits.decode_cpu_budget;

  absl::Status status;
  detection->reset();
  try {
    // Only the rows and channel the detector reads, unless the session asks
    // for whole frames.
    const std::shared_ptr<const lane::Detector> detector = session.CurrentDetector();
    absl::StatusOr<cv::Mat> frame = wire::DecodeFrame(
        request, decode, session.decode.full_decode ? nullptr : &detector->Needs());
    const SteadyTime decoded = std::chrono::steady_clock::now();
    const double decode_ms = MillisecondsBetween(start, decoded);
    timings->set_decode_ms(decode_ms);
    metrics.ObserveDecode(decode_ms * 1e-3);
    if (!frame.ok()) {
      status = frame.status();
    } else {
      if (live_sample != nullptr && session.live != nullptr &&
          session.live->ClaimDrawTurn(absl::GetCurrentTimeNanos())) {
        // Region decoding leaves the rows the detector does not read
        // undefined: only the others are kept.
        const bool region = !session.decode.full_decode && request.has_encoded();
        *live_sample = LiveFrame::Copy(*frame, region ? detector->Needs().top : 0,
                                       region ? detector->Needs().bottom : frame->rows);
      }
      absl::StatusOr<lane::Detection> detected =
          tracked ? session.tracker().Measure(*detector, *frame) : detector->Detect(*frame);
      if (detected.ok()) {
        session.ObserveLanes(detected->lanes);
        wire::TimingsToProto(detected->timings, timings);
        metrics.ObserveDetectorStages(detected->timings);
        metrics.ObserveLanes(detected->lanes.size());
        metrics.CountLanePaths(*detected);
        session.frames_processed.fetch_add(1, std::memory_order_relaxed);
        *detection = *std::move(detected);
      } else {
        status = detected.status();
      }
    }
  } catch (const std::exception& e) {
    // The core reports errors as values; an exception is a bug, not the
    // client's fault.
    status = absl::InternalError(absl::StrCat("detector failed: ", e.what()));
    detection->reset();
  }
  wire::ToFrameStatus(status, response->mutable_status());
  const wire::FrameResult result = wire::ToFrameResult(response->status().code());
  metrics.CountFrame(result);
  metrics.CountCameraFrame(session.camera_id, result,
                           *detection ? (*detection)->lanes.size() : size_t{0});
  metrics.ObserveFrameLatency(SecondsSince(arrival.steady));
  return status;
}

void FinishFrame(Session& session, bool tracked, std::optional<lane::Detection>& detection,
                 v1::FrameResponse* response) {
  if (!detection) return;
  if (tracked) {
    std::optional<double> time_s;
    if (response->capture_time_unix_ns() > 0) time_s = response->capture_time_unix_ns() * 1e-9;
    session.tracker().Commit(*session.CurrentDetector(), *detection, time_s);
  }
  wire::LanesToProto(*detection, response);
}

void AnswerUnprocessed(const absl::Status& status, Metrics& metrics, v1::FrameResponse* response) {
  wire::ToFrameStatus(status, response->mutable_status());
  metrics.CountFrame(wire::ToFrameResult(response->status().code()));
}

}  // namespace lane::server
