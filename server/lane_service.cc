#include "lane_service.h"

#include <utility>

#include "absl/time/clock.h"
#include "auth.h"
#include "frame_processor.h"
#include "frame_stream.h"
#include "process_metrics.h"
#include "raw_call.h"
#include "session_proto.h"
#include "wire/config_proto.h"
#include "wire/detection_proto.h"
#include "wire/status_map.h"

namespace lane::server {
namespace {

v1::CreateOutcome OutcomeToProto(SessionRegistry::Outcome outcome) {
  switch (outcome) {
    case SessionRegistry::Outcome::kCreated:
      return v1::CREATE_OUTCOME_CREATED;
    case SessionRegistry::Outcome::kUnchanged:
      return v1::CREATE_OUTCOME_UNCHANGED;
    case SessionRegistry::Outcome::kReplaced:
      return v1::CREATE_OUTCOME_REPLACED;
  }
  return v1::CREATE_OUTCOME_UNSPECIFIED;
}

// A session config of the defaults for `mode`.
v1::SessionConfig DefaultConfigProto(lane::Mode mode, uint32_t max_inflight) {
  lane::Config config;
  config.detector = lane::DetectorOptions::ForMode(mode);
  v1::SessionConfig out;
  wire::ConfigToProto(config, &out);
  StreamPolicy stream;
  stream.max_inflight_frames = max_inflight;
  StreamPolicyToProto(stream, out.mutable_stream());
  return out;
}

}  // namespace

LaneServiceImpl::LaneServiceImpl(ServiceOptions options, SessionRegistry& sessions,
                                 WorkerPool& pool, Metrics& metrics)
    : options_(std::move(options)), sessions_(sessions), pool_(pool), metrics_(metrics) {
  if (options_.resume_seal == nullptr) {
    options_.resume_seal = std::make_shared<ResumeStateSeal>(ResumeStateKeys::Random());
  }
}

LaneServiceImpl::~LaneServiceImpl() {
  // The server has shut down, so every stream's OnDone has returned; the last
  // of them may still have been in Unregister on another thread a moment
  // ago. Taking mu_ orders this destructor after it (gRPC's own ordering runs
  // through libgrpc++'s atomics, which a race detector does not see).
  absl::MutexLock lock(&mu_);
}

void LaneServiceImpl::SetServing() {
  absl::MutexLock lock(&mu_);
  if (state_ == State::kStarting) state_ = State::kServing;
}

void LaneServiceImpl::StartDrain() {
  absl::MutexLock lock(&mu_);
  state_ = State::kDraining;
  // Streams unregister themselves (under mu_) before they are deleted, so
  // every pointer here is alive.
  for (FrameStream* stream : streams_) stream->BeginDrain();
}

bool LaneServiceImpl::WaitForStreams(absl::Time deadline) {
  absl::MutexLock lock(&mu_);
  return mu_.AwaitWithDeadline(no_streams_, deadline);
}

size_t LaneServiceImpl::open_streams() const {
  absl::MutexLock lock(&mu_);
  return streams_.size();
}

void LaneServiceImpl::Unregister(FrameStream* stream) {
  absl::MutexLock lock(&mu_);
  streams_.erase(stream);
}

absl::Status LaneServiceImpl::Admission(const grpc::ServerContextBase& context) const {
  if (absl::Status auth = CheckBearerToken(context, options_.auth_tokens); !auth.ok()) return auth;
  absl::MutexLock lock(&mu_);
  switch (state_) {
    case State::kStarting:
      return wire::ServerStarting();
    case State::kServing:
      return absl::OkStatus();
    case State::kDraining:
      return wire::ServerDraining();
  }
  return wire::ServerDraining();
}

grpc::ServerUnaryReactor* LaneServiceImpl::CreateSession(grpc::CallbackServerContext* context,
                                                         const grpc::ByteBuffer* in,
                                                         grpc::ByteBuffer* out) {
  using Call = UnaryCall<v1::CreateSessionRequest, v1::CreateSessionResponse>;
  return StartUnary<v1::CreateSessionRequest, v1::CreateSessionResponse>(
      context, in, out, "/lane.v1.LaneService/CreateSession", metrics_, [this](Call* call) {
        if (absl::Status s = Admission(call->context()); !s.ok()) return call->Reply(s);
        // Building a detector is CPU work: on the pool.
        const bool queued = pool_.TrySubmit([this, call] {
          const v1::CreateSessionRequest& request = call->request();
          absl::StatusOr<SessionRegistry::CreateResult> created = CreateSessionFromProto(
              sessions_, request.camera_id(), request.config(), request.replace());
          if (created.ok()) {
            SessionToProto(*created->session, absl::Now(), call->response()->mutable_session());
            call->response()->set_outcome(OutcomeToProto(created->outcome));
          }
          call->Reply(created.status());
        });
        if (!queued) call->Reply(wire::WorkerQueueFull());
      });
}

grpc::ServerUnaryReactor* LaneServiceImpl::GetSession(grpc::CallbackServerContext* context,
                                                      const grpc::ByteBuffer* in,
                                                      grpc::ByteBuffer* out) {
  using Call = UnaryCall<v1::GetSessionRequest, v1::Session>;
  return StartUnary<v1::GetSessionRequest, v1::Session>(
      context, in, out, "/lane.v1.LaneService/GetSession", metrics_, [this](Call* call) {
        absl::Status status = Admission(call->context());
        if (status.ok()) status = SessionRegistry::ValidateCameraId(call->request().camera_id());
        if (status.ok()) {
          absl::StatusOr<SessionRegistry::Entry> entry = sessions_.Get(call->request().camera_id());
          if (entry.ok()) SessionToProto(*entry->session, entry->last_used, call->response());
          status = entry.status();
        }
        call->Reply(status);
      });
}

grpc::ServerUnaryReactor* LaneServiceImpl::ListSessions(grpc::CallbackServerContext* context,
                                                        const grpc::ByteBuffer* in,
                                                        grpc::ByteBuffer* out) {
  using Call = UnaryCall<v1::ListSessionsRequest, v1::ListSessionsResponse>;
  return StartUnary<v1::ListSessionsRequest, v1::ListSessionsResponse>(
      context, in, out, "/lane.v1.LaneService/ListSessions", metrics_, [this](Call* call) {
        absl::Status status = Admission(call->context());
        if (status.ok()) {
          for (const SessionRegistry::Entry& entry : sessions_.List()) {
            SessionToProto(*entry.session, entry.last_used, call->response()->add_sessions());
          }
        }
        call->Reply(status);
      });
}

grpc::ServerUnaryReactor* LaneServiceImpl::DeleteSession(grpc::CallbackServerContext* context,
                                                         const grpc::ByteBuffer* in,
                                                         grpc::ByteBuffer* out) {
  using Call = UnaryCall<v1::DeleteSessionRequest, v1::DeleteSessionResponse>;
  return StartUnary<v1::DeleteSessionRequest, v1::DeleteSessionResponse>(
      context, in, out, "/lane.v1.LaneService/DeleteSession", metrics_, [this](Call* call) {
        absl::Status status = Admission(call->context());
        if (status.ok()) status = SessionRegistry::ValidateCameraId(call->request().camera_id());
        if (status.ok()) status = sessions_.Delete(call->request().camera_id());
        call->Reply(status);
      });
}

grpc::ServerBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer>* LaneServiceImpl::StreamFrames(
    grpc::CallbackServerContext* context) {
  absl::Status reject = CheckBearerToken(*context, options_.auth_tokens);
  const bool admitted = reject.ok();
  StreamDeps deps{sessions_, *options_.resume_seal, pool_,
                  metrics_,  options_.frame_limits, options_.stream,
                  nullptr,   options_.live_view};
  if (admitted) deps.on_done = [this](FrameStream* stream) { Unregister(stream); };
  auto* stream = new FrameStream(std::move(deps));
  if (admitted) {
    absl::MutexLock lock(&mu_);
    if (state_ == State::kServing) {
      streams_.insert(stream);
    } else {
      reject = state_ == State::kStarting ? wire::ServerStarting() : wire::ServerDraining();
    }
  }
  stream->Start(reject);
  return stream;
}

grpc::ServerUnaryReactor* LaneServiceImpl::Detect(grpc::CallbackServerContext* context,
                                                  const grpc::ByteBuffer* in,
                                                  grpc::ByteBuffer* out) {
  using Call = UnaryCall<v1::FrameRequest, v1::FrameResponse>;
  return StartUnary<v1::FrameRequest, v1::FrameResponse>(
      context, in, out, "/lane.v1.LaneService/Detect", metrics_, [this](Call* call) {
        if (absl::Status s = Admission(call->context()); !s.ok()) return call->Reply(s);
        const std::string& camera_id = call->request().camera_id();
        if (camera_id.empty()) return call->Reply(wire::InvalidRequest("frame without camera_id"));
        if (absl::Status s = SessionRegistry::ValidateCameraId(camera_id); !s.ok()) {
          return call->Reply(s);
        }
        std::shared_ptr<Session> session;
        if (!call->request().has_session_config()) {
          session = sessions_.Find(camera_id);
          if (session == nullptr) return call->Reply(wire::NoSessionForFrame(camera_id));
        }
        const Arrival arrival = Arrival::Now();
        metrics_.FrameReceived();
        const bool queued =
            pool_.TrySubmit([this, call, arrival, session = std::move(session)]() mutable {
              const v1::FrameRequest& request = call->request();
              v1::FrameResponse* response = call->response();
              absl::Status status;
              if (session == nullptr) {  // the request carries its session config
                absl::StatusOr<SessionRegistry::CreateResult> created =
                    CreateSessionFromProto(sessions_, request.camera_id(), request.session_config(),
                                           request.replace_session());
                if (created.ok()) {
                  session = std::move(created->session);
                } else {
                  status = created.status();
                }
              }
              if (session != nullptr) {
                const bool track = session->TracksUnary();
                ProcessedFrame processed =
                    ProcessFrame(request, *session, options_.frame_limits, arrival, metrics_, track,
                                 options_.live_view != nullptr);
                status = processed.outcome.status;
                *response = FinishFrame(*session, track,
                                        StartResponse(request, request.camera_id(), arrival),
                                        std::move(processed.outcome));
                response->set_server_send_time_unix_ns(absl::GetCurrentTimeNanos());
                if (options_.live_view != nullptr) {
                  options_.live_view->Record(session, *response, std::move(processed.live_sample));
                }
              }
              metrics_.FrameAnswered();
              call->Reply(status);
            });
        if (!queued) {
          metrics_.FrameAnswered();
          call->Reply(wire::WorkerQueueFull());
        }
      });
}

grpc::ServerUnaryReactor* LaneServiceImpl::GetServerInfo(grpc::CallbackServerContext* context,
                                                         const grpc::ByteBuffer* in,
                                                         grpc::ByteBuffer* out) {
  using Call = UnaryCall<v1::GetServerInfoRequest, v1::ServerInfo>;
  return StartUnary<v1::GetServerInfoRequest, v1::ServerInfo>(
      context, in, out, "/lane.v1.LaneService/GetServerInfo", metrics_, [this](Call* call) {
        if (absl::Status s = CheckBearerToken(call->context(), options_.auth_tokens); !s.ok()) {
          return call->Reply(s);
        }
        *call->response() = ServerInfo();
        call->Reply(absl::OkStatus());
      });
}

v1::ServerInfo LaneServiceImpl::ServerInfo() const {
  v1::ServerInfo info;
  const BuildInfo& build = options_.build;
  info.set_version(build.version);
  info.set_build("git " + build.git_revision + ", " + build.build_type + ", gRPC " +
                 build.grpc_version + ", OpenCV " + build.opencv_version);
  info.set_process_cpu_seconds(ProcessCpuSeconds());
  info.set_live_view_port(
      static_cast<uint32_t>(std::max(0, live_view_port_.load(std::memory_order_relaxed))));
  info.add_encoded_formats("jpeg");
  info.add_encoded_formats("png");
  info.add_raw_formats(v1::PIXEL_FORMAT_BGR8);
  info.add_raw_formats(v1::PIXEL_FORMAT_RGB8);
  info.add_raw_formats(v1::PIXEL_FORMAT_GRAY8);
  const SessionRegistry::Options& registry = sessions_.options();
  v1::ServerLimits* limits = info.mutable_limits();
  limits->set_max_receive_message_bytes(options_.max_receive_message_bytes);
  limits->set_max_frame_pixels(static_cast<uint64_t>(options_.frame_limits.max_frame_pixels));
  limits->set_max_sessions(static_cast<uint32_t>(registry.max_sessions));
  limits->set_session_ttl_seconds(
      registry.ttl == absl::InfiniteDuration() ? 0.0 : absl::ToDoubleSeconds(registry.ttl));
  limits->set_max_inflight_frames(registry.default_max_inflight_frames);
  limits->set_workers(static_cast<uint32_t>(pool_.threads()));
  *info.mutable_default_config_all() =
      DefaultConfigProto(lane::Mode::kAll, registry.default_max_inflight_frames);
  *info.mutable_default_config_two() =
      DefaultConfigProto(lane::Mode::kTwo, registry.default_max_inflight_frames);
  return info;
}

}  // namespace lane::server
