#include "metrics.h"

namespace lane::server {

const char* StageLabel(Stage stage) {
  switch (stage) {
    case Stage::kDecode:
      return "decode";
    case Stage::kIpm:
      return "ipm";
    case Stage::kFilter:
      return "filter";
    case Stage::kThreshold:
      return "threshold";
    case Stage::kLines:
      return "lines";
    case Stage::kSplines:
      return "splines";
    case Stage::kPostprocess:
      return "postprocess";
  }
  return "unknown";
}

prometheus::Histogram::BucketBoundaries Metrics::LatencyBuckets() {
  return {50e-6, 100e-6, 250e-6, 500e-6, 1e-3,   2.5e-3, 5e-3,
          10e-3, 25e-3,  50e-3,  100e-3, 250e-3, 500e-3, 1.0};
}

Metrics::Metrics(prometheus::Registry& registry, const BuildInfo& build)
    : frame_latency_(prometheus::BuildHistogram()
                         .Name("lanesvc_frame_latency_seconds")
                         .Help("Time from receiving a frame to its response being ready.")
                         .Register(registry)
                         .Add({}, LatencyBuckets())),
      queue_wait_(prometheus::BuildHistogram()
                      .Name("lanesvc_queue_wait_seconds")
                      .Help("Time a received frame waits for a worker.")
                      .Register(registry)
                      .Add({}, LatencyBuckets())),
      received_(prometheus::BuildCounter()
                    .Name("lanesvc_frames_received_total")
                    .Help("Frames received (each is answered once, or the stream fails).")
                    .Register(registry)
                    .Add({})),
      inflight_(prometheus::BuildGauge()
                    .Name("lanesvc_inflight_frames")
                    .Help("Frames received and not yet answered.")
                    .Register(registry)
                    .Add({})),
      sessions_(prometheus::BuildGauge()
                    .Name("lanesvc_sessions_active")
                    .Help("Camera sessions held by the server.")
                    .Register(registry)
                    .Add({})),
      rpcs_(prometheus::BuildCounter()
                .Name("grpc_server_handled_total")
                .Help("Calls of the lane service completed, by method and status code.")
                .Register(registry)) {
  auto& stages = prometheus::BuildHistogram()
                     .Name("lanesvc_stage_duration_seconds")
                     .Help("Time spent in each stage of a frame: decode, then the detector's.")
                     .Register(registry);
  for (int i = 0; i < kNumStages; ++i) {
    stages_[i] = &stages.Add({{"stage", StageLabel(static_cast<Stage>(i))}}, LatencyBuckets());
  }
  auto& frames = prometheus::BuildCounter()
                     .Name("lanesvc_frames_total")
                     .Help("Frames answered, by result: ok, invalid, dropped, error.")
                     .Register(registry);
  for (wire::FrameResult r : wire::kAllFrameResults) {
    frames_[static_cast<int>(r)] = &frames.Add({{"result", wire::FrameResultLabel(r)}});
  }
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

void Metrics::ObserveDetectorStages(const lane::StageTimings& t) {
  ObserveStage(Stage::kIpm, t.ipm_ms * 1e-3);
  ObserveStage(Stage::kFilter, t.filter_ms * 1e-3);
  ObserveStage(Stage::kThreshold, t.threshold_ms * 1e-3);
  ObserveStage(Stage::kLines, t.lines_ms * 1e-3);
  ObserveStage(Stage::kSplines, t.splines_ms * 1e-3);
  ObserveStage(Stage::kPostprocess, t.postprocess_ms * 1e-3);
}

void Metrics::CountRpc(const std::string& method, grpc::StatusCode code) {
  // Family::Add returns the existing counter for known labels.
  rpcs_.Add({{"grpc_method", method}, {"grpc_code", wire::GrpcCodeName(code)}}).Increment();
}

}  // namespace lane::server
