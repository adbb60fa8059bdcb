#include "lane/eval/matching.h"

#include <algorithm>

namespace lane::eval {

int Matching::MatchedLabels() const {
  return static_cast<int>(
      std::count_if(label_detection.begin(), label_detection.end(), [](int d) { return d >= 0; }));
}

int Matching::MatchedDetections() const {
  return static_cast<int>(
      std::count_if(detection_label.begin(), detection_label.end(), [](int l) { return l >= 0; }));
}

int Matching::FalsePositives() const {
  return static_cast<int>(detection_label.size()) - MatchedDetections();
}

int Matching::Misses() const { return static_cast<int>(label_detection.size()) - MatchedLabels(); }

}  // namespace lane::eval
