#include "metrics.h"

#include <gtest/gtest.h>

#include "grpc_metrics.h"
#include "test_util.h"

namespace lane::server {
namespace {

using testing::MetricValue;

TEST(MetricsTest, FamiliesOnTheInjectedRegistry) {
  prometheus::Registry registry;
  Metrics metrics(registry, {"1.2.3", "abc1234", "Release", "1.51.1", "4.6.0"});
  std::set<std::string> names;
  for (const prometheus::MetricFamily& f : registry.Collect()) names.insert(f.name);
  for (const char* name :
       {"lanesvc_frame_latency_seconds", "lanesvc_stage_duration_seconds",
        "lanesvc_queue_wait_seconds", "lanesvc_frames_total", "lanesvc_frames_received_total",
        "lanesvc_inflight_frames", "lanesvc_sessions_active", "lanesvc_build_info"}) {
    EXPECT_EQ(names.count(name), 1u) << name;
  }
  EXPECT_EQ(MetricValue(registry, "lanesvc_build_info", {{"version", "1.2.3"}}), 1);
  for (const char* name :
       {"lanesvc_frame_bytes", "lanesvc_lanes_per_frame", "lanesvc_zero_lane_frames_total"}) {
    EXPECT_EQ(names.count(name), 1u) << name;
  }
  // Every stage and result exists from the start (at 0).
  for (const char* stage :
       {"decode", "ipm", "filter", "threshold", "refit", "lines", "splines", "postprocess"}) {
    bool found = false;
    for (const prometheus::MetricFamily& f : registry.Collect()) {
      if (f.name != "lanesvc_stage_duration_seconds") continue;
      for (const auto& m : f.metric) {
        for (const auto& l : m.label) found = found || (l.name == "stage" && l.value == stage);
      }
    }
    EXPECT_TRUE(found) << stage;
  }
}

TEST(MetricsTest, BucketsFrom50MicrosecondsToOneSecond) {
  const auto buckets = Metrics::LatencyBuckets();
  ASSERT_FALSE(buckets.empty());
  EXPECT_DOUBLE_EQ(buckets.front(), 50e-6);
  EXPECT_DOUBLE_EQ(buckets.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(buckets.begin(), buckets.end()));
}

TEST(MetricsTest, Records) {
  prometheus::Registry registry;
  Metrics metrics(registry, {});
  metrics.ObserveFrameLatency(0.003);
  metrics.ObserveFrameLatency(0.004);
  lane::StageTimings timings;
  const size_t ipm = lane::StageTimings::IndexOf("ipm");
  ASSERT_LT(ipm, lane::DetectorStageCount());
  timings.stage_ms[ipm] = 1;
  timings.ran[ipm] = true;
  metrics.ObserveDetectorStages(timings);
  metrics.CountFrame(wire::FrameResult::kDropped);
  metrics.FrameReceived();
  metrics.FrameReceived();
  metrics.FrameAnswered();
  metrics.SetSessions(3);
  metrics.ObserveLanes(0);
  metrics.ObserveLanes(3);
  metrics.ObserveLanes(0);
  metrics.ObserveFrameBytes(900'000);
  EXPECT_EQ(MetricValue(registry, "lanesvc_frame_latency_seconds"), 2);
  EXPECT_EQ(MetricValue(registry, "lanesvc_stage_duration_seconds", {{"stage", "ipm"}}), 1);
  // A stage that did not run is not observed.
  EXPECT_EQ(MetricValue(registry, "lanesvc_stage_duration_seconds", {{"stage", "refit"}}), 0);
  EXPECT_EQ(MetricValue(registry, "lanesvc_frames_total", {{"result", "dropped"}}), 1);
  EXPECT_EQ(MetricValue(registry, "lanesvc_frames_total", {{"result", "ok"}}), 0);
  EXPECT_EQ(MetricValue(registry, "lanesvc_frames_received_total"), 2);
  EXPECT_EQ(MetricValue(registry, "lanesvc_inflight_frames"), 1);
  EXPECT_EQ(MetricValue(registry, "lanesvc_sessions_active"), 3);
  EXPECT_EQ(MetricValue(registry, "lanesvc_lanes_per_frame"), 3);
  EXPECT_EQ(MetricValue(registry, "lanesvc_zero_lane_frames_total"), 2);
  EXPECT_EQ(MetricValue(registry, "lanesvc_frame_bytes"), 1);
}

TEST(MetricsTest, PerCameraSeriesAreOptInAndBounded) {
  {
    prometheus::Registry registry;
    Metrics metrics(registry, {});
    metrics.CountCameraFrame("cam-a", wire::FrameResult::kOk, 0);
    for (const prometheus::MetricFamily& f : registry.Collect()) {
      EXPECT_EQ(f.name.rfind("lanesvc_camera_", 0), std::string::npos) << f.name;
    }
  }
  prometheus::Registry registry;
  Metrics metrics(registry, {}, 2);
  metrics.CountCameraFrame("cam-a", wire::FrameResult::kOk, 3);
  metrics.CountCameraFrame("cam-a", wire::FrameResult::kOk, 0);
  metrics.CountCameraFrame("cam-b", wire::FrameResult::kInvalid, 0);
  for (int i = 0; i < 100; ++i) {
    metrics.CountCameraFrame("cam-" + std::to_string(i + 100), wire::FrameResult::kOk, 0);
  }
  metrics.CountCameraFrame("cam-a", wire::FrameResult::kError, 0);
  EXPECT_EQ(MetricValue(registry, "lanesvc_camera_frames_total", {{"camera", "cam-a"}}), 3);
  EXPECT_EQ(
      MetricValue(registry, "lanesvc_camera_frames_total", {{"camera", "cam-a"}, {"result", "ok"}}),
      2);
  EXPECT_EQ(MetricValue(registry, "lanesvc_camera_zero_lane_frames_total", {{"camera", "cam-a"}}),
            1);
  // An invalid frame is not a zero-lane frame.
  EXPECT_EQ(MetricValue(registry, "lanesvc_camera_zero_lane_frames_total", {{"camera", "cam-b"}}),
            0);
  EXPECT_EQ(MetricValue(registry, "lanesvc_camera_frames_total", {{"camera", "_other"}}), 100);
  std::set<std::string> cameras;
  for (const prometheus::MetricFamily& f : registry.Collect()) {
    if (f.name != "lanesvc_camera_frames_total") continue;
    for (const auto& m : f.metric) {
      for (const auto& l : m.label) {
        if (l.name == "camera") cameras.insert(l.value);
      }
    }
  }
  EXPECT_EQ(cameras, (std::set<std::string>{"cam-a", "cam-b", "_other"}));
}

TEST(GrpcMetricsTest, MethodLabelsFromTheFullName) {
  prometheus::Registry registry;
  GrpcMetrics metrics(registry);
  using Type = GrpcMetrics::Type;
  GrpcMetrics::Method& detect = metrics.ForMethod("/lane.v1.LaneService/Detect", Type::kUnary);
  EXPECT_EQ(&detect, &metrics.ForMethod("/lane.v1.LaneService/Detect", Type::kUnary));
  {
    GrpcMetrics::Call call(metrics, detect);  // started
    call.Received();
    call.Handled(grpc::StatusCode::INVALID_ARGUMENT);
    call.Handled(grpc::StatusCode::OK);  // ignored: a call is handled once
  }
  metrics.CountHandled(detect, grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(MetricValue(registry, "grpc_server_started_total",
                        {{"grpc_service", "lane.v1.LaneService"},
                         {"grpc_method", "Detect"},
                         {"grpc_type", "unary"}}),
            1);
  EXPECT_EQ(MetricValue(registry, "grpc_server_handled_total",
                        {{"grpc_service", "lane.v1.LaneService"},
                         {"grpc_method", "Detect"},
                         {"grpc_type", "unary"},
                         {"grpc_code", "INVALID_ARGUMENT"}}),
            2);
  EXPECT_EQ(MetricValue(registry, "grpc_server_handled_total", {{"grpc_code", "OK"}}), 0);
  EXPECT_EQ(MetricValue(registry, "grpc_server_handling_seconds", {{"grpc_method", "Detect"}}), 1);
  EXPECT_EQ(MetricValue(registry, "grpc_server_msg_received_total", {{"grpc_method", "Detect"}}),
            1);
  GrpcMetrics::Method& stream =
      metrics.ForMethod("/lane.v1.LaneService/StreamFrames", Type::kBidiStream);
  stream.received->Increment();
  EXPECT_EQ(MetricValue(registry, "grpc_server_msg_received_total",
                        {{"grpc_method", "StreamFrames"}, {"grpc_type", "bidi_stream"}}),
            1);
}

TEST(GrpcMetricsTest, ClientChosenMethodNamesAreBounded) {
  prometheus::Registry registry;
  GrpcMetrics metrics(registry);
  using Type = GrpcMetrics::Type;
  for (int i = 0; i < 1000; ++i) {
    metrics.ForMethod(("/x.Y/M" + std::to_string(i)).c_str(), Type::kUnary).started->Increment();
  }
  metrics.ForMethod(nullptr, Type::kUnary).started->Increment();
  size_t series = 0;
  for (const prometheus::MetricFamily& f : registry.Collect()) {
    if (f.name == "grpc_server_started_total") series = f.metric.size();
  }
  EXPECT_LE(series, 65u);
  EXPECT_EQ(MetricValue(registry, "grpc_server_started_total"), 1001);
  EXPECT_GE(MetricValue(registry, "grpc_server_started_total",
                        {{"grpc_service", "unknown"}, {"grpc_method", "unknown"}}),
            1000 - 64);
}

}  // namespace
}  // namespace lane::server
