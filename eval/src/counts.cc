#include "lane/eval/counts.h"

#include <cmath>
#include <limits>

namespace lane::eval {
namespace {

double Ratio(double num, double den) {
  return den > 0 ? num / den : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

double F1Score(double precision, double recall) {
  // Undefined precision means no detections, undefined recall no labels:
  // with the other side non-empty, nothing was found correctly.
  if (std::isnan(precision) && std::isnan(recall)) return std::numeric_limits<double>::quiet_NaN();
  if (std::isnan(precision) || std::isnan(recall)) return 0.0;
  return precision + recall > 0 ? 2 * precision * recall / (precision + recall) : 0.0;
}

void PaperCounts::Add(const Matching& m) {
  labels += static_cast<int>(m.label_detection.size());
  detections += static_cast<int>(m.detection_label.size());
  correct += m.MatchedLabels();
  true_positives += m.MatchedDetections();
  false_positives += m.FalsePositives();
}

PaperCounts& PaperCounts::operator+=(const PaperCounts& o) {
  labels += o.labels;
  detections += o.detections;
  correct += o.correct;
  true_positives += o.true_positives;
  false_positives += o.false_positives;
  return *this;
}

double PaperCounts::CorrectRate() const { return Ratio(correct, labels); }
double PaperCounts::FalsePositiveRate() const { return Ratio(false_positives, labels); }
double PaperCounts::FalsePositivesPerFrame(int frames) const {
  return Ratio(false_positives, frames);
}
double PaperCounts::Precision() const { return Ratio(true_positives, detections); }
double PaperCounts::Recall() const { return Ratio(correct, labels); }
double PaperCounts::F1() const { return F1Score(Precision(), Recall()); }

void CulaneCounts::Add(const Matching& m) {
  labels += static_cast<int>(m.label_detection.size());
  detections += static_cast<int>(m.detection_label.size());
  true_positives += m.MatchedDetections();
}

CulaneCounts& CulaneCounts::operator+=(const CulaneCounts& o) {
  labels += o.labels;
  detections += o.detections;
  true_positives += o.true_positives;
  return *this;
}

double CulaneCounts::Precision() const { return Ratio(true_positives, detections); }
double CulaneCounts::Recall() const { return Ratio(true_positives, labels); }
double CulaneCounts::F1() const { return F1Score(Precision(), Recall()); }

ClipCounts& ClipCounts::operator+=(const ClipCounts& o) {
  frames += o.frames;
  unlabelled_frames += o.unlabelled_frames;
  failed_frames += o.failed_frames;
  missing_results += o.missing_results;
  paper += o.paper;
  culane += o.culane;
  return *this;
}

}  // namespace lane::eval
