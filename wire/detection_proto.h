// A detection on the wire, both ways: lanes (image, IPM and ground control
// points, score, inferred and refit; with tracking also id, confirmed,
// predicted, colour and type), the ego lane and the detector's stage
// timings, into and out of a lane.v1.FrameResponse. The one conversion
// between the two: the server encodes with it, lane-client and the live
// view decode with it.
#ifndef LANE_WIRE_DETECTION_PROTO_H_
#define LANE_WIRE_DETECTION_PROTO_H_

#include <optional>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/track/tracked_frame.h"
#include "lane/v1/lane_service.pb.h"

namespace lane::wire {

// A response holding only the lanes of an untracked frame: their curves,
// scores, inferred and refit flags (id 0, neither confirmed nor predicted,
// colour and type unknown). Merge it into the frame's response.
v1::FrameResponse LanesToProto(const lane::Detection& detection);
// A response holding only a tracked frame's lanes, with their ids, flags,
// colours and types, and its ego lane when it has one.
v1::FrameResponse LanesToProto(const lane::TrackedFrame& frame);

// The lanes of a response back, every field (an untracked response's have id
// -1, neither confirmed nor predicted, colour and type unknown).
std::vector<lane::TrackedLane> LanesFromProto(const v1::FrameResponse& response);
// The response's ego lane (none when it has none); ids 0 become -1, and its
// boundaries are found among the response's lanes by their ids (left_index,
// right_index; -1 when absent).
std::optional<lane::EgoLane> EgoFromProto(const v1::FrameResponse& response);
// A tracked frame's response back: its lanes, its ego lane, and the
// detection's timings and lanes (the response's lanes not predicted, as
// reported) with refit_lanes counted from them.
lane::TrackedFrame TrackedFrameFromProto(const v1::FrameResponse& response);
// An untracked frame's response back: its lanes and the stage timings.
lane::Detection DetectionFromProto(const v1::FrameResponse& response);

// The detector's stage timings (milliseconds): each stage's in the field
// `<name>_ms` (lane::DetectorStageName), the total in detect_ms; the others
// (queue_wait_ms, decode_ms) are the caller's.
v1::StageTimings TimingsToProto(const lane::StageTimings& timings);
// And back; a stage whose time is 0 did not run.
lane::StageTimings TimingsFromProto(const v1::StageTimings& timings);
// StageTimings' field of each detector stage, indexed as the stages; null
// where the proto lacks one (a test holds every stage to have one).
const std::vector<const google::protobuf::FieldDescriptor*>& StageTimingFields();

}  // namespace lane::wire

#endif  // LANE_WIRE_DETECTION_PROTO_H_
