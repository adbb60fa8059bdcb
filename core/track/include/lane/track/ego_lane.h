// The ego lane: the two boundaries either side of the camera, its width,
// the car's offset and heading in it, and lane departure over frames.
#ifndef LANE_TRACK_EGO_LANE_H_
#define LANE_TRACK_EGO_LANE_H_

#include <Eigen/Core>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "lane/detector/detector.h"
#include "lane/geometry/camera.h"
#include "lane/track/ground_curve.h"

namespace lane {

// The ego lane: the nearest boundary on each side of the camera.
struct EgoLane {
  double offset_m = 0;  // camera from the lane centre, positive to the right
  double width_m = 0;
  double heading_deg = 0;      // lane direction from the optical axis on the ground, right +
  double curvature_per_m = 0;  // positive when the lane bends right
  int left_index = -1;         // into the frame's lanes
  int right_index = -1;
  int left_id = -1;  // tracking ids, -1 without tracking
  int right_id = -1;
  double left_distance_m = 0;  // camera to each boundary, laterally
  double right_distance_m = 0;
  // Lateral speed of the camera in the lane (m/s, right +), from tracking;
  // 0 without.
  double offset_rate_mps = 0;
  // Time to line crossing below departure_tlc_s while moving towards that
  // line faster than departure_min_rate_mps.
  bool departing = false;
};

struct EgoOptions {
  double min_width_m = 2.2;
  double max_width_m = 5.0;
  double departure_tlc_s = 1.0;
  double departure_min_rate_mps = 0.3;
  // The lateral speed is the slope of the offset over this window (at
  // least 4 frames spanning 0.2 s).
  double rate_window_s = 0.7;
};

// The ego lane of one frame's lanes (none when no pair of boundaries one on
// each side lies a plausible lane width apart), without ids. `camera` gives
// the optical axis (yaw).
std::optional<EgoLane> ComputeEgoLane(const std::vector<Lane>& lanes, const CameraModel& camera,
                                      const EgoOptions& options = {});
// The same from ground curves (one per lane, none for a lane that has
// none); `ids` (may be empty) fill left_id and right_id. With
// `covariances` (one per curve, a tracker's), the lanes are taken to be
// parallel: their heading and curvature are combined, each weighted by
// what it knows (the inverse of its covariance), and each lane's offset is
// then conditioned on the shared values, so that a long solid line steadies
// the dashed line beside it.
std::optional<EgoLane> EgoLaneOfCurves(const std::vector<std::optional<GroundCurve>>& curves,
                                       const std::vector<int>& ids, const CameraModel& camera,
                                       const EgoOptions& options = {},
                                       const std::vector<Eigen::Matrix3d>* covariances = nullptr);

// Follows the ego lane over frames for its lateral speed and departure
// warnings; a change of bounding lanes (a lane change) restarts the rate.
class EgoTracker {
 public:
  explicit EgoTracker(EgoOptions options = {}) : options_(options) {}
  // `ego` (from EgoLaneOfCurves, with ids) at `time_s`, with its
  // offset_rate_mps and departing set; none when `ego` is none.
  std::optional<EgoLane> Update(std::optional<EgoLane> ego, double time_s);
  void Reset();

 private:
  EgoOptions options_;
  std::deque<std::pair<double, double>> history_;  // (time, offset) in the window
  int left_id_ = -1, right_id_ = -1;
};

}  // namespace lane

#endif  // LANE_TRACK_EGO_LANE_H_
