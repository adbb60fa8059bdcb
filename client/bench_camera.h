// The cameras of a `lane-client bench` run (bench.cc): each camera's
// StreamFrames calls on gRPC's callback API, the frames it sends and what it
// counts. Internal to the load generator.
#ifndef LANE_CLIENT_BENCH_CAMERA_H_
#define LANE_CLIENT_BENCH_CAMERA_H_

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/client_callback.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "lane/v1/lane_service.pb.h"
#include "load_spec.h"
#include "reconnect_backoff.h"

namespace lane::client::load {

namespace v1 = lane::v1;
using Clock = std::chrono::steady_clock;

inline constexpr char kStreamMethod[] = "/lane.v1.LaneService/StreamFrames";

inline double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// What a run shares between its cameras.
struct RunState {
  const LoadSpec* spec = nullptr;
  Clock::time_point start;
  Clock::time_point measure_start;
  Clock::time_point measure_end;
  int64_t start_unix_ns = 0;
  std::atomic<bool> stopping{false};

  bool Measured(Clock::time_point t) const { return t >= measure_start && t < measure_end; }
  float SinceMeasureStart(Clock::time_point t) const {
    return std::chrono::duration<float>(t - measure_start).count();
  }
  int64_t UnixNanos(Clock::time_point t) const {
    return start_unix_ns + std::chrono::duration_cast<std::chrono::nanoseconds>(t - start).count();
  }
};

// Per camera: Camera::stats_, under its mutex (Camera::WithStats).
struct CameraStats {
  uint64_t scheduled = 0;
  uint64_t sent = 0;
  uint64_t ok = 0;
  uint64_t dropped = 0;
  uint64_t unsent = 0;
  uint64_t failed = 0;
  std::map<std::string, uint64_t> errors;
  std::vector<double> latency_ms;
  std::vector<double> server_ms;
  // The server's split of server_ms (FrameResponse.timings).
  std::vector<double> queue_ms;
  std::vector<double> decode_ms;
  std::vector<double> detect_ms;
  // For the timeline: when each latency_ms entry, and each error, arrived,
  // in seconds since the start of the measured window.
  std::vector<float> ok_at_s;
  std::vector<float> error_at_s;
  Clock::time_point last_ok{};
  double max_send_lag_ms = 0;
  uint64_t stream_failures = 0;
  // Since the last progress report.
  uint64_t interval_ok = 0;
  double interval_latency_ms = 0;
};

class Camera;

// One StreamFrames call of a camera, on gRPC's callback API with
// ByteBuffers: a queue of messages written one at a time, responses read
// continuously and matched by frame_id.
class CameraStream final : public grpc::ClientBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  CameraStream(Camera* camera, grpc::GenericStub* stub) : camera_(camera), stub_(stub) {}

  void Start() {
    stub_->PrepareBidiStreamingCall(&context_, kStreamMethod, grpc::StubOptions(), this);
    // Writes are started from outside the reactions (the scheduler): the hold
    // keeps OnDone away until we say no more writes will come.
    AddHold();
    StartRead(&read_buffer_);
    StartCall();
  }

  // Queues a frame unless `limit` frames are already unanswered or the
  // stream takes no more frames; Pump() then writes it. `header` is the
  // serialized request header, `image_part` the frame's bytes (not copied).
  bool Queue(uint64_t frame_id, Clock::time_point due, bool measured, const std::string& header,
             const std::string& image_part, size_t limit) {
    absl::MutexLock lock(&mu_);
    if (failed_ || half_close_ || done_ || inflight_.size() >= limit) return false;
    grpc::Slice slices[2] = {
        grpc::Slice(header.data(), header.size()),
        grpc::Slice(image_part.data(), image_part.size(), grpc::Slice::STATIC_SLICE)};
    queue_.push_back({frame_id, measured, grpc::ByteBuffer(slices, 2)});
    inflight_.emplace(frame_id, Sent{due, measured});
    return true;
  }

  // Starts the next write, the half-close, or releases the hold: one thing at
  // a time, never under mu_ (gRPC may run a reaction inline).
  void Pump();

  void HalfClose() {
    {
      absl::MutexLock lock(&mu_);
      half_close_ = true;
    }
    Pump();
  }

  void Cancel() { context_.TryCancel(); }

  bool done() {
    absl::MutexLock lock(&mu_);
    return done_;
  }
  bool answered_any() {
    absl::MutexLock lock(&mu_);
    return answered_any_;
  }
  size_t unanswered() {
    absl::MutexLock lock(&mu_);
    return inflight_.size();
  }
  // How the call ended (OK until it has).
  grpc::Status final_status() {
    absl::MutexLock lock(&mu_);
    return final_status_;
  }

  void OnWriteDone(bool ok) override {
    {
      absl::MutexLock lock(&mu_);
      writing_ = false;
      if (!ok) failed_ = true;
    }
    Pump();
  }

  void OnWritesDoneDone(bool /*ok*/) override {
    {
      absl::MutexLock lock(&mu_);
      writing_ = false;
      writes_done_ = true;
    }
    Pump();
  }

  void OnReadDone(bool ok) override;
  void OnDone(const grpc::Status& status) override;

  // done() from now on; Camera::StreamDone calls it, under the run's done mutex.
  void MarkDone() {
    absl::MutexLock lock(&mu_);
    done_ = true;
  }

 private:
  struct Outgoing {
    uint64_t frame_id;
    bool measured;
    grpc::ByteBuffer buffer;
  };
  struct Sent {
    Clock::time_point due;
    bool measured;
  };

  Camera* const camera_;
  grpc::GenericStub* const stub_;
  grpc::ClientContext context_;
  grpc::ByteBuffer read_buffer_;
  grpc::ByteBuffer write_buffer_;  // the message being written

  absl::Mutex mu_;
  std::deque<Outgoing> queue_ ABSL_GUARDED_BY(mu_);  // not yet written
  // Queued or written, unanswered.
  std::unordered_map<uint64_t, Sent> inflight_ ABSL_GUARDED_BY(mu_);
  bool writing_ ABSL_GUARDED_BY(mu_) = false;
  bool pumping_ ABSL_GUARDED_BY(mu_) = false;
  bool half_close_ ABSL_GUARDED_BY(mu_) = false;
  bool writes_done_started_ ABSL_GUARDED_BY(mu_) = false;
  bool writes_done_ ABSL_GUARDED_BY(mu_) = false;
  bool failed_ ABSL_GUARDED_BY(mu_) = false;
  bool hold_released_ ABSL_GUARDED_BY(mu_) = false;
  bool done_ ABSL_GUARDED_BY(mu_) = false;
  bool answered_any_ ABSL_GUARDED_BY(mu_) = false;
  grpc::Status final_status_ ABSL_GUARDED_BY(mu_);
};

class Camera {
 public:
  Camera(int index, std::string id, grpc::GenericStub* stub, std::string target, RunState* run,
         absl::Mutex* done_mu, absl::CondVar* done_cv)
      : budget({run->spec->max_reconnects, absl::InfiniteDuration()}, MonotonicNow()),
        id_(std::move(id)),
        stub_(stub),
        target_(std::move(target)),
        run_(run),
        done_mu_(done_mu),
        done_cv_(done_cv) {
    next_frame_ = static_cast<size_t>(index) * 7 % run_->spec->frames->size();
  }

  const std::string& id() const { return id_; }
  const std::string& target() const { return target_; }
  const RunState& run() const { return *run_; }

  // A copy of the counts.
  CameraStats stats() {
    absl::MutexLock lock(&stats_mu_);
    return stats_;
  }
  // Runs f(stats) under the stats' mutex.
  template <typename F>
  void WithStats(F f) {
    absl::MutexLock lock(&stats_mu_);
    f(stats_);
  }

  // Marks `stream` done and wakes the run, under the run's done mutex: once
  // the run sees the stream done (under that mutex too), it may destroy it.
  void StreamDone(CameraStream* stream) {
    absl::MutexLock lock(done_mu_);
    stream->MarkDone();
    done_cv_->SignalAll();
  }

  // A new call (the previous one, if any, is done).
  void OpenStream() {
    auto stream = std::make_unique<CameraStream>(this, stub_);
    CameraStream* raw = stream.get();
    {
      absl::MutexLock lock(&streams_mu_);
      streams_.push_back(std::move(stream));
      current_ = raw;
      first_message_ = true;
    }
    raw->Start();
    if (!run_->spec->open_loop) TopUp(raw);
  }

  CameraStream* current() {
    absl::MutexLock lock(&streams_mu_);
    return current_;
  }

  // Open loop: the frame due at `due`.
  void SendScheduled(Clock::time_point due) {
    const bool measured = run_->Measured(due);
    CameraStream* stream = current();
    const bool queued = stream != nullptr && !stream->done() &&
                        SendNext(stream, due, measured, std::numeric_limits<size_t>::max());
    const double lag_ms = Ms(Clock::now() - due);
    absl::MutexLock lock(&stats_mu_);
    if (!measured) return;
    ++stats_.scheduled;
    if (!queued) ++stats_.unsent;
    stats_.max_send_lag_ms = std::max(stats_.max_send_lag_ms, lag_ms);
  }

  // Closed loop: fills the stream up to K frames in flight.
  void TopUp(CameraStream* stream) {
    const size_t limit = static_cast<size_t>(std::max(1, run_->spec->inflight));
    while (!run_->stopping.load(std::memory_order_acquire)) {
      const Clock::time_point now = Clock::now();
      const bool measured = run_->Measured(now);
      if (!SendNext(stream, now, measured, limit)) break;
      if (measured) {
        absl::MutexLock lock(&stats_mu_);
        ++stats_.scheduled;
      }
    }
  }

  void OnResponse(CameraStream* stream) {
    if (!run_->spec->open_loop) TopUp(stream);
  }

  void CountSent(bool measured) {
    if (!measured) return;
    absl::MutexLock lock(&stats_mu_);
    ++stats_.sent;
  }

  std::vector<CameraStream*> streams() {
    absl::MutexLock lock(&streams_mu_);
    std::vector<CameraStream*> out;
    for (const auto& s : streams_) out.push_back(s.get());
    return out;
  }

  // Reconnection of the supervisor: when the next call is due (zero: not
  // scheduled), the shared reconnect policy, and its attempts budget (the
  // run's duration is the time budget); gave_up: not OK once the budget ran
  // out, and the camera no longer reconnects.
  Clock::time_point retry_at{};
  ReconnectBackoff backoff;
  RetryBudget budget;
  absl::Status gave_up;

 private:
  // Queues the camera's next frame on `stream` and writes it. Frame ids are
  // taken in queue order under streams_mu_, so the first message of a call
  // (the one with the session config) is the first written.
  bool SendNext(CameraStream* stream, Clock::time_point due, bool measured, size_t limit) {
    const std::vector<BenchFrame>& frames = *run_->spec->frames;
    {
      absl::MutexLock lock(&streams_mu_);
      v1::FrameRequest header;
      header.set_camera_id(id_);
      header.set_frame_id(next_frame_id_);
      header.set_capture_time_unix_ns(run_->UnixNanos(due));
      const bool first = first_message_ && stream == current_;
      if (first) {
        // The session travels with the first request of every call, so a
        // call is self-sufficient behind a load balancer.
        *header.mutable_session_config() = run_->spec->session;
        header.set_replace_session(run_->spec->replace);
      }
      if (!stream->Queue(next_frame_id_, due, measured, header.SerializeAsString(),
                         frames[next_frame_].image_part, limit)) {
        return false;
      }
      ++next_frame_id_;
      next_frame_ = (next_frame_ + 1) % frames.size();
      if (first) first_message_ = false;
    }
    stream->Pump();
    return true;
  }

  const std::string id_;
  grpc::GenericStub* const stub_;
  const std::string target_;
  RunState* const run_;
  absl::Mutex* const done_mu_;
  absl::CondVar* const done_cv_;

  absl::Mutex streams_mu_;
  // Kept until the run ends.
  std::vector<std::unique_ptr<CameraStream>> streams_ ABSL_GUARDED_BY(streams_mu_);
  CameraStream* current_ ABSL_GUARDED_BY(streams_mu_) = nullptr;
  bool first_message_ ABSL_GUARDED_BY(streams_mu_) = true;
  uint64_t next_frame_id_ ABSL_GUARDED_BY(streams_mu_) = 0;
  size_t next_frame_ ABSL_GUARDED_BY(streams_mu_) = 0;

  absl::Mutex stats_mu_;
  CameraStats stats_ ABSL_GUARDED_BY(stats_mu_);
};

}  // namespace lane::client::load

#endif  // LANE_CLIENT_BENCH_CAMERA_H_
