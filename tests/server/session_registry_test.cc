#include "session_registry.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "test_util.h"

namespace lane::server {
namespace {

class SessionRegistryTest : public ::testing::Test {
 protected:
  SessionRegistry::Options Options() {
    SessionRegistry::Options options;
    options.max_sessions = 3;
    options.ttl = absl::Seconds(10);
    options.clock = [this] { return now_; };
    options.on_size_change = [this](size_t n) { size_seen_ = n; };
    return options;
  }

  static SessionSpec Spec(double pitch = 14.0) {
    SessionSpec spec;
    spec.config.camera = testing::ScaledCamera(0.5, pitch);
    spec.config.ipm.roi = {50, 230, 110, 175};
    return spec;
  }

  absl::Time now_ = absl::FromUnixSeconds(1'000'000);
  size_t size_seen_ = 0;
};

TEST_F(SessionRegistryTest, CreateIsIdempotentAndReplaceBumpsTheVersion) {
  SessionRegistry registry(Options());
  auto created = registry.Create("cam", Spec(), false);
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_EQ(created->outcome, SessionRegistry::Outcome::kCreated);
  EXPECT_EQ(created->session->stream.max_inflight_frames, 8u);  // resolved default
  EXPECT_EQ(size_seen_, 1u);

  auto again = registry.Create("cam", Spec(), false);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->outcome, SessionRegistry::Outcome::kUnchanged);
  EXPECT_EQ(again->session, created->session);

  auto conflict = registry.Create("cam", Spec(15.0), false);
  EXPECT_EQ(conflict.status().code(), absl::StatusCode::kAlreadyExists);
  // A different stream policy is a different session too.
  SessionSpec drop = Spec();
  drop.stream.backpressure = Backpressure::kDropOldest;
  EXPECT_EQ(registry.Create("cam", drop, false).status().code(), absl::StatusCode::kAlreadyExists);

  auto replaced = registry.Create("cam", Spec(15.0), true);
  ASSERT_TRUE(replaced.ok());
  EXPECT_EQ(replaced->outcome, SessionRegistry::Outcome::kReplaced);
  EXPECT_GT(replaced->session->version, created->session->version);
  EXPECT_EQ(registry.Find("cam"), replaced->session);
  // The old snapshot stays valid for whoever holds it.
  EXPECT_DOUBLE_EQ(created->session->config.camera.pitch_deg, 14.0);
  EXPECT_EQ(registry.size(), 1u);
}

TEST_F(SessionRegistryTest, RefusesBadInput) {
  SessionRegistry registry(Options());
  EXPECT_EQ(registry.Create("", Spec(), false).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(registry.Create("a b", Spec(), false).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(registry.Create(std::string(129, 'a'), Spec(), false).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(registry.Create("site-1/cam_2:front.left", Spec(), false).ok());
  SessionSpec bad = Spec();
  bad.config.ipm.roi = {10000, 20000, 10000, 20000};  // nowhere in the image
  EXPECT_EQ(registry.Create("x", bad, false).status().code(), absl::StatusCode::kInvalidArgument);
  SessionSpec huge = Spec();
  huge.config.camera.image_width = 100000;
  huge.config.camera.image_height = 100000;
  EXPECT_EQ(registry.Create("x", huge, false).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(SessionRegistryTest, CapIsResourceExhausted) {
  SessionRegistry registry(Options());
  for (const char* id : {"a", "b", "c"}) ASSERT_TRUE(registry.Create(id, Spec(), false).ok());
  EXPECT_EQ(registry.Create("d", Spec(), false).status().code(),
            absl::StatusCode::kResourceExhausted);
  // Existing ids are still fine.
  EXPECT_TRUE(registry.Create("a", Spec(), false).ok());
  EXPECT_TRUE(registry.Create("a", Spec(16.0), true).ok());
  ASSERT_TRUE(registry.Delete("b").ok());
  EXPECT_TRUE(registry.Create("d", Spec(), false).ok());
}

TEST_F(SessionRegistryTest, EvictsIdleSessions) {
  SessionRegistry registry(Options());
  ASSERT_TRUE(registry.Create("old", Spec(), false).ok());
  now_ += absl::Seconds(6);
  ASSERT_TRUE(registry.Create("new", Spec(), false).ok());
  now_ += absl::Seconds(5);  // old: 11 s idle, new: 5 s
  EXPECT_EQ(registry.EvictIdle(), 1u);
  EXPECT_EQ(registry.Find("old"), nullptr);
  EXPECT_NE(registry.Find("new"), nullptr);  // and this use resets its clock
  now_ += absl::Seconds(9);
  EXPECT_EQ(registry.EvictIdle(), 0u);
  now_ += absl::Seconds(2);
  EXPECT_EQ(registry.EvictIdle(), 1u);
  EXPECT_EQ(size_seen_, 0u);
  EXPECT_EQ(registry.Get("new").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(registry.Delete("new").code(), absl::StatusCode::kNotFound);
}

TEST_F(SessionRegistryTest, ListIsSortedAndDoesNotTouch) {
  SessionRegistry registry(Options());
  ASSERT_TRUE(registry.Create("b", Spec(), false).ok());
  ASSERT_TRUE(registry.Create("a", Spec(), false).ok());
  now_ += absl::Seconds(11);
  std::vector<SessionRegistry::Entry> list = registry.List();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].session->camera_id, "a");
  EXPECT_EQ(list[1].session->camera_id, "b");
  EXPECT_EQ(registry.EvictIdle(), 2u);
}

TEST_F(SessionRegistryTest, ConcurrentCreatesAgreeOnOneSession) {
  SessionRegistry::Options options = Options();
  options.clock = [] { return absl::Now(); };
  options.on_size_change = nullptr;
  SessionRegistry registry(options);
  std::atomic<int> created{0};
  std::vector<uint64_t> versions(8);
  std::vector<std::thread> threads;
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&, i] {
      auto r = registry.Create("same", Spec(), false);
      ASSERT_TRUE(r.ok());
      if (r->outcome == SessionRegistry::Outcome::kCreated) ++created;
      versions[i] = r->session->version;
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(created.load(), 1);
  for (uint64_t v : versions) EXPECT_EQ(v, versions[0]);
}

}  // namespace
}  // namespace lane::server
