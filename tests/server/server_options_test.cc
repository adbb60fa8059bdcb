// ServerOptions::Validate: every option is checked where the server starts,
// with the flag's name in the message; nothing is clamped.
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "test_util.h"

namespace lane::server::testing {
namespace {

TEST(ServerOptionsTest, DefaultsAreValid) {
  EXPECT_TRUE(ServerOptions{}.Validate().ok());
  EXPECT_TRUE(TestServer::DefaultOptions().Validate().ok());
}

TEST(ServerOptionsTest, NonsenseIsRefusedByFlagName) {
  const std::vector<std::pair<std::string, std::function<void(ServerOptions&)>>> cases = {
      {"--workers", [](ServerOptions& o) { o.workers = -1; }},
      {"--max_queued_tasks", [](ServerOptions& o) { o.max_queued_tasks = 0; }},
      {"--max_inflight_frames", [](ServerOptions& o) { o.max_inflight_frames = 0; }},
      {"--max_inflight_frames", [](ServerOptions& o) { o.max_inflight_frames = 5000; }},
      {"--max_sessions", [](ServerOptions& o) { o.max_sessions = 0; }},
      {"--session_ttl", [](ServerOptions& o) { o.session_ttl = absl::ZeroDuration(); }},
      {"--max_frame_pixels", [](ServerOptions& o) { o.max_frame_pixels = 0; }},
      {"--decode_cpu_budget", [](ServerOptions& o) { o.decode_cpu_budget = -absl::Seconds(1); }},
      {"--max_receive_message_bytes", [](ServerOptions& o) { o.max_receive_message_bytes = 0; }},
      {"--keepalive_timeout", [](ServerOptions& o) { o.keepalive_timeout = absl::ZeroDuration(); }},
      {"--shutdown_deadline", [](ServerOptions& o) { o.shutdown_deadline = -absl::Seconds(1); }},
      {"--max_concurrent_streams", [](ServerOptions& o) { o.max_concurrent_streams = -2; }},
      {"--metrics_camera_labels", [](ServerOptions& o) { o.metrics_camera_labels = 10001; }},
  };
  for (const auto& [flag, spoil] : cases) {
    ServerOptions options = TestServer::DefaultOptions();
    spoil(options);
    const absl::Status status = options.Validate();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << flag;
    EXPECT_TRUE(absl::StartsWith(status.message(), flag)) << status;
    // Start refuses them before anything listens.
    auto started = LaneServer::Start(options, nullptr);
    EXPECT_EQ(started.status().code(), absl::StatusCode::kInvalidArgument) << flag;
  }
}

}  // namespace
}  // namespace lane::server::testing
