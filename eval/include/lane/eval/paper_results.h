// The paper's own results (Aly 2008, Tables II and III) for the four Caltech
// Lanes clips, printed beside ours when a Caltech clip is evaluated.
#ifndef LANE_EVAL_PAPER_RESULTS_H_
#define LANE_EVAL_PAPER_RESULTS_H_

#include <optional>
#include <string>

#include "lane/detector/detector.h"

namespace lane::eval {

struct PaperResult {
  std::string clip;         // "cordova1", "cordova2", "washington1", "washington2"
  int frames = 0;           // Table I
  int total = 0;            // "#total": labelled boundaries
  int detected = 0;         // "#detected" as printed (for clip 1 it equals the correct count)
  double correct_rate = 0;  // fraction, not percent
  double false_positive_rate = 0;  // per label, fraction
  double fp_per_frame = 0;
  // Derived from the printed rates: correct = correct_rate * total, false
  // positives = false_positive_rate * total, precision = correct / (correct +
  // false positives).
  double Precision() const;
  double F1() const;
};

// The row of Table III (mode kAll) or Table II (kTwo) for the clip whose
// name is, or ends in, one of the four clip names ("caltech-cordova1" ->
// cordova1). nullopt for any other name.
std::optional<PaperResult> PaperResultForClip(const std::string& clip_name, Mode mode);

}  // namespace lane::eval

#endif  // LANE_EVAL_PAPER_RESULTS_H_
