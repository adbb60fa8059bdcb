// The server's HTTP side, on the metrics port (civetweb):
//
//   GET /metrics   Prometheus text format 0.0.4 of the given collectables
//   GET /healthz   200 "ok" while the process serves HTTP at all (liveness)
//   GET /readyz    200 "ready" when `ready()` is true, else 503 "not ready"
//                  (starting, or draining: take this replica out of rotation)
//
// Anything else is 404, unless a `pages` handler is given (the live view,
// live_view.h): it answers every other path. The gRPC health service stays
// the probe for gRPC clients and Kubernetes' native gRPC probes; these are
// for load balancers, Triton-style tooling and curl.
#ifndef LANE_SERVER_HTTP_ENDPOINT_H_
#define LANE_SERVER_HTTP_ENDPOINT_H_

#include <prometheus/collectable.h>

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

struct mg_context;
struct mg_connection;

namespace lane::server {

// A request as the `pages` handler sees it. The path is as sent, still
// percent-encoded (civetweb's URL decoding is off, so that an encoded '/'
// stays inside its path segment); `query` is the part after '?', encoded.
struct HttpRequest {
  std::string method;
  std::string path;
  std::string query;
  std::string authorization;  // the Authorization header, or ""
  std::string cookie;         // the Cookie header, or ""
  std::string content_type;   // the Content-Type header, or ""
  std::string body;           // POST bodies up to 4 KiB; longer ones are cut
};

// The answer: status, content type, body, and extra headers. Every answer
// also gets Content-Length and Cache-Control: no-store.
struct HttpReply {
  int status = 200;
  std::string content_type = "text/plain; charset=utf-8";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
};

class HttpEndpoint {
 public:
  using PageHandler = std::function<HttpReply(const HttpRequest&)>;

  // Listens on `address` ("host:port"; port 0 picks a free one) with
  // `threads` request threads. The collectables, `ready` and `pages` (may be
  // empty: then other paths are 404) are called from those threads and must
  // outlive the endpoint.
  static absl::StatusOr<std::unique_ptr<HttpEndpoint>> Start(
      const std::string& address, int threads,
      std::vector<std::shared_ptr<prometheus::Collectable>> collectables,
      std::function<bool()> ready, PageHandler pages = {});
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
  static int HandlePages(mg_connection* connection, void* self);

  std::vector<std::shared_ptr<prometheus::Collectable>> collectables_;
  std::function<bool()> ready_;
  PageHandler pages_;
  mg_context* context_ = nullptr;
  int port_ = -1;
};

}  // namespace lane::server

#endif  // LANE_SERVER_HTTP_ENDPOINT_H_
