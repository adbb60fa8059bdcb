// A camera tracker's state as it travels with a stream: the resume state.
//
// A stream that reconnects, possibly to another replica, sends the latest
// state it was given, and the tracker there is restored from it. Ids then go
// on from where they were, and confirmed lanes stay confirmed
// (docs/deployment.md, "Tracking across reconnects"). The state comes back
// from a client, so it is untrusted: ValidateTrackerState checks every field
// before a tracker takes it.
//
// What it holds: each track's id, counters, filtered curve, covariance and
// colour and type votes, the next id, the tracker's clock, and a lineage (a
// random number drawn when a tracker starts) with its frame count. The ego
// lane's lateral-speed window is not in it: after a resume the ego lane is
// there at once (it comes from the confirmed lanes), and its lateral speed
// and departure flag come back after a few frames.
#ifndef LANE_TRACK_TRACKER_STATE_H_
#define LANE_TRACK_TRACKER_STATE_H_

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "lane/track/ground_curve.h"

namespace lane {

// One track (lane::Track) in a resume state. Frame counters are ages, so
// that a state says nothing of how long the stream has run.
struct TrackSnapshot {
  int id = 0;
  bool confirmed = false;
  int hits = 0;
  int misses = 0;
  int64_t age_frames = 0;        // frames since the track started
  int64_t since_hit_frames = 0;  // frames since it was last matched
  GroundCurve curve;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  double white_votes = 0;
  double yellow_votes = 0;
  std::array<double, 5> type_votes{};
};

struct TrackerState {
  // The format's version; a state of another version is refused.
  static constexpr uint32_t kVersion = 1;
  // Tracks in a state, at most: a frame shows 2-8 boundaries, and the
  // tracker also holds the ones it lost a few frames ago. With the
  // encoding's ~90 bytes a track, 32 tracks keep a state under 4 KiB.
  static constexpr size_t kMaxTracks = 32;
  // Ids stay below this: a stream at 30 frames per second that started a
  // new track every frame would need 400 days to reach it.
  static constexpr int kMaxId = 1 << 30;

  uint32_t version = kVersion;
  // The tracker this state continues, and the frames it had committed: a
  // replica that still runs that tracker, at least as far on, keeps it
  // (FrameTracker::Resume).
  uint64_t lineage = 0;
  uint64_t frames = 0;
  int next_id = 1;
  bool started = false;  // has seen a frame since its last reset
  double time_s = 0;     // the last frame's time
  std::vector<TrackSnapshot> tracks;
  // Frames committed in a row with refitted lanes (FrameTracker): the
  // tracker that takes the state searches in full when the one that wrote
  // it would have, so a stream handed to another replica sees the lanes it
  // would have seen on one. Unset (a state from before this field): the
  // next frame is searched in full.
  std::optional<int> refits_in_row;
};

// OK when `state` is one a tracker could have written: the version, the
// number of tracks, unique ids below next_id, counters within bounds, finite
// numbers of plausible size (curves within 1 km, a lane no steeper than 80
// degrees from the road's axis), extents in order, covariances symmetric
// positive definite. INVALID_ARGUMENT naming the first bad field otherwise.
absl::Status ValidateTrackerState(const TrackerState& state);

}  // namespace lane

#endif  // LANE_TRACK_TRACKER_STATE_H_
