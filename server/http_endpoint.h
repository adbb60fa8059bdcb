// The server's HTTP side, on the metrics port (civetweb):
//
//   GET /metrics   Prometheus text format 0.0.4 of the given collectables
//   GET /healthz   200 "ok" while the process serves HTTP at all (liveness)
//   GET /readyz    200 "ready" when `ready()` is true, else 503 "not ready"
//                  (starting, or draining: take this replica out of rotation)
//
// Anything else is 404. The gRPC health service stays the probe for gRPC
// clients and Kubernetes' native gRPC probes; these are for load balancers,
// Triton-style tooling and curl.
#ifndef LANE_SERVER_HTTP_ENDPOINT_H_
#define LANE_SERVER_HTTP_ENDPOINT_H_

#include <prometheus/collectable.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

struct mg_context;
struct mg_connection;

namespace lane::server {

class HttpEndpoint {
 public:
  // Listens on `address` ("host:port"; port 0 picks a free one) with
  // `threads` request threads. The collectables and `ready` are called from
  // those threads and must outlive the endpoint.
  static absl::StatusOr<std::unique_ptr<HttpEndpoint>> Start(
      const std::string& address, int threads,
      std::vector<std::shared_ptr<prometheus::Collectable>> collectables,
      std::function<bool()> ready);
  // Stops listening and waits for requests in progress.
  ~HttpEndpoint();

  HttpEndpoint(const HttpEndpoint&) = delete;
  HttpEndpoint& operator=(const HttpEndpoint&) = delete;

  int port() const { return port_; }

 private:
  HttpEndpoint() = default;
  static int HandleMetrics(mg_connection* connection, void* self);
  static int HandleHealthz(mg_connection* connection, void* self);
  static int HandleReadyz(mg_connection* connection, void* self);

  std::vector<std::shared_ptr<prometheus::Collectable>> collectables_;
  std::function<bool()> ready_;
  mg_context* context_ = nullptr;
  int port_ = -1;
};

}  // namespace lane::server

#endif  // LANE_SERVER_HTTP_ENDPOINT_H_
