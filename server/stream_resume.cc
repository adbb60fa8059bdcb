#include "stream_resume.h"

#include <algorithm>
#include <cstdint>

#include "absl/status/statusor.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "lane/base/excerpt.h"
#include "wire/tracker_state_proto.h"

namespace lane::server {
namespace {

// The sealed state's binding against the session's: OK, or which of camera,
// config and epoch is wrong (in that order).
absl::Status CheckBinding(const ResumeBinding& binding, Session& session,
                          const SessionRegistry& sessions) {
  if (binding.camera_id != session.camera_id) {
    return absl::InvalidArgumentError(absl::StrCat("resume state: camera: made for camera '",
                                                   lane::Excerpt(binding.camera_id), "', not '",
                                                   session.camera_id, "'"));
  }
  if (binding.config_fingerprint != session.config_fingerprint) {
    return absl::InvalidArgumentError(absl::StrCat(
        "resume state: config: made under another config of camera '", session.camera_id,
        "' (fingerprint ", absl::BytesToHexString(binding.config_fingerprint), ", the session's ",
        absl::BytesToHexString(session.config_fingerprint), ")"));
  }
  if (sessions.EpochRetired(binding.epoch) || !session.ContinueEpoch(binding.epoch)) {
    return absl::InvalidArgumentError(
        absl::StrCat("resume state: epoch: made by an earlier session of camera '",
                     session.camera_id, "' (deleted, replaced or created again since)"));
  }
  return absl::OkStatus();
}

}  // namespace

ResumeResult ResumeTracking(const v1::FrameRequest& request, Session& session,
                            const ResumeStateSeal& seal, const SessionRegistry& sessions) {
  ResumeResult result;
  if (!session.TracksStreams()) {
    result.status = absl::InvalidArgumentError(
        "resume_state: the session does not track streams (tracking.disabled)");
    result.outcome = Metrics::Resume::kRefused;
    return result;
  }
  if (!request.resume_state().empty()) {
    absl::StatusOr<bool> restored = [&]() -> absl::StatusOr<bool> {
      if (request.resume_state().size() > wire::kMaxResumeStateBytes) {
        return absl::InvalidArgumentError(
            absl::StrCat("resume state: ", request.resume_state().size(), " bytes, more than ",
                         wire::kMaxResumeStateBytes));
      }
      absl::StatusOr<OpenedResumeState> opened = seal.Open(request.resume_state());
      if (!opened.ok()) return opened.status();
      if (absl::Status bound = CheckBinding(opened->binding, session, sessions); !bound.ok()) {
        return bound;
      }
      absl::StatusOr<lane::TrackerState> state = wire::DecodeTrackerState(opened->tracker_state);
      if (!state.ok()) return state.status();
      return session.tracker().Resume(*state);
    }();
    if (!restored.ok()) {
      session.tracker().Reset();  // a fresh start, ids going on
      result.status = restored.status();
      result.outcome = Metrics::Resume::kRefused;
    } else if (*restored) {
      result.outcome = Metrics::Resume::kRestored;
    }
  }
  if (request.min_lane_id() > 0) {
    session.tracker().ReserveIdsBelow(
        static_cast<int>(std::min<uint32_t>(request.min_lane_id(), lane::TrackerState::kMaxId)));
  }
  return result;
}

std::string SealedResumeState(Session& session, const ResumeStateSeal& seal) {
  const ResumeBinding binding{session.camera_id, session.config_fingerprint, session.SealEpoch()};
  std::string sealed = seal.Seal(binding, wire::EncodeTrackerState(session.tracker().Save()));
  if (sealed.size() > wire::kMaxResumeStateBytes) return {};
  return sealed;
}

}  // namespace lane::server
