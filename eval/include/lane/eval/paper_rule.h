// The paper's rule for scoring detections against labels (Aly 2008,
// section III-A): sample both curves at 101 points, take nearest-point
// distances both ways, d^ = min of the two medians, d- = min of the two
// means, and declare a match when d^ <= 20 px AND d- <= 15 px at 640 px
// image width (thresholds scale with width / 640).
#ifndef LANE_EVAL_PAPER_RULE_H_
#define LANE_EVAL_PAPER_RULE_H_

#include <vector>

#include "absl/status/status.h"
#include "lane/eval/curve.h"
#include "lane/eval/matching.h"

namespace lane::eval {

struct PaperRuleOptions {
  // How the two tests combine. kAnd is the paper's text; kOr is what the
  // released Matlab scoring code does (a looser rule).
  enum class Rule { kAnd, kOr };
  // kOneToOne: a label is matched by at most one detection, best pairs
  // first; a second detection of a label is a false positive. kManyToOne: the
  // released code's counting, where any detection that matches some label is
  // correct, so duplicates of a label are not false positives.
  enum class Assignment { kOneToOne, kManyToOne };

  // t1: bound on d^ (min of the median distances), pixels at reference_width.
  double median_px = 20.0;
  // t2: bound on d- (min of the mean distances), pixels at reference_width.
  double mean_px = 15.0;
  // The paper's frames are 640 px wide; thresholds scale with width / this.
  double reference_width = 640.0;
  Rule rule = Rule::kAnd;
  Assignment assignment = Assignment::kOneToOne;
  // Points per curve (t = 0, 0.01, ..., 1).
  int samples = kPaperSamples;

  absl::Status Validate() const;
};

const char* RuleName(PaperRuleOptions::Rule rule);                    // "and", "or"
const char* AssignmentName(PaperRuleOptions::Assignment assignment);  // "one-to-one", ...

// True when d^ and d- (from lane::eval::CurveMatchDistances) pass the rule at this
// image width.
bool PassesPaperRule(double median, double mean, int image_width, const PaperRuleOptions& options);

// Matches detections to labels in one frame. One-to-one: every passing pair
// is ranked by d- (then d^), and pairs are taken best first while neither
// side is taken yet.
Matching MatchPaperRule(const std::vector<Curve>& detections, const std::vector<Curve>& labels,
                        int image_width, const PaperRuleOptions& options = {});

}  // namespace lane::eval

#endif  // LANE_EVAL_PAPER_RULE_H_
