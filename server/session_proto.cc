#include "session_proto.h"

#include "absl/strings/str_cat.h"
#include "wire/config_proto.h"
#include "wire/status_map.h"

namespace lane::server {

using wire::InvalidRequest;

absl::StatusOr<StreamPolicy> StreamPolicyFromProto(const v1::StreamOptions& proto) {
  StreamPolicy policy;
  switch (proto.backpressure()) {
    case v1::BACKPRESSURE_UNSPECIFIED:
    case v1::BACKPRESSURE_BLOCK:
      policy.backpressure = Backpressure::kBlock;
      break;
    case v1::BACKPRESSURE_DROP_OLDEST:
      policy.backpressure = Backpressure::kDropOldest;
      break;
    default:
      return wire::InvalidRequest(
          absl::StrCat("stream.backpressure: unknown value ", proto.backpressure()));
  }
  policy.max_inflight_frames = proto.max_inflight_frames();
  return policy;
}

void StreamPolicyToProto(const StreamPolicy& policy, v1::StreamOptions* out) {
  out->set_backpressure(policy.backpressure == Backpressure::kDropOldest
                            ? v1::BACKPRESSURE_DROP_OLDEST
                            : v1::BACKPRESSURE_BLOCK);
  out->set_max_inflight_frames(policy.max_inflight_frames);
}

absl::StatusOr<SessionSpec> SessionSpecFromProto(const v1::SessionConfig& proto) {
  absl::StatusOr<lane::Config> config = wire::ConfigFromProto(proto);
  if (!config.ok()) return config.status();
  absl::StatusOr<StreamPolicy> stream = StreamPolicyFromProto(proto.stream());
  if (!stream.ok()) return stream.status();
  DecodePolicy decode;
  decode.accept_damaged_frames = proto.decode().accept_damaged_frames();
  decode.full_decode = proto.decode().full_decode();
  CalibrationPolicy calibration;
  calibration.auto_calibrate = proto.calibration().auto_calibrate();
  TrackingPolicy tracking;
  tracking.disabled = proto.tracking().disabled();
  tracking.unary = proto.tracking().unary();
  return SessionSpec{*std::move(config), *stream, decode, calibration, tracking};
}

absl::StatusOr<SessionRegistry::CreateResult> CreateSessionFromProto(
    SessionRegistry& sessions, const std::string& camera_id, const v1::SessionConfig& config,
    bool replace) {
  absl::StatusOr<SessionSpec> spec = SessionSpecFromProto(config);
  if (!spec.ok()) return spec.status();
  return sessions.Create(camera_id, *spec, replace);
}

void SessionToProto(const Session& session, absl::Time last_used, v1::Session* out) {
  out->set_camera_id(session.camera_id);
  out->set_version(session.version);
  wire::ConfigToProto(session.config, out->mutable_config());
  StreamPolicyToProto(session.stream, out->mutable_config()->mutable_stream());
  out->mutable_config()->mutable_decode()->set_accept_damaged_frames(
      session.decode.accept_damaged_frames);
  out->mutable_config()->mutable_decode()->set_full_decode(session.decode.full_decode);
  out->set_create_time_unix_ns(absl::ToUnixNanos(session.create_time));
  out->set_last_used_unix_ns(absl::ToUnixNanos(last_used));
  out->set_frames_processed(session.frames_processed.load(std::memory_order_relaxed));
  out->mutable_config()->mutable_calibration()->set_auto_calibrate(
      session.calibration.auto_calibrate);
  out->mutable_config()->mutable_tracking()->set_disabled(session.tracking.disabled);
  out->mutable_config()->mutable_tracking()->set_unary(session.tracking.unary);
  const CalibrationSnapshot c = session.Calibration();
  v1::CalibrationState* state = out->mutable_calibration();
  state->set_pitch_deg(c.camera.pitch_deg);
  state->set_yaw_deg(c.camera.yaw_deg);
  const Eigen::Vector2d vp = c.camera.VanishingPoint();
  state->mutable_vanishing_point()->set_x(vp.x());
  state->mutable_vanishing_point()->set_y(vp.y());
  state->set_confidence(c.confidence);
  state->set_uncertainty_deg(c.uncertainty_deg);
  state->set_frames_seen(c.frames_seen);
  state->set_frames_used(c.frames_used);
  state->set_drift_pitch_deg(c.drift_pitch_deg);
  state->set_drift_yaw_deg(c.drift_yaw_deg);
  state->set_rederived(c.rederived);
  state->set_refused(c.refused);
  state->set_last_refusal(c.last_refusal);
}

}  // namespace lane::server
