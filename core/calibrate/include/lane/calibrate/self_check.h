// The check a camera estimate must pass before it is written or adopted
// (`lane calibrate`, auto-calibrating sessions; docs/calibration.md,
// "The self-check").
//
// Lanes found with a correct camera are, on the ground, near-parallel,
// near-straight-ahead on average (the car follows the road) and a lane
// width apart. A wrong camera breaks this, in a way that names the error:
//   * a yaw error turns every lane by the same angle: the frames' median
//     heading is off zero;
//   * a pitch error fans the lanes out (or in) with their lateral distance:
//     neighbouring lanes diverge, with a sign that follows the error;
//   * a gross error (a top view across the verge) finds no pair of lanes a
//     lane width apart.
// The check reads only the lanes' chords on the ground, so it serves both
// the detector's output (Lane::ground) and image lanes mapped through a
// candidate camera (an auto-calibrating session's recent frames).
#ifndef LANE_CALIBRATE_SELF_CHECK_H_
#define LANE_CALIBRATE_SELF_CHECK_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace lane {

struct LaneGeometryCheckOptions {
  // A pair of neighbouring lanes this far apart (metres, across the lanes)
  // is a lane; the default range covers the world's lane widths.
  double min_lane_width_m = 2.5;
  double max_lane_width_m = 4.5;
  // Over the frames with a lane pair: the median of the pair's mean
  // heading (from straight ahead) and the median of their signed
  // divergence must stay within these (degrees).
  double max_heading_deg = 1.0;
  double max_divergence_deg = 1.0;
  // At least this share of the checked frames, and at least min_frames
  // frames, must show a lane pair. A third: in dense traffic the detector
  // sees both boundaries of a lane in about half the frames (9 of 15 on
  // culane-driver161-a), while a top view across the verge shows none.
  double min_pair_fraction = 1.0 / 3.0;
  int min_frames = 3;
};

// A lane on the ground, from its nearest to its farthest point (metres:
// x lateral, right +; y ahead).
struct GroundChord {
  Eigen::Vector2d near = Eigen::Vector2d::Zero();
  Eigen::Vector2d far = Eigen::Vector2d::Zero();
};

struct LaneGeometryReport {
  int frames = 0;             // frames checked
  int frames_with_pair = 0;   // frames with neighbouring lanes a lane width apart
  double heading_deg = 0;     // median over those frames of the pair's mean heading
  double divergence_deg = 0;  // median of the pair's heading difference (right - left)
  double width_m = 0;         // median of the pair's width
  // OK, or FAILED_PRECONDITION saying what failed and what to try.
  absl::Status verdict;
};

class LaneGeometryCheck {
 public:
  explicit LaneGeometryCheck(LaneGeometryCheckOptions options = {}) : options_(options) {}

  // One frame's lanes. Of its neighbouring pairs a lane width apart, the
  // one nearest the camera counts.
  void AddFrame(const std::vector<GroundChord>& lanes);
  LaneGeometryReport Report() const;
  const LaneGeometryCheckOptions& options() const { return options_; }

 private:
  LaneGeometryCheckOptions options_;
  int frames_ = 0;
  std::vector<double> heading_deg_, divergence_deg_, width_m_;
};

}  // namespace lane

#endif  // LANE_CALIBRATE_SELF_CHECK_H_
