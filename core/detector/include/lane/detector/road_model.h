// A road model in ground coordinates (metres): boundaries run parallel, a
// lane width apart. With it, a boundary that a vehicle hides is inferred
// from its neighbours (issue 34): two found boundaries that stay parallel
// about two lane widths apart, with nothing found between them, have a
// hidden boundary half-way. CULane labels such boundaries; users who want
// only what the frame shows drop lanes with `inferred` set.
//
// Only gaps are filled: a boundary beyond the outermost found one is never
// invented, since nothing in the frame bounds the road there.
#ifndef LANE_DETECTOR_ROAD_MODEL_H_
#define LANE_DETECTOR_ROAD_MODEL_H_

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
  // Search where the road model puts a boundary that the first pass did not
  // find: the line and spline RANSAC run again inside a window of
  // +- search_half_width_m around it, and what survives the post-processing
  // is reported as seen (not inferred). A faint or worn line between two
  // found ones is often below the frame's threshold only because the
  // Hough's column sums are dominated by the strong lines.
  bool search_hidden = true;
  // Search also one lane width outside the outermost boundaries found: an
  // unpainted road edge or a faint outer line. CULane labels road edges;
  // Caltech Lanes labels painted lines only, and on its urban streets this
  // search finds the curbs (configs/caltech.json turns it off as that
  // dataset's labelling convention).
  bool search_outer = true;
  double search_half_width_m = 0.6;
  // Inside a window, pixels above the window's own quantile of the filtered
  // response count, if they also reach this fraction of the frame's
  // threshold.
  double search_quantile = 0.9;
  double search_min_fraction = 0.3;
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
  // The part within y_min..y_max; none when it does not reach in.
  std::optional<LateralProfile> Clipped(double y_min, double y_max) const;
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

// Where a boundary beyond the outermost found ones would run: one lane
// width (the frame's, or the middle of the plausible range) outside the
// leftmost and the rightmost, as a place to search, not as a boundary.
std::vector<Bezier> OuterBoundaryGuesses(const std::vector<Bezier>& ground,
                                         const RoadModelOptions& options);

// A boundary found by searching the places above belongs to the road model
// when it runs parallel to a found boundary a plausible lane width away
// (the gap varies by at most max_gap_change_m over min_overlap_m or more)
// and is no closer than (1 - width_tolerance) lane widths to any other.
bool FitsRoadModel(const Bezier& lane, const std::vector<Bezier>& found, double y_min, double y_max,
                   const RoadModelOptions& options);

}  // namespace lane

#endif  // LANE_DETECTOR_ROAD_MODEL_H_
