// A road model in ground coordinates (metres): boundaries run parallel, a
// lane width apart. With it, a boundary that a vehicle hides is inferred
// from its neighbours (issue 34): two found boundaries that stay parallel
// about two lane widths apart, with nothing found between them, have a
// hidden boundary half-way. CULane labels such boundaries; users who want
// only what the frame shows drop lanes with `inferred` set.
//
// Only gaps are filled: a boundary beyond the outermost found one is never
// invented, since nothing in the frame bounds the road there.
#ifndef LANE_ROAD_MODEL_H_
#define LANE_ROAD_MODEL_H_

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "lane/geometry/bezier.h"

namespace lane {

struct RoadModelOptions {
  // Infer hidden boundaries (all-lanes mode only: 2-lanes reports the ego
  // lane's boundaries, which need a measured width on each side).
  // Off by default: on culane-driver161-a it finds the right boundary (paper
  // rule: 46.0 -> 48.9 % correct at the same FP rate, 5 seeds) but half-way
  // is not where that clip's lanes are (its lanes differ in width by up to
  // 0.6 m), so most inferred lanes miss CULane's 30 px IoU: CULane F1 0.489
  // -> 0.482 (docs/accuracy-log.md entry 41). A camera or session that wants
  // them switches them on.
  bool infer_hidden = false;
  // A plausible lane width, metres (urban lanes are 2.75-3.75 m; highway up
  // to 4.2 m with worn markings read at their inner edge).
  double min_lane_width_m = 2.6;
  double max_lane_width_m = 4.3;
  // When the frame shows a lane between two adjacent found boundaries, the
  // inferred lane's width must be within this fraction of the frame's median
  // width (a wide shoulder or a turn bay is not two lanes).
  double width_tolerance = 0.2;
  // The two neighbours must run parallel: along their common extent their
  // gap may vary by at most this, metres. The common extent must be at
  // least min_overlap_m long.
  double max_gap_change_m = 0.6;
  double min_overlap_m = 8.0;

  absl::Status Validate() const;
};

// A boundary's lateral position along the road: x(y) on the ground (x right,
// y ahead, metres), from its ground Bezier sampled and interpolated in y.
class LateralProfile {
 public:
  // None when the curve does not advance along the road (y not increasing
  // from one end to the other).
  static std::optional<LateralProfile> FromGround(const Bezier& ground, int samples = 41);

  double y_near() const { return y_.front(); }
  double y_far() const { return y_.back(); }
  // x at y, y clamped into [y_near, y_far].
  double XAt(double y) const;

 private:
  std::vector<double> y_;  // increasing
  std::vector<double> x_;
};

// A hidden boundary: its ground curve (far end first, like a lane's ground
// Bezier) and the two found boundaries it lies between (indices into the
// list given to InferHiddenBoundaries).
struct InferredBoundary {
  Bezier ground;
  int left = -1;
  int right = -1;
};

// `ground`: the found boundaries' ground Beziers, sorted left to right.
std::vector<InferredBoundary> InferHiddenBoundaries(const std::vector<Bezier>& ground,
                                                    const RoadModelOptions& options);

}  // namespace lane

#endif  // LANE_ROAD_MODEL_H_
