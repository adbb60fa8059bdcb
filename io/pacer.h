// Paces a replay like a camera: frames are handed out no sooner than their
// time, start + i / rate. `--fps R` sets the rate; `--realtime` takes each
// video's own frame rate (image files: --fps, else 30 frames/s). Live
// sources are not paced: they come at their own rate. A reader that falls
// behind is not made to drop frames: it catches up, at most one second's
// worth at once.
#ifndef LANE_IO_PACER_H_
#define LANE_IO_PACER_H_

#include <chrono>

namespace lane::io {

class Pacer {
 public:
  static constexpr double kDefaultImageFps = 30.0;

  Pacer() = default;
  // fps > 0: that rate for everything; realtime: each video's own rate.
  Pacer(double fps, bool realtime) : fps_(fps), realtime_(realtime) {}

  bool enabled() const { return fps_ > 0 || realtime_; }
  // The rate for a frame of a source of `source_fps` (0: not a video, or
  // unknown); 0 = not paced.
  double RateFor(double source_fps) const;
  // Waits until the next frame's time at RateFor(source_fps).
  void Wait(double source_fps);

 private:
  double fps_ = 0;
  bool realtime_ = false;
  bool started_ = false;
  std::chrono::steady_clock::time_point next_{};
};

}  // namespace lane::io

#endif  // LANE_IO_PACER_H_
