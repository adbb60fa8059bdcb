#include "bench.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/client_callback.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <queue>
#include <thread>
#include <unordered_map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "common.h"
#include "frames.h"
#include "lane/detector.h"
#include "lane/synthetic.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "results.h"
#include "wire/config_proto.h"
#include "wire/frame_decoder.h"
#include "wire/status_map.h"

namespace lane_client {
namespace {

namespace v1 = lane::v1;
using Clock = std::chrono::steady_clock;

constexpr char kStreamMethod[] = "/lane.v1.LaneService/StreamFrames";

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

BenchFrame MakeBenchFrame(std::string name, v1::FrameRequest request) {
  BenchFrame frame;
  frame.name = std::move(name);
  frame.request = std::move(request);
  frame.image_part = frame.request.SerializeAsString();
  return frame;
}

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

  // Reconnection backoff of the supervisor.
  Clock::time_point retry_at{};
  int consecutive_failures = 0;

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

void CameraStream::Pump() {
  std::unique_lock<std::mutex> lock(mu_);
  if (pumping_) return;  // the pumping thread re-checks after its call
  pumping_ = true;
  while (true) {
    enum { kNone, kWrite, kWritesDone, kRelease } action = kNone;
    bool measured = false;
    uint64_t unsent = 0;
    if (!writing_) {
      if (failed_) {
        // Nothing more can be written: what is queued was never sent.
        for (const Outgoing& o : queue_) {
          if (o.measured) ++unsent;
          inflight_.erase(o.frame_id);
        }
        queue_.clear();
        if (!hold_released_) {
          hold_released_ = true;
          action = kRelease;
        }
      } else if (!queue_.empty()) {
        write_buffer_.Swap(&queue_.front().buffer);
        measured = queue_.front().measured;
        queue_.pop_front();
        writing_ = true;
        action = kWrite;
      } else if (half_close_ && !writes_done_started_) {
        writes_done_started_ = true;
        writing_ = true;
        action = kWritesDone;
      } else if (writes_done_ && !hold_released_) {
        hold_released_ = true;
        action = kRelease;
      }
    }
    if (action == kNone) break;
    lock.unlock();
    if (unsent > 0) {
      std::lock_guard<std::mutex> stats_lock(camera_->stats_mu());
      camera_->stats().unsent += unsent;
    }
    switch (action) {
      case kWrite:
        camera_->CountSent(measured);
        StartWrite(&write_buffer_);
        break;
      case kWritesDone:
        StartWritesDone();
        break;
      case kRelease:
        RemoveHold();
        break;
      case kNone:
        break;
    }
    lock.lock();
    if (action == kRelease) break;
  }
  pumping_ = false;
}

void CameraStream::OnReadDone(bool ok) {
  if (!ok) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      failed_ = true;  // the call is over: nothing more can be written
    }
    Pump();
    return;
  }
  const Clock::time_point now = Clock::now();
  v1::FrameResponse response;
  const bool parsed =
      grpc::SerializationTraits<v1::FrameResponse>::Deserialize(&read_buffer_, &response).ok();
  std::optional<Sent> sent;
  if (parsed) {
    std::lock_guard<std::mutex> lock(mu_);
    answered_any_ = true;
    const auto it = inflight_.find(response.frame_id());
    if (it != inflight_.end()) {
      sent = it->second;
      inflight_.erase(it);
    }
  }
  if (sent && sent->measured) {
    std::lock_guard<std::mutex> lock(camera_->stats_mu());
    CameraStats& stats = camera_->stats();
    const v1::FrameCode code = response.status().code();
    if (code == v1::FRAME_CODE_OK) {
      ++stats.ok;
      const double latency = Ms(now - sent->due);
      stats.latency_ms.push_back(latency);
      stats.server_ms.push_back(static_cast<double>(response.server_send_time_unix_ns() -
                                                    response.server_receive_time_unix_ns()) *
                                1e-6);
      stats.ok_at_s.push_back(camera_->run().SinceMeasureStart(now));
      stats.last_ok = now;
      ++stats.interval_ok;
      stats.interval_latency_ms += latency;
    } else if (code == v1::FRAME_CODE_DROPPED) {
      ++stats.dropped;
      stats.error_at_s.push_back(camera_->run().SinceMeasureStart(now));
    } else {
      ++stats.failed;
      ++stats.errors[FrameCodeName(code)];
      stats.error_at_s.push_back(camera_->run().SinceMeasureStart(now));
    }
  }
  StartRead(&read_buffer_);
  camera_->OnResponse(this);
}

void CameraStream::OnDone(const grpc::Status& status) {
  uint64_t lost = 0;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (const auto& entry : inflight_) {
      if (entry.second.measured) ++lost;
    }
    inflight_.clear();
  }
  {
    std::lock_guard<std::mutex> lock(camera_->stats_mu());
    CameraStats& stats = camera_->stats();
    if (lost > 0) {
      stats.failed += lost;
      stats.error_at_s.insert(stats.error_at_s.end(), lost,
                              camera_->run().SinceMeasureStart(Clock::now()));
      const std::string code =
          status.ok() ? std::string("UNKNOWN") : lane::wire::GrpcCodeName(status.error_code());
      stats.errors[code] += lost;
    }
    if (!status.ok() && !camera_->run().stopping.load()) ++stats.stream_failures;
  }
  // Last: once the run sees done_ (under done_mu), it may destroy this
  // stream, so the notification happens under done_mu too.
  std::lock_guard<std::mutex> lock(camera_->done_mu());
  {
    std::lock_guard<std::mutex> own(mu_);
    done_ = true;
  }
  camera_->done_cv().notify_all();
}

}  // namespace

std::vector<TimelinePoint> Timeline(const std::vector<double>& latency_ms,
                                    const std::vector<float>& ok_at_s,
                                    const std::vector<float>& error_at_s, double interval_s,
                                    double measured_s) {
  std::vector<TimelinePoint> points;
  if (interval_s <= 0 || measured_s <= 0) return points;
  const size_t n = static_cast<size_t>(std::ceil(measured_s / interval_s - 1e-9));
  points.resize(std::max<size_t>(n, 1));
  for (size_t i = 0; i < points.size(); ++i) {
    points[i].start_s = static_cast<double>(i) * interval_s;
    points[i].end_s = std::min(measured_s, static_cast<double>(i + 1) * interval_s);
  }
  // Answers after the window (the drain) count in the last interval.
  const auto bucket = [&](float t) {
    const double k = std::floor(std::max(0.0, static_cast<double>(t)) / interval_s);
    return std::min(points.size() - 1, static_cast<size_t>(k));
  };
  std::vector<std::vector<double>> values(points.size());
  for (size_t i = 0; i < latency_ms.size() && i < ok_at_s.size(); ++i) {
    values[bucket(ok_at_s[i])].push_back(latency_ms[i]);
  }
  for (const float t : error_at_s) ++points[bucket(t)].errors;
  for (size_t i = 0; i < points.size(); ++i) {
    points[i].ok = values[i].size();
    points[i].latency_ms = Summarize(values[i]);
  }
  return points;
}

absl::StatusOr<std::vector<BenchFrame>> SyntheticBenchFrames(const lane::CameraModel& camera,
                                                             int count, bool raw,
                                                             int jpeg_quality) {
  std::vector<BenchFrame> frames;
  for (int i = 0; i < count; ++i) {
    absl::StatusOr<lane::SyntheticFrame> frame =
        lane::RenderSyntheticFrame(camera, lane::SyntheticOptions(), static_cast<uint64_t>(i + 1));
    if (!frame.ok()) return frame.status();
    v1::FrameRequest request;
    if (raw) {
      SetRawBgr(frame->bgr, &request);
    } else {
      std::vector<uchar> bytes;
      if (!cv::imencode(".jpg", frame->bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality})) {
        return absl::InternalError("cannot JPEG-encode a synthetic frame");
      }
      request.set_encoded(std::string(bytes.begin(), bytes.end()));
    }
    frames.push_back(MakeBenchFrame(absl::StrCat("synthetic-", i + 1), std::move(request)));
  }
  return frames;
}

absl::StatusOr<std::vector<BenchFrame>> LoadBenchFrames(const std::vector<std::string>& inputs,
                                                        bool raw, int max_frames) {
  FrameSource source(inputs, raw);
  std::vector<BenchFrame> frames;
  ClientFrame frame;
  while (static_cast<int>(frames.size()) < max_frames && source.Next(&frame)) {
    if (!frame.error.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(frame.name, ": ", frame.error));
    }
    v1::FrameRequest request;
    SetRequestImage(frame, &request);
    frames.push_back(MakeBenchFrame(frame.name, std::move(request)));
  }
  if (frames.empty()) return absl::InvalidArgumentError("the inputs contain no frames");
  return frames;
}

LatencySummary Summarize(std::vector<double>& values) {
  LatencySummary s;
  s.count = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const auto rank = [&values](double p) {
    const double r = std::ceil(p / 100.0 * static_cast<double>(values.size()));
    const size_t index = static_cast<size_t>(std::max(1.0, r)) - 1;
    return values[std::min(index, values.size() - 1)];
  };
  s.p50 = rank(50);
  s.p90 = rank(90);
  s.p99 = rank(99);
  s.p999 = rank(99.9);
  s.max = values.back();
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / static_cast<double>(values.size());
  return s;
}

absl::StatusOr<LoadResult> RunLoad(const LoadSpec& spec) {
  if (spec.frames == nullptr || spec.frames->empty()) {
    return absl::InvalidArgumentError("no frames to send");
  }
  if (spec.channels.empty()) return absl::InvalidArgumentError("no target");

  // Sessions first, outside the measurement (and again inline on every call).
  for (int i = 0; i < spec.cameras; ++i) {
    const auto stub = v1::LaneService::NewStub(spec.channels[i % spec.channels.size()]);
    grpc::ClientContext context;
    SetDeadline(&context, absl::Seconds(10));
    context.set_wait_for_ready(true);
    v1::CreateSessionRequest request;
    request.set_camera_id(absl::StrCat(spec.camera_prefix, i));
    *request.mutable_config() = spec.session;
    request.set_replace(spec.replace);
    v1::CreateSessionResponse response;
    const grpc::Status status = stub->CreateSession(&context, request, &response);
    if (!status.ok()) {
      return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                          absl::StrCat("CreateSession ", request.camera_id(), " on ",
                                       spec.channel_targets[i % spec.channel_targets.size()], ": ",
                                       StatusText(status)));
    }
  }

  std::vector<std::unique_ptr<grpc::GenericStub>> stubs;
  for (const auto& channel : spec.channels) {
    stubs.push_back(std::make_unique<grpc::GenericStub>(channel));
  }
  RunState run;
  run.spec = &spec;
  std::mutex done_mu;
  std::condition_variable done_cv;
  std::vector<std::unique_ptr<Camera>> cameras;
  for (int i = 0; i < spec.cameras; ++i) {
    const size_t c = static_cast<size_t>(i) % stubs.size();
    cameras.push_back(std::make_unique<Camera>(
        i, absl::StrCat(spec.camera_prefix, i), stubs[c].get(),
        spec.channel_targets[c % spec.channel_targets.size()], &run, &done_mu, &done_cv));
  }

  run.start = Clock::now();
  run.start_unix_ns = absl::GetCurrentTimeNanos();
  run.measure_start = run.start + absl::ToChronoNanoseconds(spec.warmup);
  run.measure_end = run.measure_start + absl::ToChronoNanoseconds(spec.duration);
  for (auto& camera : cameras) camera->OpenStream();

  std::thread scheduler;
  if (spec.open_loop) {
    scheduler = std::thread([&] {
      const double period_s = 1.0 / spec.fps;
      // (due, camera, k): camera c's k-th frame is due at start + (k + c/N) * period.
      using Item = std::tuple<Clock::time_point, int, int64_t>;
      std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
      const auto due = [&](int c, int64_t k) {
        const double t =
            (static_cast<double>(k) + static_cast<double>(c) / spec.cameras) * period_s;
        return run.start +
               std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t));
      };
      for (int c = 0; c < spec.cameras; ++c) heap.emplace(due(c, 0), c, 0);
      while (!heap.empty()) {
        const auto [when, c, k] = heap.top();
        heap.pop();
        if (when >= run.measure_end) break;
        std::this_thread::sleep_until(when);
        cameras[static_cast<size_t>(c)]->SendScheduled(when);
        heap.emplace(due(c, k + 1), c, k + 1);
      }
    });
  }

  // Supervise: progress, and reconnection of cameras whose call failed.
  const double total_s = absl::ToDoubleSeconds(spec.warmup + spec.duration);
  auto last_progress = Clock::now();
  const auto report = [&](const char* phase) {
    Progress p;
    p.phase = phase;
    const auto now = Clock::now();
    p.elapsed_s = std::chrono::duration<double>(now - run.start).count();
    p.total_s = total_s;
    double latency_sum = 0;
    uint64_t interval_ok = 0;
    for (auto& camera : cameras) {
      std::lock_guard<std::mutex> lock(camera->stats_mu());
      CameraStats& s = camera->stats();
      p.ok += s.ok;
      p.errors += s.failed + s.dropped;
      interval_ok += s.interval_ok;
      latency_sum += s.interval_latency_ms;
      s.interval_ok = 0;
      s.interval_latency_ms = 0;
    }
    const double dt = std::chrono::duration<double>(now - last_progress).count();
    p.fps = dt > 0 ? static_cast<double>(interval_ok) / dt : 0;
    p.mean_ms = interval_ok > 0 ? latency_sum / static_cast<double>(interval_ok) : 0;
    last_progress = now;
    if (spec.progress) spec.progress(p);
  };
  while (true) {
    const auto now = Clock::now();
    if (now >= run.measure_end) break;
    for (auto& camera : cameras) {
      CameraStream* stream = camera->current();
      if (stream == nullptr || !stream->done()) continue;
      if (camera->retry_at == Clock::time_point{}) {
        camera->consecutive_failures =
            stream->answered_any() ? 1 : camera->consecutive_failures + 1;
        const int shift = std::min(camera->consecutive_failures - 1, 4);
        camera->retry_at = now + std::chrono::milliseconds(100 << shift);
      } else if (now >= camera->retry_at) {
        camera->retry_at = Clock::time_point{};
        camera->OpenStream();
      }
    }
    if (spec.progress && now - last_progress >= std::chrono::milliseconds(500)) {
      report(now < run.measure_start ? "warm-up" : "run");
    }
    std::unique_lock<std::mutex> lock(done_mu);
    done_cv.wait_until(lock, std::min(run.measure_end, now + std::chrono::milliseconds(50)));
  }
  run.stopping.store(true, std::memory_order_release);
  if (scheduler.joinable()) scheduler.join();
  for (auto& camera : cameras) {
    if (CameraStream* stream = camera->current()) stream->HalfClose();
  }
  // Wait for the answers, then cancel what is left.
  const auto drain_deadline = run.measure_end + absl::ToChronoNanoseconds(spec.drain_timeout);
  const auto all_done = [&] {
    for (auto& camera : cameras) {
      for (CameraStream* stream : camera->streams()) {
        if (!stream->done()) return false;
      }
    }
    return true;
  };
  // all_done() is decided under done_mu: every OnDone has then returned
  // from its last access to the streams. Cancel and HalfClose may run
  // reactions inline, so they are called without it.
  while (true) {
    const auto now = Clock::now();
    {
      std::unique_lock<std::mutex> lock(done_mu);
      if (all_done()) break;
      if (now < drain_deadline) {
        done_cv.wait_until(lock, std::min(drain_deadline, now + std::chrono::milliseconds(100)));
      }
    }
    if (now >= drain_deadline) {
      for (auto& camera : cameras) {
        for (CameraStream* stream : camera->streams()) {
          if (!stream->done()) stream->Cancel();
        }
      }
      std::unique_lock<std::mutex> lock(done_mu);
      done_cv.wait_for(lock, std::chrono::milliseconds(50));
    } else if (spec.progress && now - last_progress >= std::chrono::milliseconds(500)) {
      report("drain");
    }
  }

  LoadResult result;
  result.cameras = spec.cameras;
  result.open_loop = spec.open_loop;
  result.target_fps = spec.open_loop ? spec.fps * spec.cameras : 0;
  std::vector<double> latency;
  std::vector<double> server;
  std::vector<float> ok_at_s;
  std::vector<float> error_at_s;
  Clock::time_point last_ok = run.measure_start;
  for (auto& camera : cameras) {
    std::lock_guard<std::mutex> lock(camera->stats_mu());
    CameraStats& s = camera->stats();
    result.frames_scheduled += s.scheduled;
    result.frames_sent += s.sent;
    result.frames_ok += s.ok;
    result.dropped += s.dropped;
    result.errors_total += s.failed;
    result.unsent += s.unsent;
    for (const auto& [code, n] : s.errors) result.errors[code] += n;
    latency.insert(latency.end(), s.latency_ms.begin(), s.latency_ms.end());
    server.insert(server.end(), s.server_ms.begin(), s.server_ms.end());
    ok_at_s.insert(ok_at_s.end(), s.ok_at_s.begin(), s.ok_at_s.end());
    error_at_s.insert(error_at_s.end(), s.error_at_s.begin(), s.error_at_s.end());
    if (s.ok > 0) last_ok = std::max(last_ok, s.last_ok);
    result.max_send_lag_ms = std::max(result.max_send_lag_ms, s.max_send_lag_ms);
    result.stream_failures += s.stream_failures;
    result.ok_by_target[camera->target()] += s.ok;
  }
  // At least the measurement window: a run that answered everything early
  // still lasted that long.
  result.measured_s = std::max(std::chrono::duration<double>(last_ok - run.measure_start).count(),
                               absl::ToDoubleSeconds(spec.duration));
  result.achieved_fps =
      result.measured_s > 0 ? static_cast<double>(result.frames_ok) / result.measured_s : 0;
  if (spec.timeline_interval > absl::ZeroDuration()) {
    result.timeline = Timeline(latency, ok_at_s, error_at_s,
                               absl::ToDoubleSeconds(spec.timeline_interval), result.measured_s);
  }
  result.latency_ms = Summarize(latency);
  result.server_ms = Summarize(server);
  return result;
}

void DeleteSessions(const LoadSpec& spec, int cameras) {
  for (int i = 0; i < cameras && !spec.channels.empty(); ++i) {
    // Through the camera's own channel: to the target its session was made on.
    const auto stub = v1::LaneService::NewStub(spec.channels[i % spec.channels.size()]);
    grpc::ClientContext context;
    SetDeadline(&context, absl::Seconds(5));
    v1::DeleteSessionRequest request;
    request.set_camera_id(absl::StrCat(spec.camera_prefix, i));
    v1::DeleteSessionResponse response;
    stub->DeleteSession(&context, request, &response).ok();  // NOT_FOUND is fine
  }
}

absl::StatusOr<InprocessResult> RunInprocess(const std::vector<BenchFrame>& frames,
                                             const v1::SessionConfig& session, int workers,
                                             absl::Duration warmup, absl::Duration duration,
                                             const ProgressFn& progress) {
  if (frames.empty()) return absl::InvalidArgumentError("no frames");
  absl::StatusOr<lane::Config> config = lane::wire::ConfigFromProto(session);
  if (!config.ok()) return config.status();
  absl::StatusOr<lane::Detector> detector =
      lane::Detector::Create(config->camera, config->ipm, config->detector);
  if (!detector.ok()) return detector.status();
  lane::wire::DecodeOptions decode;
  decode.width = config->camera.image_width;
  decode.height = config->camera.image_height;
  decode.max_pixels = std::numeric_limits<int64_t>::max();
  decode.gray = config->detector.channel == lane::Channel::kGray;

  workers = std::max(1, workers);
  const Clock::time_point start = Clock::now();
  const Clock::time_point measure_start = start + absl::ToChronoNanoseconds(warmup);
  const Clock::time_point end = measure_start + absl::ToChronoNanoseconds(duration);
  std::atomic<size_t> next{0};
  std::atomic<uint64_t> done_frames{0};
  std::mutex mu;
  std::vector<double> latency;
  std::string failure;
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) {
    threads.emplace_back([&] {
      std::vector<double> own;
      while (true) {
        const Clock::time_point t0 = Clock::now();
        if (t0 >= end) break;
        const BenchFrame& frame = frames[next.fetch_add(1) % frames.size()];
        absl::StatusOr<cv::Mat> image = lane::wire::DecodeFrame(frame.request, decode);
        absl::Status status = image.status();
        if (image.ok()) status = detector->Detect(*image).status();
        const Clock::time_point t1 = Clock::now();
        if (!status.ok()) {
          std::lock_guard<std::mutex> lock(mu);
          failure = absl::StrCat(frame.name, ": ", status.message());
          break;
        }
        if (t0 >= measure_start) {
          own.push_back(Ms(t1 - t0));
          done_frames.fetch_add(1, std::memory_order_relaxed);
        }
      }
      std::lock_guard<std::mutex> lock(mu);
      latency.insert(latency.end(), own.begin(), own.end());
    });
  }
  if (progress) {
    uint64_t last = 0;
    auto last_time = start;
    while (Clock::now() < end) {
      std::this_thread::sleep_until(std::min(end, Clock::now() + std::chrono::milliseconds(500)));
      const auto now = Clock::now();
      const uint64_t n = done_frames.load();
      Progress p;
      p.phase = now < measure_start ? "in-process warm-up" : "in-process";
      p.elapsed_s = std::chrono::duration<double>(now - start).count();
      p.total_s = absl::ToDoubleSeconds(warmup + duration);
      p.ok = n;
      const double dt = std::chrono::duration<double>(now - last_time).count();
      p.fps = dt > 0 ? static_cast<double>(n - last) / dt : 0;
      last = n;
      last_time = now;
      progress(p);
    }
  }
  for (std::thread& t : threads) t.join();
  if (!failure.empty()) return absl::InternalError(absl::StrCat("in-process: ", failure));
  InprocessResult result;
  result.workers = workers;
  result.frames = latency.size();
  result.fps = static_cast<double>(result.frames) / absl::ToDoubleSeconds(duration);
  result.latency_ms = Summarize(latency);
  return result;
}

}  // namespace lane_client
