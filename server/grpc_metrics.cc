#include "grpc_metrics.h"

#include <chrono>
#include <string_view>

#include "wire/status_map.h"

namespace lane::server {
namespace {

constexpr size_t kMaxMethods = 64;

const char* TypeLabel(GrpcMetrics::Type type) {
  switch (type) {
    case GrpcMetrics::Type::kUnary:
      return "unary";
    case GrpcMetrics::Type::kClientStream:
      return "client_stream";
    case GrpcMetrics::Type::kServerStream:
      return "server_stream";
    case GrpcMetrics::Type::kBidiStream:
      return "bidi_stream";
  }
  return "unknown";
}

}  // namespace

prometheus::Histogram::BucketBoundaries GrpcMetrics::HandlingBuckets() {
  return {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300};
}

GrpcMetrics::GrpcMetrics(prometheus::Registry& registry)
    : started_(prometheus::BuildCounter()
                   .Name("grpc_server_started_total")
                   .Help("Total number of RPCs started on the server.")
                   .Register(registry)),
      handled_(prometheus::BuildCounter()
                   .Name("grpc_server_handled_total")
                   .Help("Total number of RPCs completed on the server, regardless of success "
                         "or failure.")
                   .Register(registry)),
      received_(prometheus::BuildCounter()
                    .Name("grpc_server_msg_received_total")
                    .Help("Total number of RPC stream messages received on the server.")
                    .Register(registry)),
      sent_(prometheus::BuildCounter()
                .Name("grpc_server_msg_sent_total")
                .Help("Total number of gRPC stream messages sent by the server.")
                .Register(registry)),
      handling_(prometheus::BuildHistogram()
                    .Name("grpc_server_handling_seconds")
                    .Help("Histogram of response latency (seconds) of gRPC that had been "
                          "application-level handled by the server.")
                    .Register(registry)) {}

GrpcMetrics::Call::Call(GrpcMetrics& metrics, Method& method)
    : metrics_(metrics), method_(method), start_(std::chrono::steady_clock::now()) {
  method_.started->Increment();
}

void GrpcMetrics::Call::Handled(grpc::StatusCode code) {
  if (handled_.exchange(true)) return;
  metrics_.CountHandled(method_, code);
  method_.handling->Observe(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
}

GrpcMetrics::Method& GrpcMetrics::ForMethod(const char* full_method, Type type) {
  // "/package.Service/Method"; anything else is kept whole as the method
  // under service "unknown".
  const std::string_view name = full_method != nullptr ? full_method : "";
  const char* type_label = TypeLabel(type);
  absl::MutexLock lock(&mu_);
  // The label set stays bounded whatever names callers pass: past
  // kMaxMethods series they share one "unknown" series.
  const bool known =
      methods_.size() < kMaxMethods || methods_.count(std::string(name) + '\n' + type_label) != 0;
  const std::string_view label_name = known ? name : std::string_view("unknown");
  std::unique_ptr<Method>& slot = methods_[std::string(label_name) + '\n' + type_label];
  if (slot == nullptr) {
    std::string service = "unknown";
    std::string method(label_name);
    const size_t slash = name.rfind('/');
    if (known && name.size() > 1 && name[0] == '/' && slash != std::string_view::npos &&
        slash > 1) {
      service = std::string(name.substr(1, slash - 1));
      method = std::string(name.substr(slash + 1));
    }
    slot = std::make_unique<Method>();
    slot->labels = {{"grpc_service", service}, {"grpc_method", method}, {"grpc_type", type_label}};
    slot->started = &started_.Add(slot->labels);
    slot->received = &received_.Add(slot->labels);
    slot->sent = &sent_.Add(slot->labels);
    slot->handling = &handling_.Add(slot->labels, HandlingBuckets());
  }
  return *slot;
}

void GrpcMetrics::CountHandled(const Method& method, grpc::StatusCode code) {
  prometheus::Labels labels = method.labels;
  labels.emplace("grpc_code", wire::GrpcCodeName(code));
  handled_.Add(labels).Increment();  // Family::Add is thread-safe
}

}  // namespace lane::server
