#include "http_endpoint.h"

#include <civetweb.h>
#include <prometheus/text_serializer.h>

#include <algorithm>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace lane::server {
namespace {

// A whole response with a length: Prometheus and probes read it and close.
int Reply(mg_connection* connection, int status, const char* content_type, const std::string& body,
          const std::vector<std::pair<std::string, std::string>>& headers = {}) {
  mg_response_header_start(connection, status);
  mg_response_header_add(connection, "Content-Type", content_type, -1);
  mg_response_header_add(connection, "Content-Length", std::to_string(body.size()).c_str(), -1);
  mg_response_header_add(connection, "Cache-Control", "no-store", -1);
  for (const auto& [name, value] : headers) {
    mg_response_header_add(connection, name.c_str(), value.c_str(), -1);
  }
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

std::string HeaderOf(mg_connection* connection, const char* name) {
  const char* value = mg_get_header(connection, name);
  return value != nullptr ? value : "";
}

// A request body up to `limit` bytes (the rest is not read).
std::string ReadBody(mg_connection* connection, size_t limit) {
  std::string body;
  char buffer[1024];
  while (body.size() < limit) {
    const int n = mg_read(connection, buffer, std::min(sizeof(buffer), limit - body.size()));
    if (n <= 0) break;
    body.append(buffer, static_cast<size_t>(n));
  }
  return body;
}

}  // namespace

absl::StatusOr<std::unique_ptr<HttpEndpoint>> HttpEndpoint::Start(
    const std::string& address, int threads,
    std::vector<std::shared_ptr<prometheus::Collectable>> collectables, std::function<bool()> ready,
    PageHandler pages) {
  std::call_once(library_once, [] { mg_init_library(0); });
  std::unique_ptr<HttpEndpoint> endpoint(new HttpEndpoint());
  endpoint->collectables_ = std::move(collectables);
  endpoint->ready_ = std::move(ready);
  endpoint->pages_ = std::move(pages);

  const std::string thread_count = std::to_string(std::max(1, threads));
  // With pages, paths reach the handler still percent-encoded: a camera id
  // may hold '/', which its links encode as %2F inside one path segment.
  const char* decode_url = endpoint->pages_ ? "no" : "yes";
  const char* options[] = {"listening_ports",    address.c_str(),      "num_threads",
                           thread_count.c_str(), "request_timeout_ms", "10000",
                           "decode_url",         decode_url,           nullptr};
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
  // Last, so that the three above keep their paths: every other path.
  if (endpoint->pages_) {
    mg_set_request_handler(endpoint->context_, "/", &HttpEndpoint::HandlePages, endpoint.get());
  }
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

int HttpEndpoint::HandlePages(mg_connection* connection, void* self) {
  auto* endpoint = static_cast<HttpEndpoint*>(self);
  const mg_request_info* info = mg_get_request_info(connection);
  HttpRequest request;
  if (info != nullptr) {
    request.method = info->request_method != nullptr ? info->request_method : "";
    request.path = info->local_uri != nullptr ? info->local_uri : "";
    request.query = info->query_string != nullptr ? info->query_string : "";
  }
  request.authorization = HeaderOf(connection, "Authorization");
  request.cookie = HeaderOf(connection, "Cookie");
  request.content_type = HeaderOf(connection, "Content-Type");
  if (request.method == "POST") request.body = ReadBody(connection, 4096);
  const HttpReply reply = endpoint->pages_(request);
  return Reply(connection, reply.status, reply.content_type.c_str(), reply.body, reply.headers);
}

}  // namespace lane::server
