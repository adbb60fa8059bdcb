// Conversions between the wire types (lane.v1 protobuf) and the core and
// server types. Pure functions: no I/O, no state.
#ifndef LANE_SERVER_CONVERT_H_
#define LANE_SERVER_CONVERT_H_

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "lane/config.h"
#include "lane/detector.h"
#include "lane/v1/lane_service.pb.h"
#include "session.h"

namespace lane::server {

// The detector config of a SessionConfig: either its `config_json` (parsed by
// lane::ParseConfig) or its structured fields applied over the defaults of
// the requested mode. INVALID_ARGUMENT for both at once, an unknown enum
// value, or a config that does not validate.
absl::StatusOr<lane::Config> ConfigFromProto(const v1::SessionConfig& proto);
// Every field set; `config_json` and `stream` are left alone.
void ConfigToProto(const lane::Config& config, v1::SessionConfig* out);

// INVALID_ARGUMENT for an unknown backpressure value.
absl::StatusOr<StreamPolicy> StreamPolicyFromProto(const v1::StreamOptions& proto);
void StreamPolicyToProto(const StreamPolicy& policy, v1::StreamOptions* out);

absl::StatusOr<SessionSpec> SessionSpecFromProto(const v1::SessionConfig& proto);

void SessionToProto(const Session& session, absl::Time last_used, v1::Session* out);

// The lanes of a detection (image, IPM and ground control points, score).
void LanesToProto(const lane::Detection& detection, v1::FrameResponse* out);
// The detector's stage timings (milliseconds) into `out`.
void TimingsToProto(const lane::StageTimings& timings, v1::StageTimings* out);

}  // namespace lane::server

#endif  // LANE_SERVER_CONVERT_H_
