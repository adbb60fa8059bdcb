#include "frame_stream.h"

#include <iterator>
#include <optional>
#include <utility>

#include "absl/time/clock.h"
#include "frame_processor.h"
#include "lane_service.h"
#include "raw_call.h"
#include "wire/status_map.h"

namespace lane::server {
namespace {

enum SlotState : int { kQueued, kRunning, kDropped };

// Beyond this many slots (most of them dropped answers waiting behind a slow
// frame) a drop_oldest stream stops reading too.
size_t MaxSlots(uint32_t max_inflight) { return 4 * size_t{max_inflight} + 16; }

}  // namespace

struct FrameStream::Slot {
  std::unique_ptr<v1::FrameRequest> request;  // released once processed
  v1::FrameResponse response;
  grpc::ByteBuffer wire;  // the response, serialized for the write
  std::string camera_id;
  Arrival arrival;
  std::shared_ptr<const Session> session;  // set at receipt, or by the setup
  std::atomic<int> state{kQueued};         // kQueued -> kRunning | kDropped
  bool setup = false;                      // create/confirm the session first
  // Guarded by the stream's mu_:
  bool done = false;                         // response ready (or stream_error / skipped)
  bool in_bound = true;                      // counts against max_inflight
  bool skipped = false;                      // abandoned: nothing to send
  std::optional<absl::Status> stream_error;  // end the stream here instead
};

FrameStream::FrameStream(LaneServiceImpl& service)
    : service_(service), max_inflight_(service.sessions().options().default_max_inflight_frames) {}

FrameStream::~FrameStream() = default;

void FrameStream::Start(const absl::Status& reject, bool registered) {
  std::lock_guard<std::mutex> lock(mu_);
  registered_ = registered;
  started_ = true;
  if (!reject.ok()) {
    FinishLocked(reject);
    return;
  }
  MaybeReadLocked();
  MaybeFinishLocked();  // a drain may have come before Start
}

void FrameStream::BeginDrain() {
  std::lock_guard<std::mutex> lock(mu_);
  draining_ = true;
  if (started_) MaybeFinishLocked();
}

void FrameStream::OnReadDone(bool ok) {
  std::lock_guard<std::mutex> lock(mu_);
  reading_ = false;
  if (!ok) {
    read_done_ = true;
    MaybeFinishLocked();
    return;
  }
  if (finished_) return;  // a read that completed as the stream ended

  auto slot = std::make_shared<Slot>();
  slot->arrival = Arrival::Now();
  slot->request = std::make_unique<v1::FrameRequest>();
  service_.metrics().FrameReceived();
  if (absl::Status parsed = ParseMessage(read_buffer_, slot->request.get()); !parsed.ok()) {
    // Nothing after an unreadable message can be trusted to be a frame: end
    // the stream with the reason, after answering the frames before it.
    slot->request.reset();
    slot->stream_error = parsed;
    slot->done = true;
    stream_failed_ = true;
    slots_.push_back(slot);
    ++inflight_;
    MaybeWriteLocked();
    return;
  }
  const v1::FrameRequest& request = *slot->request;

  const bool first = first_request_;
  first_request_ = false;
  if (camera_id_.empty()) camera_id_ = request.camera_id();
  slot->camera_id = request.camera_id().empty() ? camera_id_ : request.camera_id();
  StartResponse(request, slot->camera_id, slot->arrival, &slot->response);

  bool submit = false;
  if (slot->camera_id.empty()) {
    AnswerLocked(*slot, wire::InvalidRequest("frame without camera_id"));
  } else if (absl::Status id = SessionRegistry::ValidateCameraId(slot->camera_id); !id.ok()) {
    AnswerLocked(*slot, id);
  } else if (request.has_session_config()) {
    if (first) {
      slot->setup = true;
      awaiting_setup_ = true;  // later frames need the session: read them after
      submit = true;
    } else {
      AnswerLocked(*slot, wire::InvalidRequest("session_config is only accepted on a stream's "
                                               "first request"));
    }
  } else {
    slot->session = service_.sessions().Find(slot->camera_id);
    if (slot->session == nullptr) {
      slot->stream_error = wire::NoSessionForFrame(slot->camera_id);
      slot->done = true;
      stream_failed_ = true;
    } else {
      ApplyPolicyLocked(*slot->session);
      submit = true;
    }
  }

  slots_.push_back(slot);
  ++inflight_;
  if (submit) {
    Ref();
    if (!service_.pool().Submit([this, slot] { Process(slot); })) {
      // Only after the pool has shut down, i.e. never while serving.
      refs_.fetch_sub(1, std::memory_order_relaxed);  // gRPC's ref remains
      awaiting_setup_ = false;
      AnswerLocked(*slot, wire::ServerDraining());
    } else if (backpressure_ == Backpressure::kDropOldest && inflight_ > max_inflight_) {
      DropOldestQueuedLocked();
    }
  }
  MaybeWriteLocked();
  MaybeReadLocked();
}

void FrameStream::Process(const std::shared_ptr<Slot>& slot) {
  int expected = kQueued;
  if (!slot->state.compare_exchange_strong(expected, kRunning)) {
    Unref();  // dropped before it started
    return;
  }
  const bool abandon = abandoned_.load(std::memory_order_acquire);
  absl::Status setup_error;
  if (!abandon) {
    const v1::FrameRequest& request = *slot->request;
    if (slot->setup) {
      absl::StatusOr<SessionRegistry::CreateResult> created = service_.EnsureSession(
          slot->camera_id, request.session_config(), request.replace_session());
      if (created.ok()) {
        slot->session = std::move(created->session);
      } else {
        setup_error = created.status();
      }
    }
    if (slot->session != nullptr) {
      // A bad frame's status is in its response; the stream goes on.
      ProcessFrame(request, *slot->session, service_.options().frame_limits, slot->arrival,
                   service_.metrics(), &slot->response)
          .IgnoreError();
    }
  }
  slot->request.reset();  // the frame's bytes are no longer needed
  {
    std::lock_guard<std::mutex> lock(mu_);
    slot->done = true;
    slot->skipped = abandon;
    if (slot->setup) {
      awaiting_setup_ = false;
      if (!setup_error.ok()) {
        slot->stream_error = setup_error;
        stream_failed_ = true;
      } else if (slot->session != nullptr) {
        ApplyPolicyLocked(*slot->session);
      }
    }
    MaybeWriteLocked();
    MaybeReadLocked();
    MaybeFinishLocked();
  }
  Unref();
}

void FrameStream::OnWriteDone(bool ok) {
  std::lock_guard<std::mutex> lock(mu_);
  writing_ = false;
  if (!slots_.empty()) PopFrontLocked();  // the slot just written
  if (!ok || cancelled_) {
    FinishLocked(absl::CancelledError("the stream was cancelled or the client went away"));
    return;
  }
  MaybeWriteLocked();
  MaybeReadLocked();
  MaybeFinishLocked();
}

void FrameStream::OnCancel() {
  std::lock_guard<std::mutex> lock(mu_);
  cancelled_ = true;
  abandoned_.store(true, std::memory_order_release);
  // With a write outstanding, OnWriteDone finishes.
  if (!writing_) FinishLocked(absl::CancelledError("the stream was cancelled"));
}

void FrameStream::OnDone() {
  bool registered;
  {
    std::lock_guard<std::mutex> lock(mu_);
    registered = registered_;
  }
  if (registered) service_.Unregister(this);
  Unref();
}

void FrameStream::Unref() {
  if (refs_.fetch_sub(1, std::memory_order_acq_rel) == 1) delete this;
}

void FrameStream::ApplyPolicyLocked(const Session& session) {
  max_inflight_ = session.stream.max_inflight_frames;
  backpressure_ = session.stream.backpressure;
}

void FrameStream::AnswerLocked(Slot& slot, const absl::Status& status) {
  AnswerUnprocessed(status, service_.metrics(), &slot.response);
  slot.done = true;
}

void FrameStream::MaybeReadLocked() {
  if (reading_ || read_done_ || finished_ || cancelled_ || draining_ || stream_failed_ ||
      awaiting_setup_ || !started_) {
    return;
  }
  const bool room = backpressure_ == Backpressure::kBlock
                        ? inflight_ < max_inflight_
                        : inflight_ <= max_inflight_ && slots_.size() < MaxSlots(max_inflight_);
  if (!room) return;
  reading_ = true;
  StartRead(&read_buffer_);
}

void FrameStream::MaybeWriteLocked() {
  while (!writing_ && !finished_ && !slots_.empty() && slots_.front()->done) {
    Slot& front = *slots_.front();
    if (front.stream_error.has_value()) {
      const absl::Status error = *front.stream_error;
      PopFrontLocked();
      FinishLocked(error);
      return;
    }
    if (front.skipped) {
      PopFrontLocked();
      continue;
    }
    front.response.set_server_send_time_unix_ns(absl::GetCurrentTimeNanos());
    if (absl::Status s = SerializeMessage(front.response, &front.wire); !s.ok()) {
      PopFrontLocked();
      FinishLocked(s);
      return;
    }
    writing_ = true;
    StartWrite(&front.wire);
  }
}

void FrameStream::MaybeFinishLocked() {
  if (finished_ || writing_ || !slots_.empty()) return;
  if (read_done_) {
    FinishLocked(absl::OkStatus());
  } else if (draining_) {
    // A read may still be outstanding: Finish ends it (it completes with !ok).
    FinishLocked(wire::ServerDraining());
  }
}

void FrameStream::FinishLocked(const absl::Status& status) {
  if (finished_) return;
  finished_ = true;
  abandoned_.store(true, std::memory_order_release);
  // Only cancellation gets here with frames unanswered; their workers skip.
  while (!slots_.empty()) PopFrontLocked();
  const grpc::Status grpc_status = wire::ToGrpcStatus(status);
  service_.metrics().CountRpc("StreamFrames", grpc_status.error_code());
  Finish(grpc_status);
}

void FrameStream::PopFrontLocked() {
  if (slots_.front()->in_bound) --inflight_;
  slots_.pop_front();
  service_.metrics().FrameAnswered();
}

bool FrameStream::DropOldestQueuedLocked() {
  // The newest frame (the one just received, at the back) is never dropped:
  // when it is the only one not started, the stream stops reading instead
  // until a frame is answered (MaybeReadLocked).
  for (auto it = slots_.begin(); it != slots_.end() && std::next(it) != slots_.end(); ++it) {
    Slot* slot = it->get();
    if (!slot->in_bound || slot->done || slot->setup) continue;
    int expected = kQueued;
    if (slot->state.compare_exchange_strong(expected, kDropped)) {
      slot->in_bound = false;
      --inflight_;
      slot->request.reset();
      AnswerLocked(*slot, wire::FrameDropped(max_inflight_));
      return true;
    }
  }
  return false;
}

}  // namespace lane::server
