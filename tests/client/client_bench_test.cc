// lane-client bench against a real lane-server on a loopback port (the
// command run in-process, as the executable would run it): closed and open
// loops, reports (JSON, CSV, HTML), targets, drops, timelines; and the unit
// tests of the load generator's parts.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "bench.h"
#include "bench_report.h"
#include "client_test_util.h"
#include "commands.h"
#include "common.h"
#include "wire/config_proto.h"

namespace lane::client {
namespace {

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

// The --html page: self-contained, with both charts and the run's figures.
void ExpectSelfContainedHtml(const std::string& path, const Json& run) {
  std::ifstream html_file(path);
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
}

// The in-process reference of a closed-loop run with --inprocess.
void ExpectTrackedInprocessReference(const Json& report, const Json& run) {
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
  ExpectSelfContainedHtml(out / "report.html", run);
  ExpectTrackedInprocessReference(report, run);
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

}  // namespace
}  // namespace lane::client
