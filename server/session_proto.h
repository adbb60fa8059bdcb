// A session on the wire: the server's session types (stream and decode
// policies, the session itself) <-> lane.v1 messages. The detector config's
// own conversion is the wire library's (wire/config_proto.h).
#ifndef LANE_SERVER_SESSION_PROTO_H_
#define LANE_SERVER_SESSION_PROTO_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "lane/v1/lane_service.pb.h"
#include "session.h"
#include "session_registry.h"

namespace lane::server {

// INVALID_ARGUMENT for an unknown backpressure value.
absl::StatusOr<StreamPolicy> StreamPolicyFromProto(const v1::StreamOptions& proto);
void StreamPolicyToProto(const StreamPolicy& policy, v1::StreamOptions* out);

// The config (wire::ConfigFromProto), stream and decode policies of a request.
absl::StatusOr<SessionSpec> SessionSpecFromProto(const v1::SessionConfig& proto);

// Creates or confirms the session a request describes (CreateSession, or a
// stream's or Detect's inline session_config). CPU work (it may build a
// detector): call it on a worker.
absl::StatusOr<SessionRegistry::CreateResult> CreateSessionFromProto(
    SessionRegistry& sessions, const std::string& camera_id, const v1::SessionConfig& config,
    bool replace);

void SessionToProto(const Session& session, absl::Time last_used, v1::Session* out);

}  // namespace lane::server

#endif  // LANE_SERVER_SESSION_PROTO_H_
