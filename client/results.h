// `lane-client stream` results: JSON Lines, one object per frame, schema 1
// (docs/client.md): the record `lane detect` writes for the frame
// (io/results_json.h, from the response decoded by wire/detection_proto.h)
// and the client's own fields.
#ifndef LANE_CLIENT_RESULTS_H_
#define LANE_CLIENT_RESULTS_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "lane/detector/detector.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::client {

inline constexpr int kStreamResultsSchema = 1;

// What the records of a stream say of its session: the camera's frame size
// and the detector's mode (from its resolved config), and whether its
// streamed frames are tracked (TrackingOptions.disabled unset).
struct StreamSession {
  int width = 0;
  int height = 0;
  lane::Mode mode = lane::Mode::kAll;
  bool tracked = true;
};
// From the session as the server returned it (GetSession, CreateSession).
absl::StatusOr<StreamSession> StreamSessionOf(const lane::v1::Session& session);

// "OK", "INVALID_ARGUMENT", "DROPPED", "INTERNAL" (the FrameCode without its
// prefix), or "UNKNOWN_<n>".
std::string FrameCodeName(lane::v1::FrameCode code);

// One line (without the newline) for a frame the server answered: the
// record `lane detect` writes (with --track when `session` is tracked) for
// an OK frame, the lanes empty otherwise; its "timing_ms" also has the
// server's "queue_wait" and "detect" (= "total"); then the client's fields
// (docs/client.md). `latency_ms`: from the client's last send of the frame
// to its response; `attempts`: how many times it was sent; `connection`:
// which of the stream's calls answered it (1, 2, ...; 0 = not written).
std::string ResponseJsonLine(const std::string& frame_name, const lane::v1::FrameResponse& response,
                             const StreamSession& session, double latency_ms, int attempts,
                             uint64_t connection = 0);

// One line for a frame that could not be read here and was not sent:
// status "CLIENT_ERROR".
std::string ClientErrorJsonLine(const std::string& frame_name, const std::string& camera_id,
                                uint64_t frame_id, const std::string& error);

}  // namespace lane::client

#endif  // LANE_CLIENT_RESULTS_H_
