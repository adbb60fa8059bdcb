// The clients' retry budget (issue 47): a failure that repeats call after
// call ends the stream with its own status instead of a retry loop, and a
// camera id the server would refuse is refused before anything is sent.
//
// The server here is a fake: a LaneService whose session calls answer and
// whose StreamFrames ends every call at once with UNAVAILABLE, as a proxy
// that refuses the call does (nginx's GOAWAY ENHANCE_YOUR_CALM for a header
// too large reaches a gRPC client as UNAVAILABLE "Socket closed").
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "commands.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "reconnect_backoff.h"
#include "streamer.h"
#include "wire/status_map.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;

constexpr char kClosedMessage[] = "closed by the test server";

// Answers the session calls (or fails them with `session_status`), ends
// every StreamFrames call at once with `stream_status` (its message followed
// by " (call N)" when `number_calls`: a failure worded anew every time, as
// gRPC's transport failures are); counts the calls.
class ClosingLaneService final : public v1::LaneService::Service {
 public:
  explicit ClosingLaneService(grpc::Status stream_status,
                              grpc::Status session_status = grpc::Status::OK)
      : stream_status_(std::move(stream_status)), session_status_(std::move(session_status)) {}

  std::atomic<bool> number_calls{false};

  grpc::Status CreateSession(grpc::ServerContext* /*context*/,
                             const v1::CreateSessionRequest* request,
                             v1::CreateSessionResponse* response) override {
    ++session_calls;
    if (!session_status_.ok()) return session_status_;
    response->set_outcome(v1::CREATE_OUTCOME_UNCHANGED);
    response->mutable_session()->set_camera_id(request->camera_id());
    *response->mutable_session()->mutable_config() = request->config();
    return grpc::Status::OK;
  }
  grpc::Status GetSession(grpc::ServerContext* /*context*/, const v1::GetSessionRequest* request,
                          v1::Session* response) override {
    ++session_calls;
    if (!session_status_.ok()) return session_status_;
    response->set_camera_id(request->camera_id());
    return grpc::Status::OK;
  }
  grpc::Status StreamFrames(
      grpc::ServerContext* /*context*/,
      grpc::ServerReaderWriter<v1::FrameResponse, v1::FrameRequest>* /*stream*/) override {
    const int call = ++stream_calls;
    if (!number_calls) return stream_status_;
    return grpc::Status(stream_status_.error_code(),
                        absl::StrCat(stream_status_.error_message(), " (call ", call, ")"));
  }

  std::atomic<int> session_calls{0};
  std::atomic<int> stream_calls{0};

 private:
  const grpc::Status stream_status_;
  const grpc::Status session_status_;
};

// The fake on a free loopback port.
struct ClosingServer {
  explicit ClosingServer(grpc::Status stream_status, grpc::Status session_status = grpc::Status::OK)
      : service(std::move(stream_status), std::move(session_status)) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&service);
    server = builder.BuildAndStart();
  }
  ~ClosingServer() {
    if (server) server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(1));
  }
  std::string target() const { return absl::StrCat("127.0.0.1:", port); }

  ClosingLaneService service;
  int port = 0;
  std::unique_ptr<grpc::Server> server;
};

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Frames that are never looked at by the fake: a few bytes each.
Streamer::Source FakeFrames(int count) {
  return [count](uint64_t frame_id) -> std::optional<StreamItem> {
    if (static_cast<int>(frame_id) >= count) return std::nullopt;
    auto request = std::make_shared<v1::FrameRequest>();
    request->set_camera_id("cam");
    request->set_frame_id(frame_id);
    request->set_encoded("not a frame");
    StreamItem item;
    item.name = absl::StrCat("frame", frame_id);
    item.request = std::move(request);
    return item;
  };
}

StreamerOptions FastOptions() {
  StreamerOptions options;
  options.camera_id = "cam";
  options.session = v1::SessionConfig();
  options.reconnect = {absl::Milliseconds(5), absl::Milliseconds(20), 0};
  options.call_timeout = absl::Seconds(5);
  return options;
}

// A folder with one JPEG, removed at the end.
class RetryTempDir {
 public:
  RetryTempDir() {
    path_ = std::filesystem::temp_directory_path() /
            absl::StrCat("lane-retry-test-", getpid(), "-", counter_++);
    std::filesystem::create_directories(path_);
    const cv::Mat frame(48, 64, CV_8UC3, cv::Scalar(90, 90, 90));
    cv::imwrite((path_ / "000000.jpg").string(), frame);
  }
  ~RetryTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string str() const { return path_.string(); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  static inline std::atomic<int> counter_{0};
  std::filesystem::path path_;
};

// ---- RetryBudget ------------------------------------------------------------

const absl::Time kT0 = absl::FromUnixSeconds(1000);

TEST(RetryBudgetTest, GivesUpWhenTheSameFailurePassesTheReconnections) {
  RetryBudget budget({3, absl::InfiniteDuration()}, kT0);
  const absl::Status closed = absl::UnavailableError("Socket closed");
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(budget.Failed(closed, kT0).ok()) << i;
  const absl::Status end = budget.Failed(closed, kT0);
  EXPECT_EQ(end.code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(end.message().find("UNAVAILABLE: Socket closed"), absl::string_view::npos) << end;
  EXPECT_NE(end.message().find("4 attempts in a row"), absl::string_view::npos) << end;
  EXPECT_EQ(budget.repeats(), 4);
}

TEST(RetryBudgetTest, KeepsTheFailuresOwnCode) {
  RetryBudget budget({1, absl::InfiniteDuration()}, kT0);
  const absl::Status full = absl::ResourceExhaustedError("the session table is full");
  EXPECT_TRUE(budget.Failed(full, kT0).ok());
  EXPECT_EQ(budget.Failed(full, kT0).code(), absl::StatusCode::kResourceExhausted);
}

TEST(RetryBudgetTest, TheCodeCountsNotTheWording) {
  RetryBudget budget({2, absl::InfiniteDuration()}, kT0);
  EXPECT_TRUE(budget.Failed(absl::UnavailableError("Socket closed"), kT0).ok());
  EXPECT_TRUE(
      budget.Failed(absl::UnavailableError("connections to all backends failing"), kT0).ok());
  const absl::Status end = budget.Failed(absl::UnavailableError("tcp handshaker shutdown"), kT0);
  EXPECT_EQ(end.code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(end.message().find("UNAVAILABLE: tcp handshaker shutdown; UNAVAILABLE on 3 attempts"),
            absl::string_view::npos)
      << end;
  EXPECT_NE(end.message().find("the first of them: Socket closed"), absl::string_view::npos) << end;
}

TEST(RetryBudgetTest, ADifferentCodeOrProgressStartsTheCountAgain) {
  RetryBudget budget({2, absl::InfiniteDuration()}, kT0);
  const absl::Status refused = absl::UnavailableError("Connection refused");
  const absl::Status cancelled = absl::CancelledError("stalled");
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  EXPECT_TRUE(budget.Failed(cancelled, kT0).ok());
  EXPECT_EQ(budget.repeats(), 1);
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  budget.Progress(kT0);
  EXPECT_EQ(budget.repeats(), 0);
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  const absl::Status end = budget.Failed(refused, kT0);
  EXPECT_FALSE(end.ok());
  // One wording throughout: no "first of them".
  EXPECT_EQ(end.message().find("first of them"), absl::string_view::npos) << end;
}

TEST(RetryBudgetTest, AServerChangingStateIsNotCounted) {
  EXPECT_TRUE(IsServerChangingState(lane::wire::ServerStarting()));
  EXPECT_TRUE(IsServerChangingState(lane::wire::ServerDraining()));
  EXPECT_FALSE(IsServerChangingState(absl::UnavailableError("Socket closed")));
  EXPECT_FALSE(IsServerChangingState(absl::InternalError("the server is draining")));
  // A restart: refused, the old server draining, refused, the new one starting.
  RetryBudget budget({1, absl::Seconds(60)}, kT0);
  const absl::Status refused = absl::UnavailableError("Connection refused");
  EXPECT_TRUE(budget.Failed(refused, kT0).ok());
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE(budget.Failed(lane::wire::ServerDraining(), kT0 + absl::Seconds(i)).ok()) << i;
  }
  EXPECT_TRUE(budget.Failed(refused, kT0 + absl::Seconds(21)).ok());
  EXPECT_TRUE(budget.Failed(lane::wire::ServerStarting(), kT0 + absl::Seconds(22)).ok());
  EXPECT_TRUE(budget.Failed(refused, kT0 + absl::Seconds(23)).ok());
  EXPECT_FALSE(budget.Failed(refused, kT0 + absl::Seconds(24)).ok());
  // The time budget still counts them.
  RetryBudget timed({1, absl::Seconds(60)}, kT0);
  EXPECT_TRUE(timed.Failed(lane::wire::ServerDraining(), kT0 + absl::Seconds(59)).ok());
  EXPECT_EQ(timed.Failed(lane::wire::ServerDraining(), kT0 + absl::Seconds(61)).code(),
            absl::StatusCode::kUnavailable);
}

TEST(RetryBudgetTest, ZeroGivesUpAtTheFirstFailureAndNulloptNever) {
  RetryBudget none({0, absl::InfiniteDuration()}, kT0);
  const absl::Status end = none.Failed(absl::InternalError("broken stream"), kT0);
  EXPECT_EQ(end.code(), absl::StatusCode::kInternal);
  EXPECT_NE(end.message().find("first failure"), absl::string_view::npos) << end;

  RetryBudget unlimited({std::nullopt, absl::InfiniteDuration()}, kT0);
  for (int i = 0; i < 1000; ++i) {
    ASSERT_TRUE(unlimited.Failed(absl::UnavailableError("x"), kT0 + absl::Hours(i)).ok());
  }
}

TEST(RetryBudgetTest, TheTimeBudgetEndsWithTheLastFailuresCode) {
  RetryBudget budget({std::nullopt, absl::Seconds(60)}, kT0);
  EXPECT_TRUE(budget.Failed(absl::UnavailableError("a"), kT0 + absl::Seconds(59)).ok());
  budget.Progress(kT0 + absl::Seconds(59));
  EXPECT_TRUE(budget.Failed(absl::UnavailableError("a"), kT0 + absl::Seconds(100)).ok());
  const absl::Status end =
      budget.Failed(absl::ResourceExhaustedError("queue full"), kT0 + absl::Seconds(120));
  EXPECT_EQ(end.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(end.message().find("no frame answered for 1m"), absl::string_view::npos) << end;
  EXPECT_NE(end.message().find("RESOURCE_EXHAUSTED: queue full"), absl::string_view::npos) << end;
}

// ---- Streamer against a server that always closes the stream ----------------

TEST(RetryBudgetStreamTest, StreamerGivesUpOnAFailureThatRepeats) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  StreamerOptions options = FastOptions();
  options.max_reconnects = 3;
  Streamer streamer(MakeChannel(fake.target()), options);
  int answered = 0;
  const auto start = std::chrono::steady_clock::now();
  const absl::Status status = streamer.Run(
      FakeFrames(4), [&](const StreamItem&, const v1::FrameResponse*, double) { ++answered; });
  const double seconds = SecondsSince(start);
  std::printf("[ figures  ] Streamer, max_reconnects 3, 5-20 ms backoff: gave up in %.3f s: %s\n",
              seconds, status.ToString().c_str());
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_NE(status.message().find(kClosedMessage), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find("4 attempts in a row"), absl::string_view::npos) << status;
  EXPECT_EQ(streamer.stats().connections, 4u);
  EXPECT_EQ(fake.service.stream_calls.load(), 4);
  EXPECT_EQ(answered, 0);
  EXPECT_LT(seconds, 10.0);
}

TEST(RetryBudgetStreamTest, StreamerGivesUpOnACodeThatRepeatsInOtherWords) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  fake.service.number_calls = true;
  StreamerOptions options = FastOptions();
  options.max_reconnects = 3;
  Streamer streamer(MakeChannel(fake.target()), options);
  const absl::Status status =
      streamer.Run(FakeFrames(2), [](const StreamItem&, const v1::FrameResponse*, double) {});
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_NE(status.message().find("(call 4); UNAVAILABLE on 4 attempts in a row"),
            absl::string_view::npos)
      << status;
  EXPECT_NE(status.message().find(absl::StrCat("the first of them: ", kClosedMessage, " (call 1)")),
            absl::string_view::npos)
      << status;
  EXPECT_EQ(fake.service.stream_calls.load(), 4);
}

TEST(RetryBudgetStreamTest, StreamerWaitsOutADrainingServer) {
  // lane-server's own "the server is draining": only the time budget ends it.
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                                  std::string(lane::wire::ServerDraining().message())));
  ASSERT_NE(fake.server, nullptr);
  StreamerOptions options = FastOptions();
  options.max_reconnects = 1;
  options.give_up_after = absl::Seconds(1);
  Streamer streamer(MakeChannel(fake.target()), options);
  const absl::Status status =
      streamer.Run(FakeFrames(2), [](const StreamItem&, const v1::FrameResponse*, double) {});
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  // Ended by the time budget, after more calls than the attempts budget
  // would have allowed had they counted (it allows 2).
  EXPECT_NE(status.message().find("no frame answered for 1s"), absl::string_view::npos) << status;
  EXPECT_GE(fake.service.stream_calls.load(), 2);
}

TEST(RetryBudgetStreamTest, StreamerKeepsTheCodeOfAFailingSessionStep) {
  // Every call fails, the session step first: the run ends with its code.
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage),
                     grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "too many sessions"));
  ASSERT_NE(fake.server, nullptr);
  StreamerOptions options = FastOptions();
  options.max_reconnects = 2;
  Streamer streamer(MakeChannel(fake.target()), options);
  const absl::Status status =
      streamer.Run(FakeFrames(2), [](const StreamItem&, const v1::FrameResponse*, double) {});
  EXPECT_EQ(status.code(), absl::StatusCode::kResourceExhausted) << status;
  EXPECT_NE(status.message().find("too many sessions"), absl::string_view::npos) << status;
  EXPECT_EQ(fake.service.session_calls.load(), 3);
  EXPECT_EQ(fake.service.stream_calls.load(), 0);
}

TEST(RetryBudgetStreamTest, StreamerTimeBudgetKeepsTheFailuresCode) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  StreamerOptions options = FastOptions();
  options.max_reconnects = std::nullopt;  // the time budget alone
  options.give_up_after = absl::Milliseconds(300);
  Streamer streamer(MakeChannel(fake.target()), options);
  const auto start = std::chrono::steady_clock::now();
  const absl::Status status =
      streamer.Run(FakeFrames(2), [](const StreamItem&, const v1::FrameResponse*, double) {});
  const double seconds = SecondsSince(start);
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable) << status;
  EXPECT_NE(status.message().find("no frame answered for 300ms"), absl::string_view::npos)
      << status;
  EXPECT_GE(seconds, 0.3);
  EXPECT_LT(seconds, 10.0);
}

TEST(RetryBudgetStreamTest, StreamerRefusesABadCameraIdBeforeAnyCall) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  for (const std::string& id : {std::string(65536, 'c'), std::string("cam 1"), std::string()}) {
    StreamerOptions options = FastOptions();
    options.camera_id = id;
    Streamer streamer(MakeChannel(fake.target()), options);
    const absl::Status status =
        streamer.Run(FakeFrames(2), [](const StreamItem&, const v1::FrameResponse*, double) {});
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_LT(status.message().size(), 200u);  // quotes an excerpt, never the id
    EXPECT_EQ(streamer.stats().connections, 0u);
  }
  EXPECT_EQ(fake.service.session_calls.load(), 0);
  EXPECT_EQ(fake.service.stream_calls.load(), 0);
}

// ---- lane-client stream and bench ---------------------------------------------

TEST(RetryBudgetCommandTest, StreamExitsWithTheRepeatedStatus) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  RetryTempDir frames;
  const std::string config = std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json";
  ::testing::internal::CaptureStderr();
  const auto start = std::chrono::steady_clock::now();
  const int code = RunCommand({"stream", "--target", fake.target(), "--camera", "cam", "--config",
                               config, "--max-reconnects", "3", "--quiet", "--output",
                               frames / "out.jsonl", frames.str()});
  const double seconds = SecondsSince(start);
  const std::string err = ::testing::internal::GetCapturedStderr();
  std::printf("[ figures  ] lane-client stream --max-reconnects 3: exit %d after %.3f s\n", code,
              seconds);
  EXPECT_EQ(code, kExitFailure) << err;
  EXPECT_NE(err.find(absl::StrCat("UNAVAILABLE: ", kClosedMessage)), std::string::npos) << err;
  EXPECT_NE(err.find("4 attempts in a row"), std::string::npos) << err;
  EXPECT_EQ(fake.service.stream_calls.load(), 4);
  // Backoff 100 + 200 + 400 ms (+-20 %), far from the 60 s time budget.
  EXPECT_LT(seconds, 10.0);
}

TEST(RetryBudgetCommandTest, StreamAndSessionRefuseABadCameraId) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  RetryTempDir frames;
  const std::string config = std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json";
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunCommand({"stream", "--target", fake.target(), "--camera", std::string(65536, 'c'),
                        "--config", config, "--output", frames / "out.jsonl", frames.str()}),
            kExitUsage);
  EXPECT_EQ(RunCommand({"stream", "--target", fake.target(), "--camera", "front left", "--config",
                        config, "--output", frames / "out.jsonl", frames.str()}),
            kExitUsage);
  EXPECT_EQ(RunCommand({"session", "get", "--target", fake.target(), "--camera", "cam#1"}),
            kExitUsage);
  EXPECT_EQ(RunCommand({"bench", "--target", fake.target(), "--camera-prefix", "bench cam ",
                        "--synthetic", "1", "--duration", "1s"}),
            kExitUsage);
  // The largest id, PREFIX999, would be 129 characters.
  EXPECT_EQ(RunCommand({"bench", "--target", fake.target(), "--camera-prefix",
                        std::string(126, 'b'), "--cameras", "1000", "--synthetic", "1"}),
            kExitUsage);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("camera_id must have 1 to 128 characters, got 65536"), std::string::npos)
      << err.substr(0, 2000);
  EXPECT_NE(err.find("has a character outside [A-Za-z0-9._:/-]"), std::string::npos)
      << err.substr(0, 2000);
  EXPECT_LT(err.size(), 8000u);  // the 64 KiB id is never echoed whole
  EXPECT_EQ(fake.service.session_calls.load(), 0);
  EXPECT_EQ(fake.service.stream_calls.load(), 0);
}

TEST(RetryBudgetCommandTest, BenchEndsEarlyWhenEveryCameraGaveUp) {
  ClosingServer fake(grpc::Status(grpc::StatusCode::UNAVAILABLE, kClosedMessage));
  ASSERT_NE(fake.server, nullptr);
  RetryTempDir out;
  ::testing::internal::CaptureStderr();
  const auto start = std::chrono::steady_clock::now();
  const int code =
      RunCommand({"bench", "--target", fake.target(), "--cameras", "2", "--max-reconnects", "2",
                  "--warmup", "0", "--duration", "60s", "--drain-timeout", "1s", "--synthetic", "1",
                  "--json", "--output", out / "report.json"});
  const double seconds = SecondsSince(start);
  const std::string err = ::testing::internal::GetCapturedStderr();
  std::printf(
      "[ figures  ] lane-client bench --max-reconnects 2 (2 cameras): exit %d after %.3f s\n", code,
      seconds);
  EXPECT_EQ(code, kExitFailure) << err;
  EXPECT_NE(err.find(absl::StrCat("UNAVAILABLE: ", kClosedMessage)), std::string::npos) << err;
  EXPECT_NE(err.find("3 attempts in a row"), std::string::npos) << err;
  EXPECT_EQ(fake.service.stream_calls.load(), 6);  // 3 per camera
  EXPECT_LT(seconds, 15.0);                        // not the 60 s asked for
  std::ifstream report(out / "report.json");
  const std::string json((std::istreambuf_iterator<char>(report)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("2 of 2 camera(s) gave up reconnecting"), std::string::npos) << json;
}

}  // namespace
}  // namespace lane::client
