#include "reconnect_backoff.h"

#include <algorithm>
#include <chrono>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace lane::client {

ReconnectBackoff::ReconnectBackoff(ReconnectSchedule schedule, uint64_t seed)
    : schedule_(schedule), nominal_(schedule.initial), rng_(seed) {}

absl::Duration ReconnectBackoff::Next() {
  absl::Duration wait = nominal_;
  if (schedule_.jitter > 0) {
    std::uniform_real_distribution<double> factor(1 - schedule_.jitter, 1 + schedule_.jitter);
    wait = wait * factor(rng_);
  }
  nominal_ = std::min(nominal_ * 2, schedule_.max);
  ++failures_;
  return wait;
}

void ReconnectBackoff::Reset() {
  nominal_ = schedule_.initial;
  failures_ = 0;
}

RetryBudget::RetryBudget(RetryLimits limits, absl::Time start)
    : limits_(limits), last_progress_(start) {}

void RetryBudget::Progress(absl::Time now) {
  last_progress_ = now;
  repeats_ = 0;
  last_code_ = absl::StatusCode::kOk;
  first_message_.clear();
}

absl::Status RetryBudget::Failed(const absl::Status& failure, absl::Time now) {
  if (IsServerChangingState(failure)) {
    repeats_ = 0;  // the server is there: only the time budget counts
  } else if (repeats_ > 0 && failure.code() == last_code_) {
    ++repeats_;
  } else {
    repeats_ = 1;
    last_code_ = failure.code();
    first_message_ = std::string(failure.message());
  }
  if (limits_.max_reconnects && repeats_ > *limits_.max_reconnects) {
    const int allowed = *limits_.max_reconnects;
    if (allowed == 0) {
      return absl::Status(failure.code(), absl::StrCat(FailureText(failure),
                                                       "; gave up at the first failure (no "
                                                       "reconnection allowed)"));
    }
    return absl::Status(
        failure.code(),
        absl::StrCat(FailureText(failure), "; ", absl::StatusCodeToString(failure.code()), " on ",
                     repeats_, " attempts in a row with no frame answered: gave up (at most ",
                     allowed, " reconnection(s) after the same failure)",
                     first_message_ == failure.message()
                         ? std::string()
                         : absl::StrCat("; the first of them: ", first_message_)));
  }
  if (now - last_progress_ > limits_.give_up_after) {
    return absl::Status(failure.code(), absl::StrCat("no frame answered for ",
                                                     absl::FormatDuration(limits_.give_up_after),
                                                     "; last error: ", FailureText(failure)));
  }
  return absl::OkStatus();
}

bool IsServerChangingState(const absl::Status& status) {
  // The beginnings of wire::ServerStarting() and wire::ServerDraining()
  // (reconnect_backoff_test checks them), which a proxy may pass on with more
  // after them.
  return status.code() == absl::StatusCode::kUnavailable &&
         (absl::StartsWith(status.message(), "the server is starting") ||
          absl::StartsWith(status.message(), "the server is draining"));
}

absl::Time MonotonicNow() {
  return absl::UnixEpoch() + absl::FromChrono(std::chrono::steady_clock::now().time_since_epoch());
}

std::string FailureText(const absl::Status& status) {
  if (status.message().empty()) return absl::StatusCodeToString(status.code());
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message());
}

}  // namespace lane::client
