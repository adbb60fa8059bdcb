#include "bench.h"

#include <grpcpp/generic/generic_stub.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <queue>
#include <set>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "bench_camera.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;
using load::Camera;
using load::CameraStats;
using load::CameraStream;
using load::Clock;
using load::RunState;

// Sessions first, outside the measurement (and again inline on every call).
absl::Status CreateSessions(const LoadSpec& spec) {
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
  return absl::OkStatus();
}

// How a camera's call ended, as a failure for the retry budget: a call that
// ended with OK during the run ended early all the same.
absl::Status CallFailure(const grpc::Status& status) {
  if (status.ok()) return absl::UnknownError("the call ended before the run did");
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
}

// One run of RunLoad: its cameras, the open loop's scheduler, and the
// supervision (progress, reconnection, drain) on the calling thread.
class LoadRun {
 public:
  explicit LoadRun(const LoadSpec& spec) : spec_(spec) {
    for (const auto& channel : spec.channels) {
      stubs_.push_back(std::make_unique<grpc::GenericStub>(channel));
    }
    run_.spec = &spec;
    for (int i = 0; i < spec.cameras; ++i) {
      const size_t c = static_cast<size_t>(i) % stubs_.size();
      cameras_.push_back(std::make_unique<Camera>(
          i, absl::StrCat(spec.camera_prefix, i), stubs_[c].get(),
          spec.channel_targets[c % spec.channel_targets.size()], &run_, &done_mu_, &done_cv_));
    }
  }

  // The servers' CPU seconds now (one call per target); negative when a
  // server does not answer or does not say.
  double ServerCpuSeconds() {
    double total = 0;
    std::set<std::string> asked;
    for (size_t c = 0; c < spec_.channels.size(); ++c) {
      const std::string& target = spec_.channel_targets[c % spec_.channel_targets.size()];
      if (!asked.insert(target).second) continue;
      auto stub = v1::LaneService::NewStub(spec_.channels[c]);
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
      v1::ServerInfo info;
      if (!stub->GetServerInfo(&context, v1::GetServerInfoRequest(), &info).ok() ||
          info.process_cpu_seconds() <= 0) {
        return -1;
      }
      total += info.process_cpu_seconds();
    }
    return total;
  }

  LoadResult Run() {
    run_.start = Clock::now();
    run_.start_unix_ns = absl::GetCurrentTimeNanos();
    run_.measure_start = run_.start + absl::ToChronoNanoseconds(spec_.warmup);
    run_.measure_end = run_.measure_start + absl::ToChronoNanoseconds(spec_.duration);
    last_progress_ = Clock::now();
    for (auto& camera : cameras_) camera->OpenStream();
    std::thread scheduler;
    if (spec_.open_loop) scheduler = std::thread([this] { Schedule(); });
    Supervise();
    run_.stopping.store(true, std::memory_order_release);
    if (scheduler.joinable()) scheduler.join();
    for (auto& camera : cameras_) {
      if (CameraStream* stream = camera->current()) stream->HalfClose();
    }
    Drain();
    const double cpu_end = ServerCpuSeconds();
    LoadResult result = Collect();
    if (cpu_start_ >= 0 && cpu_end >= cpu_start_) {
      result.server_cpu_s = cpu_end - cpu_start_;
      if (result.frames_sent > 0) {
        result.server_cpu_ms_per_frame =
            1e3 * result.server_cpu_s / static_cast<double>(result.frames_sent);
      }
    }
    return result;
  }

 private:
  // Open loop: camera c's k-th frame is due at start + (k + c/N) * period.
  void Schedule() {
    const double period_s = 1.0 / spec_.fps;
    using Item = std::tuple<Clock::time_point, int, int64_t>;  // (due, camera, k)
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
    const auto due = [&](int c, int64_t k) {
      const double t = (static_cast<double>(k) + static_cast<double>(c) / spec_.cameras) * period_s;
      return run_.start +
             std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(t));
    };
    for (int c = 0; c < spec_.cameras; ++c) heap.emplace(due(c, 0), c, 0);
    while (!heap.empty()) {
      const auto [when, c, k] = heap.top();
      heap.pop();
      if (when >= run_.measure_end) break;
      std::this_thread::sleep_until(when);
      cameras_[static_cast<size_t>(c)]->SendScheduled(when);
      heap.emplace(due(c, k + 1), c, k + 1);
    }
  }

  // Until the end of the measurement: progress, and reconnection of cameras
  // whose call failed (the shared reconnect policy; its schedule and its
  // attempts budget start again after a call that was answered). Ends early
  // when every camera has given up.
  void Supervise() {
    bool cpu_sampled = false;
    while (true) {
      const auto now = Clock::now();
      if (now >= run_.measure_end) break;
      if (!cpu_sampled && now >= run_.measure_start) {
        // The servers' CPU from the start of the measured window.
        cpu_start_ = ServerCpuSeconds();
        cpu_sampled = true;
      }
      size_t gave_up = 0;
      for (auto& camera : cameras_) {
        if (!camera->gave_up.ok()) {
          ++gave_up;
          continue;
        }
        CameraStream* stream = camera->current();
        if (stream == nullptr || !stream->done()) continue;
        if (camera->retry_at == Clock::time_point{}) {
          if (stream->answered_any()) {
            camera->backoff.Reset();
            camera->budget.Progress(MonotonicNow());
          }
          // A deterministic failure (the same status, call after call, and
          // nothing answered) is not retried for the rest of the run.
          if (absl::Status s =
                  camera->budget.Failed(CallFailure(stream->final_status()), MonotonicNow());
              !s.ok()) {
            camera->gave_up = std::move(s);
            ++gave_up;
            continue;
          }
          camera->retry_at = now + absl::ToChronoNanoseconds(camera->backoff.Next());
        } else if (now >= camera->retry_at) {
          camera->retry_at = Clock::time_point{};
          camera->OpenStream();
        }
      }
      if (gave_up == cameras_.size()) break;  // nothing left to measure
      if (spec_.progress && now - last_progress_ >= std::chrono::milliseconds(500)) {
        ReportProgress(now < run_.measure_start ? "warm-up" : "run");
      }
      absl::MutexLock lock(&done_mu_);
      WaitDoneUntil(std::min(run_.measure_end, now + std::chrono::milliseconds(50)));
    }
  }

  double cpu_start_ = -1;  // the servers' CPU seconds at the start of the measured window

  void ReportProgress(const char* phase) {
    Progress p;
    p.phase = phase;
    const auto now = Clock::now();
    p.elapsed_s = std::chrono::duration<double>(now - run_.start).count();
    p.total_s = absl::ToDoubleSeconds(spec_.warmup + spec_.duration);
    double latency_sum = 0;
    uint64_t interval_ok = 0;
    for (auto& camera : cameras_) {
      camera->WithStats([&](CameraStats& s) {
        p.ok += s.ok;
        p.errors += s.failed + s.dropped;
        interval_ok += s.interval_ok;
        latency_sum += s.interval_latency_ms;
        s.interval_ok = 0;
        s.interval_latency_ms = 0;
      });
    }
    const double dt = std::chrono::duration<double>(now - last_progress_).count();
    p.fps = dt > 0 ? static_cast<double>(interval_ok) / dt : 0;
    p.mean_ms = interval_ok > 0 ? latency_sum / static_cast<double>(interval_ok) : 0;
    last_progress_ = now;
    if (spec_.progress) spec_.progress(p);
  }

  // Waits for the answers, then cancels what is left. AllDone() is decided
  // under done_mu_: every OnDone has then returned from its last access to
  // the streams. Cancel and HalfClose may run reactions inline, so they are
  // called without it.
  void Drain() {
    const auto drain_deadline = run_.measure_end + absl::ToChronoNanoseconds(spec_.drain_timeout);
    while (true) {
      const auto now = Clock::now();
      {
        absl::MutexLock lock(&done_mu_);
        if (AllDone()) break;
        if (now < drain_deadline) {
          WaitDoneUntil(std::min(drain_deadline, now + std::chrono::milliseconds(100)));
        }
      }
      if (now >= drain_deadline) {
        for (auto& camera : cameras_) {
          for (CameraStream* stream : camera->streams()) {
            if (!stream->done()) stream->Cancel();
          }
        }
        absl::MutexLock lock(&done_mu_);
        done_cv_.WaitWithTimeout(&done_mu_, absl::Milliseconds(50));
      } else if (spec_.progress && now - last_progress_ >= std::chrono::milliseconds(500)) {
        ReportProgress("drain");
      }
    }
  }

  bool AllDone() ABSL_EXCLUSIVE_LOCKS_REQUIRED(done_mu_) {
    for (auto& camera : cameras_) {
      for (CameraStream* stream : camera->streams()) {
        if (!stream->done()) return false;
      }
    }
    return true;
  }

  // Until a stream is done (or a spurious wake-up) or `deadline`.
  void WaitDoneUntil(Clock::time_point deadline) ABSL_EXCLUSIVE_LOCKS_REQUIRED(done_mu_) {
    done_cv_.WaitWithTimeout(&done_mu_, absl::FromChrono(deadline - Clock::now()));
  }

  // The cameras' counts added up.
  LoadResult Collect() {
    LoadResult result;
    result.cameras = spec_.cameras;
    result.open_loop = spec_.open_loop;
    result.target_fps = spec_.open_loop ? spec_.fps * spec_.cameras : 0;
    std::vector<double> latency;
    std::vector<double> server, queue, decode, detect;
    std::vector<float> ok_at_s;
    std::vector<float> error_at_s;
    Clock::time_point last_ok = run_.measure_start;
    for (auto& camera : cameras_) {
      const CameraStats s = camera->stats();
      result.frames_scheduled += s.scheduled;
      result.frames_sent += s.sent;
      result.frames_ok += s.ok;
      result.dropped += s.dropped;
      result.errors_total += s.failed;
      result.unsent += s.unsent;
      for (const auto& [code, n] : s.errors) result.errors[code] += n;
      latency.insert(latency.end(), s.latency_ms.begin(), s.latency_ms.end());
      server.insert(server.end(), s.server_ms.begin(), s.server_ms.end());
      queue.insert(queue.end(), s.queue_ms.begin(), s.queue_ms.end());
      decode.insert(decode.end(), s.decode_ms.begin(), s.decode_ms.end());
      detect.insert(detect.end(), s.detect_ms.begin(), s.detect_ms.end());
      ok_at_s.insert(ok_at_s.end(), s.ok_at_s.begin(), s.ok_at_s.end());
      error_at_s.insert(error_at_s.end(), s.error_at_s.begin(), s.error_at_s.end());
      if (s.ok > 0) last_ok = std::max(last_ok, s.last_ok);
      result.max_send_lag_ms = std::max(result.max_send_lag_ms, s.max_send_lag_ms);
      result.stream_failures += s.stream_failures;
      result.ok_by_target[camera->target()] += s.ok;
      if (!camera->gave_up.ok()) {
        result.gave_up.push_back(absl::StrCat(camera->id(), ": ", camera->gave_up.message()));
      }
    }
    // At least the measurement window: a run that answered everything early
    // still lasted that long.
    result.measured_s =
        std::max(std::chrono::duration<double>(last_ok - run_.measure_start).count(),
                 absl::ToDoubleSeconds(spec_.duration));
    result.achieved_fps =
        result.measured_s > 0 ? static_cast<double>(result.frames_ok) / result.measured_s : 0;
    if (spec_.timeline_interval > absl::ZeroDuration()) {
      result.timeline = Timeline(latency, ok_at_s, error_at_s,
                                 absl::ToDoubleSeconds(spec_.timeline_interval), result.measured_s);
    }
    result.latency_histogram = Histogram(latency);
    result.latency_ms = Summarize(latency);
    result.server_ms = Summarize(server);
    result.queue_ms = Summarize(queue);
    result.decode_ms = Summarize(decode);
    result.detect_ms = Summarize(detect);
    return result;
  }

  const LoadSpec& spec_;
  std::vector<std::unique_ptr<grpc::GenericStub>> stubs_;
  RunState run_;
  absl::Mutex done_mu_;
  absl::CondVar done_cv_;  // a stream is done (Camera::StreamDone)
  std::vector<std::unique_ptr<Camera>> cameras_;
  Clock::time_point last_progress_;
};

}  // namespace

absl::StatusOr<LoadResult> RunLoad(const LoadSpec& spec) {
  if (spec.frames == nullptr || spec.frames->empty()) {
    return absl::InvalidArgumentError("no frames to send");
  }
  if (spec.channels.empty()) return absl::InvalidArgumentError("no target");
  if (const absl::Status s = CreateSessions(spec); !s.ok()) return s;
  LoadRun run(spec);
  return run.Run();
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

}  // namespace lane::client
