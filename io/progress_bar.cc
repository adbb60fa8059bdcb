#include "io/progress_bar.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace lane::io {
namespace {

constexpr int kBarWidth = 30;
constexpr auto kMinInterval = std::chrono::milliseconds(100);
// Labels are cut to this many bytes so the line never wraps on a narrow
// terminal.
constexpr size_t kMaxLabel = 30;

}  // namespace

ProgressBar::ProgressBar(bool enabled) : active_(enabled && isatty(fileno(stderr)) == 1) {}

ProgressBar::~ProgressBar() { Clear(); }

void ProgressBar::Update(int done, int total, const std::string& label) {
  if (!active_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && (total <= 0 || done < total) && now - last_ < kMinInterval) return;
  last_ = now;
  const std::string shown_label =
      label.size() > kMaxLabel ? "..." + label.substr(label.size() - kMaxLabel + 3) : label;
  if (total <= 0) {
    std::fprintf(stderr, "\r%d frames  %s\033[K", done, shown_label.c_str());
    std::fflush(stderr);
    drawn_ = true;
    return;
  }
  const int filled = std::clamp(done * kBarWidth / total, 0, kBarWidth);
  std::string bar(kBarWidth, ' ');
  std::fill(bar.begin(), bar.begin() + filled, '=');
  if (filled < kBarWidth && done > 0) bar[filled] = '>';
  const std::string& shown = shown_label;
  // \r back to the line's start, \033[K erase the rest of the old line.
  std::fprintf(stderr, "\r[%s] %*d/%d  %s\033[K", bar.c_str(),
               static_cast<int>(std::to_string(total).size()), done, total, shown.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::Clear() {
  if (!active_ || !drawn_) return;
  std::fputs("\r\033[K", stderr);
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace lane::io
