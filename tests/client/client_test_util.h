// What the lane-client tests against a real lane-server share
// (client_test.cc, client_bench_test.cc): temporary folders, a server on a
// loopback port, JSON readers, and the fixture with its rendered frames.
#ifndef LANE_TESTS_CLIENT_CLIENT_TEST_UTIL_H_
#define LANE_TESTS_CLIENT_CLIENT_TEST_UTIL_H_

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "lane/config/config.h"
#include "lane/synthetic.h"
#include "server.h"

namespace lane::client {

namespace fs = std::filesystem;
namespace v1 = lane::v1;
using Json = nlohmann::json;

inline const std::string kConfig = std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json";
constexpr int kFrames = 12;

// A fresh directory, removed with its contents at the end.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = fs::temp_directory_path() /
            ("lane-client-test-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

inline std::unique_ptr<lane::server::LaneServer> StartServer(
    const std::string& address, absl::Duration shutdown_deadline = absl::Seconds(20)) {
  lane::server::ServerOptions options;
  options.address = address;
  options.metrics_address = "";
  options.workers = 2;
  options.shutdown_deadline = shutdown_deadline;
  options.build = lane::server::CurrentBuildInfo();
  auto server = lane::server::LaneServer::Start(options, std::make_shared<prometheus::Registry>());
  EXPECT_TRUE(server.ok()) << server.status();
  return server.ok() ? *std::move(server) : nullptr;
}

inline std::string Target(const lane::server::LaneServer& server) {
  return "127.0.0.1:" + std::to_string(server.port());
}

inline uint64_t FramesProcessed(lane::server::LaneServer& server, const std::string& camera) {
  const auto session = server.sessions().Find(camera);
  return session ? session->frames_processed.load() : 0;
}

inline std::vector<Json> ReadJsonLines(const std::string& path) {
  std::vector<Json> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) out.push_back(Json::parse(line));
  return out;
}

inline Json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return Json::parse(in);
}

template <typename F>
inline bool PollUntil(F condition, double timeout_s = 30) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

class ClientTest : public ::testing::Test {
 protected:
  // Synthetic 640x480 road frames, JPEG-encoded, rendered once.
  static void SetUpTestSuite() {
    frames_ = new TempDir();
    const absl::StatusOr<lane::Config> config = lane::LoadConfigFile(kConfig);
    ASSERT_TRUE(config.ok()) << config.status();
    for (int i = 0; i < kFrames; ++i) {
      absl::StatusOr<lane::SyntheticFrame> frame =
          lane::RenderSyntheticFrame(config->camera, lane::SyntheticOptions(), 100 + i);
      ASSERT_TRUE(frame.ok()) << frame.status();
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.jpg", i);
      ASSERT_TRUE(cv::imwrite(*frames_ / name, frame->bgr, {cv::IMWRITE_JPEG_QUALITY, 90}));
      names_.push_back(name);
    }
  }
  static void TearDownTestSuite() {
    delete frames_;
    frames_ = nullptr;
  }

  // A list file in the frames folder naming the frames `repeat` times over.
  static std::string RepeatList(int repeat) {
    const std::string path = *frames_ / ("repeat" + std::to_string(repeat) + ".txt");
    std::ofstream out(path);
    for (int r = 0; r < repeat; ++r) {
      for (const std::string& name : names_) out << name << "\n";
    }
    return path;
  }

  inline static TempDir* frames_ = nullptr;
  inline static std::vector<std::string> names_;
};

// A bench run's counts add up and its percentiles are in order.
inline void ExpectConsistentRun(const Json& run) {
  const uint64_t sent = run["frames_sent"];
  const uint64_t ok = run["frames_ok"];
  const uint64_t errors = run["errors_total"];
  const uint64_t dropped = run["dropped"];
  EXPECT_EQ(ok, sent - errors - dropped) << run.dump();
  uint64_t by_code = 0;
  for (const auto& [code, n] : run["errors"].items()) by_code += n.get<uint64_t>();
  EXPECT_EQ(by_code, errors);
  EXPECT_EQ(run["frames_scheduled"].get<uint64_t>(), sent + run["unsent"].get<uint64_t>());
  const Json& latency = run["latency_ms"];
  EXPECT_EQ(latency["count"].get<uint64_t>(), ok);
  EXPECT_LE(latency["min"].get<double>(), latency["p50"].get<double>());
  EXPECT_LE(latency["p50"].get<double>(), latency["p90"].get<double>());
  EXPECT_LE(latency["p90"].get<double>(), latency["p95"].get<double>());
  EXPECT_LE(latency["p95"].get<double>(), latency["p99"].get<double>());
  EXPECT_LE(latency["p99"].get<double>(), latency["p999"].get<double>());
  EXPECT_LE(latency["p999"].get<double>(), latency["max"].get<double>());
  EXPECT_GT(run["achieved_fps"].get<double>(), 0);
}

}  // namespace lane::client

#endif  // LANE_TESTS_CLIENT_CLIENT_TEST_UTIL_H_
