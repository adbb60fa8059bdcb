// The lane tracker: stable ids for one camera's lanes over frames
// (docs/tracking.md).
//
// Each lane is held on the ground as x(y) = offset + heading y +
// curvature y^2 / 2 (metres; x right, y ahead) with its extent in y. Each
// frame the tracker predicts (a random walk whose noise grows with the
// time since the last frame), associates the frame's lanes one to one with
// the tracks by the mean lateral distance over their common extent (best
// pairs first, within a gate), and updates the matched tracks with a Kalman
// filter (Eigen). A track is confirmed once it has been seen in
// confirm_frames frames and ends after max_misses frames without a match.
// Ids are never reused within a tracker. A gap longer than max_gap_s, or
// time going backwards (a new clip), resets it.
#ifndef LANE_TRACK_LANE_TRACKER_H_
#define LANE_TRACK_LANE_TRACKER_H_

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/track/ground_curve.h"
#include "lane/track/marking.h"
#include "lane/track/tracker_state.h"

namespace lane {

struct LaneTrackingOptions {
  // Confirmed after being seen in this many frames (k); ended after this
  // many frames in a row without a match (m).
  int confirm_frames = 3;
  int max_misses = 5;
  // Association gate: mean lateral distance over the common extent, metres
  // (a third of a narrow lane: neighbours never match each other).
  double gate_m = 0.9;
  // A longer gap between frames, or time going backwards, resets.
  double max_gap_s = 1.0;
  // Frame interval when frames carry no time (the camera's rate).
  double default_fps = 30.0;
  // Process noise (standard deviation per sqrt(second)) of the random walk
  // of offset (m), heading (rad) and curvature (1/m): a car weaving in its
  // lane, steering, entering a bend. The heading's 0.02 rad (1.1 degrees)
  // per sqrt(s) was the best of 0.01-0.03 for the ego heading on the
  // rendered drives (seeds 1-4 and 7) with the robust update; cordova1's
  // tracked figures did not move.
  double offset_noise = 0.3;
  double heading_noise = 0.02;
  double curvature_noise = 0.001;
  // Measurement noise: a detected lane's lateral position (m) at each of
  // the points it is measured at (6 over its extent), growing with the
  // distance y ahead (a pixel covers more road farther away):
  // measured_x_sd + measured_x_sd_per_m * y.
  double measured_x_sd = 0.04;
  double measured_x_sd_per_m = 0.005;
  // Detections' lateral errors have heavy tails (on the rendered drive the
  // robust spread is 0.03 m at every distance, the RMS 0.1-0.25 m: a spline
  // that runs off at its far end). The update is robust: a point whose
  // innovation exceeds huber_k standard deviations counts with its
  // variance scaled by |innovation| / (huber_k sd), Huber's clipped
  // influence (1.345: 95 % efficiency under Gaussian noise). 0: plain
  // Kalman.
  double huber_k = 1.345;
  // A new track's prior (standard deviations around the first lane's fit,
  // and a straight road): the first measurement then sets what it shows.
  double prior_offset_sd = 1.0;
  double prior_heading_sd = 0.1;
  double prior_curvature_sd = 0.004;
  // Two tracks closer than this (mean lateral distance, m) are one
  // boundary's: the one seen less often ends.
  double duplicate_m = 0.45;
  // Type votes fade with this time constant (s), so that a dashed line that
  // turns solid reads solid about this long after the change.
  double type_memory_s = 1.0;
  // A confirmed track missed for at most this many frames in a row is still
  // reported, from its prediction (TrackedLane::predicted), when SequenceTracker
  // is given the top view to draw it in.
  int coast_frames = 3;
  // A predicted lane (coast_frames) is not reported when a lane of the
  // frame lies closer than this (mean lateral distance, m: a third of a
  // narrow lane), the boundary found again by another track, unless that
  // lane lies farther than duplicate_m and its track was already there when
  // the predicted one was last seen: then it is another boundary (the
  // asphalt's edge 0.4-1 m outside a solid line) and must not hide the
  // line's prediction.
  double coast_clearance_m = 1.0;
  // A confirmed lane found this frame is reported as its track's filtered
  // curve (after this frame's update, over the track's extent), drawn like
  // a predicted lane, when SequenceTracker is given the top view: one
  // frame's skewed spline fit (a RANSAC draw across a dash and a stain)
  // then moves the lane by the Kalman gain's share, not all the way. false:
  // the detection's own spline, as untracked. Unconfirmed lanes are always
  // the detection's.
  bool report_filtered = true;
  // Lanes of one road are parallel: a track whose direction at the middle
  // of its extent differs from the median direction of the other confirmed
  // tracks (at the same distance ahead, at least two of them seen this
  // frame) by more than this is not reported as confirmed, nor predicted,
  // nor searched for: the verge or a curb seen at a slant, a car's side.
  // Degrees; 0 turns the check off.
  double parallel_max_deg = 4.0;
  // Tracked frames' shortcut (DetectionPrior::refit, docs/tracking.md): a
  // confirmed lane seen in the last frame is refitted in its window instead
  // of searched for, in at most this many frames in a row; then a frame is
  // searched in full, which also re-checks the lanes and renews their
  // extents. 0: every frame is searched.
  int refit_frames = 5;
};

struct Track {
  int id = 0;
  bool confirmed = false;
  int hits = 0;    // frames matched
  int misses = 0;  // frames in a row without a match
  // The tracker's frame count when the track started, and when it was
  // last matched.
  int64_t born_frame = 0;
  int64_t last_hit_frame = 0;
  GroundCurve curve;  // the filtered estimate
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  // Parallel to the other confirmed tracks (parallel_max_deg) this frame.
  bool parallel = true;
  // Reported as confirmed: seen in confirm_frames frames, and parallel.
  bool Reported() const { return confirmed && parallel; }
  // Colour votes over the frames (MarkingColorOf): white and yellow.
  double white_votes = 0;
  double yellow_votes = 0;
  // Type votes (MarkingTypeOf), indexed by MarkingType.
  std::array<double, 5> type_votes{};
};

// What the tracker says of one frame's lane.
struct LaneIdentity {
  int id = -1;
  bool confirmed = false;
  MarkingColor color = MarkingColor::kUnknown;  // voted over the track's frames
  // Voted too; dashed once 30 % of the (fading) solid/dashed votes say dashed (a
  // dash can fill the whole view for a frame, a gap never looks solid).
  MarkingType type = MarkingType::kUnknown;
  GroundCurve curve;  // the track's filtered curve after this frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // of curve.coefficients
};

class LaneTracker {
 public:
  explicit LaneTracker(LaneTrackingOptions options = {});

  // One frame, in order. `time_s`: the frame's time (capture time), or
  // none for the previous frame's time + 1 / default_fps. `colors`: each
  // lane's colour in this frame (MarkingColorOf), or empty. Returns each
  // lane's identity, in the order of `lanes`.
  std::vector<LaneIdentity> Update(const std::vector<Lane>& lanes, std::optional<double> time_s,
                                   const std::vector<MarkingColor>& colors = {},
                                   const std::vector<MarkingType>& types = {});
  void Reset();

  // The tracker's state for a resume (tracker_state.h): every track (the
  // kMaxTracks seen most often when there are more), the next id and the
  // clock. Lineage and frames are the caller's (FrameTracker).
  TrackerState Snapshot() const;
  // Takes `state`'s tracks, next id and clock. `state` must have passed
  // ValidateTrackerState. Counts as a reset (resets()), so that the ego
  // lane's rate starts over.
  void Restore(const TrackerState& state);
  // New ids start at `id` or above (ids a client saw from a state that was
  // lost). No effect when they already do.
  void ReserveIdsBelow(int id);

  const std::vector<Track>& tracks() const { return tracks_; }
  int next_id() const { return next_id_; }
  int resets() const { return resets_; }
  const LaneTrackingOptions& options() const { return options_; }
  // The time of the last frame, seconds.
  double time_s() const { return time_s_; }

 private:
  // One frame's lanes and what was read of them, as Update's steps see it.
  struct FrameLanes {
    const std::vector<Lane>& lanes;
    std::vector<std::optional<GroundCurve>> curves;  // FitGroundCurve of each
    const std::vector<MarkingColor>& colors;
    const std::vector<MarkingType>& types;
  };

  // Update's steps, in order.
  // The frame's time: a gap or time going backwards resets; returns the
  // interval since the last frame, s.
  double Advance(std::optional<double> time_s);
  // Every track's covariance grows by the random walk's noise over dt.
  void Predict(double dt);
  // For each lane, the index of the track it is matched to (one to one,
  // best pairs first, within the gate), or -1.
  std::vector<int> Associate(const FrameLanes& frame) const;
  // Track `track` takes lane j: a Kalman update and the lane's votes.
  void UpdateTrack(Track& track, const FrameLanes& frame, size_t j);
  // New tracks for the lanes no track took.
  void Spawn(const FrameLanes& frame, std::vector<int>& track_of);
  // Two tracks on one boundary: the one seen less often ends, passing a
  // lane it holds this frame to the other.
  void MergeDuplicates(const FrameLanes& frame, std::vector<int>& track_of);
  // Sets each track's `parallel` flag (parallel_max_deg).
  void MarkParallel();
  // Tracks missed max_misses frames in a row end.
  void Prune();

  LaneTrackingOptions options_;
  std::vector<Track> tracks_;
  int next_id_ = 1;
  bool started_ = false;
  double time_s_ = 0;
  int resets_ = 0;
  int64_t frame_ = 0;  // frames seen, for Track::born_frame
};

// The identity a track gives a lane it holds: its id, whether it is
// reported as confirmed, its voted colour and type, its filtered curve.
LaneIdentity IdentityOf(const Track& track);

}  // namespace lane

#endif  // LANE_TRACK_LANE_TRACKER_H_
