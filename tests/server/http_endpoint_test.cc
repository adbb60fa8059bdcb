// The HTTP side of a real server on loopback: /healthz, /readyz through a
// drain, and /metrics with the go-grpc-prometheus, process and domain
// families (and `promtool check metrics` on the scrape, when installed).
#include <gtest/gtest.h>
#include <stdio.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "test_util.h"

namespace lane::server::testing {
namespace {

// The value of the first sample line starting with `prefix` ("name{...} v"),
// or NaN.
double SampleValue(const std::string& text, const std::string& prefix) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(prefix, 0) != 0) continue;
    const size_t space = line.rfind(' ');
    return std::strtod(line.c_str() + space + 1, nullptr);
  }
  return std::nan("");
}

ServerOptions WithMetrics() {
  ServerOptions options = TestServer::DefaultOptions();
  options.metrics_address = "127.0.0.1:0";
  return options;
}

TEST(HttpEndpointTest, HealthAndReadinessFollowTheServer) {
  TestServer server(WithMetrics());
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  ASSERT_GT(port, 0);

  HttpResponse healthz = HttpFetch(port, "/healthz");
  EXPECT_EQ(healthz.status, 200);
  EXPECT_EQ(healthz.body, "ok\n");
  HttpResponse readyz = HttpFetch(port, "/readyz");
  EXPECT_EQ(readyz.status, 200);
  EXPECT_EQ(readyz.body, "ready\n");
  EXPECT_EQ(HttpFetch(port, "/readyz", "HEAD").status, 200);
  EXPECT_TRUE(HttpFetch(port, "/readyz", "HEAD").body.empty());
  EXPECT_EQ(HttpFetch(port, "/nothing-here").status, 404);
  EXPECT_EQ(HttpFetch(port, "/metrics", "POST").status, 405);

  // Draining: not ready (out of rotation), still alive, still scraped.
  server.server().BeginDrain();
  readyz = HttpFetch(port, "/readyz");
  EXPECT_EQ(readyz.status, 503);
  EXPECT_EQ(readyz.body, "not ready\n");
  EXPECT_EQ(HttpFetch(port, "/healthz").status, 200);
  EXPECT_EQ(HttpFetch(port, "/metrics").status, 200);
  EXPECT_EQ(HealthStatus(server.channel()), 2);  // gRPC health agrees
}

// The go-grpc-prometheus families after one stream of `frames` frames and
// one GetSession of an unknown camera, labels sorted by name.
void ExpectGoGrpcFamilies(const std::string& text, int frames) {
  const std::string stream =
      "{grpc_method=\"StreamFrames\",grpc_service=\"lane.v1.LaneService\","
      "grpc_type=\"bidi_stream\"}";
  EXPECT_EQ(SampleValue(text, "grpc_server_started_total" + stream), 1) << text;
  EXPECT_EQ(SampleValue(text, "grpc_server_msg_received_total" + stream), frames);
  EXPECT_EQ(SampleValue(text, "grpc_server_msg_sent_total" + stream), frames);
  EXPECT_EQ(SampleValue(text, "grpc_server_handling_seconds_count" + stream), 1);
  EXPECT_EQ(SampleValue(text,
                        "grpc_server_handled_total{grpc_code=\"OK\",grpc_method=\"StreamFrames\","
                        "grpc_service=\"lane.v1.LaneService\",grpc_type=\"bidi_stream\"}"),
            1);
  EXPECT_EQ(SampleValue(text,
                        "grpc_server_handled_total{grpc_code=\"NOT_FOUND\",grpc_method="
                        "\"GetSession\",grpc_service=\"lane.v1.LaneService\",grpc_type=\"unary\"}"),
            1);
  // The lane service's calls only: health checks are not counted.
  EXPECT_EQ(text.find("grpc.health.v1.Health"), std::string::npos);
  EXPECT_EQ(SampleValue(text,
                        "grpc_server_msg_received_total{grpc_method=\"GetSession\","
                        "grpc_service=\"lane.v1.LaneService\",grpc_type=\"unary\"}"),
            1);
  EXPECT_EQ(SampleValue(text,
                        "grpc_server_msg_sent_total{grpc_method=\"GetSession\","
                        "grpc_service=\"lane.v1.LaneService\",grpc_type=\"unary\"}"),
            0);
}

void ExpectProcessFamilies(const std::string& text) {
  EXPECT_GT(SampleValue(text, "process_resident_memory_bytes "), 1e6);
  EXPECT_GT(SampleValue(text, "process_virtual_memory_bytes "), 1e6);
  EXPECT_GT(SampleValue(text, "process_cpu_seconds_total "), 0);
  EXPECT_GE(SampleValue(text, "process_open_fds "), 3);
  EXPECT_GT(SampleValue(text, "process_max_fds "), 0);
  const double started = SampleValue(text, "process_start_time_seconds ");
  const double now = static_cast<double>(std::time(nullptr));
  EXPECT_LE(started, now + 1);
  EXPECT_GT(started, now - 24 * 3600);
}

// `promtool check metrics` on a scrape: its exit status and what it said.
struct PromtoolVerdict {
  bool passed = false;
  std::string output;
};
PromtoolVerdict RunPromtool(const char* promtool, const std::string& text, int port) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("lane-metrics-" + std::to_string(port) + ".txt");
  std::ofstream(file) << text;
  const std::string command = std::string(promtool) + " check metrics < " + file.string() + " 2>&1";
  PromtoolVerdict verdict;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return verdict;
  char buffer[512];
  while (fgets(buffer, sizeof(buffer), pipe) != nullptr) verdict.output += buffer;
  const int status = pclose(pipe);
  std::filesystem::remove(file);
  verdict.passed = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  return verdict;
}

TEST(HttpEndpointTest, MetricsHaveTheStandardFamilies) {
  TestServer server(WithMetrics());
  ASSERT_FALSE(HasFailure());
  const int port = server.server().metrics_port();
  ASSERT_GT(port, 0);

  const lane::CameraModel camera = ScaledCamera(0.5);
  server.CreateSession("cam", SessionConfigFor(camera));
  const std::string jpeg = EncodeJpeg(RoadFrame(camera, kLineOffsets, 4));
  constexpr int kFrames = 6;
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < kFrames; ++i) requests.push_back(JpegRequest("cam", i, jpeg));
  StreamResult result = RunStream(server.stub(), requests);
  ASSERT_TRUE(result.status.ok());
  ASSERT_EQ(result.responses.size(), static_cast<size_t>(kFrames));
  {
    grpc::ClientContext context;
    v1::GetSessionRequest get;
    get.set_camera_id("nobody");
    v1::Session session;
    EXPECT_EQ(server.stub().GetSession(&context, get, &session).error_code(),
              grpc::StatusCode::NOT_FOUND);
  }
  EXPECT_EQ(HealthStatus(server.channel()), 1);

  const HttpResponse scrape = HttpFetch(port, "/metrics");
  ASSERT_EQ(scrape.status, 200);
  EXPECT_NE(scrape.headers.find("text/plain; version=0.0.4"), std::string::npos);
  const std::string& text = scrape.body;
  ExpectGoGrpcFamilies(text, kFrames);
  ExpectProcessFamilies(text);

  // Domain signals.
  EXPECT_EQ(SampleValue(text, "lanesvc_lanes_per_frame_count "), kFrames);
  EXPECT_EQ(SampleValue(text, "lanesvc_frame_bytes_count "), kFrames);
  double bytes = 0;
  for (const v1::FrameRequest& request : requests) bytes += request.ByteSizeLong();
  EXPECT_EQ(SampleValue(text, "lanesvc_frame_bytes_sum "), bytes);
  EXPECT_FALSE(std::isnan(SampleValue(text, "lanesvc_zero_lane_frames_total ")));
  // Per-camera series are opt-in.
  EXPECT_EQ(text.find("lanesvc_camera_"), std::string::npos);
  // No unit-less microsecond metrics of the old exposer.
  EXPECT_EQ(text.find("exposer_"), std::string::npos);

  // promtool lints the exposition (names, units, help, types).
  constexpr char kPromtool[] = "/usr/bin/promtool";
  if (!std::filesystem::exists(kPromtool)) {
    GTEST_SKIP() << kPromtool << " is not installed (Debian package prometheus)";
  }
  const PromtoolVerdict verdict = RunPromtool(kPromtool, text, port);
  EXPECT_TRUE(verdict.passed) << "promtool:\n" << verdict.output;
}

TEST(HttpEndpointTest, PerCameraSeriesWhenAskedFor) {
  ServerOptions options = WithMetrics();
  options.metrics_camera_labels = 1;
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const lane::CameraModel camera = ScaledCamera(0.5);
  server.CreateSession("front", SessionConfigFor(camera));
  server.CreateSession("rear", SessionConfigFor(camera));
  const std::string jpeg = EncodeJpeg(RoadFrame(camera, kLineOffsets, 4));
  for (const char* id : {"front", "rear"}) {
    std::vector<v1::FrameRequest> requests;
    for (int i = 0; i < 3; ++i) requests.push_back(JpegRequest(id, i, jpeg));
    ASSERT_TRUE(RunStream(server.stub(), requests).status.ok());
  }
  const HttpResponse scrape = HttpFetch(server.server().metrics_port(), "/metrics");
  ASSERT_EQ(scrape.status, 200);
  EXPECT_EQ(SampleValue(scrape.body, "lanesvc_camera_frames_total{camera=\"front\",result=\"ok\"}"),
            3)
      << scrape.body;
  // One label allowed: the second camera is "_other".
  EXPECT_EQ(
      SampleValue(scrape.body, "lanesvc_camera_frames_total{camera=\"_other\",result=\"ok\"}"), 3);
  EXPECT_EQ(scrape.body.find("camera=\"rear\""), std::string::npos);
}

// Online calibration: a session configured 1 degree off the camera that
// renders its frames follows the true pitch when it auto-calibrates, reports
// it in GetSession and exports the drift; a session that does not keep its
// camera.
TEST(HttpEndpointTest, AutoCalibratingSessionFollowsTheCameraAndExportsItsDrift) {
  TestServer server(WithMetrics());
  ASSERT_FALSE(HasFailure());
  const lane::CameraModel truth = ScaledCamera(0.5, 14.0);
  v1::SessionConfig config = SessionConfigFor(ScaledCamera(0.5, 13.0));
  server.CreateSession("fixed", config);
  config.mutable_calibration()->set_auto_calibrate(true);
  server.CreateSession("drift", config);
  constexpr int kFrames = 150;
  for (const char* id : {"fixed", "drift"}) {
    std::vector<v1::FrameRequest> requests;
    for (int i = 0; i < kFrames; ++i) {
      requests.push_back(JpegRequest(id, i, EncodeJpeg(RoadFrame(truth, kLineOffsets, i + 1))));
    }
    const StreamResult result = RunStream(server.stub(), requests);
    ASSERT_TRUE(result.status.ok()) << result.status.error_message();
    ASSERT_EQ(result.responses.size(), static_cast<size_t>(kFrames));
  }
  auto get = [&](const std::string& id) {
    grpc::ClientContext context;
    v1::GetSessionRequest request;
    request.set_camera_id(id);
    v1::Session session;
    EXPECT_TRUE(server.stub().GetSession(&context, request, &session).ok());
    return session;
  };
  const v1::Session drift = get("drift");
  EXPECT_TRUE(drift.config().calibration().auto_calibrate());
  EXPECT_NEAR(drift.calibration().drift_pitch_deg(), 1.0, 0.3) << drift.calibration().DebugString();
  EXPECT_NEAR(drift.calibration().pitch_deg(), 14.0, 0.3);
  EXPECT_NEAR(drift.calibration().drift_yaw_deg(), 0.0, 0.3);
  EXPECT_GT(drift.calibration().frames_used(), kFrames / 2u);
  EXPECT_GE(drift.calibration().rederived(), 3u);
  // A refusal by the self-check always comes with its reason.
  EXPECT_EQ(drift.calibration().refused() == 0, drift.calibration().last_refusal().empty())
      << drift.calibration().DebugString();
  EXPECT_GT(drift.calibration().confidence(), 0.5);
  // The configured camera is what the session was created with.
  EXPECT_DOUBLE_EQ(drift.config().camera().pitch_deg(), 13.0);
  const v1::Session fixed = get("fixed");
  EXPECT_FALSE(fixed.config().calibration().auto_calibrate());
  EXPECT_EQ(fixed.calibration().frames_used(), 0u);
  EXPECT_DOUBLE_EQ(fixed.calibration().pitch_deg(), 13.0);

  const HttpResponse scrape = HttpFetch(server.server().metrics_port(), "/metrics");
  ASSERT_EQ(scrape.status, 200);
  EXPECT_NEAR(SampleValue(scrape.body,
                          "lanesvc_calibration_drift_degrees{camera=\"drift\",axis=\"pitch\"}"),
              drift.calibration().drift_pitch_deg(), 1e-6)
      << scrape.body;
  EXPECT_EQ(scrape.body.find("camera=\"fixed\""), std::string::npos);
}

}  // namespace
}  // namespace lane::server::testing
