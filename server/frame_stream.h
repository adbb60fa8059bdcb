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
#include <functional>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "frame_processor.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "live_view.h"
#include "metrics.h"
#include "resume_seal.h"
#include "session.h"
#include "session_registry.h"
#include "stream_resume.h"
#include "worker_pool.h"

namespace lane::server {

class FrameStream;

// What every stream of the server does beyond its session's policy.
struct StreamOptions {
  // A tracked stream's response carries the camera tracker's resume state
  // (FrameResponse.resume_state) on its first frame, every this many frames
  // after, and on every frame answered while the stream drains. 0 = never.
  uint32_t resume_state_every = 15;
  // A stream older than this (each stream draws it within -10 %..+0 %, so
  // that streams started together do not all end together) stops reading at
  // its next frame, answers every frame it received and ends with
  // UNAVAILABLE: its client reconnects, through the proxy or the resolver,
  // to whichever replica now owns its camera. Infinite = never.
  absl::Duration max_age = absl::InfiniteDuration();
};

// What a stream needs from the server, handed over once.
struct StreamDeps {
  SessionRegistry& sessions;
  // Seals and opens resume states.
  const ResumeStateSeal& seal;
  WorkerPool& pool;
  Metrics& metrics;
  FrameLimits limits;
  StreamOptions options;
  // Called once from OnDone, before the stream deletes itself (the service
  // unregisters it there). May be empty.
  std::function<void(FrameStream*)> on_done;
  // The live view (--live_view), or null: every written response is
  // recorded there.
  LiveView* live_view = nullptr;
};

// Requests and responses are bytes (see raw_call.h): a message that does not
// parse ends the stream with INVALID_ARGUMENT once the frames before it are
// answered.
class FrameStream final : public grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  explicit FrameStream(StreamDeps deps);

  // Starts reading, or finishes at once with `reject` when it is not OK.
  // Called once, after the service has registered the stream (or decided
  // not to).
  void Start(const absl::Status& reject);
  // The server drains: stop reading, answer what was received, end with
  // UNAVAILABLE.
  void BeginDrain();

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  struct Slot;

  // The stream's lifecycle. Reads happen only while kOpen; every other state
  // but kFinished answers the frames already received and then finishes with
  // the state's status.
  enum class Phase {
    kCreated,     // Start not called yet
    kOpen,        // reading frames
    kHalfClosed,  // the client half-closed (or the read side failed): then OK
    kFailing,     // a stream-level error is queued behind earlier frames: then it
    kDraining,    // the server drains, or the stream reached max_age: then UNAVAILABLE
    kCancelled,   // cancelled or the client went away: nothing more is written
    kFinished,    // Finish was called
  };

  ~FrameStream() override;

  // Runs on a worker.
  void Process(const std::shared_ptr<Slot>& slot);

  void ReceiveLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void ApplyPolicyLocked(const Session& session) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void MaybeReadLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The resume state goes into the front slot's response when it is due.
  void MaybeAttachResumeStateLocked(Slot& front) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void MaybeWriteLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void MaybeFinishLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void FinishLocked(const absl::Status& status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void FailLocked(const std::shared_ptr<Slot>& slot, const absl::Status& error)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void PopFrontLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  bool DropOldestQueuedLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void AnswerLocked(Slot& slot, const absl::Status& status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  void Ref() { refs_.fetch_add(1, std::memory_order_relaxed); }
  void Unref();

  StreamDeps deps_;
  // grpc_server_* of this call: a frame read is a message received, a
  // response written a message sent.
  GrpcMetrics::Call call_metrics_;
  // One for gRPC (released in OnDone) and one per task on the pool.
  std::atomic<int> refs_{1};
  // Set when the answers are no longer wanted (cancelled or finished):
  // workers then skip the work.
  std::atomic<bool> abandoned_{false};

  absl::Mutex mu_;
  Phase phase_ ABSL_GUARDED_BY(mu_) = Phase::kCreated;
  grpc::ByteBuffer read_buffer_ ABSL_GUARDED_BY(mu_);
  // Received, not yet answered, in order.
  std::deque<std::shared_ptr<Slot>> slots_ ABSL_GUARDED_BY(mu_);
  // Slots that count against the bound.
  size_t inflight_ ABSL_GUARDED_BY(mu_) = 0;
  uint32_t max_inflight_ ABSL_GUARDED_BY(mu_) = 1;
  Backpressure backpressure_ ABSL_GUARDED_BY(mu_) = Backpressure::kBlock;
  // The first camera id seen on the stream.
  std::string camera_id_ ABSL_GUARDED_BY(mu_);
  bool first_request_ ABSL_GUARDED_BY(mu_) = true;    // no request received yet
  bool reading_ ABSL_GUARDED_BY(mu_) = false;         // a read is outstanding
  bool writing_ ABSL_GUARDED_BY(mu_) = false;         // a write is outstanding
  bool awaiting_setup_ ABSL_GUARDED_BY(mu_) = false;  // the first frame's session is being created
                                                      // or its tracker resumed
  // Responses written since the last one with a resume state; -1 before
  // the first tracked answer.
  int64_t since_resume_state_ ABSL_GUARDED_BY(mu_) = -1;
  // When the stream drains by itself (StreamOptions::max_age).
  absl::Time end_of_life_ ABSL_GUARDED_BY(mu_) = absl::InfiniteFuture();
  bool aged_ ABSL_GUARDED_BY(mu_) = false;  // drained by max_age
};

}  // namespace lane::server

#endif  // LANE_SERVER_FRAME_STREAM_H_
