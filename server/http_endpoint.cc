#include "http_endpoint.h"

#include <civetweb.h>
#include <prometheus/text_serializer.h>

#include <mutex>

#include "absl/strings/str_cat.h"

namespace lane::server {
namespace {

// A whole response with a length: Prometheus and probes read it and close.
int Reply(mg_connection* connection, int status, const char* content_type,
          const std::string& body) {
  mg_response_header_start(connection, status);
  mg_response_header_add(connection, "Content-Type", content_type, -1);
  mg_response_header_add(connection, "Content-Length", std::to_string(body.size()).c_str(), -1);
  mg_response_header_add(connection, "Cache-Control", "no-store", -1);
  mg_response_header_send(connection);
  const mg_request_info* request = mg_get_request_info(connection);
  const bool head = request != nullptr && request->request_method != nullptr &&
                    std::string(request->request_method) == "HEAD";
  if (!head) mg_write(connection, body.data(), body.size());
  return status;
}

int OnlyGet(mg_connection* connection) {
  const mg_request_info* request = mg_get_request_info(connection);
  const std::string method =
      request != nullptr && request->request_method != nullptr ? request->request_method : "";
  if (method == "GET" || method == "HEAD") return 0;
  return Reply(connection, 405, "text/plain; charset=utf-8", "only GET and HEAD\n");
}

std::once_flag library_once;

}  // namespace

absl::StatusOr<std::unique_ptr<HttpEndpoint>> HttpEndpoint::Start(
    const std::string& address, int threads,
    std::vector<std::shared_ptr<prometheus::Collectable>> collectables,
    std::function<bool()> ready) {
  std::call_once(library_once, [] { mg_init_library(0); });
  std::unique_ptr<HttpEndpoint> endpoint(new HttpEndpoint());
  endpoint->collectables_ = std::move(collectables);
  endpoint->ready_ = std::move(ready);

  const std::string thread_count = std::to_string(std::max(1, threads));
  const char* options[] = {
      "listening_ports",    address.c_str(), "num_threads", thread_count.c_str(),
      "request_timeout_ms", "10000",         nullptr};
  mg_callbacks callbacks{};
  // civetweb would print to stderr; the error comes back through mg_start2.
  callbacks.log_message = [](const mg_connection*, const char*) { return 1; };
  mg_init_data init{};
  init.callbacks = &callbacks;
  init.user_data = nullptr;
  init.configuration_options = options;
  char text[256] = {};
  unsigned code = 0;
  mg_error_data error{};
  error.code = &code;
  error.text = text;
  error.text_buffer_size = sizeof(text);
  endpoint->context_ = mg_start2(&init, &error);
  if (endpoint->context_ == nullptr) {
    return absl::UnavailableError(absl::StrCat("cannot serve HTTP on ", address, ": ",
                                               text[0] != '\0' ? text : "civetweb failed"));
  }
  mg_server_port ports[4] = {};
  const int n = mg_get_server_ports(endpoint->context_, 4, ports);
  endpoint->port_ = n > 0 ? ports[0].port : -1;
  mg_set_request_handler(endpoint->context_, "/metrics$", &HttpEndpoint::HandleMetrics,
                         endpoint.get());
  mg_set_request_handler(endpoint->context_, "/healthz$", &HttpEndpoint::HandleHealthz,
                         endpoint.get());
  mg_set_request_handler(endpoint->context_, "/readyz$", &HttpEndpoint::HandleReadyz,
                         endpoint.get());
  return endpoint;
}

HttpEndpoint::~HttpEndpoint() {
  if (context_ != nullptr) mg_stop(context_);
}

int HttpEndpoint::HandleMetrics(mg_connection* connection, void* self) {
  if (int refused = OnlyGet(connection); refused != 0) return refused;
  auto* endpoint = static_cast<HttpEndpoint*>(self);
  std::vector<prometheus::MetricFamily> families;
  for (const auto& collectable : endpoint->collectables_) {
    std::vector<prometheus::MetricFamily> more = collectable->Collect();
    families.insert(families.end(), std::make_move_iterator(more.begin()),
                    std::make_move_iterator(more.end()));
  }
  return Reply(connection, 200, "text/plain; version=0.0.4; charset=utf-8",
               prometheus::TextSerializer().Serialize(families));
}

int HttpEndpoint::HandleHealthz(mg_connection* connection, void* /*self*/) {
  if (int refused = OnlyGet(connection); refused != 0) return refused;
  return Reply(connection, 200, "text/plain; charset=utf-8", "ok\n");
}

int HttpEndpoint::HandleReadyz(mg_connection* connection, void* self) {
  if (int refused = OnlyGet(connection); refused != 0) return refused;
  auto* endpoint = static_cast<HttpEndpoint*>(self);
  if (endpoint->ready_ && endpoint->ready_()) {
    return Reply(connection, 200, "text/plain; charset=utf-8", "ready\n");
  }
  return Reply(connection, 503, "text/plain; charset=utf-8", "not ready\n");
}

}  // namespace lane::server
