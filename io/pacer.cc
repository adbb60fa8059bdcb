#include "io/pacer.h"

#include <thread>

namespace lane::io {

double Pacer::RateFor(double source_fps) const {
  if (fps_ > 0) return fps_;
  if (!realtime_) return 0;
  return source_fps > 0 ? source_fps : kDefaultImageFps;
}

void Pacer::Wait(double source_fps) {
  const double rate = RateFor(source_fps);
  if (rate <= 0) return;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point now = Clock::now();
  if (!started_) {
    started_ = true;
    next_ = now;
    return;
  }
  next_ += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
  if (next_ < now - std::chrono::seconds(1)) next_ = now - std::chrono::seconds(1);
  std::this_thread::sleep_until(next_);
}

}  // namespace lane::io
