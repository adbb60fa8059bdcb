// The in-process reference of `lane-client bench`: the service's decode and
// detect on the same frames, without gRPC.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench.h"
#include "lane/detector.h"
#include "lane/track/frame_tracker.h"
#include "wire/config_proto.h"
#include "wire/frame_decoder.h"

namespace lane_client {
namespace {

namespace v1 = lane::v1;
using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

}  // namespace

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
  // As the service decodes the session's frames: what its detector reads,
  // unless the session asks for whole frames.
  const lane::FrameNeeds* needs = session.decode().full_decode() ? nullptr : &detector->Needs();
  // A stream of a tracked session (the default) also searches the tracker's
  // predicted lanes, reads each lane's colour and type and updates the
  // tracker (server/frame_processor.cc): the reference does the same work,
  // with a tracker per worker, so the ratio measures the service's overhead
  // and not tracking.
  const bool tracked = !session.tracking().disabled();

  workers = std::max(1, workers);
  const Clock::time_point start = Clock::now();
  const Clock::time_point measure_start = start + absl::ToChronoNanoseconds(warmup);
  const Clock::time_point end = measure_start + absl::ToChronoNanoseconds(duration);
  std::atomic<size_t> next{0};
  std::atomic<uint64_t> done_frames{0};
  std::atomic<uint64_t> tracked_frames{0};
  std::mutex mu;
  std::vector<double> latency;
  std::string failure;
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) {
    threads.emplace_back([&] {
      std::vector<double> own;
      lane::FrameTracker tracker(config->camera);
      while (true) {
        const Clock::time_point t0 = Clock::now();
        if (t0 >= end) break;
        const BenchFrame& frame = frames[next.fetch_add(1) % frames.size()];
        absl::StatusOr<cv::Mat> image = lane::wire::DecodeFrame(frame.request, decode, needs);
        absl::Status status = image.status();
        if (image.ok()) {
          absl::StatusOr<lane::Detection> detection =
              tracked ? tracker.Process(*detector, *image, std::nullopt) : detector->Detect(*image);
          status = detection.status();
          if (detection.ok() && tracked && t0 >= measure_start) {
            tracked_frames.fetch_add(1, std::memory_order_relaxed);
          }
        }
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
  result.tracked = tracked;
  result.tracked_frames = tracked_frames.load();
  result.fps = static_cast<double>(result.frames) / absl::ToDoubleSeconds(duration);
  result.latency_ms = Summarize(latency);
  result.latency_samples = std::move(latency);
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
  out.latency_samples = std::move(a.latency_samples);
  out.latency_samples.insert(out.latency_samples.end(), b.latency_samples.begin(),
                             b.latency_samples.end());
  out.latency_ms = Summarize(out.latency_samples);
  return out;
}

}  // namespace lane_client
