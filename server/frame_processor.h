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
#include "lane/detector/detector.h"
#include "lane/track/tracked_frame.h"
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

// A response with the fields that do not depend on processing: frame id,
// capture time, camera id, receive time.
v1::FrameResponse StartResponse(const v1::FrameRequest& request, const std::string& camera_id,
                                const Arrival& arrival);

// Server-wide bounds on one frame's work.
struct FrameLimits {
  // Largest frame accepted, width * height (checked on the header).
  int64_t max_frame_pixels = int64_t{3840} * 2160;
  // CPU-time budget of one frame's decode (lane::decode::DecodeOptions::
  // cpu_budget, the worker thread's own CPU time): beyond it the frame is
  // FRAME_CODE_RESOURCE_EXHAUSTED and the worker is free again.
  absl::Duration decode_cpu_budget = absl::Milliseconds(500);
};

// What processing made of a frame, kept until its response is written
// (FinishFrame).
struct FrameOutcome {
  // OK, or why the frame failed (bad data, too large, a detector error): the
  // frame's status, not the call's.
  absl::Status status;
  uint64_t calibration_version = 0;  // the session version used
  v1::StageTimings timings;          // queue wait, decode and the detector's stages
  // An OK frame's detection (its lanes stay lanes until FinishFrame) and,
  // for a tracked session, each lane's marking for the tracker's vote.
  std::optional<lane::MeasuredFrame> measured;
};

struct ProcessedFrame {
  FrameOutcome outcome;
  // With `sample_live`, when the session's camera is watched and its draw
  // interval has passed (LiveFeed::ClaimDrawTurn): the decoded frame's rows
  // (LiveFrame: the rows the detector read, or the whole frame for raw
  // frames and full_decode sessions). Otherwise empty, and nothing is copied.
  LiveFrame live_sample;
};

// Decodes and detects `request`'s frame with the session's detector. A bad
// frame is not an error of the call: its status is the outcome's. Records
// queue wait, stage durations, frame latency and the frame's result in
// `metrics`.
// With `tracked` (a tracked session's frame), this is the session tracker's
// Measure: the detector also searches the predicted lanes, and each lane's
// colour and type are read for FinishFrame's vote.
ProcessedFrame ProcessFrame(const v1::FrameRequest& request, Session& session,
                            const FrameLimits& limits, const Arrival& arrival, Metrics& metrics,
                            bool tracked = false, bool sample_live = false);

// In frame order, after ProcessFrame, when the response is about to be
// written: `response` (StartResponse's) completed with `outcome`'s status,
// calibration version and timings and, for an OK frame, its lanes. With
// `tracked`, an OK frame goes through the session tracker's Commit first
// (ids, confirmed flags, voted colours and types, predicted lanes, the ego
// lane; time: the frame's capture time when it has one).
v1::FrameResponse FinishFrame(Session& session, bool tracked, v1::FrameResponse response,
                              FrameOutcome outcome);

// Answers a frame without processing it (dropped, or refused before
// processing): `response` with the status set; counts the result.
v1::FrameResponse AnswerUnprocessed(const absl::Status& status, Metrics& metrics,
                                    v1::FrameResponse response);

}  // namespace lane::server

#endif  // LANE_SERVER_FRAME_PROCESSOR_H_
