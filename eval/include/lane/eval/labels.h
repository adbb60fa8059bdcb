// Hand-drawn (or synthetic) labels of one frame, whatever file they came from.
#ifndef LANE_EVAL_LABELS_H_
#define LANE_EVAL_LABELS_H_

#include <string>
#include <vector>

#include "lane/eval/curve.h"

namespace lane::eval {

struct LabelledBoundary {
  Curve curve;  // image pixels
  // Marking type when the label file gives one: a Caltech Lanes subtype
  // ("bw", "sw", "dy", "by", "sy") or "dashed white", "solid yellow", ...
  // for `lane render` labels. Empty otherwise. Informational only.
  std::string type;
};

struct LabelledFrame {
  // Name of the frame within its dataset: its path relative to the dataset
  // folder, with '/' separators ("cordova1/f00000.png", "00090.jpg").
  std::string name;
  // Where its image is read from.
  std::string image_path;
  // False when the frame is in the image list but has no label entry: it is
  // run (results keep their frame numbering) but not scored.
  bool labelled = true;
  std::vector<LabelledBoundary> boundaries;
  // Image size when the label file states it (`lane render` labels); 0 when
  // unknown.
  int width = 0;
  int height = 0;
};

}  // namespace lane::eval

#endif  // LANE_EVAL_LABELS_H_
