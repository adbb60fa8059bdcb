// The in-process reference of `lane-client bench`: the service's decode and
// detect on the same frames, without gRPC.
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/synchronization/mutex.h"
#include "bench.h"
#include "lane/detector/detector.h"
#include "lane/track/frame_tracker.h"
#include "wire/config_proto.h"
#include "wire/frame_decoder.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;
using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// What the in-process workers share: frames, detector, interval, counts and latencies.
struct InprocessRun {
  InprocessRun(const std::vector<BenchFrame>& frames, const lane::Detector& detector,
               const lane::CameraModel& camera)
      : frames(frames), detector(detector), camera(camera) {}

  const std::vector<BenchFrame>& frames;
  const lane::Detector& detector;
  const lane::CameraModel& camera;
  lane::wire::DecodeOptions decode;
  const lane::FrameNeeds* needs = nullptr;
  bool tracked = false;
  Clock::time_point start, measure_start, end;
  std::atomic<size_t> next{0};
  std::atomic<uint64_t> done_frames{0};
  std::atomic<uint64_t> tracked_frames{0};
  absl::Mutex mu;
  std::vector<double> latency ABSL_GUARDED_BY(mu);
  std::string failure ABSL_GUARDED_BY(mu);
};

// One worker: decodes and detects (or tracks) frames until the end, timing the measured ones.
void RunWorker(InprocessRun& run) {
  std::vector<double> own;
  lane::FrameTracker tracker(run.camera);
  while (true) {
    const Clock::time_point t0 = Clock::now();
    if (t0 >= run.end) break;
    const BenchFrame& frame = run.frames[run.next.fetch_add(1) % run.frames.size()];
    absl::StatusOr<cv::Mat> image = lane::wire::DecodeFrame(frame.request, run.decode, run.needs);
    absl::Status status = image.status();
    if (image.ok()) {
      status = run.tracked ? tracker.Process(run.detector, *image, std::nullopt).status()
                           : run.detector.Detect(*image).status();
      if (status.ok() && run.tracked && t0 >= run.measure_start) {
        run.tracked_frames.fetch_add(1, std::memory_order_relaxed);
      }
    }
    const Clock::time_point t1 = Clock::now();
    if (!status.ok()) {
      absl::MutexLock lock(&run.mu);
      run.failure = absl::StrCat(frame.name, ": ", status.message());
      break;
    }
    if (t0 >= run.measure_start) {
      own.push_back(Ms(t1 - t0));
      run.done_frames.fetch_add(1, std::memory_order_relaxed);
    }
  }
  absl::MutexLock lock(&run.mu);
  run.latency.insert(run.latency.end(), own.begin(), own.end());
}

// Reports the workers' progress every half second until the end.
void ReportProgress(const InprocessRun& run, double total_s, const ProgressFn& progress) {
  uint64_t last = 0;
  auto last_time = run.start;
  while (Clock::now() < run.end) {
    std::this_thread::sleep_until(std::min(run.end, Clock::now() + std::chrono::milliseconds(500)));
    const auto now = Clock::now();
    const uint64_t n = run.done_frames.load();
    Progress p;
    p.phase = now < run.measure_start ? "in-process warm-up" : "in-process";
    p.elapsed_s = std::chrono::duration<double>(now - run.start).count();
    p.total_s = total_s;
    p.ok = n;
    const double dt = std::chrono::duration<double>(now - last_time).count();
    p.fps = dt > 0 ? static_cast<double>(n - last) / dt : 0;
    last = n;
    last_time = now;
    progress(p);
  }
}

}  // namespace

double ProcessCpuSeconds() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) * 1e-6;
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
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
  InprocessRun run(frames, *detector, config->camera);
  run.decode.width = config->camera.image_width;
  run.decode.height = config->camera.image_height;
  run.decode.max_pixels = std::numeric_limits<int64_t>::max();
  // As the service decodes the session's frames: what its detector reads,
  // unless the session asks for whole frames.
  run.needs = session.decode().full_decode() ? nullptr : &detector->Needs();
  // A stream of a tracked session (the default) also searches the tracker's
  // predicted lanes, reads each lane's colour and type and updates the
  // tracker (server/frame_processor.cc): the reference does the same work,
  // with a tracker per worker, so the ratio measures the service's overhead
  // and not tracking.
  run.tracked = !session.tracking().disabled();

  workers = std::max(1, workers);
  run.start = Clock::now();
  run.measure_start = run.start + absl::ToChronoNanoseconds(warmup);
  run.end = run.measure_start + absl::ToChronoNanoseconds(duration);
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) threads.emplace_back([&run] { RunWorker(run); });
  // This process's CPU over the measured part: from its start to the
  // workers' end (they stop at run.end, having measured up to it).
  double cpu_start = 0;
  std::thread cpu_sampler([&run, &cpu_start] {
    std::this_thread::sleep_until(run.measure_start);
    cpu_start = ProcessCpuSeconds();
  });
  if (progress) ReportProgress(run, absl::ToDoubleSeconds(warmup + duration), progress);
  for (std::thread& t : threads) t.join();
  cpu_sampler.join();
  const double cpu_s = ProcessCpuSeconds() - cpu_start;
  // The workers are joined; what they left is read under the lock they wrote it under.
  absl::MutexLock lock(&run.mu);
  if (!run.failure.empty()) return absl::InternalError(absl::StrCat("in-process: ", run.failure));
  InprocessResult result;
  result.workers = workers;
  result.frames = run.latency.size();
  result.tracked = run.tracked;
  result.tracked_frames = run.tracked_frames.load();
  result.fps = static_cast<double>(result.frames) / absl::ToDoubleSeconds(duration);
  result.latency_ms = Summarize(run.latency);
  result.latency_samples = std::move(run.latency);
  result.cpu_s = cpu_s;
  result.cpu_ms_per_frame =
      result.frames > 0 ? 1e3 * cpu_s / static_cast<double>(result.frames) : 0;
  return result;
}

InprocessResult CombineInprocess(InprocessResult a, InprocessResult b, absl::Duration a_duration,
                                 absl::Duration b_duration) {
  InprocessResult out;
  out.workers = a.workers;
  out.frames = a.frames + b.frames;
  out.fps = static_cast<double>(out.frames) / absl::ToDoubleSeconds(a_duration + b_duration);
  out.tracked = a.tracked;
  out.tracked_frames = a.tracked_frames + b.tracked_frames;
  out.fps_before = a.fps;
  out.fps_after = b.fps;
  out.cpu_s = a.cpu_s + b.cpu_s;
  out.cpu_ms_per_frame = out.frames > 0 ? 1e3 * out.cpu_s / static_cast<double>(out.frames) : 0;
  out.latency_samples = std::move(a.latency_samples);
  out.latency_samples.insert(out.latency_samples.end(), b.latency_samples.begin(),
                             b.latency_samples.end());
  out.latency_ms = Summarize(out.latency_samples);
  return out;
}

}  // namespace lane::client
