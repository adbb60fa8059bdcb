#include "worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>

namespace lane::server {
namespace {

TEST(WorkerPoolTest, RunsEveryTask) {
  std::atomic<int> done{0};
  {
    WorkerPool pool({3, 1024});
    EXPECT_EQ(pool.threads(), 3);
    for (int i = 0; i < 500; ++i) ASSERT_TRUE(pool.Submit([&] { ++done; }));
    pool.Shutdown();
    EXPECT_EQ(done.load(), 500);
    EXPECT_FALSE(pool.Submit([] {}));
  }
}

TEST(WorkerPoolTest, DefaultIsOneThreadPerCore) {
  WorkerPool pool({});
  EXPECT_EQ(pool.threads(), static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
}

TEST(WorkerPoolTest, TrySubmitIsBounded) {
  WorkerPool pool({1, 2});
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::promise<void> started;
  ASSERT_TRUE(pool.Submit([&started, gate] {
    started.set_value();
    gate.wait();
  }));
  started.get_future().wait();  // the only worker is busy
  std::atomic<int> ran{0};
  EXPECT_TRUE(pool.TrySubmit([&] { ++ran; }));
  EXPECT_TRUE(pool.TrySubmit([&] { ++ran; }));
  EXPECT_FALSE(pool.TrySubmit([&] { ++ran; }));  // two queued already
  EXPECT_TRUE(pool.Submit([&] { ++ran; }));      // unbounded
  EXPECT_EQ(pool.queued(), 3u);
  release.set_value();
  pool.Shutdown();  // runs what is queued
  EXPECT_EQ(ran.load(), 3);
}

}  // namespace
}  // namespace lane::server
