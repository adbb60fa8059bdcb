// How long a stream engine waits before it reconnects after a failed call:
// one policy for `stream` (Streamer) and the cameras of `bench`.
//
// The first wait is `initial`; each further failure without progress doubles
// it, up to `max`; every wait is multiplied by a random factor in
// [1 - jitter, 1 + jitter], so cameras cut off together do not come back
// together. Once a call makes progress (a frame answered), the schedule
// starts again from `initial`.
#ifndef LANE_CLIENT_RECONNECT_BACKOFF_H_
#define LANE_CLIENT_RECONNECT_BACKOFF_H_

#include <cstdint>
#include <random>

#include "absl/time/time.h"

namespace lane_client {

struct ReconnectSchedule {
  absl::Duration initial = absl::Milliseconds(100);
  absl::Duration max = absl::Seconds(2);
  double jitter = 0.2;  // +-20 %; 0 for exact waits
};

class ReconnectBackoff {
 public:
  explicit ReconnectBackoff(ReconnectSchedule schedule = {},
                            uint64_t seed = std::random_device{}());

  // The wait before the next attempt; the nominal wait after it doubles (up
  // to `max`).
  absl::Duration Next();
  // A call made progress: the next wait is `initial` again.
  void Reset();
  // Next() calls since the last Reset().
  int failures() const { return failures_; }
  const ReconnectSchedule& schedule() const { return schedule_; }

 private:
  ReconnectSchedule schedule_;
  absl::Duration nominal_;
  int failures_ = 0;
  std::mt19937_64 rng_;
};

}  // namespace lane_client

#endif  // LANE_CLIENT_RECONNECT_BACKOFF_H_
