// The work budget of one decode, in CPU time of the decoding thread. Internal
// to lane_decode.
#ifndef LANE_DECODE_SRC_CPU_BUDGET_H_
#define LANE_DECODE_SRC_CPU_BUDGET_H_

#include <chrono>

#include "absl/time/time.h"
#include "lane/decode/cpu_clock.h"

namespace lane::decode::internal {

// Exceeded() once the calling thread has spent more than `budget` of CPU
// time since construction. The decoders call it often (every iMCU row, every
// PNG row and input slice), so it is cheap: a thread's CPU time never runs
// ahead of the wall clock, so the CPU clock (a system call) is read only
// once the wall time since the start, or since the last reading, could have
// held the rest of the budget. On an idle machine that is never for an honest
// frame; on a busy one, about once per budget of waiting.
class CpuBudget {
 public:
  // An infinite budget is never exceeded; a zero or negative one always is.
  explicit CpuBudget(absl::Duration budget);

  bool Exceeded();
  absl::Duration budget() const { return budget_; }

 private:
  absl::Duration budget_;
  bool infinite_;
  ThreadCpuClock::time_point cpu_start_;
  // Before this (monotonic) time the budget cannot have been spent.
  std::chrono::steady_clock::time_point next_check_;
};

}  // namespace lane::decode::internal

#endif  // LANE_DECODE_SRC_CPU_BUDGET_H_
