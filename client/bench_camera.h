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
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "bench.h"
#include "lane/v1/lane_service.pb.h"
#include "reconnect_backoff.h"

namespace lane_client::load {

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

// Per camera, guarded by its mutex.
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
    std::lock_guard<std::mutex> lock(mu_);
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
      std::lock_guard<std::mutex> lock(mu_);
      half_close_ = true;
    }
    Pump();
  }

  void Cancel() { context_.TryCancel(); }

  bool done() {
    std::lock_guard<std::mutex> lock(mu_);
    return done_;
  }
  bool answered_any() {
    std::lock_guard<std::mutex> lock(mu_);
    return answered_any_;
  }
  size_t unanswered() {
    std::lock_guard<std::mutex> lock(mu_);
    return inflight_.size();
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      writing_ = false;
      if (!ok) failed_ = true;
    }
    Pump();
  }

  void OnWritesDoneDone(bool /*ok*/) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      writing_ = false;
      writes_done_ = true;
    }
    Pump();
  }

  void OnReadDone(bool ok) override;
  void OnDone(const grpc::Status& status) override;

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

  std::mutex mu_;
  std::deque<Outgoing> queue_;                   // not yet written
  std::unordered_map<uint64_t, Sent> inflight_;  // queued or written, unanswered
  bool writing_ = false;
  bool pumping_ = false;
  bool half_close_ = false;
  bool writes_done_started_ = false;
  bool writes_done_ = false;
  bool failed_ = false;
  bool hold_released_ = false;
  bool done_ = false;
  bool answered_any_ = false;
};

class Camera {
 public:
  Camera(int index, std::string id, grpc::GenericStub* stub, std::string target, RunState* run,
         std::mutex* done_mu, std::condition_variable* done_cv)
      : id_(std::move(id)),
        stub_(stub),
        target_(std::move(target)),
        run_(run),
        done_mu_(done_mu),
        done_cv_(done_cv) {
    next_frame_ = static_cast<size_t>(index) * 7 % run_->spec->frames->size();
  }

  const std::string& target() const { return target_; }
  std::mutex& stats_mu() { return stats_mu_; }
  CameraStats& stats() { return stats_; }  // under stats_mu()
  std::mutex& done_mu() { return *done_mu_; }
  std::condition_variable& done_cv() { return *done_cv_; }
  const RunState& run() const { return *run_; }

  // A new call (the previous one, if any, is done).
  void OpenStream() {
    auto stream = std::make_unique<CameraStream>(this, stub_);
    CameraStream* raw = stream.get();
    {
      std::lock_guard<std::mutex> lock(streams_mu_);
      streams_.push_back(std::move(stream));
      current_ = raw;
      first_message_ = true;
    }
    raw->Start();
    if (!run_->spec->open_loop) TopUp(raw);
  }

  CameraStream* current() {
    std::lock_guard<std::mutex> lock(streams_mu_);
    return current_;
  }

  // Open loop: the frame due at `due`.
  void SendScheduled(Clock::time_point due) {
    const bool measured = run_->Measured(due);
    CameraStream* stream = current();
    const bool queued = stream != nullptr && !stream->done() &&
                        SendNext(stream, due, measured, std::numeric_limits<size_t>::max());
    const double lag_ms = Ms(Clock::now() - due);
    std::lock_guard<std::mutex> lock(stats_mu_);
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
        std::lock_guard<std::mutex> lock(stats_mu_);
        ++stats_.scheduled;
      }
    }
  }

  void OnResponse(CameraStream* stream) {
    if (!run_->spec->open_loop) TopUp(stream);
  }

  void CountSent(bool measured) {
    if (!measured) return;
    std::lock_guard<std::mutex> lock(stats_mu_);
    ++stats_.sent;
  }

  std::vector<CameraStream*> streams() {
    std::lock_guard<std::mutex> lock(streams_mu_);
    std::vector<CameraStream*> out;
    for (const auto& s : streams_) out.push_back(s.get());
    return out;
  }

  // Reconnection of the supervisor: when the next call is due (zero: not
  // scheduled), and the shared reconnect policy.
  Clock::time_point retry_at{};
  ReconnectBackoff backoff;

 private:
  // Queues the camera's next frame on `stream` and writes it. Frame ids are
  // taken in queue order under streams_mu_, so the first message of a call
  // (the one with the session config) is the first written.
  bool SendNext(CameraStream* stream, Clock::time_point due, bool measured, size_t limit) {
    const std::vector<BenchFrame>& frames = *run_->spec->frames;
    {
      std::lock_guard<std::mutex> lock(streams_mu_);
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
  std::mutex* const done_mu_;
  std::condition_variable* const done_cv_;

  std::mutex streams_mu_;
  std::vector<std::unique_ptr<CameraStream>> streams_;  // kept until the run ends
  CameraStream* current_ = nullptr;
  bool first_message_ = true;
  uint64_t next_frame_id_ = 0;
  size_t next_frame_ = 0;

  std::mutex stats_mu_;
  CameraStats stats_;
};

}  // namespace lane_client::load

#endif  // LANE_CLIENT_BENCH_CAMERA_H_
