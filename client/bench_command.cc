// `lane-client bench`: load against the service with per-frame latency, and
// the in-process reference. The report's fields are in docs/client.md.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "bench.h"
#include "commands.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "session_config.h"
#include "wire/config_proto.h"
#include "wire/frame_decoder.h"

namespace lane_client {
namespace {

namespace v1 = lane::v1;
using Json = nlohmann::ordered_json;

inline constexpr int kBenchReportSchema = 1;

constexpr char kUsage[] =
    "usage: lane-client bench [options] [INPUT...]\n"
    "\n"
    "Load-tests the service with N concurrent camera streams, each with its own\n"
    "session (camera ids PREFIX0, PREFIX1, ...), and times every frame: its send\n"
    "time is matched with its response by frame_id. Frames come from INPUT (as\n"
    "for `stream`, read into memory first) or are rendered: synthetic road frames\n"
    "of the session camera's size, JPEG-encoded.\n"
    "\n"
    "load:\n"
    "  --cameras N          concurrent camera streams (default 1)\n"
    "  --sweep LIST         one run per camera count, e.g. 1,2,4,8,16\n"
    "  --inflight K         closed loop: at most K frames in flight per camera\n"
    "                       (default 2)\n"
    "  --fps R              open loop instead: R frames/s per camera on an absolute\n"
    "                       schedule; latency counts from the scheduled time\n"
    "  --warmup D           discarded warm-up (default 2s)\n"
    "  --duration D         measured time (default 10s)\n"
    "  --drain-timeout D    wait for the last answers this long (default 10s)\n"
    "  --timeline D         also report each interval D of the measured time:\n"
    "                       answers, errors and latency percentiles (for soaks)\n"
    "frames:\n"
    "  --synthetic N        render N synthetic frames (default 50; without INPUT)\n"
    "  --jpeg-quality Q     JPEG quality of the synthetic frames (default 90)\n"
    "  --raw                send decoded BGR pixels instead of JPEG/PNG bytes\n"
    "  --max-frames N       frames read from INPUT at most (default 200)\n"
    "targets and sessions:\n"
    "  --target T           host:port, a comma list a:1,b:2 (cameras spread over\n"
    "                       them in turn) or dns:///name (round_robin over its\n"
    "                       addresses) (default 127.0.0.1:50051)\n"
    "  --connections C      gRPC channels (TCP connections) per target, shared by\n"
    "                       its cameras (default: one per camera)\n"
    "  --camera-prefix P    camera id prefix (default \"bench-\")\n"
    "%s"
    "  --replace            replace sessions with a different config\n"
    "  --keep-sessions      do not delete the sessions at the end\n"
    "reference and report:\n"
    "  --inprocess          also run the same decode + detect on the same frames\n"
    "                       without gRPC, on the server's number of workers, and\n"
    "                       report service / in-process throughput\n"
    "  --workers W          worker threads of the in-process run (default: the\n"
    "                       server's, from GetServerInfo)\n"
    "  --json, --csv        report as JSON or CSV instead of text\n"
    "  --output FILE        write the report to FILE instead of stdout\n"
    "  --slo-p99-ms X       exit status 3 when a run's p99 latency exceeds X ms\n"
    "  -h, --help           show this help\n"
    "\n"
    "A progress line is shown on stderr when it is a terminal.\n"
    "Exit status: 0, 1 on an error (no session, no frames), 2 for a bad command\n"
    "line, 3 when --slo-p99-ms is breached.\n";

std::string Usage() {
  char buffer[8192];
  std::snprintf(buffer, sizeof(buffer), kUsage, kSessionConfigUsage);
  return buffer;
}

double Round3(double v) { return std::round(v * 1e3) / 1e3; }

Json LatencyJson(const LatencySummary& s) {
  Json j = Json::object();
  j["count"] = s.count;
  j["p50"] = Round3(s.p50);
  j["p90"] = Round3(s.p90);
  j["p99"] = Round3(s.p99);
  j["p999"] = Round3(s.p999);
  j["max"] = Round3(s.max);
  j["mean"] = Round3(s.mean);
  return j;
}

struct FramesInfo {
  std::string source;    // "synthetic" or "inputs"
  std::string encoding;  // "jpeg", "png", "raw" or "mixed"
  double mean_bytes = 0;
  int width = 0;
  int height = 0;
};

FramesInfo DescribeFrames(const std::vector<BenchFrame>& frames, const std::string& source) {
  FramesInfo info;
  info.source = source;
  double bytes = 0;
  for (const BenchFrame& frame : frames) {
    std::string kind = "raw";
    if (frame.request.has_raw()) {
      info.width = static_cast<int>(frame.request.raw().width());
      info.height = static_cast<int>(frame.request.raw().height());
    } else if (auto header = lane::wire::ReadEncodedHeader(frame.request.encoded()); header.ok()) {
      kind = header->format == lane::wire::EncodedFormat::kJpeg ? "jpeg" : "png";
      info.width = header->width;
      info.height = header->height;
    }
    if (info.encoding.empty()) info.encoding = kind;
    if (info.encoding != kind) info.encoding = "mixed";
    bytes += static_cast<double>(frame.image_part.size());
  }
  info.mean_bytes = frames.empty() ? 0 : bytes / static_cast<double>(frames.size());
  return info;
}

struct Report {
  std::vector<std::string> targets;
  int connections = 1;
  bool connections_given = false;  // else one per camera
  bool open_loop = false;
  int inflight = 0;
  double fps = 0;
  double warmup_s = 0;
  double duration_s = 0;
  FramesInfo frames;
  std::vector<LoadResult> runs;
  std::optional<InprocessResult> inprocess;
  std::optional<double> slo_p99_ms;

  bool SloMet(const LoadResult& run) const {
    return !slo_p99_ms || (run.latency_ms.count > 0 && run.latency_ms.p99 <= *slo_p99_ms);
  }
  bool AllSloMet() const {
    for (const LoadResult& run : runs) {
      if (!SloMet(run)) return false;
    }
    return true;
  }
  std::optional<double> Ratio(const LoadResult& run) const {
    if (!inprocess || inprocess->fps <= 0) return std::nullopt;
    return run.achieved_fps / inprocess->fps;
  }
};

std::string ErrorsText(const std::map<std::string, uint64_t>& errors) {
  std::vector<std::string> parts;
  for (const auto& [code, n] : errors) parts.push_back(absl::StrCat(code, ":", n));
  return absl::StrJoin(parts, ";");
}

std::string JsonReport(const Report& r) {
  Json j = Json::object();
  j["schema"] = kBenchReportSchema;
  j["targets"] = r.targets;
  j["connections_per_target"] = r.connections;
  j["mode"] = r.open_loop ? "open" : "closed";
  j["inflight_per_camera"] = r.open_loop ? Json() : Json(r.inflight);
  j["fps_per_camera"] = r.open_loop ? Json(r.fps) : Json();
  j["warmup_s"] = r.warmup_s;
  j["duration_s"] = r.duration_s;
  Json frames = Json::object();
  frames["source"] = r.frames.source;
  frames["encoding"] = r.frames.encoding;
  frames["width"] = r.frames.width;
  frames["height"] = r.frames.height;
  frames["mean_bytes"] = std::round(r.frames.mean_bytes);
  j["frames"] = frames;
  Json runs = Json::array();
  for (const LoadResult& run : r.runs) {
    Json x = Json::object();
    x["cameras"] = run.cameras;
    x["target_fps"] = run.open_loop ? Json(run.target_fps) : Json();
    x["achieved_fps"] = Round3(run.achieved_fps);
    x["measured_s"] = Round3(run.measured_s);
    x["frames_scheduled"] = run.frames_scheduled;
    x["frames_sent"] = run.frames_sent;
    x["frames_ok"] = run.frames_ok;
    x["errors_total"] = run.errors_total;
    x["errors"] = Json::object();
    for (const auto& [code, n] : run.errors) x["errors"][code] = n;
    x["dropped"] = run.dropped;
    x["unsent"] = run.unsent;
    x["latency_ms"] = LatencyJson(run.latency_ms);
    x["server_ms"] = LatencyJson(run.server_ms);
    x["max_send_lag_ms"] = Round3(run.max_send_lag_ms);
    x["stream_failures"] = run.stream_failures;
    x["ok_by_target"] = Json::object();
    for (const auto& [target, n] : run.ok_by_target) x["ok_by_target"][target] = n;
    const std::optional<double> ratio = r.Ratio(run);
    x["service_vs_inprocess"] = ratio ? Json(Round3(*ratio)) : Json();
    x["slo_met"] = r.slo_p99_ms ? Json(r.SloMet(run)) : Json();
    if (!run.timeline.empty()) {
      Json timeline = Json::array();
      for (const TimelinePoint& point : run.timeline) {
        Json t = Json::object();
        t["start_s"] = Round3(point.start_s);
        t["end_s"] = Round3(point.end_s);
        t["frames_ok"] = point.ok;
        t["errors"] = point.errors;
        t["latency_ms"] = LatencyJson(point.latency_ms);
        timeline.push_back(std::move(t));
      }
      x["timeline"] = std::move(timeline);
    }
    runs.push_back(std::move(x));
  }
  j["runs"] = std::move(runs);
  if (r.inprocess) {
    Json x = Json::object();
    x["workers"] = r.inprocess->workers;
    x["fps"] = Round3(r.inprocess->fps);
    x["frames"] = r.inprocess->frames;
    x["latency_ms"] = LatencyJson(r.inprocess->latency_ms);
    j["inprocess"] = std::move(x);
  } else {
    j["inprocess"] = Json();
  }
  j["slo_p99_ms"] = r.slo_p99_ms ? Json(*r.slo_p99_ms) : Json();
  j["slo_met"] = r.slo_p99_ms ? Json(r.AllSloMet()) : Json();
  return j.dump(2) + "\n";
}

std::string CsvReport(const Report& r) {
  std::ostringstream out;
  out << "mode,cameras,inflight_per_camera,fps_per_camera,target_fps,achieved_fps,p50_ms,p90_ms,"
         "p99_ms,p999_ms,max_ms,mean_ms,frames_scheduled,frames_sent,frames_ok,errors_total,"
         "dropped,unsent,errors,inprocess_fps,service_vs_inprocess,slo_met\n";
  for (const LoadResult& run : r.runs) {
    const std::optional<double> ratio = r.Ratio(run);
    out << (r.open_loop ? "open" : "closed") << ',' << run.cameras << ','
        << (r.open_loop ? std::string() : absl::StrCat(r.inflight)) << ','
        << (r.open_loop ? absl::StrCat(r.fps) : std::string()) << ','
        << (r.open_loop ? absl::StrFormat("%.3f", run.target_fps) : std::string()) << ','
        << absl::StrFormat("%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f", run.achieved_fps,
                           run.latency_ms.p50, run.latency_ms.p90, run.latency_ms.p99,
                           run.latency_ms.p999, run.latency_ms.max, run.latency_ms.mean)
        << ',' << run.frames_scheduled << ',' << run.frames_sent << ',' << run.frames_ok << ','
        << run.errors_total << ',' << run.dropped << ',' << run.unsent << ','
        << ErrorsText(run.errors) << ','
        << (r.inprocess ? absl::StrFormat("%.3f", r.inprocess->fps) : std::string()) << ','
        << (ratio ? absl::StrFormat("%.3f", *ratio) : std::string()) << ','
        << (r.slo_p99_ms ? (r.SloMet(run) ? "true" : "false") : "") << '\n';
  }
  return out.str();
}

std::string TextReport(const Report& r) {
  std::ostringstream out;
  out << "lane-client bench: " << absl::StrJoin(r.targets, ",");
  out << (r.connections_given ? absl::StrCat(" (", r.connections, " connection(s) per target)")
                              : std::string(" (a connection per camera)"));
  out << ", "
      << (r.open_loop ? absl::StrFormat("open loop at %g fps per camera", r.fps)
                      : absl::StrFormat("closed loop, %d in flight per camera", r.inflight))
      << "\n  frames: " << r.frames.source << ", " << r.frames.encoding << " " << r.frames.width
      << "x" << r.frames.height << absl::StrFormat(", %.1f KB mean", r.frames.mean_bytes / 1e3)
      << absl::StrFormat("; warm-up %g s, measured %g s\n\n", r.warmup_s, r.duration_s);
  out << absl::StrFormat("%7s %10s %10s %8s %8s %8s %8s %8s %8s %8s %8s %8s\n", "cameras",
                         "target/s", "achieved/s", "p50 ms", "p90 ms", "p99 ms", "p99.9 ms",
                         "max ms", "sent", "ok", "errors", "dropped");
  for (const LoadResult& run : r.runs) {
    out << absl::StrFormat(
        "%7d %10s %10.1f %8.2f %8.2f %8.2f %8.2f %8.2f %8d %8d %8d %8d\n", run.cameras,
        run.open_loop ? absl::StrFormat("%.1f", run.target_fps) : std::string("max"),
        run.achieved_fps, run.latency_ms.p50, run.latency_ms.p90, run.latency_ms.p99,
        run.latency_ms.p999, run.latency_ms.max, run.frames_sent, run.frames_ok, run.errors_total,
        run.dropped);
  }
  for (const LoadResult& run : r.runs) {
    std::vector<std::string> notes;
    if (!run.errors.empty()) notes.push_back("errors " + ErrorsText(run.errors));
    if (run.unsent > 0) notes.push_back(absl::StrCat(run.unsent, " frames unsent"));
    if (run.stream_failures > 0) {
      notes.push_back(absl::StrCat(run.stream_failures, " stream failures"));
    }
    if (run.open_loop && run.max_send_lag_ms > 1) {
      notes.push_back(absl::StrFormat("sender up to %.1f ms behind schedule", run.max_send_lag_ms));
    }
    notes.push_back(
        absl::StrFormat("server p50 %.2f ms p99 %.2f ms", run.server_ms.p50, run.server_ms.p99));
    if (run.ok_by_target.size() > 1) {
      std::vector<std::string> parts;
      for (const auto& [target, n] : run.ok_by_target)
        parts.push_back(absl::StrCat(target, " ", n));
      notes.push_back("ok by target: " + absl::StrJoin(parts, ", "));
    }
    if (const std::optional<double> ratio = r.Ratio(run)) {
      notes.push_back(absl::StrFormat("service/in-process %.1f %%", *ratio * 100));
    }
    out << absl::StrFormat("  %d cameras: ", run.cameras) << absl::StrJoin(notes, "; ") << "\n";
    if (!run.timeline.empty()) {
      out << absl::StrFormat("    %15s %8s %8s %8s %8s %8s\n", "interval s", "ok", "errors",
                             "p50 ms", "p99 ms", "max ms");
      for (const TimelinePoint& p : run.timeline) {
        out << absl::StrFormat("    %7.0f-%-7.0f %8d %8d %8.2f %8.2f %8.2f\n", p.start_s, p.end_s,
                               p.ok, p.errors, p.latency_ms.p50, p.latency_ms.p99,
                               p.latency_ms.max);
      }
    }
  }
  if (r.inprocess) {
    out << absl::StrFormat(
        "in-process: %d workers, %.1f frames/s, decode+detect p50 %.2f ms p99 %.2f ms\n",
        r.inprocess->workers, r.inprocess->fps, r.inprocess->latency_ms.p50,
        r.inprocess->latency_ms.p99);
  }
  if (r.slo_p99_ms) {
    out << absl::StrFormat("SLO p99 <= %g ms: %s\n", *r.slo_p99_ms,
                           r.AllSloMet() ? "met" : "BREACHED");
  }
  return out.str();
}

// The progress line, on stderr, only when it is a terminal.
class ProgressLine {
 public:
  ProgressLine() : enabled_(isatty(STDERR_FILENO) == 1) {}
  ProgressFn fn(const std::string& label) {
    if (!enabled_) return nullptr;
    return [label](const Progress& p) {
      std::fprintf(stderr, "\r\033[K%s %s %4.1f/%.0f s  ok %llu  errors %llu  %.1f fps  %.2f ms",
                   label.c_str(), p.phase, p.elapsed_s, p.total_s,
                   static_cast<unsigned long long>(p.ok), static_cast<unsigned long long>(p.errors),
                   p.fps, p.mean_ms);
      std::fflush(stderr);
    };
  }
  void Clear() const {
    if (enabled_) std::fputs("\r\033[K", stderr);
  }

 private:
  const bool enabled_;
};

}  // namespace

int RunBench(const std::vector<std::string>& argv) {
  const std::string usage = Usage();
  std::vector<lane_tools::OptionSpec> specs = SessionConfigOptionSpecs();
  for (const char* name : {"target", "connections", "cameras", "sweep", "inflight", "fps", "warmup",
                           "duration", "drain-timeout", "synthetic", "jpeg-quality", "max-frames",
                           "camera-prefix", "workers", "output", "slo-p99-ms", "timeline"}) {
    specs.push_back({name});
  }
  for (const char* name : {"raw", "replace", "keep-sessions", "inprocess", "json", "csv"}) {
    specs.push_back({name, false});
  }
  const absl::StatusOr<lane_tools::Args> args = lane_tools::Args::Parse(argv, specs);
  if (!args.ok()) return UsageError("bench", std::string(args.status().message()), usage.c_str());
  if (args->help()) {
    std::fputs(usage.c_str(), stdout);
    return kExitOk;
  }
  const auto usage_error = [&usage](const absl::Status& s) {
    return UsageError("bench", std::string(s.message()), usage.c_str());
  };
  const auto connections = args->GetInt("connections", 1, 64);
  const auto cameras = args->GetInt("cameras", 1, 4096);
  const auto inflight = args->GetInt("inflight", 1, 4096);
  const auto synthetic = args->GetInt("synthetic", 1, 100000);
  const auto quality = args->GetInt("jpeg-quality", 1, 100);
  const auto max_frames = args->GetInt("max-frames", 1, 1000000);
  const auto workers = args->GetInt("workers", 1, 1024);
  const auto fps = GetNumber(*args, "fps");
  const auto slo = GetNumber(*args, "slo-p99-ms");
  const auto warmup = GetDuration(*args, "warmup");
  const auto duration = GetDuration(*args, "duration");
  const auto drain = GetDuration(*args, "drain-timeout");
  const auto timeline = GetDuration(*args, "timeline");
  for (const absl::Status& s :
       {connections.status(), cameras.status(), inflight.status(), synthetic.status(),
        quality.status(), max_frames.status(), workers.status(), fps.status(), slo.status(),
        warmup.status(), duration.status(), drain.status(), timeline.status()}) {
    if (!s.ok()) return usage_error(s);
  }
  if (args->Has("json") && args->Has("csv")) {
    return usage_error(absl::InvalidArgumentError("--json and --csv exclude each other"));
  }
  if (*fps && **fps <= 0) return usage_error(absl::InvalidArgumentError("--fps must be > 0"));
  if (*fps && *inflight) {
    return usage_error(absl::InvalidArgumentError("--inflight is for the closed loop, not --fps"));
  }
  std::vector<int> sweep = {static_cast<int>(cameras->value_or(1))};
  if (const auto list = args->Get("sweep")) {
    if (*cameras) return usage_error(absl::InvalidArgumentError("--sweep replaces --cameras"));
    absl::StatusOr<std::vector<int>> parsed = ParseIntList(*list, "sweep");
    if (!parsed.ok()) return usage_error(parsed.status());
    sweep = *parsed;
  }
  const absl::StatusOr<std::vector<std::string>> targets =
      SplitTargets(args->Get("target").value_or(kDefaultTarget));
  if (!targets.ok()) return usage_error(targets.status());
  if (args->Has("synthetic") && !args->positional().empty()) {
    return usage_error(absl::InvalidArgumentError("--synthetic and INPUT exclude each other"));
  }
  absl::StatusOr<std::optional<v1::SessionConfig>> session = SessionConfigFromArgs(*args, true);
  if (!session.ok()) return Failure("bench", std::string(session.status().message()));
  const absl::StatusOr<lane::Config> config = lane::wire::ConfigFromProto(**session);
  if (!config.ok()) return Failure("bench", std::string(config.status().message()));

  // The server runs OpenCV single-threaded (--opencv_threads=1); so does the
  // in-process reference.
  cv::setNumThreads(1);
  const bool raw = args->Has("raw");
  absl::StatusOr<std::vector<BenchFrame>> frames =
      args->positional().empty()
          ? SyntheticBenchFrames(config->camera, static_cast<int>(synthetic->value_or(50)), raw,
                                 static_cast<int>(quality->value_or(90)))
          : LoadBenchFrames(args->positional(), raw, static_cast<int>(max_frames->value_or(200)));
  if (!frames.ok()) return Failure("bench", std::string(frames.status().message()));

  LoadSpec spec;
  // Channel k goes to target k % T as its connection k / T; camera i uses
  // channel i % channels. By default every camera has its own connection, as
  // independent cameras would.
  const int most_cameras = *std::max_element(sweep.begin(), sweep.end());
  const int num_targets = static_cast<int>(targets->size());
  const int per_target = connections->has_value()
                             ? static_cast<int>(**connections)
                             : std::max(1, (most_cameras + num_targets - 1) / num_targets);
  for (int k = 0; k < per_target * num_targets; ++k) {
    const std::string& target = (*targets)[static_cast<size_t>(k % num_targets)];
    spec.channels.push_back(MakeChannel(target, k / num_targets));
    spec.channel_targets.push_back(target);
  }
  spec.camera_prefix = args->Get("camera-prefix").value_or("bench-");
  spec.session = **session;
  spec.replace = args->Has("replace");
  spec.open_loop = fps->has_value();
  spec.fps = fps->value_or(0);
  spec.inflight = static_cast<int>(inflight->value_or(2));
  spec.warmup = warmup->value_or(absl::Seconds(2));
  spec.duration = duration->value_or(absl::Seconds(10));
  if (spec.duration <= absl::ZeroDuration()) {
    return usage_error(absl::InvalidArgumentError("--duration must be > 0"));
  }
  spec.drain_timeout = drain->value_or(absl::Seconds(10));
  spec.timeline_interval = timeline->value_or(absl::ZeroDuration());
  if (timeline->has_value() && spec.timeline_interval <= absl::ZeroDuration()) {
    return usage_error(absl::InvalidArgumentError("--timeline must be > 0"));
  }
  spec.frames = &*frames;

  Report report;
  report.targets = *targets;
  report.connections = per_target;
  report.connections_given = connections->has_value();
  report.open_loop = spec.open_loop;
  report.inflight = spec.inflight;
  report.fps = spec.fps;
  report.warmup_s = absl::ToDoubleSeconds(spec.warmup);
  report.duration_s = absl::ToDoubleSeconds(spec.duration);
  report.frames = DescribeFrames(*frames, args->positional().empty() ? "synthetic" : "inputs");
  report.slo_p99_ms = *slo;
  ProgressLine progress;

  if (args->Has("inprocess")) {
    int threads = static_cast<int>(workers->value_or(0));
    if (threads == 0) {
      const auto stub = v1::LaneService::NewStub(spec.channels.front());
      grpc::ClientContext context;
      SetDeadline(&context, absl::Seconds(10));
      v1::ServerInfo info;
      const grpc::Status status = stub->GetServerInfo(&context, v1::GetServerInfoRequest(), &info);
      if (!status.ok()) {
        return Failure("bench", absl::StrCat("GetServerInfo (for the number of workers; or give "
                                             "--workers): ",
                                             StatusText(status)));
      }
      threads = static_cast<int>(info.limits().workers());
    }
    if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    absl::StatusOr<InprocessResult> inprocess = RunInprocess(
        *frames, spec.session, threads, spec.warmup, spec.duration, progress.fn("in-process"));
    progress.Clear();
    if (!inprocess.ok()) return Failure("bench", std::string(inprocess.status().message()));
    report.inprocess = *inprocess;
  }

  int max_cameras = 0;
  for (int n : sweep) {
    spec.cameras = n;
    max_cameras = std::max(max_cameras, n);
    spec.progress = progress.fn(absl::StrCat(n, " cameras"));
    absl::StatusOr<LoadResult> result = RunLoad(spec);
    progress.Clear();
    if (!result.ok()) {
      if (!args->Has("keep-sessions")) DeleteSessions(spec, max_cameras);
      return Failure("bench", std::string(result.status().message()));
    }
    report.runs.push_back(*std::move(result));
  }
  if (!args->Has("keep-sessions")) DeleteSessions(spec, max_cameras);

  const std::string text = args->Has("json")  ? JsonReport(report)
                           : args->Has("csv") ? CsvReport(report)
                                              : TextReport(report);
  if (const auto output = args->Get("output")) {
    std::ofstream file(*output, std::ios::binary | std::ios::trunc);
    file << text;
    if (!file) return Failure("bench", absl::StrCat("cannot write ", *output));
  } else {
    std::fputs(text.c_str(), stdout);
    std::fflush(stdout);
  }
  return report.AllSloMet() ? kExitOk : kExitSlo;
}

}  // namespace lane_client
