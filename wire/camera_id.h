// What a camera id may be: the one rule the server enforces on every call
// (SessionRegistry::ValidateCameraId) and the clients check before they send
// one. A camera id names a session, goes into metrics labels and log lines,
// and travels in the `x-camera-id` header that a proxy hashes
// (deploy/nginx); an id the server would refuse, or a header a proxy would
// refuse (a 64 KiB one gets GOAWAY ENHANCE_YOUR_CALM from nginx, which a
// client sees as UNAVAILABLE), is better caught before anything is sent.
// The Python client has the same rule (lane_client.client.check_camera_id).
#ifndef LANE_WIRE_CAMERA_ID_H_
#define LANE_WIRE_CAMERA_ID_H_

#include <cstddef>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace lane::wire {

inline constexpr size_t kMaxCameraIdBytes = 128;

// OK or INVALID_ARGUMENT: 1 to kMaxCameraIdBytes characters of
// [A-Za-z0-9._:/-]. The message quotes a bad id only as a short excerpt.
absl::Status ValidateCameraId(absl::string_view camera_id);

}  // namespace lane::wire

#endif  // LANE_WIRE_CAMERA_ID_H_
