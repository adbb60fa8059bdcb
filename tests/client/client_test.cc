// lane-client against a real lane-server on a loopback port, with real JPEG
// frames: the commands run in-process (lane_client::RunCommand) as the
// executable would run them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "bench.h"
#include "bench_report.h"
#include "commands.h"
#include "common.h"
#include "frames.h"
#include "lane/config/config.h"
#include "lane/synthetic.h"
#include "server.h"
#include "test_ca.h"
#include "wire/config_proto.h"

namespace lane_client {
namespace {

namespace fs = std::filesystem;
namespace v1 = lane::v1;
using Json = nlohmann::json;

const std::string kConfig = std::string(LANE_SOURCE_DIR) + "/configs/synthetic.json";
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

std::unique_ptr<lane::server::LaneServer> StartServer(
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

std::string Target(const lane::server::LaneServer& server) {
  return "127.0.0.1:" + std::to_string(server.port());
}

uint64_t FramesProcessed(lane::server::LaneServer& server, const std::string& camera) {
  const auto session = server.sessions().Find(camera);
  return session ? session->frames_processed.load() : 0;
}

std::vector<Json> ReadJsonLines(const std::string& path) {
  std::vector<Json> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) out.push_back(Json::parse(line));
  return out;
}

Json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return Json::parse(in);
}

template <typename F>
bool PollUntil(F condition, double timeout_s = 30) {
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

  static TempDir* frames_;
  static std::vector<std::string> names_;
};

TempDir* ClientTest::frames_ = nullptr;
std::vector<std::string> ClientTest::names_;

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

// The bench writes a small header and the frame's pre-serialized bytes one
// after the other: the server must parse that as one request.
TEST(ClientUnitTest, HeaderAndImagePartMakeOneRequest) {
  lane::CameraModel camera;
  const auto frames = SyntheticBenchFrames(camera, 1, /*raw=*/false, 90);
  ASSERT_TRUE(frames.ok()) << frames.status();
  v1::FrameRequest header;
  header.set_camera_id("cam");
  header.set_frame_id(42);
  header.set_capture_time_unix_ns(7);
  v1::FrameRequest parsed;
  ASSERT_TRUE(parsed.ParseFromString(header.SerializeAsString() + frames->front().image_part));
  EXPECT_EQ(parsed.camera_id(), "cam");
  EXPECT_EQ(parsed.frame_id(), 42u);
  EXPECT_EQ(parsed.capture_time_unix_ns(), 7);
  EXPECT_EQ(parsed.encoded(), frames->front().request.encoded());
}

// The in-process reference does the session's work: with tracking (the
// default) each measured frame goes through a tracker, without it none does.
TEST(ClientUnitTest, InprocessReferenceTracksLikeTheSession) {
  lane::CameraModel camera;
  const auto frames = SyntheticBenchFrames(camera, 2, /*raw=*/false, 90);
  ASSERT_TRUE(frames.ok()) << frames.status();
  lane::Config config;
  config.camera = camera;
  v1::SessionConfig session;
  lane::wire::ConfigToProto(config, &session);
  for (const bool disabled : {false, true}) {
    session.mutable_tracking()->set_disabled(disabled);
    const absl::StatusOr<InprocessResult> result =
        RunInprocess(*frames, session, 1, absl::ZeroDuration(), absl::Milliseconds(300), nullptr);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_GT(result->frames, 0u);
    EXPECT_EQ(result->tracked, !disabled);
    EXPECT_EQ(result->tracked_frames, disabled ? 0u : result->frames);
  }
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

void ExpectConsistentRun(const Json& run) {
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

TEST_F(ClientTest, BenchClosedLoopJsonReport) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  const int code = RunCommand({"bench",
                               "--target",
                               Target(*server),
                               "--cameras",
                               "2",
                               "--window",
                               "2",
                               "--warmup",
                               "300ms",
                               "--duration",
                               "1.5s",
                               "--synthetic",
                               "6",
                               "--inprocess",
                               "--json",
                               "--slo-p99-ms",
                               "10000",
                               "--output",
                               out / "report.json",
                               "--html",
                               out / "report.html"});
  EXPECT_EQ(code, kExitOk);
  const Json report = ReadJson(out / "report.json");
  EXPECT_EQ(report["schema"], 1);
  EXPECT_EQ(report["mode"], "closed");
  EXPECT_EQ(report["inflight_per_camera"], 2);
  EXPECT_TRUE(report["fps_per_camera"].is_null());
  EXPECT_EQ(report["frames"]["encoding"], "jpeg");
  EXPECT_EQ(report["frames"]["width"], 640);
  EXPECT_EQ(report["frames"]["height"], 480);
  ASSERT_EQ(report["runs"].size(), 1u);
  const Json& run = report["runs"][0];
  EXPECT_EQ(run["cameras"], 2);
  EXPECT_TRUE(run["target_fps"].is_null());
  EXPECT_GT(run["frames_sent"].get<uint64_t>(), 0u);
  EXPECT_GT(run["frames_ok"].get<uint64_t>(), 0u);
  EXPECT_EQ(run["errors_total"], 0);
  ExpectConsistentRun(run);
  EXPECT_GT(run["server_ms"]["p50"].get<double>(), 0);
  // The server's split: every OK frame's queue, decode and detect times, each
  // below its whole server time.
  for (const char* part : {"server_queue_ms", "server_decode_ms", "server_detect_ms"}) {
    EXPECT_EQ(run[part]["count"], run["frames_ok"]) << part;
    EXPECT_LE(run[part]["p50"].get<double>(), run["server_ms"]["max"].get<double>()) << part;
  }
  EXPECT_GT(run["server_detect_ms"]["p50"].get<double>(), 0);
  EXPECT_TRUE(run["warnings"].is_array());
  EXPECT_TRUE(run.find("timeline") == run.end());  // computed, printed only with --timeline
  EXPECT_NE(report["meta"]["server_version"].get<std::string>().find(
                lane::server::CurrentBuildInfo().version),
            std::string::npos);
  EXPECT_NE(report["meta"]["command_line"].get<std::string>().find("client_test"),
            std::string::npos);
  EXPECT_FALSE(report["meta"]["date_utc"].get<std::string>().empty());
  // The HTML page: self-contained, with both charts and the run's figures.
  std::ifstream html_file(out / "report.html");
  const std::string html((std::istreambuf_iterator<char>(html_file)),
                         std::istreambuf_iterator<char>());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("aria-label=\"latency over time\""), std::string::npos);
  EXPECT_NE(html.find("aria-label=\"latency histogram\""), std::string::npos);
  EXPECT_NE(html.find("<polyline"), std::string::npos);
  // The page prints the unrounded p95 to 2 decimals, the JSON holds it
  // rounded to 3: the page's figure is one of the JSON value's +-0.0005.
  const double p95 = run["latency_ms"]["p95"].get<double>();
  bool p95_shown = false;
  for (const double v : {p95 - 0.0005, p95, p95 + 0.0005}) {
    p95_shown = p95_shown || html.find(absl::StrFormat("<td>%.2f</td>", v)) != std::string::npos;
  }
  EXPECT_TRUE(p95_shown) << "p95 " << p95 << " not in the HTML table";
  EXPECT_EQ(html.find(" src="), std::string::npos);
  EXPECT_EQ(html.find(" href="), std::string::npos);
  EXPECT_NE(html.find("</html>"), std::string::npos);
  EXPECT_EQ(report["inprocess"]["workers"], 2);  // the server's, from GetServerInfo
  EXPECT_GT(report["inprocess"]["fps"].get<double>(), 0);
  // The bench's sessions track their streams (the default), so the reference
  // tracked every measured frame as the server did.
  EXPECT_EQ(report["inprocess"]["tracked"], true);
  EXPECT_EQ(report["inprocess"]["tracked_frames"], report["inprocess"]["frames"]);
  // It ran in two halves, before and after the service.
  EXPECT_GT(report["inprocess"]["fps_before"].get<double>(), 0);
  EXPECT_GT(report["inprocess"]["fps_after"].get<double>(), 0);
  EXPECT_GT(run["service_vs_inprocess"].get<double>(), 0);
  // CPU per frame: the server's (its ServerInfo.process_cpu_seconds over the
  // run; here the server runs in the test's own process, so the figure also
  // holds the client's share) and the in-process reference's.
  ASSERT_TRUE(run["server_cpu_ms_per_frame"].is_number()) << run.dump();
  EXPECT_GT(run["server_cpu_ms_per_frame"].get<double>(), 0);
  EXPECT_GT(report["inprocess"]["cpu_ms_per_frame"].get<double>(), 0);
  EXPECT_GT(run["server_cpu_vs_inprocess"].get<double>(), 0);
  EXPECT_EQ(run["slo_met"], true);
  EXPECT_EQ(report["slo_met"], true);
  // The sessions are deleted at the end.
  EXPECT_EQ(server->sessions().size(), 0u);
}

TEST_F(ClientTest, BenchOpenLoopSweepCsvAndSloBreach) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  const int code = RunCommand({"bench", "--target", Target(*server), "--sweep", "1,2", "--fps",
                               "25", "--warmup", "200ms", "--duration", "1s", "--synthetic", "4",
                               "--json", "--slo-p99-ms", "0.001", "--output", out / "report.json"});
  EXPECT_EQ(code, kExitSlo);
  const Json report = ReadJson(out / "report.json");
  EXPECT_EQ(report["mode"], "open");
  EXPECT_EQ(report["fps_per_camera"], 25.0);
  ASSERT_EQ(report["runs"].size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const Json& run = report["runs"][i];
    const int cameras = static_cast<int>(i) + 1;
    EXPECT_EQ(run["cameras"], cameras);
    EXPECT_EQ(run["target_fps"], 25.0 * cameras);
    // 1 s at 25 fps per camera on an absolute schedule.
    EXPECT_NEAR(run["frames_scheduled"].get<double>(), 25.0 * cameras, 1.0 * cameras);
    ExpectConsistentRun(run);
    EXPECT_EQ(run["slo_met"], false);
  }
  EXPECT_EQ(report["slo_met"], false);

  const int csv_code = RunCommand({"bench", "--target", Target(*server), "--cameras", "1",
                                   "--warmup", "0", "--duration", "300ms", "--synthetic", "2",
                                   "--csv", "--output", out / "report.csv"});
  EXPECT_EQ(csv_code, kExitOk);
  std::ifstream csv(out / "report.csv");
  std::string header;
  std::string row;
  std::getline(csv, header);
  std::getline(csv, row);
  EXPECT_EQ(header.rfind("mode,cameras,", 0), 0u) << header;
  EXPECT_EQ(row.rfind("closed,1,", 0), 0u) << row;
  // The CSV has the JSON's run fields, flattened: latency_ms.p95 is
  // latency_p95_ms, server_decode_ms.p50 is server_decode_p50_ms.
  const std::vector<std::string> columns = absl::StrSplit(header, ',');
  const std::set<std::string> column_set(columns.begin(), columns.end());
  const Json& json_run = report["runs"][0];
  for (const auto& [key, value] : json_run.items()) {
    if (key == "timeline") continue;
    if (value.is_object() && value.contains("p50")) {
      const std::string prefix = key.substr(0, key.size() - 3);  // drop "_ms"
      for (const auto& [field, unused] : value.items()) {
        const std::string column =
            field == "count" ? prefix + "_count" : prefix + "_" + field + "_ms";
        EXPECT_EQ(column_set.count(column), 1u) << column;
      }
    } else {
      EXPECT_EQ(column_set.count(key), 1u) << key;
    }
  }
}

// Warnings: a ratio over 100 %, a timeline whose intervals disagree, too few
// frames for the tail; none for a steady run.
TEST(BenchReportTest, WarningsSayWhyFiguresMayNotBeTrusted) {
  Report report;
  LoadResult run;
  run.achieved_fps = 500;
  run.latency_ms.count = 5000;
  for (int i = 0; i < 6; ++i) {
    TimelinePoint p;
    p.start_s = i * 0.5;
    p.end_s = p.start_s + 0.5;
    p.ok = 250;
    p.latency_ms.count = 250;
    p.latency_ms.p50 = 4;
    run.timeline.push_back(p);
  }
  EXPECT_TRUE(Warnings(report, run).empty());
  InprocessResult inprocess;
  inprocess.fps = 400;
  report.inprocess = inprocess;
  ASSERT_EQ(Warnings(report, run).size(), 1u);
  EXPECT_NE(Warnings(report, run)[0].find("over 100 %"), std::string::npos);
  report.inprocess->fps = 1000;
  run.timeline[2].ok = 100;
  run.timeline[3].latency_ms.p50 = 20;
  const std::vector<std::string> moved = Warnings(report, run);
  ASSERT_EQ(moved.size(), 2u);
  EXPECT_NE(moved[0].find("throughput moved"), std::string::npos);
  EXPECT_NE(moved[1].find("median latency moved"), std::string::npos);
  // The last interval also holds the drain: it does not count.
  run.timeline[2].ok = 250;
  run.timeline[3].latency_ms.p50 = 4;
  run.timeline.back().ok = 3;
  EXPECT_TRUE(Warnings(report, run).empty());
  run.latency_ms.count = 200;
  ASSERT_EQ(Warnings(report, run).size(), 1u);
  EXPECT_NE(Warnings(report, run)[0].find("200 frames measured"), std::string::npos);
  run.latency_ms.count = 5000;
  // The reference's two halves: within 1.25x of each other no warning, past
  // it one that gives both figures.
  report.inprocess->fps_before = 1000;
  report.inprocess->fps_after = 1240;
  EXPECT_TRUE(Warnings(report, run).empty());
  report.inprocess->fps_after = 1260;
  ASSERT_EQ(Warnings(report, run).size(), 1u);
  EXPECT_NE(Warnings(report, run)[0].find("1000.0 frames/s before the service and 1260.0 after"),
            std::string::npos);
}

// The reference's halves make one figure: frames and samples added, frames/s
// over both durations.
TEST(BenchReportTest, InprocessHalvesCombine) {
  InprocessResult a;
  a.workers = 2;
  a.frames = 300;
  a.fps = 100;
  a.tracked = true;
  a.tracked_frames = 300;
  a.latency_samples = {1, 2, 3};
  InprocessResult b = a;
  b.frames = 100;
  b.fps = 50;
  b.tracked_frames = 100;
  b.latency_samples = {10};
  const InprocessResult c = CombineInprocess(a, b, absl::Seconds(3), absl::Seconds(2));
  EXPECT_EQ(c.workers, 2);
  EXPECT_EQ(c.frames, 400u);
  EXPECT_DOUBLE_EQ(c.fps, 80);  // 400 frames in 5 s, not the mean of 100 and 50
  EXPECT_EQ(c.fps_before, 100);
  EXPECT_EQ(c.fps_after, 50);
  EXPECT_TRUE(c.tracked);
  EXPECT_EQ(c.tracked_frames, 400u);
  EXPECT_EQ(c.latency_ms.count, 4u);
  EXPECT_EQ(c.latency_ms.max, 10);
  EXPECT_EQ(c.latency_ms.p50, 2);
}

// A comma list of targets: camera i goes to target i mod 2.
TEST_F(ClientTest, BenchSpreadsCamerasOverTargets) {
  auto a = StartServer("127.0.0.1:0");
  auto b = StartServer("127.0.0.1:0");
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  TempDir out;
  const std::string targets = Target(*a) + "," + Target(*b);
  EXPECT_EQ(RunCommand({"bench", "--target", targets, "--cameras", "4", "--warmup", "0",
                        "--duration", "500ms", "--synthetic", "2", "--keep-sessions", "--json",
                        "--output", out / "report.json"}),
            kExitOk);
  const Json report = ReadJson(out / "report.json");
  const Json& run = report["runs"][0];
  ExpectConsistentRun(run);
  ASSERT_EQ(run["ok_by_target"].size(), 2u) << run.dump();
  EXPECT_GT(run["ok_by_target"][Target(*a)].get<uint64_t>(), 0u);
  EXPECT_GT(run["ok_by_target"][Target(*b)].get<uint64_t>(), 0u);
  // Cameras 0 and 2 on the first server, 1 and 3 on the second.
  EXPECT_GT(FramesProcessed(*a, "bench-0"), 0u);
  EXPECT_GT(FramesProcessed(*a, "bench-2"), 0u);
  EXPECT_GT(FramesProcessed(*b, "bench-1"), 0u);
  EXPECT_GT(FramesProcessed(*b, "bench-3"), 0u);
  EXPECT_EQ(FramesProcessed(*a, "bench-1"), 0u);
}

// drop_oldest with one frame in flight and far more frames than the server
// can take: the server drops, the report counts the drops, and the counts
// still add up.
TEST_F(ClientTest, BenchCountsDroppedFrames) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  const int code = RunCommand({"bench",
                               "--target",
                               Target(*server),
                               "--cameras",
                               "1",
                               "--fps",
                               "1500",
                               "--warmup",
                               "0",
                               "--duration",
                               "1s",
                               "--synthetic",
                               "4",
                               "--backpressure",
                               "drop_oldest",
                               "--max-inflight-frames",
                               "1",
                               "--json",
                               "--output",
                               out / "report.json"});
  EXPECT_EQ(code, kExitOk);
  const Json run = ReadJson(out / "report.json")["runs"][0];
  EXPECT_GT(run["dropped"].get<uint64_t>(), 0u) << run.dump();
  ExpectConsistentRun(run);
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

// --timeline splits the measured window into intervals that add up to the
// run's totals.
TEST_F(ClientTest, BenchTimelineAddsUpToTheRun) {
  auto server = StartServer("127.0.0.1:0");
  ASSERT_NE(server, nullptr);
  TempDir out;
  const int code = RunCommand({"bench", "--target", Target(*server), "--cameras", "2", "--fps",
                               "20", "--warmup", "200ms", "--duration", "2s", "--timeline", "500ms",
                               "--synthetic", "4", "--json", "--output", out / "report.json"});
  EXPECT_EQ(code, kExitOk);
  const Json report = ReadJson(out / "report.json");
  ASSERT_EQ(report["runs"].size(), 1u);
  const Json& run = report["runs"][0];
  ASSERT_TRUE(run.contains("timeline")) << run.dump();
  const Json& timeline = run["timeline"];
  // 2 s in 500 ms intervals; the window stretches to the last answer when the
  // drain runs late (a loaded machine, a sanitizer build), adding intervals.
  const double measured_s = run["measured_s"].get<double>();
  EXPECT_GE(measured_s, 2.0);
  ASSERT_GE(timeline.size(), 4u);
  // Every interval is 500 ms but the last, which ends with the window.
  EXPECT_NEAR(timeline.back()["end_s"].get<double>(), measured_s, 2e-3);
  EXPECT_GT(timeline.back()["end_s"].get<double>() - timeline.back()["start_s"].get<double>(), 0);
  for (size_t i = 0; i + 1 < timeline.size(); ++i) {
    EXPECT_NEAR(timeline[i]["end_s"].get<double>(), 0.5 * static_cast<double>(i + 1), 2e-3);
  }
  uint64_t ok = 0, errors = 0;
  double previous_end = 0;
  for (const Json& point : timeline) {
    EXPECT_DOUBLE_EQ(point["start_s"].get<double>(), previous_end);
    previous_end = point["end_s"].get<double>();
    ok += point["frames_ok"].get<uint64_t>();
    errors += point["errors"].get<uint64_t>();
    // Frames are sent during the window only; the intervals of a late drain
    // may be empty.
    if (point["end_s"].get<double>() <= 2.0 + 1e-9) {
      EXPECT_GT(point["frames_ok"].get<uint64_t>(), 0u) << point.dump();
    }
    EXPECT_LE(point["latency_ms"]["p99"].get<double>(), run["latency_ms"]["max"].get<double>());
  }
  EXPECT_EQ(ok, run["frames_ok"].get<uint64_t>());
  EXPECT_EQ(errors, run["errors_total"].get<uint64_t>() + run["dropped"].get<uint64_t>());
  EXPECT_EQ(RunCommand({"bench", "--timeline", "0s"}), kExitUsage);
}

TEST(ClientUnitTest, TimelineBucketsByArrival) {
  // Latencies 1..10 ms arriving at 0.0, 0.1, ... 0.9 s; errors at 0.05 and
  // 2.5 s (after the window: the last interval).
  std::vector<double> latency;
  std::vector<float> at;
  for (int i = 0; i < 10; ++i) {
    latency.push_back(i + 1);
    at.push_back(0.1f * static_cast<float>(i));
  }
  const std::vector<TimelinePoint> points = Timeline(latency, at, {0.05f, 2.5f}, 0.5, 1.2);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_DOUBLE_EQ(points[2].start_s, 1.0);
  EXPECT_DOUBLE_EQ(points[2].end_s, 1.2);
  EXPECT_EQ(points[0].ok, 5u);
  EXPECT_EQ(points[1].ok, 5u);
  EXPECT_EQ(points[2].ok, 0u);
  EXPECT_EQ(points[0].errors, 1u);
  EXPECT_EQ(points[2].errors, 1u);
  EXPECT_DOUBLE_EQ(points[0].latency_ms.max, 5);
  EXPECT_DOUBLE_EQ(points[1].latency_ms.max, 10);
  EXPECT_GE(points[1].latency_ms.p50, 7);
  EXPECT_LE(points[1].latency_ms.p50, 8);
  EXPECT_TRUE(Timeline(latency, at, {}, 0, 1).empty());
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
}  // namespace lane_client
