// lane-client against a real lane-server on a loopback port, with real JPEG
// frames: the commands run in-process (lane::client::RunCommand) as the
// executable would run them. stream (results, raw and video frames,
// restarts), sessions, health, security and the command line; bench is in
// client_bench_test.cc.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <thread>
#include <vector>

#include "client_test_util.h"
#include "commands.h"
#include "common.h"
#include "frames.h"
#include "server.h"
#include "test_ca.h"

namespace lane::client {
namespace {

TEST(ClientUnitTest, SplitsTargets) {
  EXPECT_EQ(*SplitTargets("a:1"), std::vector<std::string>({"a:1"}));
  EXPECT_EQ(*SplitTargets("a:1, b:2,c:3"), std::vector<std::string>({"a:1", "b:2", "c:3"}));
  EXPECT_EQ(*SplitTargets("dns:///lanes.example:50051"),
            std::vector<std::string>({"dns:///lanes.example:50051"}));
  EXPECT_EQ(*SplitTargets("ipv4:127.0.0.1:1,127.0.0.1:2"),
            std::vector<std::string>({"ipv4:127.0.0.1:1,127.0.0.1:2"}));
  EXPECT_FALSE(SplitTargets("a:1,,b:2").ok());
}

TEST(ClientUnitTest, StemsLikeTheCli) {
  EXPECT_EQ(MakeStem("cordova1/f00001.png"), "cordova1_f00001");
  EXPECT_EQ(MakeStem("drive.mp4#000012"), "drive_000012");
  EXPECT_EQ(MakeStem("000003.jpg"), "000003");
}

TEST_F(ClientTest, StreamWritesOneResultPerFrameInOrder) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  const int code = RunCommand({"stream", "--target", Target(*server), "--camera", "cam0",
                               "--config", kConfig, "--output", out / "results.jsonl", "--overlay",
                               out / "overlays", frames_->str()});
  EXPECT_EQ(code, kExitOk);
  const std::vector<Json> lines = ReadJsonLines(out / "results.jsonl");
  ASSERT_EQ(lines.size(), static_cast<size_t>(kFrames));
  int with_lanes = 0;
  for (int i = 0; i < kFrames; ++i) {
    const Json& line = lines[static_cast<size_t>(i)];
    EXPECT_EQ(line["schema"], 1);
    EXPECT_EQ(line["frame"], names_[static_cast<size_t>(i)]);
    EXPECT_EQ(line["camera_id"], "cam0");
    EXPECT_EQ(line["frame_id"], i);
    EXPECT_EQ(line["status"], "OK") << line.dump();
    EXPECT_EQ(line["attempts"], 1);
    EXPECT_GT(line["capture_time_unix_ns"].get<int64_t>(), 0);
    EXPECT_GE(line["server_send_time_unix_ns"].get<int64_t>(),
              line["server_receive_time_unix_ns"].get<int64_t>());
    EXPECT_GT(line["calibration_version"].get<uint64_t>(), 0u);
    EXPECT_GT(line["timing_ms"]["detect"].get<double>(), 0);
    EXPECT_GE(line["latency_ms"].get<double>(), 0);
    for (const Json& lane : line["lanes"]) {
      for (const char* frame : {"image", "ipm", "ground"}) {
        ASSERT_EQ(lane[frame].size(), 4u);
        EXPECT_EQ(lane[frame][0].size(), 2u);
      }
    }
    if (!line["lanes"].empty()) ++with_lanes;
    const std::string stem = names_[static_cast<size_t>(i)].substr(0, 6);
    EXPECT_TRUE(fs::exists(out / ("overlays/" + stem + ".png")));
    EXPECT_TRUE(fs::exists(out / ("overlays/" + stem + "_ipm.png")));
  }
  EXPECT_GE(with_lanes, kFrames - 1);
  EXPECT_EQ(FramesProcessed(*server, "cam0"), static_cast<uint64_t>(kFrames));
}

// --raw sends pixels; an unreadable entry of a list keeps its place in the
// output as a CLIENT_ERROR record, and the run exits 1.
TEST_F(ClientTest, StreamRawKeepsUnreadableFramesInPlace) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  const std::string list = *frames_ / "with-missing.txt";
  {
    std::ofstream file(list);
    file << names_[0] << "\nmissing.jpg\n" << names_[1] << "\n";
  }
  const int code =
      RunCommand({"stream", "--target", Target(*server), "--camera", "raw0", "--config", kConfig,
                  "--raw", "--output", out / "results.jsonl", list});
  EXPECT_EQ(code, kExitFailure);
  const std::vector<Json> lines = ReadJsonLines(out / "results.jsonl");
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0]["frame"], names_[0]);
  EXPECT_EQ(lines[0]["status"], "OK");
  EXPECT_EQ(lines[1]["frame"], "missing.jpg");
  EXPECT_EQ(lines[1]["status"], "CLIENT_ERROR");
  EXPECT_EQ(lines[1]["frame_id"], 1);
  EXPECT_EQ(lines[2]["frame"], names_[1]);
  EXPECT_EQ(lines[2]["status"], "OK");
  EXPECT_EQ(lines[2]["frame_id"], 2);
}

// Video frames are decoded here and sent raw; they are named VIDEO#000123.
TEST_F(ClientTest, StreamSendsVideoFramesRaw) {
  TempDir out;
  const std::string video = out / "drive.avi";
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10,
                           cv::Size(640, 480));
    if (!writer.isOpened()) GTEST_SKIP() << "OpenCV cannot write an MJPG .avi here";
    for (int i = 0; i < 3; ++i) writer.write(cv::imread(*frames_ / names_[static_cast<size_t>(i)]));
  }
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  EXPECT_EQ(RunCommand({"stream", "--target", Target(*server), "--camera", "video", "--config",
                        kConfig, "--output", out / "results.jsonl", video}),
            kExitOk);
  const std::vector<Json> lines = ReadJsonLines(out / "results.jsonl");
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0]["frame"], "drive.avi#000000");
  EXPECT_EQ(lines[2]["frame"], "drive.avi#000002");
  for (const Json& line : lines) EXPECT_EQ(line["status"], "OK") << line.dump();
}

// Without --config the session must exist; it is found with GetSession.
TEST_F(ClientTest, StreamWithoutConfigNeedsASession) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  EXPECT_EQ(RunCommand({"stream", "--target", Target(*server), "--camera", "nobody", "--output",
                        out / "results.jsonl", frames_->str()}),
            kExitFailure);
  ASSERT_EQ(RunCommand({"session", "create", "--target", Target(*server), "--camera", "known",
                        "--config", kConfig}),
            kExitOk);
  EXPECT_EQ(RunCommand({"stream", "--target", Target(*server), "--camera", "known", "--output",
                        out / "results.jsonl", frames_->str()}),
            kExitOk);
  EXPECT_EQ(ReadJsonLines(out / "results.jsonl").size(), static_cast<size_t>(kFrames));
}

// The server stops mid-stream and a new one starts on the same port: every
// frame is answered exactly once, in order. `deadline` is the first server's
// shutdown deadline: 20 s lets it answer what it received (a drain), 0 cuts
// the frames in flight off.
void RunRestart(const std::string& list, const std::vector<std::string>& names, int total,
                absl::Duration deadline, bool expect_resends) {
  auto first = StartServer("127.0.0.1:0", deadline);
  ASSERT_NE(first, nullptr);
  const std::string target = Target(*first);
  TempDir out;
  std::atomic<int> code{-1};
  // A client window (16) above the server's in-flight bound (8): frames
  // written but not yet read by the server when it stops are resent.
  std::thread client([&] {
    code = RunCommand({"stream", "--target", target, "--camera", "cam", "--config", kConfig,
                       "--window", "16", "--retry-timeout", "60s", "--output",
                       out / "results.jsonl", list});
  });
  // A failed ASSERT returns early: the client thread is joined first (a
  // joinable std::thread's destructor would terminate the whole binary).
  struct Joiner {
    std::thread& thread;
    ~Joiner() {
      if (thread.joinable()) thread.join();
    }
  } joiner{client};
  ASSERT_TRUE(PollUntil([&] { return FramesProcessed(*first, "cam") >= 40; }));
  first->Drain();
  const uint64_t by_first = FramesProcessed(*first, "cam");
  first.reset();
  auto second = StartServer(target);  // same port; no session yet: the client re-creates it
  client.join();
  ASSERT_NE(second, nullptr);
  EXPECT_EQ(code.load(), kExitOk);
  EXPECT_LT(by_first, static_cast<uint64_t>(total)) << "the restart came too late";
  EXPECT_GT(FramesProcessed(*second, "cam"), 0u);
  const std::vector<Json> lines = ReadJsonLines(out / "results.jsonl");
  ASSERT_EQ(lines.size(), static_cast<size_t>(total));
  int resent = 0;
  for (int i = 0; i < total; ++i) {
    const Json& line = lines[static_cast<size_t>(i)];
    ASSERT_EQ(line["frame_id"], i);
    ASSERT_EQ(line["frame"], names[static_cast<size_t>(i) % names.size()]);
    ASSERT_EQ(line["status"], "OK") << line.dump();
    if (line["attempts"].get<int>() > 1) ++resent;
  }
  if (expect_resends) {
    EXPECT_GT(resent, 0);
  }
}

TEST_F(ClientTest, StreamSurvivesServerRestartAfterDrain) {
  RunRestart(RepeatList(50), names_, 50 * kFrames, absl::Seconds(20), /*expect_resends=*/true);
}

TEST_F(ClientTest, StreamSurvivesServerCuttingFramesOff) {
  RunRestart(RepeatList(50), names_, 50 * kFrames, absl::ZeroDuration(), /*expect_resends=*/false);
}

TEST_F(ClientTest, HealthExitsZeroOnlyWhenServing) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  const std::string target = Target(*server);
  EXPECT_EQ(RunCommand({"health", "--target", target}), kExitOk);
  server->BeginDrain();
  EXPECT_EQ(RunCommand({"health", "--target", target}), kExitFailure);  // NOT_SERVING
  server->Drain();
  server.reset();
  EXPECT_EQ(RunCommand({"health", "--target", target, "--timeout", "2s"}), kExitFailure);
}

TEST_F(ClientTest, SessionCommands) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  const std::string target = Target(*server);
  ::testing::internal::CaptureStdout();
  EXPECT_EQ(
      RunCommand({"session", "create", "--target", target, "--camera", "s1", "--config", kConfig}),
      kExitOk);
  EXPECT_EQ(
      RunCommand({"session", "create", "--target", target, "--camera", "s1", "--config", kConfig}),
      kExitOk);
  EXPECT_EQ(RunCommand({"session", "create", "--target", target, "--camera", "s1", "--config",
                        kConfig, "--mode", "two"}),
            kExitFailure);  // ALREADY_EXISTS without --replace
  EXPECT_EQ(RunCommand({"session", "get", "--target", target, "--camera", "s1"}), kExitOk);
  EXPECT_EQ(RunCommand({"session", "list", "--target", target}), kExitOk);
  EXPECT_EQ(RunCommand({"session", "delete", "--target", target, "--camera", "s1"}), kExitOk);
  EXPECT_EQ(RunCommand({"session", "get", "--target", target, "--camera", "s1"}), kExitFailure);
  const std::string output = ::testing::internal::GetCapturedStdout();
  std::vector<Json> lines;
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) lines.push_back(Json::parse(line));
  ASSERT_EQ(lines.size(), 5u) << output;
  EXPECT_EQ(lines[0]["outcome"], "CREATE_OUTCOME_CREATED");
  EXPECT_EQ(lines[1]["outcome"], "CREATE_OUTCOME_UNCHANGED");
  EXPECT_EQ(lines[2]["camera_id"], "s1");
  EXPECT_EQ(lines[2]["config"]["camera"]["image_width"], 640);
  EXPECT_EQ(lines[3]["sessions"].size(), 1u);
  EXPECT_EQ(lines[4]["deleted"], "s1");
  EXPECT_EQ(server->sessions().size(), 0u);
}

TEST(ClientSecurityTest, TakesSecurityOptionsOutOfTheCommandLine) {
  TempDir dir;
  const std::string token_file = (dir / "token");
  std::ofstream(token_file) << "  tok-123 \nignored\n";
  std::vector<std::string> args = {"list", "--token-file", token_file, "--target",
                                   "x",    "--",           "--ca",     "y"};
  absl::StatusOr<Security> security = TakeSecurityOptions(args);
  ASSERT_TRUE(security.ok()) << security.status();
  EXPECT_EQ(security->token, "tok-123");
  EXPECT_TRUE(security->ca_pem.empty());
  EXPECT_EQ(args, (std::vector<std::string>{"list", "--target", "x", "--", "--ca", "y"}));

  std::vector<std::string> missing = {"--ca=" + (dir / "none.pem")};
  EXPECT_FALSE(TakeSecurityOptions(missing).ok());
  std::vector<std::string> no_value = {"--token-file"};
  EXPECT_FALSE(TakeSecurityOptions(no_value).ok());
  std::vector<std::string> cert_only = {"--cert", token_file};
  EXPECT_FALSE(TakeSecurityOptions(cert_only).ok());
}

TEST(ClientSecurityTest, SendsTheBearerTokenOnEveryCommand) {
  lane::server::ServerOptions options;
  options.address = "127.0.0.1:0";
  options.metrics_address = "";
  options.workers = 2;
  options.auth_tokens = {"fleet-token"};
  options.build = lane::server::CurrentBuildInfo();
  auto server = lane::server::LaneServer::Start(options, std::make_shared<prometheus::Registry>());
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string target = Target(**server);
  TempDir dir;
  const std::string good = (dir / "good");
  const std::string bad = (dir / "bad");
  std::ofstream(good) << "fleet-token\n";
  std::ofstream(bad) << "guess\n";

  EXPECT_EQ(RunCommand({"session", "list", "--target", target}), kExitFailure);
  EXPECT_EQ(RunCommand({"session", "list", "--target", target, "--token-file", bad}), kExitFailure);
  EXPECT_EQ(RunCommand({"session", "list", "--target", target, "--token-file", good}), kExitOk);
  EXPECT_EQ(RunCommand({"info", "--token-file=" + good, "--target", target}), kExitOk);
  // Health needs no token.
  EXPECT_EQ(RunCommand({"health", "--target", target}), kExitOk);
  setenv("LANE_TOKEN", "fleet-token", 1);
  EXPECT_EQ(RunCommand({"session", "list", "--target", target}), kExitOk);
  unsetenv("LANE_TOKEN");
  EXPECT_EQ(RunCommand({"info", "--target", target}), kExitFailure);
  (*server)->Drain();
}

// TLS end to end: the client's --ca (and --cert/--key for mutual TLS)
// against lane-server's certificate flags, with a CA made by openssl now.
TEST_F(ClientTest, StreamAndSessionsOverTls) {
  const lane::testing::TestCa ca;
  if (!ca.ok()) GTEST_SKIP() << "no test CA: " << ca.error();
  for (const bool mutual : {false, true}) {
    SCOPED_TRACE(mutual ? "mutual TLS" : "TLS");
    lane::server::ServerOptions options;
    options.address = "127.0.0.1:0";
    options.metrics_address = "";
    options.workers = 2;
    options.tls_cert_path = ca.Path("server.crt");
    options.tls_key_path = ca.Path("server.key");
    if (mutual) options.tls_client_ca_path = ca.Path("ca.crt");
    options.build = lane::server::CurrentBuildInfo();
    auto server =
        lane::server::LaneServer::Start(options, std::make_shared<prometheus::Registry>());
    ASSERT_TRUE(server.ok()) << server.status();
    const std::string target = Target(**server);
    std::vector<std::string> tls = {"--ca", ca.Path("ca.crt")};
    if (mutual) {
      tls.insert(tls.end(), {"--cert", ca.Path("client.crt"), "--key", ca.Path("client.key")});
    }
    const auto with = [](std::vector<std::string> args, const std::vector<std::string>& extra) {
      args.insert(args.end(), extra.begin(), extra.end());
      return args;
    };
    // Plaintext, and (mutual) TLS without a client certificate, are refused.
    EXPECT_EQ(RunCommand({"session", "list", "--target", target}), kExitFailure);
    if (mutual) {
      EXPECT_EQ(RunCommand({"session", "list", "--target", target, "--ca", ca.Path("ca.crt")}),
                kExitFailure);
    }
    EXPECT_EQ(RunCommand(with({"session", "list", "--target", target}, tls)), kExitOk);
    EXPECT_EQ(RunCommand(with({"health", "--target", target}, tls)), kExitOk);
    TempDir out;
    EXPECT_EQ(RunCommand(with({"stream", "--target", target, "--camera", "tls-cam", "--config",
                               kConfig, "--output", out / "results.jsonl", frames_->str()},
                              tls)),
              kExitOk);
    const std::vector<Json> lines = ReadJsonLines(out / "results.jsonl");
    ASSERT_EQ(lines.size(), static_cast<size_t>(kFrames));
    for (const Json& line : lines) EXPECT_EQ(line["status"], "OK") << line.dump();
    EXPECT_EQ(FramesProcessed(**server, "tls-cam"), static_cast<uint64_t>(kFrames));
    (*server)->Drain();
  }
}

TEST(ClientUsageTest, BadCommandLinesExitTwo) {
  EXPECT_EQ(RunCommand({}), kExitUsage);
  EXPECT_EQ(RunCommand({"nope"}), kExitUsage);
  EXPECT_EQ(RunCommand({"stream"}), kExitUsage);
  EXPECT_EQ(RunCommand({"bench", "--fps", "10", "--window", "2"}), kExitUsage);
  EXPECT_EQ(RunCommand({"bench", "--fps", "10", "--inflight", "2"}), kExitUsage);  // old spelling
  EXPECT_EQ(RunCommand({"bench", "--sweep", "1,x"}), kExitUsage);
  EXPECT_EQ(RunCommand({"session", "get"}), kExitUsage);
  EXPECT_EQ(RunCommand({"info", "--token-file"}), kExitUsage);
  EXPECT_EQ(RunCommand({"info", "--ca", "/nonexistent/ca.pem"}), kExitUsage);
  EXPECT_EQ(RunCommand({"session", "nope"}), kExitUsage);
  EXPECT_EQ(RunCommand({"stream", "--window", "0", "x.jpg"}), kExitUsage);
  EXPECT_EQ(RunCommand({"stream", "--max-inflight-frames", "-1", "x.jpg"}), kExitUsage);
  EXPECT_EQ(RunCommand({"bench", "--duration", "soon"}), kExitUsage);
  EXPECT_EQ(RunCommand({"bench", "--json", "--csv"}), kExitUsage);
  EXPECT_EQ(RunCommand({"bench", "--cameras", "2", "--sweep", "1,2"}), kExitUsage);
}

TEST(ClientUsageTest, HelpAndVersionExitZero) {
  ::testing::internal::CaptureStdout();
  EXPECT_EQ(RunCommand({"--help"}), kExitOk);
  EXPECT_EQ(RunCommand({"help"}), kExitOk);
  EXPECT_EQ(RunCommand({"bench", "--help"}), kExitOk);
  EXPECT_EQ(RunCommand({"session", "create", "--help"}), kExitOk);
  EXPECT_EQ(RunCommand({"--version"}), kExitOk);
  const std::string out = ::testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("--max-inflight-frames"), std::string::npos) << out;
  EXPECT_NE(out.find("Security (every command)"), std::string::npos) << out;
  EXPECT_NE(out.find("lane-client 0."), std::string::npos) << out;
  // The old spellings are aliases, not shown in --help.
  EXPECT_EQ(out.find("--session-inflight"), std::string::npos) << out;
  EXPECT_EQ(out.find("--inflight"), std::string::npos) << out;
}

// The spellings before the renames (--inflight, --session-inflight) still
// work, as hidden aliases of --window and --max-inflight-frames.
TEST_F(ClientTest, OldFlagSpellingsAreAliases) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  EXPECT_EQ(RunCommand({"bench", "--target", Target(*server), "--cameras", "1", "--inflight", "3",
                        "--session-inflight", "2", "--warmup", "0", "--duration", "300ms",
                        "--synthetic", "2", "--json", "--output", out / "report.json"}),
            kExitOk);
  EXPECT_EQ(ReadJson(out / "report.json")["inflight_per_camera"], 3);
  EXPECT_EQ(RunCommand({"stream", "--target", Target(*server), "--camera", "old", "--config",
                        kConfig, "--inflight", "2", "--session-inflight", "4", "--output",
                        out / "results.jsonl", frames_->str()}),
            kExitOk);
  EXPECT_EQ(ReadJsonLines(out / "results.jsonl").size(), static_cast<size_t>(kFrames));
  const auto session = server->sessions().Find("old");
  ASSERT_NE(session, nullptr);
  EXPECT_EQ(session->stream.max_inflight_frames, 4u);
}

}  // namespace
}  // namespace lane::client
