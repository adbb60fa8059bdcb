// The go-grpc-prometheus metric families, so that the dashboards and alerts
// written for Go and Java gRPC servers work on lane-server unchanged:
//
//   grpc_server_started_total{grpc_service,grpc_method,grpc_type}
//   grpc_server_handled_total{grpc_service,grpc_method,grpc_type,grpc_code}
//   grpc_server_msg_received_total{grpc_service,grpc_method,grpc_type}
//   grpc_server_msg_sent_total{grpc_service,grpc_method,grpc_type}
//   grpc_server_handling_seconds{grpc_service,grpc_method,grpc_type} (histogram)
//
// They count the calls of lane.v1.LaneService: each call object of the
// service (raw_call.h's UnaryCall, FrameStream) holds a GrpcMetrics::Call
// and reports its messages and its status to it. Health checks and
// reflection are not counted. (A server interceptor would count those too,
// but gRPC hands its interceptor state between threads inside the
// uninstrumented libgrpc++, which ThreadSanitizer reports as races; the
// service's own objects are already proved race-free.) grpc_type is unary or
// bidi_stream.
#ifndef LANE_SERVER_GRPC_METRICS_H_
#define LANE_SERVER_GRPC_METRICS_H_

#include <grpcpp/support/status.h>
#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace lane::server {

class GrpcMetrics {
 public:
  // The series of one method (its labels fixed).
  struct Method {
    prometheus::Labels labels;  // grpc_service, grpc_method, grpc_type
    prometheus::Counter* started = nullptr;
    prometheus::Counter* received = nullptr;
    prometheus::Counter* sent = nullptr;
    prometheus::Histogram* handling = nullptr;
  };

  // go-grpc-prometheus's handling-time buckets, extended to 5 minutes for
  // long frame streams.
  static prometheus::Histogram::BucketBoundaries HandlingBuckets();

  explicit GrpcMetrics(prometheus::Registry& registry);

  enum class Type { kUnary, kClientStream, kServerStream, kBidiStream };

  // One call: started when made; messages counted as they go; handled once,
  // with its status code and its handling time. Thread-safe.
  class Call {
   public:
    Call(GrpcMetrics& metrics, Method& method);
    void Received() { method_.received->Increment(); }
    void Sent() { method_.sent->Increment(); }
    // The first call counts; later ones are ignored.
    void Handled(grpc::StatusCode code);

   private:
    GrpcMetrics& metrics_;
    Method& method_;
    const std::chrono::steady_clock::time_point start_;
    std::atomic<bool> handled_{false};
  };

  // The series of a full method name ("/lane.v1.LaneService/Detect") and
  // call type; created on first use, then shared. Past 64 names, the rest
  // share one "unknown" series.
  Method& ForMethod(const char* full_method, Type type);
  void CountHandled(const Method& method, grpc::StatusCode code);

 private:
  prometheus::Family<prometheus::Counter>& started_;
  prometheus::Family<prometheus::Counter>& handled_;
  prometheus::Family<prometheus::Counter>& received_;
  prometheus::Family<prometheus::Counter>& sent_;
  prometheus::Family<prometheus::Histogram>& handling_;
  absl::Mutex mu_;
  std::map<std::string, std::unique_ptr<Method>> methods_ ABSL_GUARDED_BY(mu_);
};

}  // namespace lane::server

#endif  // LANE_SERVER_GRPC_METRICS_H_
