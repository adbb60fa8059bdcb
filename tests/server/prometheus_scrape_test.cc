// A real Prometheus server (Debian's `prometheus` package) scrapes the
// metrics endpoint; its HTTP API must report as many frame latencies as
// frames were sent.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "test_util.h"

extern char** environ;

namespace lane::server::testing {
namespace {

constexpr char kPrometheus[] = "/usr/bin/prometheus";

// The body of a 200 response to GET path, or nullopt.
std::optional<std::string> HttpGet(int port, const std::string& path) {
  HttpResponse response = HttpFetch(port, path);
  if (response.status != 200) return std::nullopt;
  return std::move(response.body);
}

// A loopback port nobody listens on right now.
int FreeLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  close(fd);
  return ntohs(addr.sin_port);
}

// A Prometheus process for the test's lifetime, with its own storage.
class PrometheusProcess {
 public:
  PrometheusProcess(int target_port, int web_port) : web_port_(web_port) {
    char dir_template[] = "/tmp/lanesvc-prometheus-XXXXXX";
    dir_ = mkdtemp(dir_template);
    const std::string config = dir_ + "/prometheus.yml";
    std::ofstream(config) << "global:\n"
                             "  scrape_interval: 1s\n"
                             "  evaluation_interval: 1s\n"
                             "scrape_configs:\n"
                             "  - job_name: lanesvc\n"
                             "    static_configs:\n"
                             "      - targets: ['127.0.0.1:"
                          << target_port << "']\n";
    const std::string log = dir_ + "/prometheus.log";
    std::vector<std::string> args = {
        kPrometheus, "--config.file=" + config, "--storage.tsdb.path=" + dir_ + "/data",
        "--web.listen-address=127.0.0.1:" + std::to_string(web_port), "--log.level=warn"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    if (posix_spawn(&pid_, kPrometheus, &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }

  ~PrometheusProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  bool started() const { return pid_ > 0; }
  std::string log() const {
    std::ifstream in(dir_ + "/prometheus.log");
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

  // The value of an instant query's first sample, or nullopt.
  std::optional<double> Query(const std::string& expr) const {
    const std::optional<std::string> body = HttpGet(web_port_, "/api/v1/query?query=" + expr);
    if (!body) return std::nullopt;
    const nlohmann::json reply = nlohmann::json::parse(*body, nullptr, false);
    if (reply.is_discarded() || reply.value("status", "") != "success") return std::nullopt;
    const nlohmann::json& result = reply["data"]["result"];
    if (!result.is_array() || result.empty()) return std::nullopt;
    return std::stod(result[0]["value"][1].get<std::string>());
  }

 private:
  std::string dir_;
  int web_port_;
  pid_t pid_ = -1;
};

TEST(PrometheusScrapeTest, FrameLatencyCountEqualsFramesSent) {
  if (access(kPrometheus, X_OK) != 0) {
    GTEST_SKIP() << kPrometheus << " is missing: apt-get install prometheus to run this test";
  }
  ServerOptions options = TestServer::DefaultOptions();
  options.metrics_address = "127.0.0.1:0";
  TestServer server(options);
  ASSERT_FALSE(HasFailure());
  const int metrics_port = server.server().metrics_port();
  ASSERT_GT(metrics_port, 0);

  const lane::CameraModel camera = ScaledCamera(0.5);
  server.CreateSession("cam", SessionConfigFor(camera));
  const std::string jpeg = EncodeJpeg(RoadFrame(camera, kLineOffsets, 4));
  constexpr int kFrames = 25;
  std::vector<v1::FrameRequest> requests;
  for (int i = 0; i < kFrames; ++i) requests.push_back(JpegRequest("cam", i, jpeg));
  StreamResult result = RunStream(server.stub(), requests);
  ASSERT_TRUE(result.status.ok());
  ASSERT_EQ(result.responses.size(), static_cast<size_t>(kFrames));

  // Our endpoint speaks the text format.
  const std::optional<std::string> text = HttpGet(metrics_port, "/metrics");
  ASSERT_TRUE(text.has_value());
  EXPECT_NE(text->find("lanesvc_frame_latency_seconds_count " + std::to_string(kFrames)),
            std::string::npos);
  EXPECT_NE(text->find("lanesvc_build_info{"), std::string::npos);
  EXPECT_NE(text->find("lanesvc_frame_latency_seconds_bucket{le=\"5e-05\"}"), std::string::npos);

  PrometheusProcess prometheus(metrics_port, FreeLoopbackPort());
  ASSERT_TRUE(prometheus.started());
  std::optional<double> count;
  const bool scraped = PollUntil(
      [&] {
        count = prometheus.Query("lanesvc_frame_latency_seconds_count");
        return count.has_value();
      },
      60.0);
  ASSERT_TRUE(scraped) << "Prometheus never reported the metric; its log:\n" << prometheus.log();
  EXPECT_EQ(*count, kFrames);
  EXPECT_EQ(prometheus.Query("up").value_or(0), 1);
  EXPECT_EQ(prometheus.Query("lanesvc_frames_total%7Bresult%3D%22ok%22%7D").value_or(0), kFrames);
}

}  // namespace
}  // namespace lane::server::testing
