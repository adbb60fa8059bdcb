// `lane backfill`'s work on one recording (docs/backfill.md): its frames
// decoded and detected on a shared pool of threads, tracked and written in
// order into a partial output of this process's own, published only where no
// output exists, under the output's claim (backfill_output.h). The command,
// its shards and summary are backfill_command.cc.
#ifndef LANE_TOOLS_BACKFILL_RECORDING_H_
#define LANE_TOOLS_BACKFILL_RECORDING_H_

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "backfill_manifest.h"
#include "io/inputs.h"

namespace lane::cli {

// Frames in flight per recording, and the tracker's prior lag: frame i is
// detected with the tracker's state after frame i - kWindow (the lanes do not
// depend on the threads' timing, nor on --jobs up to kWindow).
inline constexpr int kBackfillWindow = 8;

// A fixed set of threads running tasks in submission order.
class BackfillWorkers {
 public:
  explicit BackfillWorkers(int n) {
    for (int i = 0; i < n; ++i) threads_.emplace_back([this] { Loop(); });
  }
  ~BackfillWorkers() {
    {
      absl::MutexLock lock(&mu_);
      done_ = true;
    }
    for (std::thread& t : threads_) t.join();
  }
  // `task` must not throw (RecordingRun's catch everything themselves).
  void Submit(std::function<void()> task) {
    absl::MutexLock lock(&mu_);
    tasks_.push_back(std::move(task));
  }

 private:
  bool HasWorkOrDone() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return done_ || !tasks_.empty(); }
  void Loop() {
    for (;;) {
      std::function<void()> task;
      {
        absl::MutexLock lock(&mu_);
        mu_.Await(absl::Condition(this, &BackfillWorkers::HasWorkOrDone));
        if (tasks_.empty()) return;
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  absl::Mutex mu_;
  std::deque<std::function<void()>> tasks_ ABSL_GUARDED_BY(mu_);
  bool done_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> threads_;
};

struct RecordingResult {
  std::string status;  // done, redone, skipped, failed; claimed_elsewhere (deferred)
  std::string error;
  std::string redo_reason;         // redone: what was wrong with the output found
  bool claimed_elsewhere = false;  // another process held it first; waited for
  int removed_partials = 0;        // dead processes' partial files removed
  long frames = 0;
  long failed_frames = 0;
  long lanes = 0;
  double wall_s = 0;
};

// What a shard's recordings share.
struct BackfillContext {
  std::string out_dir;
  BackfillWorkers* workers = nullptr;
  int64_t max_image_bytes = io::kDefaultMaxImageBytes;
  // Partial outputs found in out_dir at the start, by output name; removed
  // once the output's claim is held.
  std::map<std::string, std::vector<std::string>> partials;
};

// One recording: skipped when its output checks; claimed, else left to the
// process that holds it (status claimed_elsewhere; with `wait`, waited for);
// computed into a partial file of this process's own; published only where
// no output exists (a torn one is removed first, under the claim).
RecordingResult ProcessRecording(const BackfillRecording& r, BackfillContext& ctx, bool wait);

}  // namespace lane::cli

#endif  // LANE_TOOLS_BACKFILL_RECORDING_H_
