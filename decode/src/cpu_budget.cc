#include "cpu_budget.h"

#include <time.h>

namespace lane::decode {

ThreadCpuClock::time_point ThreadCpuClock::now() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return time_point(std::chrono::seconds(ts.tv_sec) + std::chrono::nanoseconds(ts.tv_nsec));
}

namespace internal {

CpuBudget::CpuBudget(absl::Duration budget)
    : budget_(budget),
      infinite_(budget == absl::InfiniteDuration()),
      cpu_start_(infinite_ ? ThreadCpuClock::time_point() : ThreadCpuClock::now()),
      next_check_(std::chrono::steady_clock::now()) {
  if (!infinite_ && budget > absl::ZeroDuration()) next_check_ += absl::ToChronoNanoseconds(budget);
}

bool CpuBudget::Exceeded() {
  if (infinite_) return false;
  const std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now();
  if (now < next_check_) return false;
  const absl::Duration used = absl::FromChrono(ThreadCpuClock::now() - cpu_start_);
  if (used > budget_ || budget_ <= absl::ZeroDuration()) return true;
  // The thread cannot spend the rest in less wall time than that.
  next_check_ = now + absl::ToChronoNanoseconds(budget_ - used);
  return false;
}

}  // namespace internal
}  // namespace lane::decode
