// The go-grpc-prometheus metric families, so that the dashboards and alerts
// written for Go and Java gRPC servers work on lane-server unchanged:
//
//   grpc_server_started_total{grpc_service,grpc_method,grpc_type}
//   grpc_server_handled_total{grpc_service,grpc_method,grpc_type,grpc_code}
//   grpc_server_msg_received_total{grpc_service,grpc_method,grpc_type}
//   grpc_server_msg_sent_total{grpc_service,grpc_method,grpc_type}
//   grpc_server_handling_seconds{grpc_service,grpc_method,grpc_type} (histogram)
//
// They are counted by a server interceptor, so every service the server hosts
// is covered the same way (the lane service, health, reflection) and no
// handler counts its own calls. A call is "handled" when its status is sent;
// a call that ends without one (the client went away first) is counted as
// CANCELLED. grpc_type is unary, client_stream, server_stream or bidi_stream.
#ifndef LANE_SERVER_GRPC_METRICS_H_
#define LANE_SERVER_GRPC_METRICS_H_

#include <grpcpp/support/server_interceptor.h>
#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>

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

  // The series of a full method name ("/lane.v1.LaneService/Detect") and
  // call type; created on first use, then shared.
  Method& ForMethod(const char* full_method, grpc::experimental::ServerRpcInfo::Type type);
  void CountHandled(const Method& method, grpc::StatusCode code);

  // For grpc::ServerBuilder::experimental().SetInterceptorCreators. The
  // factory refers to this object, which must outlive the server.
  std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> InterceptorFactory();

 private:
  prometheus::Family<prometheus::Counter>& started_;
  prometheus::Family<prometheus::Counter>& handled_;
  prometheus::Family<prometheus::Counter>& received_;
  prometheus::Family<prometheus::Counter>& sent_;
  prometheus::Family<prometheus::Histogram>& handling_;
  std::mutex mu_;
  std::map<std::string, std::unique_ptr<Method>> methods_;  // guarded by mu_
};

}  // namespace lane::server

#endif  // LANE_SERVER_GRPC_METRICS_H_
