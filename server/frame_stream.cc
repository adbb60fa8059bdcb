#include "frame_stream.h"

#include <iterator>
#include <optional>
#include <random>
#include <utility>

#include "absl/time/clock.h"
#include "frame_processor.h"
#include "raw_call.h"
#include "session_proto.h"
#include "wire/status_map.h"

namespace lane::server {
namespace {

enum SlotState : int { kQueued, kRunning, kDropped };

// Beyond this many slots (most of them dropped answers waiting behind a slow
// frame) a drop_oldest stream stops reading too.
size_t MaxSlots(uint32_t max_inflight) { return 4 * size_t{max_inflight} + 16; }

// StreamOptions::max_age, drawn for one stream within -10 %..+0 %.
absl::Duration DrawMaxAge(absl::Duration max_age) {
  if (max_age == absl::InfiniteDuration()) return max_age;
  thread_local std::mt19937_64 random{std::random_device{}()};
  return max_age * std::uniform_real_distribution<double>(0.9, 1.0)(random);
}

absl::Status StreamAged() {
  return absl::UnavailableError(
      "the stream reached the server's --max_connection_age: every frame it received was "
      "answered; reconnect (the camera's resume state goes with the new stream)");
}

}  // namespace

struct FrameStream::Slot {
  std::unique_ptr<v1::FrameRequest> request;  // released once processed
  v1::FrameResponse response;
  // What processing made of the frame, once processed: an OK frame's lanes
  // stay lanes until the response is written (and, for a tracked session,
  // are committed to its tracker in stream order then).
  std::optional<FrameOutcome> outcome;
  // The live view's copy of the frame, when its camera is watched and due.
  LiveFrame live_sample;
  grpc::ByteBuffer wire;  // the response, serialized for the write
  std::string camera_id;
  Arrival arrival;
  std::shared_ptr<Session> session;  // set at receipt, or by the setup
  std::atomic<int> state{kQueued};   // kQueued -> kRunning | kDropped
  bool setup = false;                // create/confirm the session first
  bool resume = false;               // then resume its tracker (ResumeTracking)
  // Guarded by the stream's mu_ (a slot is another object, so the
  // compiler cannot check this; every access is in a *Locked method or
  // under a MutexLock):
  bool done = false;                         // response ready (or stream_error / skipped)
  bool in_bound = true;                      // counts against max_inflight
  bool skipped = false;                      // abandoned: nothing to send
  std::optional<absl::Status> stream_error;  // end the stream here instead
};

FrameStream::FrameStream(StreamDeps deps)
    : deps_(std::move(deps)),
      call_metrics_(deps_.metrics.grpc(),
                    deps_.metrics.grpc().ForMethod("/lane.v1.LaneService/StreamFrames",
                                                   GrpcMetrics::Type::kBidiStream)),
      max_inflight_(deps_.sessions.options().default_max_inflight_frames) {}

FrameStream::~FrameStream() = default;

void FrameStream::Start(const absl::Status& reject) {
  absl::MutexLock lock(&mu_);
  if (!reject.ok()) {
    FinishLocked(reject);
    return;
  }
  if (phase_ == Phase::kCreated) phase_ = Phase::kOpen;  // else a drain came first
  end_of_life_ = absl::Now() + DrawMaxAge(deps_.options.max_age);
  MaybeReadLocked();
  MaybeFinishLocked();
}

void FrameStream::BeginDrain() {
  absl::MutexLock lock(&mu_);
  if (phase_ != Phase::kCreated && phase_ != Phase::kOpen) return;
  const bool started = phase_ == Phase::kOpen;
  phase_ = Phase::kDraining;
  if (started) MaybeFinishLocked();
}

void FrameStream::OnReadDone(bool ok) {
  absl::MutexLock lock(&mu_);
  reading_ = false;
  if (!ok) {
    // The client half-closed (or the read side failed). A drain gives way to
    // it: the client has sent everything, so the stream can end OK.
    if (phase_ == Phase::kOpen || phase_ == Phase::kDraining) phase_ = Phase::kHalfClosed;
    MaybeFinishLocked();
    return;
  }
  if (phase_ == Phase::kFinished || phase_ == Phase::kCancelled) return;  // read as it ended
  call_metrics_.Received();
  ReceiveLocked();
  if (phase_ == Phase::kOpen && absl::Now() >= end_of_life_) {
    // Old enough to move: this frame is the last one read.
    phase_ = Phase::kDraining;
    aged_ = true;
  }
  MaybeWriteLocked();
  MaybeReadLocked();
}

void FrameStream::ReceiveLocked() {
  auto slot = std::make_shared<Slot>();
  slot->arrival = Arrival::Now();
  slot->request = std::make_unique<v1::FrameRequest>();
  deps_.metrics.FrameReceived();
  slots_.push_back(slot);
  ++inflight_;
  if (absl::Status parsed = ParseMessage(read_buffer_, slot->request.get()); !parsed.ok()) {
    // Nothing after an unreadable message can be trusted to be a frame: end
    // the stream with the reason, after answering the frames before it.
    slot->request.reset();
    FailLocked(slot, parsed);
    return;
  }
  const v1::FrameRequest& request = *slot->request;
  const bool first = first_request_;
  first_request_ = false;
  if (camera_id_.empty()) camera_id_ = request.camera_id();
  slot->camera_id = request.camera_id().empty() ? camera_id_ : request.camera_id();
  slot->response = StartResponse(request, slot->camera_id, slot->arrival);

  if (slot->camera_id.empty()) {
    AnswerLocked(*slot, wire::InvalidRequest("frame without camera_id"));
    return;
  }
  if (absl::Status id = SessionRegistry::ValidateCameraId(slot->camera_id); !id.ok()) {
    AnswerLocked(*slot, id);
    return;
  }
  if (!request.resume_state().empty() || request.min_lane_id() > 0) {
    if (first) {
      slot->resume = true;
      awaiting_setup_ = true;  // later frames are measured with the resumed tracker
    } else {
      wire::ToFrameStatus(wire::InvalidRequest("resume_state and min_lane_id are only accepted "
                                               "on a stream's first request; ignored"),
                          slot->response.mutable_resume_status());
    }
  }
  if (request.has_session_config()) {
    if (!first) {
      AnswerLocked(*slot, wire::InvalidRequest("session_config is only accepted on a stream's "
                                               "first request"));
      return;
    }
    slot->setup = true;
    awaiting_setup_ = true;  // later frames need the session: read them after
  } else {
    slot->session = deps_.sessions.Find(slot->camera_id);
    if (slot->session == nullptr) {
      FailLocked(slot, wire::NoSessionForFrame(slot->camera_id));
      return;
    }
    ApplyPolicyLocked(*slot->session);
  }
  Ref();
  if (!deps_.pool.Submit([this, slot] { Process(slot); })) {
    // Only after the pool has shut down, i.e. never while serving.
    refs_.fetch_sub(1, std::memory_order_relaxed);  // gRPC's ref remains
    awaiting_setup_ = false;
    AnswerLocked(*slot, wire::ServerDraining());
  } else if (backpressure_ == Backpressure::kDropOldest && inflight_ > max_inflight_) {
    DropOldestQueuedLocked();
  }
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
      absl::StatusOr<SessionRegistry::CreateResult> created = CreateSessionFromProto(
          deps_.sessions, slot->camera_id, request.session_config(), request.replace_session());
      if (created.ok()) {
        slot->session = std::move(created->session);
      } else {
        setup_error = created.status();
      }
    }
    if (slot->resume && slot->session != nullptr) {
      const ResumeResult resumed =
          ResumeTracking(request, *slot->session, deps_.seal, deps_.sessions);
      deps_.metrics.CountResume(resumed.outcome);
      wire::ToFrameStatus(resumed.status, slot->response.mutable_resume_status());
    }
    if (slot->session != nullptr) {
      // A bad frame's status goes into its response; the stream goes on.
      ProcessedFrame processed =
          ProcessFrame(request, *slot->session, deps_.limits, slot->arrival, deps_.metrics,
                       slot->session->TracksStreams(), deps_.live_view != nullptr);
      slot->outcome = std::move(processed.outcome);
      slot->live_sample = std::move(processed.live_sample);
    }
  }
  slot->request.reset();  // the frame's bytes are no longer needed
  {
    absl::MutexLock lock(&mu_);
    slot->done = true;
    slot->skipped = abandon;
    if (slot->setup || slot->resume) awaiting_setup_ = false;
    if (slot->setup) {
      if (!setup_error.ok()) {
        FailLocked(slot, setup_error);
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
  absl::MutexLock lock(&mu_);
  writing_ = false;
  if (!slots_.empty()) PopFrontLocked();  // the slot just written
  if (!ok || phase_ == Phase::kCancelled) {
    FinishLocked(absl::CancelledError("the stream was cancelled or the client went away"));
    return;
  }
  MaybeWriteLocked();
  MaybeReadLocked();
  MaybeFinishLocked();
}

void FrameStream::OnCancel() {
  absl::MutexLock lock(&mu_);
  if (phase_ == Phase::kFinished) return;
  phase_ = Phase::kCancelled;
  abandoned_.store(true, std::memory_order_release);
  // With a write outstanding, OnWriteDone finishes.
  if (!writing_) FinishLocked(absl::CancelledError("the stream was cancelled"));
}

void FrameStream::OnDone() {
  // gRPC runs OnDone after every other reaction, OnCancel included, but it
  // hands OnCancel's end to OnDone inside libgrpc++ (the reference it drops
  // after OnCancel), where a race detector cannot see the order. Taking mu_,
  // which every reaction holds while it touches the stream, states that order
  // in this code: nothing the reactions wrote is read or freed before they
  // have let go of the stream.
  { absl::MutexLock lock(&mu_); }
  call_metrics_.Handled(grpc::StatusCode::CANCELLED);  // only if nothing was counted
  if (deps_.on_done) deps_.on_done(this);
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
  slot.response = AnswerUnprocessed(status, deps_.metrics, std::move(slot.response));
  slot.done = true;
}

void FrameStream::FailLocked(const std::shared_ptr<Slot>& slot, const absl::Status& error) {
  slot->stream_error = error;
  slot->done = true;
  if (phase_ == Phase::kOpen || phase_ == Phase::kDraining || phase_ == Phase::kHalfClosed) {
    phase_ = Phase::kFailing;
  }
}

void FrameStream::MaybeReadLocked() {
  if (phase_ != Phase::kOpen || reading_ || awaiting_setup_) return;
  const bool room = backpressure_ == Backpressure::kBlock
                        ? inflight_ < max_inflight_
                        : inflight_ <= max_inflight_ && slots_.size() < MaxSlots(max_inflight_);
  if (!room) return;
  reading_ = true;
  StartRead(&read_buffer_);
}

void FrameStream::MaybeWriteLocked() {
  while (!writing_ && phase_ != Phase::kFinished && !slots_.empty() && slots_.front()->done) {
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
    // Tracking sees the frames in the stream's order.
    if (front.session != nullptr) {
      if (front.outcome) {
        front.response = FinishFrame(*front.session, front.session->TracksStreams(),
                                     std::move(front.response), *std::move(front.outcome));
        front.outcome.reset();
      }
      MaybeAttachResumeStateLocked(front);
    }
    front.response.set_server_send_time_unix_ns(absl::GetCurrentTimeNanos());
    if (deps_.live_view != nullptr && front.session != nullptr) {
      deps_.live_view->Record(front.session, front.response, std::move(front.live_sample));
    }
    if (absl::Status s = SerializeMessage(front.response, &front.wire); !s.ok()) {
      PopFrontLocked();
      FinishLocked(s);
      return;
    }
    writing_ = true;
    call_metrics_.Sent();
    StartWrite(&front.wire);
  }
}

void FrameStream::MaybeAttachResumeStateLocked(Slot& front) {
  const uint32_t every = deps_.options.resume_state_every;
  if (every == 0 || !front.session->TracksStreams()) return;
  const bool due = since_resume_state_ < 0 || since_resume_state_ + 1 >= every ||
                   phase_ == Phase::kDraining || front.resume;
  if (!due) {
    ++since_resume_state_;
    return;
  }
  std::string sealed = SealedResumeState(*front.session, deps_.seal);
  if (!sealed.empty()) {
    deps_.metrics.ObserveResumeStateBytes(sealed.size());
    front.response.set_resume_state(std::move(sealed));
  }
  since_resume_state_ = 0;
}

void FrameStream::MaybeFinishLocked() {
  if (writing_ || !slots_.empty()) return;
  if (phase_ == Phase::kHalfClosed) {
    FinishLocked(absl::OkStatus());
  } else if (phase_ == Phase::kDraining) {
    // A read may still be outstanding: Finish ends it (it completes with !ok).
    FinishLocked(aged_ ? StreamAged() : wire::ServerDraining());
  }
}

void FrameStream::FinishLocked(const absl::Status& status) {
  if (phase_ == Phase::kFinished) return;
  phase_ = Phase::kFinished;
  abandoned_.store(true, std::memory_order_release);
  // Only cancellation gets here with frames unanswered; their workers skip.
  while (!slots_.empty()) PopFrontLocked();
  const grpc::Status grpc_status = wire::ToGrpcStatus(status);
  call_metrics_.Handled(grpc_status.error_code());
  Finish(grpc_status);
}

void FrameStream::PopFrontLocked() {
  if (slots_.front()->in_bound) --inflight_;
  slots_.pop_front();
  deps_.metrics.FrameAnswered();
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
