// The work of one frame: on a worker thread, decode and detect (for a tracked
// session, lane::FrameTracker's Measure); in frame order, when the response
// is written, track (Commit) and put the lanes into the response. Shared by
// StreamFrames and Detect.
#ifndef LANE_SERVER_FRAME_PROCESSOR_H_
#define LANE_SERVER_FRAME_PROCESSOR_H_

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "lane/detector.h"
#include "lane/v1/lane_service.pb.h"
#include "live_feed.h"
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

// Decodes and detects `request`'s frame with the session's detector: an OK
// frame's detection goes into `detection` (its lanes stay lanes until
// FinishFrame), and `response` gets the status, timings and calibration
// version. A bad frame is not an error of the call: its status goes into the
// response and is also returned. Records queue wait, stage durations, frame
// latency and the frame's result in `metrics`.
// With `tracked` (a tracked session's frame), this is the session tracker's
// Measure: the detector also searches the predicted lanes, and each lane's
// colour and type are read for FinishFrame's vote.
// With `live_sample` (the live view is on): when the session's camera is
// watched and its draw interval has passed (LiveFeed::ClaimDrawTurn), the
// decoded frame's rows go there (LiveFrame: the rows the detector read, or
// the whole frame for raw frames and full_decode sessions); otherwise it is
// left empty, and nothing is copied.
absl::Status ProcessFrame(const v1::FrameRequest& request, Session& session,
                          const FrameLimits& limits, const Arrival& arrival, Metrics& metrics,
                          v1::FrameResponse* response, std::optional<lane::Detection>* detection,
                          bool tracked = false, LiveFrame* live_sample = nullptr);

// In frame order, after ProcessFrame, when the response is about to be
// written: with `tracked`, an OK frame's detection goes through the session
// tracker's Commit (ids, confirmed flags, voted colours and types, predicted
// lanes, the ego lane; time: the frame's capture time when it has one); then
// its lanes and ego lane go into `response`. Nothing for a failed frame.
void FinishFrame(Session& session, bool tracked, std::optional<lane::Detection>& detection,
                 v1::FrameResponse* response);

// Answers a frame without processing it (dropped, or refused before
// processing): sets the status and counts the result.
void AnswerUnprocessed(const absl::Status& status, Metrics& metrics, v1::FrameResponse* response);

}  // namespace lane::server

#endif  // LANE_SERVER_FRAME_PROCESSOR_H_
