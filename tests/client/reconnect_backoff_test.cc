// The reconnect policy that `stream` and `bench` share.
#include "reconnect_backoff.h"

#include <gtest/gtest.h>

#include <vector>

namespace lane::client {
namespace {

TEST(ReconnectBackoffTest, DoublesUpToTheMaximum) {
  ReconnectBackoff backoff({absl::Milliseconds(100), absl::Seconds(2), 0});
  std::vector<absl::Duration> waits;
  for (int i = 0; i < 8; ++i) waits.push_back(backoff.Next());
  const std::vector<absl::Duration> expected = {absl::Milliseconds(100),  absl::Milliseconds(200),
                                                absl::Milliseconds(400),  absl::Milliseconds(800),
                                                absl::Milliseconds(1600), absl::Seconds(2),
                                                absl::Seconds(2),         absl::Seconds(2)};
  EXPECT_EQ(waits, expected);
  EXPECT_EQ(backoff.failures(), 8);
}

TEST(ReconnectBackoffTest, ProgressStartsTheScheduleAgain) {
  ReconnectBackoff backoff({absl::Milliseconds(50), absl::Seconds(1), 0});
  backoff.Next();
  backoff.Next();
  EXPECT_EQ(backoff.Next(), absl::Milliseconds(200));
  backoff.Reset();
  EXPECT_EQ(backoff.failures(), 0);
  EXPECT_EQ(backoff.Next(), absl::Milliseconds(50));
  EXPECT_EQ(backoff.Next(), absl::Milliseconds(100));
}

TEST(ReconnectBackoffTest, JitterStaysWithinItsBoundsAndFollowsTheSeed) {
  const ReconnectSchedule schedule;  // the default: 100 ms to 2 s, +-20 %
  EXPECT_EQ(schedule.initial, absl::Milliseconds(100));
  EXPECT_EQ(schedule.max, absl::Seconds(2));
  EXPECT_DOUBLE_EQ(schedule.jitter, 0.2);
  ReconnectBackoff a(schedule, 7);
  ReconnectBackoff b(schedule, 7);
  absl::Duration nominal = schedule.initial;
  bool any_off_nominal = false;
  for (int i = 0; i < 200; ++i) {
    const absl::Duration wait = a.Next();
    EXPECT_EQ(wait, b.Next()) << "same seed, same waits";
    EXPECT_GE(wait, nominal * 0.8);
    EXPECT_LE(wait, nominal * 1.2);
    any_off_nominal = any_off_nominal || wait != nominal;
    nominal = std::min(nominal * 2, schedule.max);
  }
  EXPECT_TRUE(any_off_nominal);
}

}  // namespace
}  // namespace lane::client
