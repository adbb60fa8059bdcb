// An evaluation repeated over several RANSAC seeds: the mean and spread of
// every figure. At 40 RANSAC iterations the seed alone moves a clip's CULane
// F1 by a few hundredths, so config comparisons quote the spread too.
#ifndef LANE_EVAL_SEEDS_H_
#define LANE_EVAL_SEEDS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "lane/eval/evaluate.h"

namespace lane::eval {

// Mean, sample standard deviation (n - 1; 0 for one value), minimum and
// maximum of the defined (non-NaN) values; all NaN when none is defined.
struct Spread {
  double mean = 0, std = 0, min = 0, max = 0;
  int n = 0;  // defined values
  static Spread Of(const std::vector<double>& values);
};

// One clip's (or the total's) figures over the seeds.
struct ClipSpread {
  std::string clip;
  Spread detected;             // paper "#detected"
  Spread correct_rate;         // fractions
  Spread false_positive_rate;  // per label
  Spread fp_per_frame;
  Spread paper_precision;
  Spread paper_f1;
  Spread culane_precision;
  Spread culane_recall;
  Spread culane_f1;
};

struct SeedSummary {
  std::vector<uint64_t> seeds;
  std::vector<ClipSpread> clips;  // in data set order
  ClipSpread total;
};

// `reports[i]` is the evaluation with `seeds[i]`; all of the same data set.
SeedSummary SummariseSeeds(const std::vector<EvalReport>& reports,
                           const std::vector<uint64_t>& seeds);

}  // namespace lane::eval

#endif  // LANE_EVAL_SEEDS_H_
