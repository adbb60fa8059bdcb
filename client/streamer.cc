#include "streamer.h"

#include <algorithm>
#include <thread>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "common.h"
#include "wire/camera_id.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;

double MillisecondsBetween(std::chrono::steady_clock::time_point a,
                           std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

bool IsTransient(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::UNAVAILABLE:          // server starting, draining, unreachable
    case grpc::StatusCode::DEADLINE_EXCEEDED:    // a unary call timed out
    case grpc::StatusCode::CANCELLED:            // the server went away, or a stall
    case grpc::StatusCode::ABORTED:              //
    case grpc::StatusCode::INTERNAL:             // a broken HTTP/2 stream
    case grpc::StatusCode::UNKNOWN:              //
    case grpc::StatusCode::RESOURCE_EXHAUSTED:   // full worker queue or session table
    case grpc::StatusCode::FAILED_PRECONDITION:  // the session is gone: re-created
      return true;
    default:
      return false;
  }
}

Streamer::Streamer(std::shared_ptr<grpc::Channel> channel, StreamerOptions options, Logger log)
    : stub_(v1::LaneService::NewStub(std::move(channel))),
      options_(std::move(options)),
      log_(std::move(log)),
      config_(options_.session),
      next_frame_id_(options_.first_frame_id) {}

void Streamer::Log(const std::string& message) const {
  if (log_) log_(message);
}

grpc::Status Streamer::PrepareSession(bool first_connection) {
  if (!config_) {
    grpc::ClientContext context;
    SetDeadline(&context, options_.call_timeout);
    context.AddMetadata(kCameraIdHeader, options_.camera_id);
    v1::GetSessionRequest request;
    request.set_camera_id(options_.camera_id);
    v1::Session session;
    const grpc::Status status = stub_->GetSession(&context, request, &session);
    if (status.error_code() == grpc::StatusCode::NOT_FOUND) {
      return grpc::Status(grpc::StatusCode::NOT_FOUND,
                          absl::StrCat("the server has no session for camera '", options_.camera_id,
                                       "'; give --config to create it"));
    }
    if (!status.ok()) return status;
    // The resolved config: re-creating it after a restart gives the same session.
    config_ = session.config();
    session_ = std::move(session);
  }
  grpc::ClientContext context;
  SetDeadline(&context, options_.call_timeout);
  context.AddMetadata(kCameraIdHeader, options_.camera_id);
  v1::CreateSessionRequest request;
  request.set_camera_id(options_.camera_id);
  *request.mutable_config() = *config_;
  request.set_replace(options_.replace && first_connection);
  v1::CreateSessionResponse response;
  const grpc::Status status = stub_->CreateSession(&context, request, &response);
  if (!status.ok()) return status;
  if (!first_connection && response.outcome() != v1::CREATE_OUTCOME_UNCHANGED) {
    Log(absl::StrCat("session of camera '", options_.camera_id, "' re-created (version ",
                     response.session().version(), ")"));
  }
  session_ = response.session();
  return grpc::Status::OK;
}

absl::Status Streamer::Run(const Source& source, const Sink& sink) {
  // A bad id would be refused by the server (INVALID_ARGUMENT), or before
  // that by a proxy as a header it will not take (UNAVAILABLE, retried).
  if (absl::Status id = lane::wire::ValidateCameraId(options_.camera_id); !id.ok()) return id;
  ReconnectBackoff backoff(options_.reconnect);
  RetryBudget budget({options_.max_reconnects, options_.give_up_after}, MonotonicNow());
  bool first_connection = true;
  while (true) {
    {
      absl::MutexLock lock(&mu_);
      if (source_done_ && pending_.empty()) return absl::OkStatus();
    }
    bool progress = false;
    grpc::Status status = PrepareSession(first_connection);
    if (status.ok()) {
      first_connection = false;
      Attempt attempt = RunAttempt(source, sink);
      status = std::move(attempt.status);
      progress = attempt.progress;
    }
    EmitLocalErrors(sink);
    {
      absl::MutexLock lock(&mu_);
      if (status.ok() && source_done_ && pending_.empty()) return absl::OkStatus();
    }
    if (status.ok()) {
      status = grpc::Status(grpc::StatusCode::UNKNOWN, "the stream ended with frames unanswered");
    }
    if (progress) {
      backoff.Reset();
      budget.Progress(MonotonicNow());
    }
    const absl::Status failure(static_cast<absl::StatusCode>(status.error_code()),
                               status.error_message());
    const std::string why = StatusText(status);
    if (!IsTransient(status.error_code())) return absl::Status(failure.code(), why);
    // The status the run ends with keeps the failure's own code.
    if (absl::Status give_up = budget.Failed(failure, MonotonicNow()); !give_up.ok()) {
      return give_up;
    }
    stats_.failures.push_back(why);
    size_t unanswered = 0;
    {
      absl::MutexLock lock(&mu_);
      unanswered = unanswered_;
    }
    const absl::Duration wait = backoff.Next();
    Log(absl::StrCat(why, "; reconnecting in ",
                     absl::FormatDuration(absl::Trunc(wait, absl::Milliseconds(1))), " (",
                     unanswered, " frames to resend)"));
    std::this_thread::sleep_for(absl::ToChronoNanoseconds(wait));
  }
}

void Streamer::EmitLocalErrors(const Sink& sink) {
  std::vector<std::shared_ptr<StreamItem>> ready;
  {
    absl::MutexLock lock(&mu_);
    while (!pending_.empty() && pending_.front()->request == nullptr) {
      ready.push_back(std::move(pending_.front()));
      pending_.pop_front();
      if (passed_ > 0) --passed_;
    }
  }
  for (const auto& item : ready) {
    sink(*item, nullptr, 0.0);
    ++stats_.frames;
  }
}

Streamer::Answered Streamer::TakeAnswered(uint64_t frame_id, Clock::time_point now) {
  Answered answered;
  absl::MutexLock lock(&mu_);
  while (!pending_.empty() && pending_.front()->request == nullptr && passed_ > 0) {
    answered.ready.push_back(std::move(pending_.front()));
    pending_.pop_front();
    --passed_;
  }
  if (pending_.empty() || passed_ == 0 || written_ == 0 || pending_.front()->frame_id != frame_id) {
    answered.protocol_error = absl::StrCat(
        "response for frame_id ", frame_id, " but the oldest unanswered frame is ",
        pending_.empty() ? std::string("none") : absl::StrCat(pending_.front()->frame_id));
    return answered;
  }
  answered.ready.push_back(std::move(pending_.front()));
  pending_.pop_front();
  --passed_;
  --unanswered_;
  --written_;
  last_activity_ = now;
  return answered;
}

Streamer::Attempt Streamer::RunAttempt(const Source& source, const Sink& sink) {
  Attempt attempt;
  grpc::ClientContext context;
  context.AddMetadata(kCameraIdHeader, options_.camera_id);
  std::unique_ptr<Stream> stream = stub_->StreamFrames(&context);
  ++stats_.connections;
  {
    absl::MutexLock lock(&mu_);
    resuming_ = options_.resume_tracking && (!resume_state_.empty() || max_lane_id_ > 0);
    passed_ = 0;
    written_ = 0;
    attempt_over_ = false;
    writer_done_ = false;
    stalled_ = false;
    last_activity_ = Clock::now();
  }
  std::thread writer([this, &stream, &source] { WriterLoop(stream.get(), source); });
  std::thread watchdog([this, &context] { WatchdogLoop(&context); });

  std::string protocol_error;
  v1::FrameResponse response;
  while (stream->Read(&response)) {
    const auto now = Clock::now();
    Answered answered = TakeAnswered(response.frame_id(), now);
    cv_.SignalAll();
    protocol_error = std::move(answered.protocol_error);
    if (!protocol_error.empty()) break;
    Remember(response);
    const std::vector<std::shared_ptr<StreamItem>>& ready = answered.ready;
    for (size_t i = 0; i < ready.size(); ++i) {
      ready[i]->connection = stats_.connections;
      const StreamItem& item = *ready[i];
      if (i + 1 < ready.size()) {
        sink(item, nullptr, 0.0);
      } else {
        sink(item, &response, MillisecondsBetween(item.last_sent, now));
        attempt.progress = true;
      }
      ++stats_.frames;
    }
  }
  bool writer_running = false;
  {
    absl::MutexLock lock(&mu_);
    attempt_over_ = true;
    cv_.SignalAll();
    // The call is over, so a Write in progress fails by itself. Cancelling
    // would replace the server's status (UNAVAILABLE) with CANCELLED: only
    // when the writer does not return.
    const absl::Time deadline = absl::Now() + absl::Seconds(2);
    while (!writer_done_) {
      if (cv_.WaitWithDeadline(&mu_, deadline)) break;  // timed out
    }
    writer_running = !writer_done_;
  }
  if (writer_running || !protocol_error.empty()) context.TryCancel();
  writer.join();
  watchdog.join();
  attempt.status = stream->Finish();
  if (!protocol_error.empty()) {
    attempt.status = grpc::Status(grpc::StatusCode::INTERNAL, protocol_error);
    return attempt;
  }
  bool stalled = false;
  {
    absl::MutexLock lock(&mu_);
    stalled = stalled_;
  }
  if (stalled) {
    attempt.status =
        grpc::Status(grpc::StatusCode::CANCELLED,
                     absl::StrCat("no response for ", absl::FormatDuration(options_.stall_timeout),
                                  " with frames in flight"));
  }
  return attempt;
}

void Streamer::Remember(const v1::FrameResponse& response) {
  if (response.has_resume_status() && response.resume_status().code() != v1::FRAME_CODE_OK) {
    ++stats_.resumes_refused;
    Log(absl::StrCat("camera '", options_.camera_id, "': the server did not resume tracking (",
                     response.resume_status().message(), "); lane ids go on from ",
                     "the largest seen"));
  }
  if (!response.resume_state().empty()) {
    ++stats_.resume_states;
    stats_.resume_state_bytes += response.resume_state().size();
  }
  absl::MutexLock lock(&mu_);
  if (!response.resume_state().empty()) resume_state_ = response.resume_state();
  for (const v1::Lane& lane : response.lanes()) max_lane_id_ = std::max(max_lane_id_, lane.id());
}

void Streamer::WriterLoop(Stream* stream, const Source& source) {
  mu_.Lock();
  bool first_write = true;
  while (!attempt_over_) {
    if (passed_ < pending_.size()) {
      std::shared_ptr<StreamItem> item = pending_[passed_];
      ++passed_;
      if (item->request == nullptr) continue;  // not readable here: nothing to send
      if (item->attempts > 0) ++stats_.resent;
      ++item->attempts;
      item->last_sent = Clock::now();
      if (written_++ == 0) last_activity_ = item->last_sent;
      bool ok;
      if (first_write && (config_ || resuming_)) {
        // The first request carries the session config too, so the stream is
        // self-sufficient behind a load balancer, and after a reconnection
        // what the replica needs to go on tracking.
        v1::FrameRequest request = *item->request;
        if (config_) *request.mutable_session_config() = *config_;
        if (resuming_) {
          request.set_resume_state(resume_state_);
          request.set_min_lane_id(static_cast<uint32_t>(max_lane_id_) + 1);
          ++stats_.resumes;
        }
        mu_.Unlock();
        ok = stream->Write(request);
      } else {
        mu_.Unlock();
        ok = stream->Write(*item->request);
      }
      first_write = false;
      mu_.Lock();
      if (!ok) break;  // the call is over; the reader learns why
      continue;
    }
    if (!source_done_ && unanswered_ < options_.window) {
      const uint64_t frame_id = next_frame_id_;
      mu_.Unlock();
      std::optional<StreamItem> got = source(frame_id);
      mu_.Lock();
      if (!got) {
        source_done_ = true;
      } else {
        auto item = std::make_shared<StreamItem>(*std::move(got));
        item->frame_id = frame_id;
        ++next_frame_id_;
        if (item->request != nullptr) ++unanswered_;
        pending_.push_back(std::move(item));
      }
      continue;
    }
    if (source_done_) {
      mu_.Unlock();
      stream->WritesDone();
      mu_.Lock();
      break;
    }
    cv_.Wait(&mu_);
  }
  writer_done_ = true;
  mu_.Unlock();
  cv_.SignalAll();
}

void Streamer::WatchdogLoop(grpc::ClientContext* context) {
  const auto timeout = absl::ToChronoNanoseconds(options_.stall_timeout);
  mu_.Lock();
  while (!attempt_over_) {
    cv_.WaitWithTimeout(&mu_, std::min(options_.stall_timeout, absl::Milliseconds(250)));
    if (!attempt_over_ && written_ > 0 && Clock::now() - last_activity_ > timeout) {
      stalled_ = true;
      mu_.Unlock();
      context->TryCancel();
      return;
    }
  }
  mu_.Unlock();
}

}  // namespace lane::client
