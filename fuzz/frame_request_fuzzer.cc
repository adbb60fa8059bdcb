// Arbitrary bytes as a serialized lane.v1.FrameRequest, through the server's
// frame path: the inline session_config conversion, then ProcessFrame
// (decode, size checks, detection, response) against a real session.
#include <prometheus/registry.h>

#include <cstddef>
#include <cstdint>
#include <utility>

#include "frame_processor.h"
#include "fuzz_common.h"
#include "metrics.h"
#include "session_proto.h"
#include "wire/config_proto.h"
#include "wire/detection_proto.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto session = lane::fuzz::SyntheticSession();
  static prometheus::Registry* registry = new prometheus::Registry();
  static lane::server::Metrics* metrics =
      new lane::server::Metrics(*registry, lane::server::BuildInfo());
  lane::v1::FrameRequest request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  if (request.has_session_config()) {
    (void)lane::server::SessionSpecFromProto(request.session_config());
  }
  const lane::server::Arrival arrival = lane::server::Arrival::Now();
  lane::server::ProcessedFrame processed = lane::server::ProcessFrame(
      request, *session, lane::server::FrameLimits{int64_t{1920} * 1080, absl::Milliseconds(500)},
      arrival, *metrics);
  (void)lane::server::FinishFrame(
      *session, /*tracked=*/false,
      lane::server::StartResponse(request, request.camera_id(), arrival),
      std::move(processed.outcome));
  return 0;
}
