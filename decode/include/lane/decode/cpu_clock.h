// The CPU time of the calling thread (CLOCK_THREAD_CPUTIME_ID): what a
// decode's work budget is measured in. Unlike the wall clock, it does not
// advance while the thread waits to be scheduled, so a busy machine or an
// overloaded server does not make a frame look expensive.
#ifndef LANE_DECODE_CPU_CLOCK_H_
#define LANE_DECODE_CPU_CLOCK_H_

#include <chrono>

namespace lane::decode {

// A std::chrono clock over the calling thread's CPU time. Time points of
// different threads are not comparable.
struct ThreadCpuClock {
  using duration = std::chrono::nanoseconds;
  using rep = duration::rep;
  using period = duration::period;
  using time_point = std::chrono::time_point<ThreadCpuClock>;
  static constexpr bool is_steady = true;  // per thread, it never goes back
  static time_point now() noexcept;
};

}  // namespace lane::decode

#endif  // LANE_DECODE_CPU_CLOCK_H_
