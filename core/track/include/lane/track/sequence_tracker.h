// Everything video-aware for one camera: the lane tracker, the ego lane and
// the predicted lanes, frame after frame (docs/tracking.md).
#ifndef LANE_TRACK_SEQUENCE_TRACKER_H_
#define LANE_TRACK_SEQUENCE_TRACKER_H_

#include <optional>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/geometry/camera.h"
#include "lane/geometry/ipm.h"
#include "lane/track/ego_lane.h"
#include "lane/track/lane_tracker.h"
#include "lane/track/marking.h"
#include "lane/track/tracked_frame.h"

namespace lane {

// Everything video-aware for one camera, frame after frame: Track gives each
// lane its track's id, confirmed flag and voted colour and type, adds the
// predicted lanes, and returns them with the ego lane, its lateral speed and
// departure flag.
class SequenceTracker {
 public:
  explicit SequenceTracker(const CameraModel& camera, LaneTrackingOptions lanes = {},
                           EgoOptions ego = {})
      : camera_(camera), lanes_(lanes), ego_options_(ego), ego_(ego) {}

  // What Track reports of one frame.
  struct Frame {
    std::vector<TrackedLane> lanes;  // left to right (with a top view; else in `lanes`' order)
    std::optional<EgoLane> ego;
  };

  // One frame, in order: its lanes and their markings in this frame (one a
  // lane, or empty: unknown; MarkingColorOf, MarkingTypeOf), at `time_s`
  // (LaneTracker::Update). With `ipm` (the detector's top view), confirmed
  // tracks missed for up to coast_frames frames are added from their
  // prediction (TrackedLane::predicted), confirmed lanes of the frame are
  // drawn from their filtered curves (LaneTrackingOptions::report_filtered),
  // and the lanes are sorted left to right.
  Frame Track(const std::vector<Lane>& lanes, const std::vector<Marking>& markings,
              std::optional<double> time_s, const IpmMapping* ipm = nullptr);
  void Reset();
  const LaneTracker& lane_tracker() const { return lanes_; }
  // The lane tracker's resume state (LaneTracker::Snapshot, Restore,
  // ReserveIdsBelow); a restore restarts the ego lane's rate.
  TrackerState Snapshot() const { return lanes_.Snapshot(); }
  void Restore(const TrackerState& state) { lanes_.Restore(state); }
  void ReserveIdsBelow(int id) { lanes_.ReserveIdsBelow(id); }

  // What the tracker expects in the next frame, for the detector
  // (Detector::Detect's prior): each confirmed track's line in the top view
  // `ipm`, through its curve over the part of its extent inside the view,
  // with a window of 0.3 m + 2.5 standard deviations of its predicted
  // lateral position (DetectorOptions cap it at the line window). Empty
  // before the first frame and after a reset.
  // Each window also carries its track's curve, and may be refitted
  // (DetectionPrior) when its track is reported and was seen in the last
  // frame; the caller decides whether refits are allowed (`refit`).
  DetectionPrior Prior(const IpmMapping& ipm) const;

 private:
  // A lane of the frame being tracked and its track's identity (id -1:
  // none).
  struct Entry {
    TrackedLane lane;
    LaneIdentity identity;
  };
  // Track's steps after the lane tracker's update, with a top view: the
  // confirmed lanes of the frame drawn from their filtered curves
  // (report_filtered), the confirmed tracks missed for up to coast_frames
  // frames added from their prediction, and all sorted left to right.
  std::vector<Entry> DrawFiltered(std::vector<Entry> entries, const IpmMapping& ipm) const;
  std::vector<Entry> WithCoasting(std::vector<Entry> entries, const IpmMapping& ipm) const;
  static std::vector<Entry> SortedLeftToRight(std::vector<Entry> entries);
  // The ego lane of the confirmed lanes, followed over frames.
  std::optional<EgoLane> EgoOfConfirmed(const std::vector<Entry>& entries);

  CameraModel camera_;
  LaneTracker lanes_;
  EgoOptions ego_options_;
  EgoTracker ego_;
  int resets_seen_ = 0;
};

}  // namespace lane

#endif  // LANE_TRACK_SEQUENCE_TRACKER_H_
