// How long a stream engine waits before it reconnects after a failed call,
// and when it stops reconnecting: one policy for `stream` (Streamer) and the
// cameras of `bench`.
//
// The first wait is `initial`; each further failure without progress doubles
// it, up to `max`; every wait is multiplied by a random factor in
// [1 - jitter, 1 + jitter], so cameras cut off together do not come back
// together. Once a call makes progress (a frame answered), the schedule
// starts again from `initial`.
//
// RetryBudget says when to stop: after too many failures in a row with the
// same status, or too long without progress (docs/client.md, "Reconnection").
#ifndef LANE_CLIENT_RECONNECT_BACKOFF_H_
#define LANE_CLIENT_RECONNECT_BACKOFF_H_

#include <cstdint>
#include <optional>
#include <random>
#include <string>

#include "absl/status/status.h"
#include "absl/time/time.h"

namespace lane::client {

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

// The default of `--max-reconnects`: 10 reconnections in a row after failures
// with the same status code, i.e. 11 attempts over about 13 s of backoff
// (0.1 + 0.2 + 0.4 + 0.8 + 1.6 + 5 x 2 s, +-20 %). That outlasts a restart:
// lane-server's own "the server is draining" and "the server is starting"
// never count (the server is there, changing state), and the connection is
// refused only until the new process listens, about 0.1 s after it starts;
// a proxy fails over to another replica within seconds. A code that comes
// back 11 times with nothing answered is a failure that repeats (a proxy
// refusing every call, a header too large, a server that stays away) and
// ends the run in ~13 s instead of the 60 s of the time budget.
//
// The code, not the message, is compared: gRPC words one transport failure
// in many ways (through nginx, a refused call reads "Socket closed", then
// "connections to all backends failing; ... tcp handshaker shutdown", then
// "... timed out before receiving SETTINGS frame", in turn).
inline constexpr int kDefaultMaxReconnects = 10;

struct RetryLimits {
  // Reconnections in a row after failures with the same status code and no
  // progress in between; nullopt: no limit. 0: give up at the first failure.
  std::optional<int> max_reconnects = kDefaultMaxReconnects;
  // Give up when a failure comes this long after the last progress (or the
  // start).
  absl::Duration give_up_after = absl::InfiniteDuration();
};

class RetryBudget {
 public:
  RetryBudget(RetryLimits limits, absl::Time start);

  // A call made progress (a frame answered): both budgets start again.
  void Progress(absl::Time now);
  // A failed attempt (a call, or the session step before it) ended with
  // `failure` (not OK) at `now`: OK when it may be retried; else the status
  // to give up with, with failure's own code and a message naming it, the
  // attempts, and the first failure of the run when its message differs
  // (or the time without progress).
  absl::Status Failed(const absl::Status& failure, absl::Time now);

  // Failures in a row with the code of the last one, since the last
  // progress (0 after a status of a server changing state).
  int repeats() const { return repeats_; }
  const RetryLimits& limits() const { return limits_; }

 private:
  RetryLimits limits_;
  absl::Time last_progress_;
  absl::StatusCode last_code_ = absl::StatusCode::kOk;
  std::string first_message_;  // of the failures in a row
  int repeats_ = 0;
};

// UNAVAILABLE "the server is starting" or "the server is draining ..."
// (wire/status_map.h): a server that is there and changing state, which an
// attempts budget does not count.
bool IsServerChangingState(const absl::Status& status);

// The steady clock as an absl::Time, for RetryBudget: a change of the
// system's clock neither ends a budget early nor stretches it.
absl::Time MonotonicNow();

// "UNAVAILABLE: Socket closed" (gRPC's names of the codes).
std::string FailureText(const absl::Status& status);

}  // namespace lane::client

#endif  // LANE_CLIENT_RECONNECT_BACKOFF_H_
