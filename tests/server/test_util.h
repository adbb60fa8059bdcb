// Shared helpers of the server tests: synthetic road frames, session configs,
// an in-process server on a loopback port, metric readers.
#ifndef LANE_TESTS_SERVER_TEST_UTIL_H_
#define LANE_TESTS_SERVER_TEST_UTIL_H_

#include <grpcpp/grpcpp.h>
#include <prometheus/registry.h>

#include <chrono>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "lane/geometry/camera.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "road_frames.h"
#include "server.h"

namespace lane::server::testing {

// Synthetic frames and session configs (tests/common/road_frames.h).
using lane::testing::EncodeJpeg;
using lane::testing::EncodePng;
using lane::testing::JpegRequest;
using lane::testing::kLineOffsets;
using lane::testing::RoadFrame;
using lane::testing::ScaledCamera;
using lane::testing::SessionConfigFor;

// A LaneServer on 127.0.0.1 (port chosen by the system) and a stub to it.
class TestServer {
 public:
  // Options for tests: loopback, no metrics endpoint, 2 workers.
  static ServerOptions DefaultOptions();

  explicit TestServer(ServerOptions options = DefaultOptions());
  ~TestServer();

  LaneServer& server() { return *server_; }
  v1::LaneService::Stub& stub() { return *stub_; }
  std::shared_ptr<grpc::Channel> channel() { return channel_; }
  prometheus::Registry& registry() { return *registry_; }
  std::string target() const;

  // Creates a session; fails the test on error. Returns its version.
  uint64_t CreateSession(const std::string& camera_id, const v1::SessionConfig& config);

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  std::unique_ptr<LaneServer> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::LaneService::Stub> stub_;
};

// CreateSession(camera_id, config) with a 30 s deadline: the call's status.
grpc::Status CreateSessionStatus(v1::LaneService::Stub& stub, const std::string& camera_id,
                                 const v1::SessionConfig& config);

// Sum of the samples of a counter/gauge family whose labels include all of
// `labels` (an empty list matches every sample). Histograms: the count.
double MetricValue(const prometheus::Registry& registry, const std::string& name,
                   const std::vector<std::pair<std::string, std::string>>& labels = {});

// Runs one stream: writes every request (from a thread), reads every
// response, returns the final status.
struct StreamResult {
  std::vector<v1::FrameResponse> responses;
  grpc::Status status;
};
StreamResult RunStream(v1::LaneService::Stub& stub, const std::vector<v1::FrameRequest>& requests);

// grpc.health.v1.Health/Check for the whole server (service ""), through a
// generic stub: 1 SERVING, 2 NOT_SERVING; -1 if the call failed.
int HealthStatus(const std::shared_ptr<grpc::Channel>& channel);

// Asks the server reflection service (v1alpha, through a generic stub) for
// its services; true if lane.v1.LaneService is among them.
bool ReflectionListsLaneService(const std::shared_ptr<grpc::Channel>& channel);

// One HTTP/1.0 request to 127.0.0.1:port (the server closes the connection
// after the response). status 0 when no response came.
struct HttpResponse {
  int status = 0;
  std::string headers;
  std::string body;
};
HttpResponse HttpFetch(int port, const std::string& path, const std::string& method = "GET");

// Polls `condition` every 10 ms until it holds or `timeout_s` passes.
template <typename F>
bool PollUntil(F condition, double timeout_s = 30.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}
}  // namespace lane::server::testing

#endif  // LANE_TESTS_SERVER_TEST_UTIL_H_
