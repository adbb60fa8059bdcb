// One StreamFrames call: a bidirectional reactor with one outstanding read
// and one outstanding write.
//
//   read  -> Slot (in arrival order) -> worker: decode + detect -> Slot done
//   front Slot done -> write -> pop -> next read / write / finish
//
// Frames are processed in parallel on the worker pool, but only the oldest
// slot is ever written, so responses keep the order of the requests. At most
// the session's max_inflight_frames frames are received and unanswered; at
// that bound the stream stops reading (block) or drops the oldest earlier
// frame not yet started (drop_oldest). Finish is called exactly once: after
// the client half-closes and every frame is answered (OK), at a stream-level
// error (after the frames before it are answered), when the server drains
// (after every received frame is answered; UNAVAILABLE), or when the call is
// cancelled.
#ifndef LANE_SERVER_FRAME_STREAM_H_
#define LANE_SERVER_FRAME_STREAM_H_

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/status.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "session.h"

namespace lane::server {

class LaneServiceImpl;

// Requests and responses are bytes (see raw_call.h): a message that does not
// parse ends the stream with INVALID_ARGUMENT once the frames before it are
// answered.
class FrameStream final : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  explicit FrameStream(LaneServiceImpl& service);

  // Starts reading, or finishes at once with `reject` when it is not OK.
  // Called once, by the service, after it has registered the stream (or
  // decided not to).
  void Start(const absl::Status& reject, bool registered);
  // The server drains: stop reading, answer what was received, end with
  // UNAVAILABLE.
  void BeginDrain();

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  struct Slot;

  ~FrameStream() override;

  // Runs on a worker.
  void Process(const std::shared_ptr<Slot>& slot);

  void ApplyPolicyLocked(const Session& session);
  void MaybeReadLocked();
  void MaybeWriteLocked();
  void MaybeFinishLocked();
  void FinishLocked(const absl::Status& status);
  void PopFrontLocked();
  bool DropOldestQueuedLocked();
  void AnswerLocked(Slot& slot, const absl::Status& status);

  void Ref() { refs_.fetch_add(1, std::memory_order_relaxed); }
  void Unref();

  LaneServiceImpl& service_;
  // One for gRPC (released in OnDone) and one per task on the pool.
  std::atomic<int> refs_{1};
  // Set when the answers are no longer wanted (cancelled or finished):
  // workers then skip the work.
  std::atomic<bool> abandoned_{false};

  std::mutex mu_;
  // Everything below is guarded by mu_.
  grpc::ByteBuffer read_buffer_;
  std::deque<std::shared_ptr<Slot>> slots_;  // received, not yet answered, in order
  size_t inflight_ = 0;                      // slots that count against the bound
  uint32_t max_inflight_ = 1;
  Backpressure backpressure_ = Backpressure::kBlock;
  std::string camera_id_;  // the first camera id seen on the stream
  bool registered_ = false;
  bool started_ = false;
  bool first_request_ = true;
  bool reading_ = false;
  bool writing_ = false;
  bool read_done_ = false;       // the client half-closed (or the read side failed)
  bool awaiting_setup_ = false;  // the first frame's session is being created
  bool stream_failed_ = false;   // a stream-level error is queued
  bool draining_ = false;
  bool cancelled_ = false;
  bool finished_ = false;
};

}  // namespace lane::server

#endif  // LANE_SERVER_FRAME_STREAM_H_
