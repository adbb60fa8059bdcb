// The work of one frame, on a worker thread: decode, detect, fill the
// response, record the metrics. Shared by StreamFrames and Detect.
#ifndef LANE_SERVER_FRAME_PROCESSOR_H_
#define LANE_SERVER_FRAME_PROCESSOR_H_

#include <chrono>
#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "lane/v1/lane_service.pb.h"
#include "metrics.h"
#include "session.h"

namespace lane::server {

using SteadyTime = std::chrono::steady_clock::time_point;

// When the server read a frame.
struct Arrival {
  SteadyTime steady;    // for durations
  int64_t unix_ns = 0;  // for the response's timestamps
  static Arrival Now();
};

double SecondsSince(SteadyTime start);

// The fields of a response that do not depend on processing: frame id,
// capture time, camera id, receive time.
void StartResponse(const v1::FrameRequest& request, const std::string& camera_id,
                   const Arrival& arrival, v1::FrameResponse* response);

// Server-wide bounds on one frame's work.
struct FrameLimits {
  // Largest frame accepted, width * height (checked on the header).
  int64_t max_frame_pixels = int64_t{3840} * 2160;
  // CPU-time budget of one frame's decode (lane::decode::DecodeOptions::
  // cpu_budget, the worker thread's own CPU time): beyond it the frame is
  // FRAME_CODE_RESOURCE_EXHAUSTED and the worker is free again.
  absl::Duration decode_cpu_budget = absl::Milliseconds(500);
};

// Decodes and detects `request`'s frame with the session's detector and fills
// `response` (status, lanes, timings, calibration version). A bad frame is
// not an error of the call: its status goes into the response and is also
// returned. Records queue wait, stage durations, frame latency and the
// frame's result in `metrics`.
// With `tracked` (a tracked session's frame), the detector also searches the
// tracker's predicted lanes (Session::Prior), and each lane's paint colour
// and type in this frame go into the response for TrackFrame's vote.
absl::Status ProcessFrame(const v1::FrameRequest& request, const Session& session,
                          const FrameLimits& limits, const Arrival& arrival, Metrics& metrics,
                          v1::FrameResponse* response, bool tracked = false);

// In frame order, after ProcessFrame: an OK frame's lanes through the
// session's tracker: ids, confirmed flags, voted colours and the ego lane
// into the response. Time: the frame's capture time when it has one.
void TrackFrame(const Session& session, v1::FrameResponse* response);

// Answers a frame without processing it (dropped, or refused before
// processing): sets the status and counts the result.
void AnswerUnprocessed(const absl::Status& status, Metrics& metrics, v1::FrameResponse* response);

}  // namespace lane::server

#endif  // LANE_SERVER_FRAME_PROCESSOR_H_
