// What tracking reports of a frame (docs/tracking.md): each lane with its
// track's identity, colour and type, the predicted lanes of confirmed
// tracks missed for a few frames, and the ego lane. The detection it wraps
// knows only what the detector found (lane/detector/detector.h).
#ifndef LANE_TRACK_TRACKED_FRAME_H_
#define LANE_TRACK_TRACKED_FRAME_H_

#include <optional>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/track/ego_lane.h"
#include "lane/track/marking.h"

namespace lane {

// One lane of a tracked frame.
struct TrackedLane {
  // Its curves and score, and whether it was inferred or refitted, as the
  // detector found it; a confirmed lane's curves are its track's filtered
  // curve (LaneTrackingOptions::report_filtered). A predicted lane's are
  // drawn from its track's prediction, with score 0.
  Lane lane;
  // The track's id: from 1, stable while the lane is tracked, never reused
  // within a tracker; -1 for a lane no tracker has seen.
  int id = -1;
  // Seen in confirm_frames frames (and parallel to the other confirmed lanes).
  bool confirmed = false;
  // Not detected in this frame: a confirmed track's prediction, reported for
  // a few frames after it was last seen (LaneTrackingOptions::coast_frames).
  bool predicted = false;
  // Voted over the track's frames (MarkingColorOf, MarkingTypeOf).
  MarkingColor color = MarkingColor::kUnknown;
  MarkingType type = MarkingType::kUnknown;
};

// One frame through the detector and the tracker (FrameTracker::Commit).
struct TrackedFrame {
  // The frame's detection as measured (FrameTracker::Measure): its lanes as
  // found in this frame, its timings and refit counts. What is reported is
  // `lanes`.
  Detection detection;
  // Sorted left to right: the detection's lanes with their identities, and
  // the predicted ones.
  std::vector<TrackedLane> lanes;
  // The ego lane of the confirmed lanes; none when it is not found.
  std::optional<EgoLane> ego;
};

// One frame measured for tracking (FrameTracker::Measure), not yet
// committed: the detection and each of its lanes' marking in this frame.
struct MeasuredFrame {
  Detection detection;
  std::vector<Marking> markings;  // one a lane of detection.lanes
};

}  // namespace lane

#endif  // LANE_TRACK_TRACKED_FRAME_H_
