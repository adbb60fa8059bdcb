// The lane.v1.LaneService implementation on gRPC's callback API.
//
// Reactions never block: session lookups take a short lock, and all CPU work
// (building detectors, decoding, detecting) goes to the server's WorkerPool.
// The service converts between protobuf and core types and records metrics;
// sessions live in SessionRegistry, frame work in frame_processor, the stream
// protocol in FrameStream.
#ifndef LANE_SERVER_LANE_SERVICE_H_
#define LANE_SERVER_LANE_SERVICE_H_

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_set>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "frame_processor.h"
#include "frame_stream.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "metrics.h"
#include "resume_seal.h"
#include "session_registry.h"
#include "worker_pool.h"

namespace lane::server {

class FrameStream;

struct ServiceOptions {
  // Largest frame accepted and the decode deadline.
  FrameLimits frame_limits;
  // Tracked streams (StreamOptions in frame_stream.h): how often a response
  // carries the tracker's resume state, and the longest a stream reads
  // before it drains so that its client reconnects (rebalancing).
  StreamOptions stream;
  // Reported by GetServerInfo.
  uint64_t max_receive_message_bytes = 0;
  // Seals the resume states of tracked streams and opens those clients send
  // back (resume_seal.h). Null: a random key of the service's own.
  std::shared_ptr<const ResumeStateSeal> resume_seal;
  // Accepted Bearer tokens (authorization metadata); empty = no auth.
  std::vector<std::string> auth_tokens;
  // The live view (--live_view), or null: frames of streams and Detect are
  // recorded there. Must outlive the service.
  LiveView* live_view = nullptr;
  BuildInfo build;
};

// Every method is registered raw (ByteBuffer in and out) and parses its own
// requests (raw_call.h): a request that does not parse gets INVALID_ARGUMENT
// with the reason, not gRPC's bare UNIMPLEMENTED or a stream ended as if
// half-closed.
using RawLaneService = v1::LaneService::WithRawCallbackMethod_CreateSession<
    v1::LaneService::WithRawCallbackMethod_GetSession<
        v1::LaneService::WithRawCallbackMethod_ListSessions<
            v1::LaneService::WithRawCallbackMethod_DeleteSession<
                v1::LaneService::WithRawCallbackMethod_StreamFrames<
                    v1::LaneService::WithRawCallbackMethod_Detect<
                        v1::LaneService::WithRawCallbackMethod_GetServerInfo<
                            v1::LaneService::Service>>>>>>>;

class LaneServiceImpl final : public RawLaneService {
 public:
  LaneServiceImpl(ServiceOptions options, SessionRegistry& sessions, WorkerPool& pool,
                  Metrics& metrics);
  ~LaneServiceImpl() override;

  // The raw methods. Requests: lane.v1 messages as bytes (see the proto).
  grpc::ServerUnaryReactor* CreateSession(grpc::CallbackServerContext* context,
                                          const grpc::ByteBuffer* in,
                                          grpc::ByteBuffer* out) override;
  grpc::ServerUnaryReactor* GetSession(grpc::CallbackServerContext* context,
                                       const grpc::ByteBuffer* in, grpc::ByteBuffer* out) override;
  grpc::ServerUnaryReactor* ListSessions(grpc::CallbackServerContext* context,
                                         const grpc::ByteBuffer* in,
                                         grpc::ByteBuffer* out) override;
  grpc::ServerUnaryReactor* DeleteSession(grpc::CallbackServerContext* context,
                                          const grpc::ByteBuffer* in,
                                          grpc::ByteBuffer* out) override;
  grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* StreamFrames(
      grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* Detect(grpc::CallbackServerContext* context, const grpc::ByteBuffer* in,
                                   grpc::ByteBuffer* out) override;
  grpc::ServerUnaryReactor* GetServerInfo(grpc::CallbackServerContext* context,
                                          const grpc::ByteBuffer* in,
                                          grpc::ByteBuffer* out) override;

  // Lifecycle: calls are refused with UNAVAILABLE until SetServing and after
  // StartDrain. StartDrain also tells every open stream to stop reading,
  // answer the frames it has received and end with UNAVAILABLE.
  void SetServing();
  // The live view's port, for GetServerInfo (set once the metrics endpoint
  // listens; 0 = no live view).
  void SetLiveViewPort(int port) { live_view_port_.store(port, std::memory_order_relaxed); }
  void StartDrain();
  // Waits until every stream has ended or `deadline` passes; true if all did.
  bool WaitForStreams(absl::Time deadline);
  size_t open_streams() const;

 private:
  enum class State { kStarting, kServing, kDraining };

  // OK while serving, else UNAVAILABLE.
  // The one check of every call: the Bearer token (auth.h), then the
  // serving state.
  absl::Status Admission(const grpc::ServerContextBase& context) const;
  // GetServerInfo's answer.
  v1::ServerInfo ServerInfo() const;
  // Drops a finished stream from streams_ (its on_done callback).
  void Unregister(FrameStream* stream);

  ServiceOptions options_;  // const after construction
  SessionRegistry& sessions_;
  WorkerPool& pool_;
  Metrics& metrics_;

  // WaitForStreams' condition.
  bool NoStreams() const ABSL_SHARED_LOCKS_REQUIRED(mu_) { return streams_.empty(); }

  mutable absl::Mutex mu_;
  // Conditions that other threads evaluate are members, not temporaries on
  // the waiter's stack: absl evaluates a waiter's Condition on the thread
  // that unlocks, inside its (uninstrumented) lock code, so TSan saw that
  // thread read the waiter's stack after the waiter had returned and reused
  // it (a loaded run of the suite, issue 40).
  const absl::Condition no_streams_{this, &LaneServiceImpl::NoStreams};
  State state_ ABSL_GUARDED_BY(mu_) = State::kStarting;
  std::unordered_set<FrameStream*> streams_ ABSL_GUARDED_BY(mu_);
  std::atomic<int> live_view_port_{0};
};

}  // namespace lane::server

#endif  // LANE_SERVER_LANE_SERVICE_H_
