// The tables of an evaluation: Markdown for people, JSON for programs, and
// the regression baseline file.
//
// Markdown: a heading naming the data set, format, mode and source; then the
// paper's rule in the layout of its Tables II/III (Clip, #frames, #total,
// #detected, correct rate, false pos. rate, fp/frame) plus precision, recall
// and F1; then the CULane metric (Clip, #frames, #labels, #detected, TP, FP,
// FN, precision, recall, F1). One row per clip and a Total row.
#ifndef LANE_EVAL_REPORT_H_
#define LANE_EVAL_REPORT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lane/eval/evaluate.h"
#include "lane/eval/seeds.h"

namespace lane::eval {

// On a Caltech Lanes clip the paper's own row (Table III, or Table II in
// 2-lanes mode) is printed under ours. With `seeds` (an evaluation repeated
// over several RANSAC seeds, `report` being the first seed's), a section with
// the mean, standard deviation and range of every figure comes first.
std::string ReportMarkdown(const EvalReport& report, const SeedSummary* seeds = nullptr);

// {"schema":1,"dataset":...,"format":...,"mode":...,"source":...,
//  "paper_rule":{...options},"culane_metric":{...options},
//  "clips":[{"clip":...,"frames":...,"paper":{...},"culane":{...}}],"total":{...},
//  "warnings":[...]}; undefined rates are null. Indented, ending in a newline.
// With `seeds`, a "seeds" object is added: {"seeds":[...],"clips":[...],
// "total":{figure:{"mean","std","min","max"}}}.
std::string ReportJson(const EvalReport& report, const SeedSummary* seeds = nullptr);

// The regression baseline: data set name, mode, frame count and the total
// CULane and paper-rule figures, with `command` (how to regenerate it)
// recorded in the file.
// With `seeds`, the figures are the means over the seeds, and the seeds are
// recorded ("seeds": [...]) so the regression test can repeat them.
std::string BaselineJson(const EvalReport& report, const std::string& command,
                         const SeedSummary* seeds = nullptr);

struct Baseline {
  std::string dataset;
  std::string mode;
  int frames = 0;
  double culane_f1 = 0;
  // The paper rule's total correct and false-positive rates (fractions);
  // NaN when the file does not record them.
  double paper_correct_rate = 0;
  double paper_false_positive_rate = 0;
  std::vector<uint64_t> seeds;  // empty: the config's seed
};
// Reads what BaselineJson wrote. INVALID_ARGUMENT naming the file when a
// key is missing.
absl::StatusOr<Baseline> ReadBaseline(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_REPORT_H_
