// A one-line progress bar on stderr, drawn only when stderr is a terminal,
// so logs and pipes never see it.
#ifndef LANE_IO_PROGRESS_BAR_H_
#define LANE_IO_PROGRESS_BAR_H_

#include <chrono>
#include <string>

namespace lane::io {

class ProgressBar {
 public:
  // Active when `enabled` and stderr is a terminal (isatty).
  explicit ProgressBar(bool enabled);
  ~ProgressBar();

  bool active() const { return active_; }
  // "[=========>          ]  30/60  label", redrawn at most every 100 ms
  // and always for the last frame. With total <= 0 (a video or a live
  // source: the count is not known) a counter: "30 frames  label".
  void Update(int done, int total, const std::string& label);
  // Erases the bar so later messages start on a clean line.
  void Clear();

 private:
  bool active_ = false;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_;
};

}  // namespace lane::io

#endif  // LANE_IO_PROGRESS_BAR_H_
