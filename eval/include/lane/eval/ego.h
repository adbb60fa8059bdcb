// The ego lane's two labelled boundaries, for scoring 2-lanes mode.
//
// Definition: at image row `row` (the bottom of the detector's ROI), every
// label's x is taken where it crosses the row (lane::eval::XAtRow: extended
// along its end when it stops short of the row). The ego lane's left
// boundary is the label with the largest x < centre_x, its right boundary
// the label with the smallest x >= centre_x, where centre_x is the image
// centre column (width / 2). Either may be missing.
#ifndef LANE_EVAL_EGO_H_
#define LANE_EVAL_EGO_H_

#include <vector>

#include "lane/eval/curve.h"

namespace lane::eval {

struct EgoBoundaries {
  int left = -1;   // index into the labels, or -1
  int right = -1;  // index into the labels, or -1
};

EgoBoundaries SelectEgoBoundaries(const std::vector<Curve>& labels, double centre_x, double row);

}  // namespace lane::eval

#endif  // LANE_EVAL_EGO_H_
