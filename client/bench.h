// The load generator of `lane-client bench`: N camera streams against the
// service, each with its own session, and the in-process reference (the same
// decode and detect without gRPC).
//
// Every frame is timed on its own: its send time is recorded under its
// frame_id and its response is matched by frame_id. In open loop the send
// times follow an absolute schedule computed from the start (camera c sends
// frame k at start + (k + c/N)/R), and latency is counted from the scheduled
// time, so a server that slows the sender down (HTTP/2 flow control,
// backpressure) shows up in the latency instead of hiding it.
#ifndef LANE_CLIENT_BENCH_H_
#define LANE_CLIENT_BENCH_H_

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "lane/config/config.h"
#include "lane/v1/lane_service.pb.h"
#include "load_spec.h"
#include "reconnect_backoff.h"

namespace lane::client {

// Synthetic 640x480 road frames (or the camera's size), rendered with
// lane::RenderSyntheticFrame through `camera`, seeds 1..count, JPEG-encoded
// at `jpeg_quality` with cv::imencode, or raw BGR8 when `raw`.
absl::StatusOr<std::vector<BenchFrame>> SyntheticBenchFrames(const lane::CameraModel& camera,
                                                             int count, bool raw, int jpeg_quality);
// The frames of INPUT arguments (as `stream` reads them), at most `max_frames`.
absl::StatusOr<std::vector<BenchFrame>> LoadBenchFrames(const std::vector<std::string>& inputs,
                                                        bool raw, int max_frames);

struct LatencySummary {
  uint64_t count = 0;
  double min = 0, p50 = 0, p90 = 0, p95 = 0, p99 = 0, p999 = 0, max = 0, mean = 0;  // ms
};

// Counts of latencies in log-spaced bins: kHistogramBins bins from
// kHistogramMinMs to kHistogramMaxMs, plus one below and one above.
inline constexpr int kHistogramBins = 48;
inline constexpr double kHistogramMinMs = 0.1;
inline constexpr double kHistogramMaxMs = 10000;
struct LatencyHistogram {
  std::vector<uint64_t> counts;  // kHistogramBins + 2 once filled
  // Lower edge of bin i (1..kHistogramBins), ms.
  static double Edge(int i);
};
LatencyHistogram Histogram(const std::vector<double>& values);
// Nearest-rank percentiles of `values` (sorted in place).
LatencySummary Summarize(std::vector<double>& values);

// One interval of a run's timeline: the frames whose answer arrived in
// [start_s, end_s) seconds after the start of the measured window.
struct TimelinePoint {
  double start_s = 0;
  double end_s = 0;
  uint64_t ok = 0;
  uint64_t errors = 0;  // answered with an error or dropped, or lost with their stream
  LatencySummary latency_ms;
};

struct LoadResult {
  int cameras = 0;
  bool open_loop = false;
  double target_fps = 0;  // open loop: cameras x fps; closed loop: 0
  // OK answers of measured frames per second, over the time from the start
  // of the measurement to the last of those answers.
  double achieved_fps = 0;
  double measured_s = 0;
  // Measured frames: those due (open loop) or sent (closed loop) after the
  // warm-up and before the end. frames_ok = frames_sent - errors_total - dropped.
  uint64_t frames_scheduled = 0;
  uint64_t frames_sent = 0;
  uint64_t frames_ok = 0;
  uint64_t dropped = 0;                    // answered FRAME_CODE_DROPPED (server backpressure)
  uint64_t errors_total = 0;               // answered with an error, or lost with their stream
  uint64_t unsent = 0;                     // due but not sent: no stream at the time
  std::map<std::string, uint64_t> errors;  // by code: frame codes and gRPC codes
  LatencySummary latency_ms;               // client: due/sent -> response received (OK frames)
  LatencySummary server_ms;                // server: received -> response ready (OK frames)
  LatencySummary queue_ms;                 // ... of which waiting for a worker
  LatencySummary decode_ms;                // ... decoding
  LatencySummary detect_ms;                // ... detecting
  LatencyHistogram latency_histogram;      // of latency_ms
  double max_send_lag_ms = 0;              // open loop: the latest a frame was handed to gRPC
  uint64_t stream_failures = 0;
  // "CAMERA: why" for each camera that gave up reconnecting
  // (LoadSpec::max_reconnects), in camera order.
  std::vector<std::string> gave_up;
  std::map<std::string, uint64_t> ok_by_target;
  std::vector<TimelinePoint> timeline;  // empty unless LoadSpec::timeline_interval > 0
  // The servers' CPU time over the measured window and the drain (their
  // ServerInfo.process_cpu_seconds, summed over the targets), and per frame
  // sent in the window; negative when a server did not say.
  double server_cpu_s = -1;
  double server_cpu_ms_per_frame = -1;
};

// CPU time this process has used, user + system, seconds (getrusage).
double ProcessCpuSeconds();

// Creates (or confirms) the sessions, runs the load, waits for the answers.
// An error only when the sessions cannot be created.
absl::StatusOr<LoadResult> RunLoad(const LoadSpec& spec);

// The timeline of a run: latency_ms[i] arrived ok_at_s[i] seconds after the
// start of the measured window, errors at error_at_s. Intervals of
// interval_s cover [0, measured_s); later arrivals count in the last one.
std::vector<TimelinePoint> Timeline(const std::vector<double>& latency_ms,
                                    const std::vector<float>& ok_at_s,
                                    const std::vector<float>& error_at_s, double interval_s,
                                    double measured_s);

// Deletes the sessions camera_prefix + 0 .. cameras-1, each through its
// camera's channel. Best effort.
void DeleteSessions(const LoadSpec& spec, int cameras);

struct InprocessResult {
  int workers = 0;
  double fps = 0;
  uint64_t frames = 0;
  // The session tracks its streams, so the reference tracked as the server
  // does (the predicted lanes searched, colours and types read, the tracker
  // updated), and `tracked_frames` of the measured frames went through a
  // tracker (all of them, unless a frame failed).
  bool tracked = false;
  uint64_t tracked_frames = 0;
  LatencySummary latency_ms;  // decode + detect (+ tracking) of one frame
  // `lane-client bench --inprocess` runs the reference in two halves, one
  // before the service runs and one after, and `fps` is their combined
  // figure: a machine whose speed drifts during the bench (a shared VM)
  // then biases the ratio less. The two halves' own figures (0 when the
  // reference ran once):
  double fps_before = 0;
  double fps_after = 0;
  // This process's CPU time over the measured part (all its threads: the
  // workers, nothing else runs then), and per measured frame.
  double cpu_s = 0;
  double cpu_ms_per_frame = 0;
  std::vector<double> latency_samples;  // what latency_ms summarizes
};

// `a` and `b`, two halves of one reference, as one: frames added, fps over
// both durations, latency over both halves' samples; fps_before/after are
// a's and b's.
InprocessResult CombineInprocess(InprocessResult a, InprocessResult b, absl::Duration a_duration,
                                 absl::Duration b_duration);

// The service's work without gRPC: `workers` threads decode (the server's
// lane::wire::DecodeFrame) and detect the same frames with a detector built
// from `session`, for warm-up + duration; if the session tracks its streams,
// each thread also tracks its frames as the server does.
absl::StatusOr<InprocessResult> RunInprocess(const std::vector<BenchFrame>& frames,
                                             const lane::v1::SessionConfig& session, int workers,
                                             absl::Duration warmup, absl::Duration duration,
                                             const ProgressFn& progress);

}  // namespace lane::client

#endif  // LANE_CLIENT_BENCH_H_
