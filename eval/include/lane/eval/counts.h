// Tallies of matched and unmatched lanes, and the rates derived from them.
// Rates with a zero denominator are NaN (printed "n/a", null in JSON).
#ifndef LANE_EVAL_COUNTS_H_
#define LANE_EVAL_COUNTS_H_

#include <string>

#include "lane/eval/matching.h"

namespace lane::eval {

// The paper's Tables II/III, plus precision, recall and F1.
struct PaperCounts {
  int labels = 0;           // "#total": labelled boundaries scored
  int detections = 0;       // "#detected"
  int correct = 0;          // labels matched by a detection
  int true_positives = 0;   // detections that matched a label (= correct, one-to-one)
  int false_positives = 0;  // detections that matched no label

  void Add(const Matching& m);
  PaperCounts& operator+=(const PaperCounts& o);

  double CorrectRate() const;        // correct / labels
  double FalsePositiveRate() const;  // false_positives / labels (the paper's definition)
  double FalsePositivesPerFrame(int frames) const;
  double Precision() const;  // true_positives / detections
  double Recall() const;     // correct / labels
  double F1() const;
};

// The CULane metric's tallies.
struct CulaneCounts {
  int labels = 0;
  int detections = 0;
  int true_positives = 0;  // matched pairs (IoU >= threshold, one-to-one)

  void Add(const Matching& m);
  CulaneCounts& operator+=(const CulaneCounts& o);

  int FalsePositives() const { return detections - true_positives; }
  int FalseNegatives() const { return labels - true_positives; }
  double Precision() const;
  double Recall() const;
  double F1() const;
};

// One clip's row of the tables (or the total).
struct ClipCounts {
  std::string clip;
  int frames = 0;             // frames scored (labelled ones)
  int unlabelled_frames = 0;  // run but not scored: no label entry
  int failed_frames = 0;      // could not be read or detected: scored as no detections
  int missing_results = 0;    // results file had no record: scored as no detections
  PaperCounts paper;
  CulaneCounts culane;

  ClipCounts& operator+=(const ClipCounts& o);
};

// 2 p r / (p + r). 0 when exactly one of them is NaN (no detections, or no
// labels, while the other side has some); NaN when both are.
double F1Score(double precision, double recall);

}  // namespace lane::eval

#endif  // LANE_EVAL_COUNTS_H_
