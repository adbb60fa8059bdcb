#include "reconnect_backoff.h"

#include <algorithm>

namespace lane_client {

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

}  // namespace lane_client
