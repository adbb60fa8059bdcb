// Which detection of a frame matched which label, under one metric.
#ifndef LANE_EVAL_MATCHING_H_
#define LANE_EVAL_MATCHING_H_

#include <vector>

namespace lane::eval {

struct Matching {
  // Per detection: the label it matched, or -1 (a false positive).
  std::vector<int> detection_label;
  // Per label: the detection that matched it, or -1 (a miss). With
  // many-to-one counting several detections may name the same label; this
  // holds the best of them.
  std::vector<int> label_detection;

  int MatchedLabels() const;      // labels found (correct)
  int MatchedDetections() const;  // detections on some label (true positives)
  int FalsePositives() const;     // detections on no label
  int Misses() const;             // labels not found
};

}  // namespace lane::eval

#endif  // LANE_EVAL_MATCHING_H_
