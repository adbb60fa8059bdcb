// Arbitrary bytes as a client's resume state (FrameRequest.resume_state):
// decoded and checked as the server does; a state that passes must be
// taken by a tracker, and the state that tracker writes back must decode and
// pass the checks too.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "lane/track/frame_tracker.h"
#include "wire/tracker_state_proto.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<lane::TrackerState> state = lane::wire::DecodeTrackerState(bytes);
  if (!state.ok()) return 0;
  lane::FrameTracker tracker{lane::CameraModel()};
  if (!tracker.Resume(*state).ok()) std::abort();  // decoded means valid
  lane::TrackerState saved = tracker.Save();
  if (!lane::wire::DecodeTrackerState(lane::wire::EncodeTrackerState(saved)).ok()) std::abort();
  return 0;
}
