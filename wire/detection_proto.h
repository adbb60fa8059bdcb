// A detection on the wire: lanes (image, IPM and ground control points,
// score) and the detector's stage timings into a lane.v1.FrameResponse.
#ifndef LANE_WIRE_DETECTION_PROTO_H_
#define LANE_WIRE_DETECTION_PROTO_H_

#include <optional>
#include <vector>

#include "lane/detector.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {

// Lanes with their id, confirmed flag and colour; the ego lane when set.
void LanesToProto(const lane::Detection& detection, v1::FrameResponse* out);
// The lanes of a response back (control points, score, id, confirmed,
// colour).
std::vector<lane::Lane> LanesFromProto(const v1::FrameResponse& response);
// The response's ego lane (none when it has none); ids 0 become -1.
std::optional<lane::EgoLane> EgoFromProto(const v1::FrameResponse& response);
// The detector's stage timings (milliseconds) into `out`: each stage's into
// the field `<name>_ms` (lane::DetectorStageName), the total into detect_ms.
void TimingsToProto(const lane::StageTimings& timings, v1::StageTimings* out);
// And back; a stage whose time is 0 did not run.
lane::StageTimings TimingsFromProto(const v1::StageTimings& timings);
// StageTimings' field of each detector stage, indexed as the stages; null
// where the proto lacks one (a test holds every stage to have one).
const std::vector<const google::protobuf::FieldDescriptor*>& StageTimingFields();

}  // namespace lane::wire

#endif  // LANE_WIRE_DETECTION_PROTO_H_
