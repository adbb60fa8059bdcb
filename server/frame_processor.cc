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

// A tracked session's frame is its tracker's Measure; an untracked one's,
// the detection alone (no markings read).
absl::StatusOr<lane::MeasuredFrame> Measure(Session& session, const lane::Detector& detector,
                                            const cv::Mat& frame, bool tracked) {
  if (tracked) return session.tracker().Measure(detector, frame);
  absl::StatusOr<lane::Detection> detection = detector.Detect(frame);
  if (!detection.ok()) return detection.status();
  return lane::MeasuredFrame{*std::move(detection), {}};
}

}  // namespace

Arrival Arrival::Now() {
  return Arrival{std::chrono::steady_clock::now(), absl::GetCurrentTimeNanos()};
}

double SecondsSince(SteadyTime start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

v1::FrameResponse StartResponse(const v1::FrameRequest& request, const std::string& camera_id,
                                const Arrival& arrival) {
  v1::FrameResponse response;
  response.set_frame_id(request.frame_id());
  response.set_capture_time_unix_ns(request.capture_time_unix_ns());
  response.set_camera_id(camera_id);
  response.set_server_receive_time_unix_ns(arrival.unix_ns);
  return response;
}

ProcessedFrame ProcessFrame(const v1::FrameRequest& request, Session& session,
                            const FrameLimits& limits, const Arrival& arrival, Metrics& metrics,
                            bool tracked, bool sample_live) {
  const SteadyTime start = std::chrono::steady_clock::now();
  const double queue_wait_ms = MillisecondsBetween(arrival.steady, start);
  metrics.ObserveQueueWait(queue_wait_ms * 1e-3);
  metrics.ObserveFrameBytes(request.ByteSizeLong());
  ProcessedFrame processed;
  FrameOutcome& outcome = processed.outcome;
  outcome.calibration_version = session.version;
  double decode_ms = 0;

  wire::DecodeOptions decode;
  decode.width = session.config.camera.image_width;
  decode.height = session.config.camera.image_height;
  decode.max_pixels = limits.max_frame_pixels;
  decode.accept_damaged = session.decode.accept_damaged_frames;
  decode.cpu_budget = limits.decode_cpu_budget;

  try {
    // Only the rows and channel the detector reads, unless the session asks
    // for whole frames.
    const std::shared_ptr<const lane::Detector> detector = session.CurrentDetector();
    absl::StatusOr<cv::Mat> frame = wire::DecodeFrame(
        request, decode, session.decode.full_decode ? nullptr : &detector->Needs());
    decode_ms = MillisecondsBetween(start, std::chrono::steady_clock::now());
    metrics.ObserveDecode(decode_ms * 1e-3);
    if (!frame.ok()) {
      outcome.status = frame.status();
    } else {
      if (sample_live && session.live != nullptr &&
          session.live->ClaimDrawTurn(absl::GetCurrentTimeNanos())) {
        // Region decoding leaves the rows the detector does not read
        // undefined: only the others are kept.
        const bool region = !session.decode.full_decode && request.has_encoded();
        processed.live_sample = LiveFrame::Copy(*frame, region ? detector->Needs().top : 0,
                                                region ? detector->Needs().bottom : frame->rows);
      }
      absl::StatusOr<lane::MeasuredFrame> measured = Measure(session, *detector, *frame, tracked);
      if (measured.ok()) {
        const lane::Detection& detected = measured->detection;
        session.ObserveLanes(detected.lanes);
        outcome.timings = wire::TimingsToProto(detected.timings);
        metrics.ObserveDetectorStages(detected.timings);
        metrics.ObserveLanes(detected.lanes.size());
        metrics.CountLanePaths(detected);
        session.frames_processed.fetch_add(1, std::memory_order_relaxed);
        outcome.measured = *std::move(measured);
      } else {
        outcome.status = measured.status();
      }
    }
  } catch (const std::exception& e) {
    // The core reports errors as values; an exception is a bug, not the
    // client's fault.
    outcome.status = absl::InternalError(absl::StrCat("detector failed: ", e.what()));
    outcome.measured.reset();
  }
  outcome.timings.set_queue_wait_ms(queue_wait_ms);
  outcome.timings.set_decode_ms(decode_ms);
  v1::FrameStatus frame_status;
  wire::ToFrameStatus(outcome.status, &frame_status);
  const wire::FrameResult result = wire::ToFrameResult(frame_status.code());
  metrics.CountFrame(result);
  metrics.CountCameraFrame(session.camera_id, result,
                           outcome.measured ? outcome.measured->detection.lanes.size() : size_t{0});
  metrics.ObserveFrameLatency(SecondsSince(arrival.steady));
  return processed;
}

v1::FrameResponse FinishFrame(Session& session, bool tracked, v1::FrameResponse response,
                              FrameOutcome outcome) {
  wire::ToFrameStatus(outcome.status, response.mutable_status());
  response.set_calibration_version(outcome.calibration_version);
  *response.mutable_timings() = std::move(outcome.timings);
  if (!outcome.measured) return response;
  if (tracked) {
    std::optional<double> time_s;
    if (response.capture_time_unix_ns() > 0) time_s = response.capture_time_unix_ns() * 1e-9;
    const lane::TrackedFrame frame =
        session.tracker().Commit(*session.CurrentDetector(), *std::move(outcome.measured), time_s);
    response.MergeFrom(wire::LanesToProto(frame));
  } else {
    response.MergeFrom(wire::LanesToProto(outcome.measured->detection));
  }
  return response;
}

v1::FrameResponse AnswerUnprocessed(const absl::Status& status, Metrics& metrics,
                                    v1::FrameResponse response) {
  wire::ToFrameStatus(status, response.mutable_status());
  metrics.CountFrame(wire::ToFrameResult(response.status().code()));
  return response;
}

}  // namespace lane::server
