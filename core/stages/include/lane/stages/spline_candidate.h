// Stage 6's output: a lane candidate, its RANSAC line and spline in the top
// view, and (after stage 7) its spline in the image.
#ifndef LANE_STAGES_SPLINE_CANDIDATE_H_
#define LANE_STAGES_SPLINE_CANDIDATE_H_

#include "lane/geometry/bezier.h"
#include "lane/stages/line_fit.h"

namespace lane {

// A lane candidate through stages 6 to 8.
struct SplineCandidate {
  IpmLine line;  // the RANSAC line it was fitted around: the shape checks' fallback
  Bezier ipm;    // top view, P0 the farther end
  Bezier image;  // image, set by post-processing, P0 the upper end
  double score = 0;
};

}  // namespace lane

#endif  // LANE_STAGES_SPLINE_CANDIDATE_H_
