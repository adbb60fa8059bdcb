// `lane eval --drive`: a rendered drive (`lane render --sequence`) scored as
// one camera's sequence with the tracking figures of docs/tracking.md.
#ifndef LANE_TOOLS_EVAL_DRIVE_H_
#define LANE_TOOLS_EVAL_DRIVE_H_

#include <cstdint>
#include <optional>
#include <string>

#include "lane/eval/paper_rule.h"

namespace lane::cli {

struct DriveEvalArgs {
  std::string dataset;                 // the folder lane render --sequence wrote
  std::optional<std::string> config;   // run the detector, untracked and tracked
  std::optional<std::string> mode;     // --mode
  std::optional<uint64_t> seed;        // --seed
  std::optional<std::string> results;  // or score this lane detect results file
  lane::eval::PaperRuleOptions rule;
};

// Prints the Markdown report on stdout; returns the exit status.
int RunDriveEval(const DriveEvalArgs& args);

}  // namespace lane::cli

#endif  // LANE_TOOLS_EVAL_DRIVE_H_
