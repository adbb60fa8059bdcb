// A camera tracker's resume state on the wire (lane.v1.TrackerState, sent as
// bytes in FrameResponse.resume_state and FrameRequest.resume_state).
#ifndef LANE_WIRE_TRACKER_STATE_PROTO_H_
#define LANE_WIRE_TRACKER_STATE_PROTO_H_

#include <cstddef>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "lane/track/tracker_state.h"

namespace lane::wire {

// The largest encoded state accepted or sent, bytes.
inline constexpr size_t kMaxResumeStateBytes = 4096;

// `state` as the bytes of a lane.v1.TrackerState (floats: a lane's position
// to a micrometre, which the tracker's own noise dwarfs). A covariance that
// rounding to float left not quite positive definite gets its diagonal
// raised by a millionth of its trace.
std::string EncodeTrackerState(const lane::TrackerState& state);

// Bytes from a client back to a state: INVALID_ARGUMENT when they are
// longer than kMaxResumeStateBytes, do not parse, have repeated fields of
// the wrong length, or fail lane::ValidateTrackerState.
absl::StatusOr<lane::TrackerState> DecodeTrackerState(std::string_view bytes);

}  // namespace lane::wire

#endif  // LANE_WIRE_TRACKER_STATE_PROTO_H_
