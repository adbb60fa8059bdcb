// Detections of one frame, read back from a results file.
#ifndef LANE_EVAL_RESULTS_H_
#define LANE_EVAL_RESULTS_H_

#include <string>
#include <vector>

#include "lane/eval/curve.h"

namespace lane::eval {

struct DetectedLane {
  Curve curve;  // image pixels; a Bezier for our results
  double score = 0;
};

struct FrameResult {
  // The frame's name as the file records it (JSON Lines: "frame"; the
  // original .txt format has only a number: "#N", 0-based).
  std::string frame;
  int index = -1;  // original .txt format: the frame number; -1 otherwise
  int width = 0;   // 0 when the file does not say
  int height = 0;
  std::string mode;  // "all", "two", or "" when the file does not say
  std::vector<DetectedLane> lanes;
  // Non-empty: the frame failed when the results were made (no lanes).
  std::string error;
};

}  // namespace lane::eval

#endif  // LANE_EVAL_RESULTS_H_
