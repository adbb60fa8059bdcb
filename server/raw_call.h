// Requests as bytes: every method of the lane service is registered "raw"
// (ByteBuffer in and out) and parses its requests here. A message that does
// not parse (bytes that are not the message, a proto3 string that is not
// UTF-8) is then the service's to answer: INVALID_ARGUMENT with the reason,
// and on a stream only after the frames before it are answered. With typed
// handlers gRPC answers such a unary call UNIMPLEMENTED with no message, and a
// stream's failed read looks like the client's half-close.
#ifndef LANE_SERVER_RAW_CALL_H_
#define LANE_SERVER_RAW_CALL_H_

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <string>
#include <utility>

#include "absl/status/status.h"
#include "metrics.h"
#include "wire/status_map.h"

namespace lane::server {

// Parses `bytes` into `message`. INVALID_ARGUMENT naming the message type and,
// where protobuf says it, the field and the reason. `bytes` is left empty.
absl::Status ParseMessage(grpc::ByteBuffer& bytes, google::protobuf::Message* message);
// Serializes `message` into `out` (INTERNAL if protobuf cannot).
absl::Status SerializeMessage(const google::protobuf::Message& message, grpc::ByteBuffer* out);

// One unary call: owns the parsed request and the response until gRPC is done
// with the call. The handler reads request(), fills response() and calls
// Reply exactly once, from any thread.
template <class Request, class Response>
class UnaryCall final : public grpc::ServerUnaryReactor {
 public:
  // The request has arrived with the call: counted as received.
  UnaryCall(grpc::CallbackServerContext* context, grpc::ByteBuffer* out, GrpcMetrics& metrics,
            GrpcMetrics::Method& method)
      : context_(context), out_(out), call_metrics_(metrics, method) {
    call_metrics_.Received();
  }

  grpc::CallbackServerContext& context() { return *context_; }
  const Request& request() const { return request_; }
  Request* mutable_request() { return &request_; }
  Response* response() { return &response_; }

  // Serializes the response (when OK), finishes the call and counts it.
  void Reply(absl::Status status) {
    if (status.ok()) status = SerializeMessage(response_, out_);
    const grpc::Status grpc_status = wire::ToGrpcStatus(status);
    if (grpc_status.ok()) call_metrics_.Sent();
    call_metrics_.Handled(grpc_status.error_code());
    Finish(grpc_status);
  }

  void OnDone() override { delete this; }

 private:
  grpc::CallbackServerContext* const context_;
  grpc::ByteBuffer* const out_;
  GrpcMetrics::Call call_metrics_;
  Request request_;
  Response response_;
};

// Starts a unary call: parses `in` and hands the call to `handler` (a
// callable taking UnaryCall<Request, Response>*), or answers INVALID_ARGUMENT
// when the request does not parse. Returns the call's reactor for gRPC.
template <class Request, class Response, class Handler>
grpc::ServerUnaryReactor* StartUnary(grpc::CallbackServerContext* context,
                                     const grpc::ByteBuffer* in, grpc::ByteBuffer* out,
                                     const char* method, Metrics& metrics, Handler&& handler) {
  GrpcMetrics& grpc_metrics = metrics.grpc();
  auto* call = new UnaryCall<Request, Response>(
      context, out, grpc_metrics, grpc_metrics.ForMethod(method, GrpcMetrics::Type::kUnary));
  grpc::ByteBuffer bytes(*in);  // shares the slices: no copy of the payload
  if (absl::Status parsed = ParseMessage(bytes, call->mutable_request()); !parsed.ok()) {
    call->Reply(parsed);
    return call;
  }
  std::forward<Handler>(handler)(call);
  return call;
}

}  // namespace lane::server

#endif  // LANE_SERVER_RAW_CALL_H_
