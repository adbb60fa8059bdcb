// A detection on the wire: lanes (image, IPM and ground control points,
// score) and the detector's stage timings into a lane.v1.FrameResponse.
#ifndef LANE_WIRE_DETECTION_PROTO_H_
#define LANE_WIRE_DETECTION_PROTO_H_

#include "lane/detector.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {

void LanesToProto(const lane::Detection& detection, v1::FrameResponse* out);
// The detector's stage timings (milliseconds) into `out`.
void TimingsToProto(const lane::StageTimings& timings, v1::StageTimings* out);

}  // namespace lane::wire

#endif  // LANE_WIRE_DETECTION_PROTO_H_
