// Tracking across reconnects (docs/deployment.md): the sealed resume state a
// tracked stream's responses carry, and what the first request of the next
// stream does with it.
#ifndef LANE_SERVER_STREAM_RESUME_H_
#define LANE_SERVER_STREAM_RESUME_H_

#include <string>

#include "absl/status/status.h"
#include "lane/v1/lane_service.pb.h"
#include "metrics.h"
#include "resume_seal.h"
#include "session.h"
#include "session_registry.h"

namespace lane::server {

// What a stream's first request's resume fields did: the status for its
// resume_status, and the outcome the metrics count.
struct ResumeResult {
  absl::Status status;
  Metrics::Resume outcome = Metrics::Resume::kKept;
};

// A tracked stream's first request asks to resume (resume_state,
// min_lane_id). The state is opened with `seal` (its tag before anything
// else), then must name this session's camera, config fingerprint and
// epoch (or an epoch this fresh session may continue: not one that
// `sessions` retired). Taken, the session's tracker is restored from it (or
// kept, when it already continues it); refused, the tracker starts afresh
// and the status names what was wrong. Either way new ids start at
// min_lane_id. Before the frame is measured.
ResumeResult ResumeTracking(const v1::FrameRequest& request, Session& session,
                            const ResumeStateSeal& seal, const SessionRegistry& sessions);

// The session tracker's state after the last committed frame, sealed for
// the session (FrameResponse.resume_state); empty if it would exceed
// wire::kMaxResumeStateBytes, which kMaxTracks rules out.
std::string SealedResumeState(Session& session, const ResumeStateSeal& seal);

}  // namespace lane::server

#endif  // LANE_SERVER_STREAM_RESUME_H_
