#include "worker_pool.h"

#include <algorithm>
#include <utility>

namespace lane::server {

WorkerPool::WorkerPool(Options options) : max_queued_(options.max_queued) {
  num_threads_ = options.threads > 0
                     ? options.threads
                     : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  absl::MutexLock lock(&shutdown_mu_);
  threads_.reserve(num_threads_);
  for (int i = 0; i < num_threads_; ++i) threads_.emplace_back([this] { Run(); });
}

WorkerPool::~WorkerPool() { Shutdown(); }

bool WorkerPool::Submit(std::function<void()> task) { return Push(std::move(task), false); }

bool WorkerPool::TrySubmit(std::function<void()> task) { return Push(std::move(task), true); }

bool WorkerPool::Push(std::function<void()> task, bool bounded) {
  // A waiting worker wakes when the lock is released (its condition holds).
  absl::MutexLock lock(&mu_);
  if (stopping_) return false;
  if (bounded && queue_.size() >= max_queued_) return false;
  queue_.push_back(std::move(task));
  return true;
}

void WorkerPool::Shutdown() {
  absl::MutexLock shutdown_lock(&shutdown_mu_);
  {
    absl::MutexLock lock(&mu_);
    stopping_ = true;
  }
  for (std::thread& t : threads_) {
    if (t.joinable()) t.join();
  }
}

size_t WorkerPool::queued() const {
  absl::MutexLock lock(&mu_);
  return queue_.size();
}

void WorkerPool::Run() {
  for (;;) {
    std::function<void()> task;
    {
      absl::MutexLock lock(&mu_, work_or_stopping_);
      if (queue_.empty()) return;  // stopping, nothing left
      task = std::move(queue_.front());
      queue_.pop_front();
    }
    task();
  }
}

}  // namespace lane::server
