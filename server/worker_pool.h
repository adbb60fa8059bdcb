// A fixed set of threads running tasks in FIFO order. The server owns one;
// gRPC reactions hand it all CPU work (decoding, detection, building
// detectors) so that they never block.
#ifndef LANE_SERVER_WORKER_POOL_H_
#define LANE_SERVER_WORKER_POOL_H_

#include <cstddef>
#include <deque>
#include <functional>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace lane::server {

class WorkerPool {
 public:
  struct Options {
    // Threads; 0 = one per core (std::thread::hardware_concurrency()).
    int threads = 0;
    // TrySubmit refuses tasks beyond this many queued ones.
    size_t max_queued = 1024;
  };

  explicit WorkerPool(Options options);
  // Shutdown().
  ~WorkerPool();

  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Queues a task whatever the queue's length: for callers that bound their
  // own work (a stream's frames in flight). False only after Shutdown.
  bool Submit(std::function<void()> task);
  // Queues a task unless max_queued tasks are waiting or after Shutdown.
  bool TrySubmit(std::function<void()> task);

  // Refuses new tasks, runs the queued ones and joins the threads.
  // Idempotent. Must not be called from a worker.
  void Shutdown();

  int threads() const { return num_threads_; }
  size_t queued() const;

 private:
  bool Push(std::function<void()> task, bool bounded);
  void Run();
  // A worker's wait ends: a task is queued, or the pool stops.
  bool WorkOrStopping() const ABSL_SHARED_LOCKS_REQUIRED(mu_) {
    return stopping_ || !queue_.empty();
  }

  const size_t max_queued_;
  int num_threads_ = 0;
  absl::Mutex shutdown_mu_;  // serialises Shutdown
  mutable absl::Mutex mu_;
  // Conditions that other threads evaluate are members, not temporaries on
  // the waiter's stack: absl evaluates a waiter's Condition on the thread
  // that unlocks, inside its (uninstrumented) lock code, so TSan saw that
  // thread read the waiter's stack after the waiter had returned and reused
  // it (a loaded run of the suite, issue 40).
  const absl::Condition work_or_stopping_{this, &WorkerPool::WorkOrStopping};
  std::deque<std::function<void()>> queue_ ABSL_GUARDED_BY(mu_);
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> threads_ ABSL_GUARDED_BY(shutdown_mu_);
};

}  // namespace lane::server

#endif  // LANE_SERVER_WORKER_POOL_H_
