// What a lane's marking looks like: its paint colour and its pattern. Read
// from one frame (lane/track/marking_reader.h) and voted over a track's
// frames (lane/track/lane_tracker.h); the detector itself does not classify.
#ifndef LANE_TRACK_MARKING_H_
#define LANE_TRACK_MARKING_H_

namespace lane {

// A marking's paint colour (MarkingColorOf).
enum class MarkingColor { kUnknown, kWhite, kYellow };
const char* MarkingColorName(MarkingColor color);  // "unknown", "white", "yellow"

// A marking's pattern (MarkingTypeOf); kRoadEdge: a boundary without paint
// (a curb, the asphalt's edge). The order is the wire's (lane.v1.MarkingType).
enum class MarkingType { kUnknown, kSolid, kDashed, kDouble, kRoadEdge };
// "unknown", "solid", "dashed", "double", "road_edge"
const char* MarkingTypeName(MarkingType type);

// One lane's marking as read in one frame (ReadMarkings).
struct Marking {
  MarkingColor color = MarkingColor::kUnknown;
  MarkingType type = MarkingType::kUnknown;
};

}  // namespace lane

#endif  // LANE_TRACK_MARKING_H_
