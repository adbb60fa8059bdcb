#include "metrics.h"

namespace lane::server {

prometheus::Histogram::BucketBoundaries Metrics::LatencyBuckets() {
  return {50e-6, 100e-6, 250e-6, 500e-6, 1e-3,   2.5e-3, 5e-3,
          10e-3, 25e-3,  50e-3,  100e-3, 250e-3, 500e-3, 1.0};
}

namespace {

// The one unlabelled series of a new family.
prometheus::Histogram& NewMetricsHistogram(prometheus::Registry& registry, const char* name,
                                           const char* help,
                                           const prometheus::Histogram::BucketBoundaries& buckets) {
  return prometheus::BuildHistogram().Name(name).Help(help).Register(registry).Add({}, buckets);
}
prometheus::Counter& NewMetricsCounter(prometheus::Registry& registry, const char* name,
                                       const char* help) {
  return prometheus::BuildCounter().Name(name).Help(help).Register(registry).Add({});
}
prometheus::Gauge& NewMetricsGauge(prometheus::Registry& registry, const char* name,
                                   const char* help) {
  return prometheus::BuildGauge().Name(name).Help(help).Register(registry).Add({});
}

}  // namespace

Metrics::Metrics(prometheus::Registry& registry, const BuildInfo& build, size_t camera_labels)
    : frame_latency_(NewMetricsHistogram(registry, "lanesvc_frame_latency_seconds",
                                         "Time from receiving a frame to its response being ready.",
                                         LatencyBuckets())),
      queue_wait_(NewMetricsHistogram(registry, "lanesvc_queue_wait_seconds",
                                      "Time a received frame waits for a worker.",
                                      LatencyBuckets())),
      received_(NewMetricsCounter(registry, "lanesvc_frames_received_total",
                                  "Frames received (each is answered once, or the stream fails).")),
      inflight_(NewMetricsGauge(registry, "lanesvc_inflight_frames",
                                "Frames received and not yet answered.")),
      sessions_(NewMetricsGauge(registry, "lanesvc_sessions_active",
                                "Camera sessions held by the server.")),
      frame_bytes_(
          NewMetricsHistogram(registry, "lanesvc_frame_bytes",
                              "Size of each frame request processed, bytes (encoded or raw).",
                              {16e3, 64e3, 128e3, 256e3, 512e3, 1e6, 2e6, 4e6, 8e6, 16e6, 32e6})),
      lanes_per_frame_(NewMetricsHistogram(registry, "lanesvc_lanes_per_frame",
                                           "Lanes found in each frame detected without error.",
                                           {0, 1, 2, 3, 4, 5, 6, 8, 10})),
      zero_lane_frames_(
          NewMetricsCounter(registry, "lanesvc_zero_lane_frames_total",
                            "Frames detected without error in which no lane was found.")),
      resume_state_bytes_(
          NewMetricsHistogram(registry, "lanesvc_resume_state_bytes",
                              "Size of each tracker resume state sent in a response, bytes.",
                              {64, 128, 256, 512, 1024, 2048, 4096})),
      grpc_(registry),
      camera_labels_(camera_labels) {
  if (camera_labels_ > 0) {
    camera_frames_ = &prometheus::BuildCounter()
                          .Name("lanesvc_camera_frames_total")
                          .Help(
                              "Frames answered per camera (the first --metrics_camera_labels "
                              "camera ids; the rest as camera=\"_other\"), by result.")
                          .Register(registry);
    camera_zero_lanes_ = &prometheus::BuildCounter()
                              .Name("lanesvc_camera_zero_lane_frames_total")
                              .Help(
                                  "Frames detected without error and without a lane, per "
                                  "camera (as lanesvc_camera_frames_total).")
                              .Register(registry);
  }
  RegisterLabelledFamilies(registry);
  prometheus::BuildGauge()
      .Name("lanesvc_build_info")
      .Help("Always 1; the labels describe the build.")
      .Register(registry)
      .Add({{"version", build.version},
            {"git_revision", build.git_revision},
            {"build_type", build.build_type},
            {"grpc_version", build.grpc_version},
            {"opencv_version", build.opencv_version}})
      .Set(1);
}

void Metrics::RegisterLabelledFamilies(prometheus::Registry& registry) {
  auto& resumes = prometheus::BuildCounter()
                      .Name("lanesvc_stream_resumes_total")
                      .Help(
                          "Streams that asked to resume tracking, by outcome: restored (the "
                          "tracker took the client's state), kept (it already continued it), "
                          "refused (a bad state: tracking started afresh).")
                      .Register(registry);
  resumes_[static_cast<int>(Resume::kRestored)] = &resumes.Add({{"outcome", "restored"}});
  resumes_[static_cast<int>(Resume::kKept)] = &resumes.Add({{"outcome", "kept"}});
  resumes_[static_cast<int>(Resume::kRefused)] = &resumes.Add({{"outcome", "refused"}});
  auto& paths = prometheus::BuildCounter()
                    .Name("lanesvc_lanes_found_total")
                    .Help(
                        "Lanes found, by path: search (the detector's pipeline) or refit (a "
                        "tracked lane refitted in its predicted window); refit_failed: "
                        "refits tried that fell back to the search.")
                    .Register(registry);
  lanes_searched_ = &paths.Add({{"path", "search"}});
  lanes_refit_ = &paths.Add({{"path", "refit"}});
  refits_failed_ = &paths.Add({{"path", "refit_failed"}});
  auto& stages = prometheus::BuildHistogram()
                     .Name("lanesvc_stage_duration_seconds")
                     .Help("Time spent in each stage of a frame: decode, then the detector's.")
                     .Register(registry);
  decode_stage_ = &stages.Add({{"stage", "decode"}}, LatencyBuckets());
  for (size_t i = 0; i < lane::DetectorStageCount(); ++i) {
    stages_[i] = &stages.Add({{"stage", lane::DetectorStageName(i)}}, LatencyBuckets());
  }
  auto& frames = prometheus::BuildCounter()
                     .Name("lanesvc_frames_total")
                     .Help("Frames answered, by result: ok, invalid, dropped, error.")
                     .Register(registry);
  for (wire::FrameResult r : wire::kAllFrameResults) {
    frames_[static_cast<int>(r)] = &frames.Add({{"result", wire::FrameResultLabel(r)}});
  }
}

void Metrics::ObserveDetectorStages(const lane::StageTimings& t) {
  for (size_t i = 0; i < lane::DetectorStageCount(); ++i) {
    if (t.ran[i]) stages_[i]->Observe(t.stage_ms[i] * 1e-3);
  }
}

void Metrics::CountLanePaths(const lane::Detection& detection) {
  const lane::LanePathCounts paths = lane::CountLanePaths(detection);
  lanes_searched_->Increment(paths.searched);
  lanes_refit_->Increment(paths.refit);
  refits_failed_->Increment(detection.refit_failed);
}

Metrics::CameraSeries& Metrics::CameraSeriesFor(const std::string& camera_id) {
  absl::MutexLock lock(&camera_mu_);
  auto it = cameras_.find(camera_id);
  if (it != cameras_.end()) return it->second;
  // One series set per camera up to the limit, then "_other" (one more).
  const std::string label = cameras_.size() < camera_labels_ ? camera_id : "_other";
  it = cameras_.find(label);
  if (it != cameras_.end()) return it->second;
  CameraSeries& series = cameras_[label];
  for (wire::FrameResult r : wire::kAllFrameResults) {
    series.frames[static_cast<int>(r)] =
        &camera_frames_->Add({{"camera", label}, {"result", wire::FrameResultLabel(r)}});
  }
  series.zero_lanes = &camera_zero_lanes_->Add({{"camera", label}});
  return series;
}

void Metrics::CountCameraFrame(const std::string& camera_id, wire::FrameResult result,
                               size_t lanes) {
  if (camera_labels_ == 0) return;
  CameraSeries& series = CameraSeriesFor(camera_id);
  series.frames[static_cast<int>(result)]->Increment();
  if (result == wire::FrameResult::kOk && lanes == 0) series.zero_lanes->Increment();
}

}  // namespace lane::server
