// Arbitrary bytes as a client's resume state (FrameRequest.resume_state),
// against a server holding a key (server/resume_seal.h):
//  * as sent: opened as the server opens it. Only a state sealed under the
//    key may open, so every input must be refused, by its tag or before;
//  * as the tracker state inside a state the key's holder sealed: it must
//    open to the same bytes, then is decoded and checked as the server does;
//    a state that passes must be taken by a tracker, and the state that
//    tracker writes back must seal, open, decode and pass the checks too.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "lane/track/frame_tracker.h"
#include "resume_seal.h"
#include "wire/tracker_state_proto.h"

namespace {

const lane::server::ResumeStateSeal& Seal() {
  static const lane::server::ResumeStateSeal seal{
      lane::server::ResumeStateKeys(std::string(lane::server::ResumeStateKeys::kMinKeyBytes, 'f'))};
  return seal;
}

const lane::server::ResumeBinding kBinding{"cam0", lane::server::ConfigFingerprint("{}"), 7};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (Seal().Open(bytes).ok()) std::abort();  // a forged tag

  absl::StatusOr<lane::server::OpenedResumeState> opened =
      Seal().Open(Seal().Seal(kBinding, bytes));
  if (!opened.ok() || opened->tracker_state != bytes) std::abort();
  absl::StatusOr<lane::TrackerState> state = lane::wire::DecodeTrackerState(opened->tracker_state);
  if (!state.ok()) return 0;
  lane::FrameTracker tracker{lane::CameraModel()};
  if (!tracker.Resume(*state).ok()) std::abort();  // decoded means valid
  const std::string again = Seal().Seal(kBinding, lane::wire::EncodeTrackerState(tracker.Save()));
  absl::StatusOr<lane::server::OpenedResumeState> reopened = Seal().Open(again);
  if (!reopened.ok() || !lane::wire::DecodeTrackerState(reopened->tracker_state).ok()) {
    std::abort();
  }
  return 0;
}
