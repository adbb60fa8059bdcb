// A stream of one camera's frames that survives server restarts: every frame
// is answered exactly once, in order.
//
// Frames are read from a source as the window allows (at most `window` frames
// unanswered), written on a StreamFrames call from a writer thread, and their
// responses are matched to them by frame_id, in order, on the calling thread.
// When the call fails with a transient status (UNAVAILABLE, a broken
// connection, a stalled stream, a session gone missing), the streamer backs
// off, re-creates the session with CreateSession (idempotent: UNCHANGED when
// it exists), opens a new call and resends every frame that was not answered;
// within a budget: it gives up when the same status code repeats past
// max_reconnects reconnections, or no frame is answered for give_up_after.
// Responses already received are never asked for again, so no frame is
// answered twice.
//
// Tracking survives the reconnection too (docs/deployment.md): the streamer
// keeps the latest resume state the server sent and the largest lane id it
// has seen, and sends both with the first frame of the next call, so that
// whichever replica takes the camera goes on with the same lane ids. Every
// call carries the camera id in the `x-camera-id` header, which a proxy
// hashes to keep a camera on one replica (deploy/nginx).
#ifndef LANE_CLIENT_STREAMER_H_
#define LANE_CLIENT_STREAMER_H_

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "reconnect_backoff.h"

namespace lane::client {

struct StreamItem {
  uint64_t frame_id = 0;  // set by the streamer
  std::string name;
  std::string stem;
  // What is sent; null when the frame could not be read (local_error).
  std::shared_ptr<const lane::v1::FrameRequest> request;
  std::string local_error;
  // Sends so far, and when the last one started.
  int attempts = 0;
  // The call (1, 2, ...: StreamerStats::connections) that answered it.
  uint64_t connection = 0;
  std::chrono::steady_clock::time_point last_sent{};
};

struct StreamerOptions {
  std::string camera_id = "default";
  // The session to create (or confirm) on every connection. Without it the
  // session must exist: its config is read with GetSession at the first
  // connection and used to re-create it after a reconnection.
  std::optional<lane::v1::SessionConfig> session;
  // Replace a session with a different config (first connection only).
  bool replace = false;
  // Frames sent and not answered, at most.
  size_t window = 8;
  uint64_t first_frame_id = 0;
  // Reconnection backoff (reconnect_backoff.h): doubles from 100 ms to 2 s,
  // +-20 % jitter, from the start again once a frame is answered.
  ReconnectSchedule reconnect;
  // Give up when no frame has been answered for this long across failures
  // (the time budget) ...
  absl::Duration give_up_after = absl::Seconds(60);
  // ... or after this many reconnections in a row following failures with
  // the same status code and no frame answered (the attempts budget;
  // nullopt: no limit, 0: none). reconnect_backoff.h says why 10.
  std::optional<int> max_reconnects = kDefaultMaxReconnects;
  // A call with frames in flight and no response for this long is cancelled
  // and retried.
  absl::Duration stall_timeout = absl::Seconds(30);
  // Deadline of the unary calls (GetSession, CreateSession).
  absl::Duration call_timeout = absl::Seconds(10);
  // Send the resume state and the lowest new lane id on a reconnection.
  bool resume_tracking = true;
};

struct StreamerStats {
  uint64_t frames = 0;                // frames handed to the sink
  uint64_t connections = 0;           // StreamFrames calls opened
  uint64_t resent = 0;                // sends of a frame after its first
  uint64_t resumes = 0;               // calls opened with a resume state or lowest lane id
  uint64_t resumes_refused = 0;       // ... that the server refused (tracking restarted)
  uint64_t resume_state_bytes = 0;    // resume states received, bytes in all
  uint64_t resume_states = 0;         // resume states received
  std::vector<std::string> failures;  // why calls were retried
};

class Streamer {
 public:
  // The frame with id `frame_id` (its name, stem and request, or
  // local_error); none when there are no more frames. Runs on the writer
  // thread.
  using Source = std::function<std::optional<StreamItem>(uint64_t frame_id)>;
  // Called once per frame, in frame order, on Run's thread. `response` is
  // null for a frame with a local_error. `latency_ms`: last send to response.
  using Sink = std::function<void(const StreamItem& item, const lane::v1::FrameResponse* response,
                                  double latency_ms)>;
  using Logger = std::function<void(const std::string& message)>;

  Streamer(std::shared_ptr<grpc::Channel> channel, StreamerOptions options, Logger log = nullptr);

  // OK when every frame of the source has been handed to the sink. Otherwise
  // the error that stopped it, with the failed call's own code: not
  // transient, the same code past max_reconnects reconnections, or no
  // progress for give_up_after (RetryBudget). INVALID_ARGUMENT at once, before
  // any call, for a camera id the server would refuse (wire/camera_id.h).
  // Frames handed to the sink before stay handed.
  absl::Status Run(const Source& source, const Sink& sink);

  const StreamerStats& stats() const { return stats_; }
  // The session as the server last returned it (set once Run has connected).
  const std::optional<lane::v1::Session>& session() const { return session_; }

 private:
  using Clock = std::chrono::steady_clock;
  using Stream = grpc::ClientReaderWriter<lane::v1::FrameRequest, lane::v1::FrameResponse>;

  grpc::Status PrepareSession(bool first_connection);
  // How one StreamFrames call ended, and whether it answered some frame.
  struct Attempt {
    grpc::Status status;
    bool progress = false;
  };
  Attempt RunAttempt(const Source& source, const Sink& sink);
  // The frames a response for `frame_id` answers (local errors before it,
  // then its own), taken from pending_; or, when it answers no frame in
  // flight, a protocol error message.
  struct Answered {
    std::vector<std::shared_ptr<StreamItem>> ready;
    std::string protocol_error;  // "" when it answered a frame
  };
  Answered TakeAnswered(uint64_t frame_id, Clock::time_point now);
  void WriterLoop(Stream* stream, const Source& source);
  void WatchdogLoop(grpc::ClientContext* context);
  void EmitLocalErrors(const Sink& sink);
  // What a response says for the next call: its resume state, its lane ids.
  void Remember(const lane::v1::FrameResponse& response);
  void Log(const std::string& message) const;

  std::unique_ptr<lane::v1::LaneService::Stub> stub_;
  const StreamerOptions options_;
  const Logger log_;
  std::optional<lane::v1::SessionConfig> config_;  // what is (re-)created
  std::optional<lane::v1::Session> session_;
  StreamerStats stats_;

  absl::Mutex mu_;
  absl::CondVar cv_;
  // Not yet handed to the sink, in order.
  std::deque<std::shared_ptr<StreamItem>> pending_ ABSL_GUARDED_BY(mu_);
  // Items at the front of pending_ the writer has passed this call.
  size_t passed_ ABSL_GUARDED_BY(mu_) = 0;
  size_t unanswered_ ABSL_GUARDED_BY(mu_) = 0;  // items of pending_ with a request
  size_t written_ ABSL_GUARDED_BY(mu_) = 0;     // items written on this call and not answered
  uint64_t next_frame_id_ ABSL_GUARDED_BY(mu_) = 0;
  // The latest resume state received, and the largest lane id seen.
  std::string resume_state_ ABSL_GUARDED_BY(mu_);
  int32_t max_lane_id_ ABSL_GUARDED_BY(mu_) = 0;
  bool resuming_ ABSL_GUARDED_BY(mu_) = false;  // this call's first frame resumes
  bool source_done_ ABSL_GUARDED_BY(mu_) = false;
  bool attempt_over_ ABSL_GUARDED_BY(mu_) = false;
  bool writer_done_ ABSL_GUARDED_BY(mu_) = false;
  bool stalled_ ABSL_GUARDED_BY(mu_) = false;
  Clock::time_point last_activity_ ABSL_GUARDED_BY(mu_);
};

// Whether a failed call is worth retrying after a reconnection.
bool IsTransient(grpc::StatusCode code);

}  // namespace lane::client

#endif  // LANE_CLIENT_STREAMER_H_
