// One camera's frames through the detector and the tracker: the one place
// where a tracked frame goes prior -> detect with the prior -> read the
// markings -> track (docs/tracking.md). Every caller uses it: lane detect
// --track, the server's streams, the bench's in-process reference, the
// drive evaluation and the benchmarks.
//
// Two steps, so that frames can be detected concurrently and tracked in
// order:
//   Measure  on any thread: the detection, searched along the tracker's
//            predicted lanes, and each lane's colour and type;
//   Commit   in frame order: the tracker takes the measured lanes (ids,
//            confirmed flags, voted colours and types, predicted lanes of
//            confirmed tracks missed for a few frames, the ego lane).
// Process does both, for one thread.
#ifndef LANE_TRACK_FRAME_TRACKER_H_
#define LANE_TRACK_FRAME_TRACKER_H_

#include <opencv2/core.hpp>
#include <optional>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "lane/detector/detector.h"
#include "lane/geometry/camera.h"
#include "lane/track/sequence_tracker.h"
#include "lane/track/tracked_frame.h"
#include "lane/track/tracker_state.h"

namespace lane {

class FrameTracker {
 public:
  // `camera`: the camera whose ground the ego lane is measured on.
  explicit FrameTracker(const CameraModel& camera, LaneTrackingOptions lanes = {},
                        EgoOptions ego = {});

  // Step 1. Detects `frame` with `detector`, searching the tracker's
  // predicted lanes too (its state after the last committed frame: with k
  // frames in flight, up to k frames old; a prior only adds search windows,
  // which still need evidence in the frame), and reads each lane's colour
  // and type in the rows the detector read (Detector::Needs: a frame decoded
  // only there reads as a whole one). Safe to call from several threads at
  // once, and concurrently with Commit.
  absl::StatusOr<MeasuredFrame> Measure(const Detector& detector, const cv::Mat& frame) const;

  // The prior Measure would search now: the tracker's predicted lanes after
  // the last committed frame.
  DetectionPrior Prior(const Detector& detector) const;
  // Step 1 with a prior taken earlier (Prior): the lanes depend on the frame
  // and that prior only, not on when this runs. A batch that takes frame i's
  // prior right after committing frame i - k gets the same lanes whatever
  // its threads' timing (lane backfill).
  absl::StatusOr<MeasuredFrame> Measure(const Detector& detector, const cv::Mat& frame,
                                        const DetectionPrior& prior) const;

  // Step 2, in frame order: the tracker takes `measured` (from Measure) and
  // returns the tracked frame: its lanes with their ids, confirmed flags and
  // voted colours and types, the predicted lanes of confirmed tracks missed
  // for a few frames, drawn in `detector`'s top view, and the ego lane.
  // `time_s`: the frame's capture time, if it has one (else the previous
  // frame's + 1 / default_fps).
  TrackedFrame Commit(const Detector& detector, MeasuredFrame measured,
                      std::optional<double> time_s);

  // Measure, then Commit.
  absl::StatusOr<TrackedFrame> Process(const Detector& detector, const cv::Mat& frame,
                                       std::optional<double> time_s);

  // Forgets every track (a new clip).
  void Reset();

  // The resume state after the last committed frame (tracker_state.h),
  // for a stream to carry to whichever replica serves it next.
  TrackerState Save() const;
  // A stream resumes with `state`, a client's copy of an earlier Save
  // (here or on another replica):
  //  * a state this tracker wrote, not ahead of it (same lineage, at most
  //    as many frames): kept, this tracker already continues it (the
  //    stream came back to the same replica); returns false;
  //  * any other valid state: the tracker takes its tracks, ids and clock,
  //    and continues its lineage; returns true;
  //  * an invalid one (ValidateTrackerState): INVALID_ARGUMENT, and the
  //    tracker starts afresh (its tracks are dropped, its ids go on).
  absl::StatusOr<bool> Resume(const TrackerState& state);
  // New ids start at `id` or above: a client that lost its state but saw
  // ids up to id - 1 never gets one of them again for another lane.
  void ReserveIdsBelow(int id);

 private:
  mutable absl::Mutex mu_;
  SequenceTracker tracker_ ABSL_GUARDED_BY(mu_);
  // Which tracker this is, across replicas: drawn at random when it starts,
  // taken over from a restored state. `frames_`: frames committed in it.
  uint64_t lineage_ ABSL_GUARDED_BY(mu_);
  uint64_t frames_ ABSL_GUARDED_BY(mu_) = 0;
  // Frames committed in a row with refitted lanes (LaneTrackingOptions::
  // refit_frames); starts at the limit, so that the first frame after a
  // reset is searched in full. A resume takes the state's count (if it has
  // one), so that the schedule goes on as on the replica that wrote it.
  static constexpr int kSearchNext = 1 << 20;
  int refits_in_row_ ABSL_GUARDED_BY(mu_) = kSearchNext;
};

}  // namespace lane

#endif  // LANE_TRACK_FRAME_TRACKER_H_
