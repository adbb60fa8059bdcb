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

#include <string>

#include "absl/status/statusor.h"
#include "lane/eval/evaluate.h"

namespace lane::eval {

std::string ReportMarkdown(const EvalReport& report);

// {"schema":1,"dataset":...,"format":...,"mode":...,"source":...,
//  "paper_rule":{...options},"culane_metric":{...options},
//  "clips":[{"clip":...,"frames":...,"paper":{...},"culane":{...}}],"total":{...},
//  "warnings":[...]}; undefined rates are null. Indented, ending in a newline.
std::string ReportJson(const EvalReport& report);

// The regression baseline: data set name, mode, frame count and the total
// CULane and paper-rule figures, with `command` (how to regenerate it)
// recorded in the file.
std::string BaselineJson(const EvalReport& report, const std::string& command);

struct Baseline {
  std::string dataset;
  std::string mode;
  int frames = 0;
  double culane_f1 = 0;
};
// Reads what BaselineJson wrote. INVALID_ARGUMENT naming the file when a
// key is missing.
absl::StatusOr<Baseline> ReadBaseline(const std::string& path);

}  // namespace lane::eval

#endif  // LANE_EVAL_REPORT_H_
