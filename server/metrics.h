// The service's Prometheus metrics, all built on a registry the caller owns
// (no globals): the server exposes that registry on /metrics, tests read it
// through Registry::Collect().
//
// Latency histograms are in seconds, with buckets from 50 us to 1 s.
#ifndef LANE_SERVER_METRICS_H_
#define LANE_SERVER_METRICS_H_

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <array>
#include <map>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "grpc_metrics.h"
#include "lane/detector/detector.h"
#include "wire/status_map.h"

namespace lane::server {

// Labels of lanesvc_build_info.
struct BuildInfo {
  std::string version;
  std::string git_revision;  // `git describe` at configure time, or "unknown"
  std::string build_type;
  std::string grpc_version;
  std::string opencv_version;
};

class Metrics {
 public:
  // 50 us .. 1 s in 1-2.5-5 steps.
  static prometheus::Histogram::BucketBoundaries LatencyBuckets();

  // `camera_labels`: how many camera ids get series of their own in the
  // per-camera families (0: none, the families do not exist).
  Metrics(prometheus::Registry& registry, const BuildInfo& build, size_t camera_labels = 0);

  // lanesvc_frame_latency_seconds: from receiving a frame to its response
  // being ready (every processed frame, whatever its status; not dropped ones).
  void ObserveFrameLatency(double seconds) { frame_latency_.Observe(seconds); }
  // lanesvc_stage_duration_seconds{stage="decode"}.
  void ObserveDecode(double seconds) { decode_stage_->Observe(seconds); }
  // lanesvc_stage_duration_seconds{stage}: each detector stage that ran, by
  // its name (lane::DetectorStageName), from its timings (milliseconds).
  void ObserveDetectorStages(const lane::StageTimings& timings);
  // lanesvc_queue_wait_seconds: from receiving a frame to a worker starting it.
  void ObserveQueueWait(double seconds) { queue_wait_.Observe(seconds); }
  // lanesvc_frames_total{result}.
  void CountFrame(wire::FrameResult result) { frames_[static_cast<int>(result)]->Increment(); }
  // lanesvc_frames_received_total, and lanesvc_inflight_frames: received and
  // not yet answered.
  void FrameReceived() {
    received_.Increment();
    inflight_.Increment();
  }
  void FrameAnswered() { inflight_.Decrement(); }
  // lanesvc_sessions_active.
  void SetSessions(double n) { sessions_.Set(n); }
  // For frames a worker processed (not dropped ones):
  // lanesvc_camera_frames_total{camera,result} and
  // lanesvc_camera_zero_lane_frames_total{camera}, when camera labels are on:
  // the first `camera_labels` camera ids seen get their own series, later
  // ones share camera="_other" (camera ids come from clients, so the label
  // set is bounded). `lanes` counts only for OK frames.
  void CountCameraFrame(const std::string& camera_id, wire::FrameResult result, size_t lanes);
  // The grpc_server_* families of the lane service's calls.
  GrpcMetrics& grpc() { return grpc_; }
  // lanesvc_frame_bytes: the size of each frame request a worker takes up
  // (encoded or raw; dropped frames are not counted).
  void ObserveFrameBytes(size_t bytes) { frame_bytes_.Observe(static_cast<double>(bytes)); }
  // lanesvc_lanes_per_frame and lanesvc_zero_lane_frames_total, for every
  // frame detected without error: a dirty, misaligned or blinded camera shows
  // as a shift to zero lanes long before anyone looks at its output.
  void ObserveLanes(size_t lanes) {
    lanes_per_frame_.Observe(static_cast<double>(lanes));
    if (lanes == 0) zero_lane_frames_.Increment();
  }
  // lanesvc_lanes_found_total: the lanes a frame's detection found, by
  // path: search (the paper's pipeline) or refit (a tracked lane refitted in
  // its window, docs/tracking.md); refit_failed counts the refits tried
  // that fell back to the search.
  void CountLanePaths(const lane::Detection& detection);
  // lanesvc_resume_state_bytes: each resume state sent (what tracking
  // across replicas costs on the wire).
  void ObserveResumeStateBytes(size_t bytes) {
    resume_state_bytes_.Observe(static_cast<double>(bytes));
  }
  // lanesvc_stream_resumes_total: streams that came with a resume state or a
  // lowest lane id, by what the tracker did.
  enum class Resume { kRestored, kKept, kRefused };
  void CountResume(Resume outcome) { resumes_[static_cast<int>(outcome)]->Increment(); }

 private:
  // The families with labels (resumes, lane paths, stages, frames by result).
  void RegisterLabelledFamilies(prometheus::Registry& registry);

  prometheus::Histogram& frame_latency_;
  prometheus::Histogram& queue_wait_;
  prometheus::Histogram* decode_stage_ = nullptr;
  // Indexed as the detector's stages.
  std::array<prometheus::Histogram*, lane::StageTimings::kMaxStages> stages_{};
  std::array<prometheus::Counter*, 4> frames_{};
  prometheus::Counter& received_;
  prometheus::Gauge& inflight_;
  prometheus::Gauge& sessions_;
  prometheus::Histogram& frame_bytes_;
  prometheus::Histogram& lanes_per_frame_;
  prometheus::Counter& zero_lane_frames_;
  prometheus::Histogram& resume_state_bytes_;
  std::array<prometheus::Counter*, 3> resumes_{};
  prometheus::Counter* lanes_searched_ = nullptr;
  prometheus::Counter* lanes_refit_ = nullptr;
  prometheus::Counter* refits_failed_ = nullptr;
  GrpcMetrics grpc_;
  struct CameraSeries {
    std::array<prometheus::Counter*, 4> frames{};
    prometheus::Counter* zero_lanes = nullptr;
  };
  CameraSeries& CameraSeriesFor(const std::string& camera_id);  // locks camera_mu_
  const size_t camera_labels_;
  prometheus::Family<prometheus::Counter>* camera_frames_ = nullptr;
  prometheus::Family<prometheus::Counter>* camera_zero_lanes_ = nullptr;
  absl::Mutex camera_mu_;
  std::map<std::string, CameraSeries> cameras_ ABSL_GUARDED_BY(camera_mu_);
};

}  // namespace lane::server

#endif  // LANE_SERVER_METRICS_H_
