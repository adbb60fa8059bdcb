// The decoders' work budget: CPU time of the decoding thread, which waiting
// does not spend (issue 40: a wall-clock deadline refused valid frames on a
// busy machine).
#include "cpu_budget.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "lane/decode/cpu_clock.h"

namespace lane::decode {
namespace {

using std::chrono::milliseconds;

// Spins until this thread has used `cpu` of CPU time (however long that
// takes on a loaded machine).
void Spin(ThreadCpuClock::duration cpu) {
  const ThreadCpuClock::time_point end = ThreadCpuClock::now() + cpu;
  volatile uint64_t x = 0;
  while (ThreadCpuClock::now() < end) x = x + 1;
}

TEST(ThreadCpuClockTest, SleepingDoesNotCountWorkingDoes) {
  ThreadCpuClock::time_point start = ThreadCpuClock::now();
  std::this_thread::sleep_for(milliseconds(300));
  EXPECT_LT(ThreadCpuClock::now() - start, milliseconds(100));

  start = ThreadCpuClock::now();
  Spin(milliseconds(30));
  EXPECT_GE(ThreadCpuClock::now() - start, milliseconds(30));
}

TEST(CpuBudgetTest, WaitingLongerThanTheBudgetDoesNotExceedIt) {
  internal::CpuBudget budget(absl::Milliseconds(50));
  EXPECT_FALSE(budget.Exceeded());
  std::this_thread::sleep_for(milliseconds(200));  // 4x the budget of wall time
  EXPECT_FALSE(budget.Exceeded());
  // Checked again after more waiting: the CPU clock is read again.
  std::this_thread::sleep_for(milliseconds(100));
  EXPECT_FALSE(budget.Exceeded());
  Spin(milliseconds(60));
  EXPECT_TRUE(budget.Exceeded());
  EXPECT_EQ(budget.budget(), absl::Milliseconds(50));
}

TEST(CpuBudgetTest, WorkBeyondTheBudgetExceedsIt) {
  internal::CpuBudget budget(absl::Milliseconds(20));
  Spin(milliseconds(10));
  EXPECT_FALSE(budget.Exceeded());
  Spin(milliseconds(15));
  EXPECT_TRUE(budget.Exceeded());
}

TEST(CpuBudgetTest, InfiniteIsNeverExceededNonPositiveAlwaysIs) {
  internal::CpuBudget infinite(absl::InfiniteDuration());
  Spin(milliseconds(5));
  EXPECT_FALSE(infinite.Exceeded());
  internal::CpuBudget zero(absl::ZeroDuration());
  EXPECT_TRUE(zero.Exceeded());
}

}  // namespace
}  // namespace lane::decode
