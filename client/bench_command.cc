// `lane-client bench`: load against the service with per-frame latency, and
// the in-process reference. The report's fields are in docs/client.md.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench.h"
#include "bench_report.h"
#include "commands.h"
#include "common.h"
#include "lane/v1/lane_service.grpc.pb.h"
#include "session_config.h"
#include "wire/camera_id.h"
#include "wire/config_proto.h"

namespace lane::client {
namespace {

namespace v1 = lane::v1;

constexpr char kBenchDescription[] =
    "Load-tests the service with N concurrent camera streams, each with its own\n"
    "session (camera ids PREFIX0, PREFIX1, ...), and times every frame: its send\n"
    "time is matched with its response by frame_id. Frames come from INPUT (as\n"
    "for `stream`, read into memory first) or are rendered: synthetic road frames\n"
    "of the session camera's size, JPEG-encoded.";

constexpr char kBenchFooter[] =
    "A progress line is shown on stderr when it is a terminal.\n"
    "Exit status: 0, 1 on an error (no session, no frames, a camera that gave up\n"
    "reconnecting: the report is written first), 2 for a bad command line, 3 when\n"
    "--slo-p99-ms is breached.";

struct BenchFlags {
  // Load.
  int cameras = 1;
  std::vector<int> sweep;
  int window = 2;
  std::optional<double> fps;
  std::optional<absl::Duration> warmup;
  std::optional<absl::Duration> duration;
  std::optional<absl::Duration> drain_timeout;
  std::optional<absl::Duration> timeline;
  int max_reconnects = kDefaultMaxReconnects;
  // Frames.
  int synthetic = 50;
  int jpeg_quality = 90;
  bool raw = false;
  int max_frames = 200;
  std::vector<std::string> inputs;
  // Targets and sessions.
  std::string target;
  std::optional<int> connections;
  std::string camera_prefix = "bench-";
  SessionConfigFlags session;
  bool replace = false;
  bool keep_sessions = false;
  // Reference and report.
  bool inprocess = false;
  std::optional<int> workers;
  bool json = false;
  bool csv = false;
  std::optional<std::string> output;
  std::optional<std::string> html;
  std::optional<double> slo_p99_ms;
};

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

// The checks CLI11 does not make: "" or the usage error.
std::string FlagsError(const BenchFlags& flags) {
  if (flags.fps && *flags.fps <= 0) return "--fps must be > 0";
  if (flags.duration && *flags.duration <= absl::ZeroDuration()) return "--duration must be > 0";
  if (flags.timeline && *flags.timeline <= absl::ZeroDuration()) return "--timeline must be > 0";
  // The largest camera id: what the server would refuse is refused here.
  const int most_cameras = flags.sweep.empty()
                               ? flags.cameras
                               : *std::max_element(flags.sweep.begin(), flags.sweep.end());
  if (const absl::Status id = lane::wire::ValidateCameraId(
          absl::StrCat(flags.camera_prefix, std::max(0, most_cameras - 1)));
      !id.ok()) {
    return absl::StrCat("--camera-prefix: ", id.message());
  }
  return "";
}

// The load of every run but its camera count. Channel k goes to target k % T
// as its connection k / T; camera i uses channel i % channels. By default
// every camera has its own connection, as independent cameras would.
LoadSpec MakeLoadSpec(const BenchFlags& flags, const std::vector<std::string>& targets,
                      int most_cameras, const v1::SessionConfig& session,
                      const std::vector<BenchFrame>* frames) {
  LoadSpec spec;
  const int num_targets = static_cast<int>(targets.size());
  const int per_target = flags.connections
                             ? *flags.connections
                             : std::max(1, (most_cameras + num_targets - 1) / num_targets);
  for (int k = 0; k < per_target * num_targets; ++k) {
    const std::string& target = targets[static_cast<size_t>(k % num_targets)];
    spec.channels.push_back(MakeChannel(target, k / num_targets));
    spec.channel_targets.push_back(target);
  }
  spec.camera_prefix = flags.camera_prefix;
  spec.session = session;
  spec.replace = flags.replace;
  spec.open_loop = flags.fps.has_value();
  spec.fps = flags.fps.value_or(0);
  spec.inflight = flags.window;
  spec.warmup = flags.warmup.value_or(absl::Seconds(2));
  spec.duration = flags.duration.value_or(absl::Seconds(10));
  spec.drain_timeout = flags.drain_timeout.value_or(absl::Seconds(10));
  // The HTML page and the warnings want a timeline; it is printed only
  // with --timeline.
  spec.timeline_interval = flags.timeline.value_or(
      absl::Milliseconds(500) * std::max<int64_t>(1, absl::ToInt64Seconds(spec.duration) / 60));
  spec.frames = frames;
  spec.max_reconnects = flags.max_reconnects;
  return spec;
}

// The report's description of the runs, without their results.
Report MakeReport(const BenchFlags& flags, const LoadSpec& spec,
                  const std::vector<std::string>& targets,
                  const absl::StatusOr<v1::ServerInfo>& server_info) {
  Report report;
  report.targets = targets;
  report.connections = static_cast<int>(spec.channels.size() / targets.size());
  report.connections_given = flags.connections.has_value();
  report.open_loop = spec.open_loop;
  report.inflight = spec.inflight;
  report.fps = spec.fps;
  report.warmup_s = absl::ToDoubleSeconds(spec.warmup);
  report.duration_s = absl::ToDoubleSeconds(spec.duration);
  report.frames = DescribeFrames(*spec.frames, flags.inputs.empty() ? "synthetic" : "inputs");
  report.slo_p99_ms = flags.slo_p99_ms;
  report.show_timeline = flags.timeline.has_value();
  report.meta = LocalMetadata();
  // The server's version, best effort: the report says "unknown" without it.
  if (server_info.ok()) {
    report.meta.server_version =
        absl::StrCat(server_info->version(), " (", server_info->build(), ")");
  }
  return report;
}

// GetServerInfo of the first target, once per run: the report's server
// version and the in-process reference's worker count.
absl::StatusOr<v1::ServerInfo> FetchServerInfo(const LoadSpec& spec) {
  const auto stub = v1::LaneService::NewStub(spec.channels.front());
  grpc::ClientContext context;
  SetDeadline(&context, absl::Seconds(10));
  v1::ServerInfo info;
  const grpc::Status status = stub->GetServerInfo(&context, v1::GetServerInfoRequest(), &info);
  if (!status.ok()) return absl::UnavailableError(StatusText(status));
  return info;
}

// --inprocess: one half of the reference run (`duration`), on --workers
// threads or the server's.
absl::StatusOr<InprocessResult> RunReference(const BenchFlags& flags, const LoadSpec& spec,
                                             const absl::StatusOr<v1::ServerInfo>& server_info,
                                             absl::Duration duration, const char* phase,
                                             ProgressLine& progress) {
  int threads = flags.workers.value_or(0);
  if (threads == 0) {
    if (!server_info.ok()) {
      return absl::UnavailableError(
          absl::StrCat("GetServerInfo (for the number of workers; or give --workers): ",
                       server_info.status().message()));
    }
    threads = static_cast<int>(server_info->limits().workers());
  }
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  absl::StatusOr<InprocessResult> inprocess =
      RunInprocess(*spec.frames, spec.session, threads, spec.warmup, duration, progress.fn(phase));
  progress.Clear();
  return inprocess;
}

// One run per camera count of `sweep`; the sessions are deleted at the end
// unless --keep-sessions. The sweep stops after a run in which a camera gave
// up reconnecting: a failure that repeats would repeat in the next run too.
absl::Status RunSweep(const BenchFlags& flags, const std::vector<int>& sweep, LoadSpec& spec,
                      ProgressLine& progress, Report* report) {
  int max_cameras = 0;
  for (int n : sweep) {
    spec.cameras = n;
    max_cameras = std::max(max_cameras, n);
    spec.progress = progress.fn(absl::StrCat(n, " cameras"));
    absl::StatusOr<LoadResult> result = RunLoad(spec);
    progress.Clear();
    if (!result.ok()) {
      if (!flags.keep_sessions) DeleteSessions(spec, max_cameras);
      return result.status();
    }
    report->runs.push_back(*std::move(result));
    if (!report->runs.back().gave_up.empty()) break;
  }
  if (!flags.keep_sessions) DeleteSessions(spec, max_cameras);
  return absl::OkStatus();
}

int WriteReport(const BenchFlags& flags, const Report& report) {
  const std::string text = flags.json  ? JsonReport(report)
                           : flags.csv ? CsvReport(report)
                                       : TextReport(report);
  if (flags.html) {
    std::ofstream file(*flags.html, std::ios::binary | std::ios::trunc);
    file << HtmlReport(report);
    if (!file) return Failure("bench", absl::StrCat("cannot write ", *flags.html));
  }
  if (flags.output) {
    std::ofstream file(*flags.output, std::ios::binary | std::ios::trunc);
    file << text;
    if (!file) return Failure("bench", absl::StrCat("cannot write ", *flags.output));
  } else {
    std::fputs(text.c_str(), stdout);
    std::fflush(stdout);
  }
  return report.AllSloMet() ? kExitOk : kExitSlo;
}

int RunBench(const CLI::App& app, const BenchFlags& flags) {
  if (const std::string e = FlagsError(flags); !e.empty()) return io::UsageError(app, e);
  const std::vector<int> sweep =
      flags.sweep.empty() ? std::vector<int>{flags.cameras} : flags.sweep;
  const absl::StatusOr<std::vector<std::string>> targets = SplitTargets(flags.target);
  if (!targets.ok()) return io::UsageError(app, std::string(targets.status().message()));
  absl::StatusOr<std::optional<v1::SessionConfig>> session =
      SessionConfigFromFlags(flags.session, true);
  if (!session.ok()) return Failure("bench", std::string(session.status().message()));
  const absl::StatusOr<lane::Config> config = lane::wire::ConfigFromProto(**session);
  if (!config.ok()) return Failure("bench", std::string(config.status().message()));

  // The server runs OpenCV single-threaded (--opencv_threads=1); so does the
  // in-process reference.
  cv::setNumThreads(1);
  absl::StatusOr<std::vector<BenchFrame>> frames =
      flags.inputs.empty()
          ? SyntheticBenchFrames(config->camera, flags.synthetic, flags.raw, flags.jpeg_quality)
          : LoadBenchFrames(flags.inputs, flags.raw, flags.max_frames);
  if (!frames.ok()) return Failure("bench", std::string(frames.status().message()));

  const int most_cameras = *std::max_element(sweep.begin(), sweep.end());
  LoadSpec spec = MakeLoadSpec(flags, *targets, most_cameras, **session, &*frames);
  const absl::StatusOr<v1::ServerInfo> server_info = FetchServerInfo(spec);
  Report report = MakeReport(flags, spec, *targets, server_info);
  ProgressLine progress;
  // The reference brackets the service runs: half of --duration before them,
  // half after (each after its own warm-up), so that a machine whose speed
  // drifts during the bench biases service / in-process less.
  const absl::Duration before = spec.duration / 2;
  const absl::Duration after = spec.duration - before;
  std::optional<InprocessResult> first_half;
  if (flags.inprocess) {
    absl::StatusOr<InprocessResult> half =
        RunReference(flags, spec, server_info, before, "in-process (1/2)", progress);
    if (!half.ok()) return Failure("bench", std::string(half.status().message()));
    first_half = *std::move(half);
  }
  if (const absl::Status s = RunSweep(flags, sweep, spec, progress, &report); !s.ok()) {
    return Failure("bench", std::string(s.message()));
  }
  const std::vector<std::string>& gave_up = report.runs.back().gave_up;
  if (!gave_up.empty()) {
    // The report says what was measured until then; the status is the failure's.
    const int written = WriteReport(flags, report);
    if (written == kExitFailure) return written;
    return Failure(
        "bench", absl::StrCat("camera ", gave_up.front(),
                              gave_up.size() > 1
                                  ? absl::StrCat(" (and ", gave_up.size() - 1, " other camera(s))")
                                  : std::string()));
  }
  if (first_half) {
    absl::StatusOr<InprocessResult> half =
        RunReference(flags, spec, server_info, after, "in-process (2/2)", progress);
    if (!half.ok()) return Failure("bench", std::string(half.status().message()));
    report.inprocess = CombineInprocess(*std::move(first_half), *std::move(half), before, after);
  }
  return WriteReport(flags, report);
}

void AddLoadOptions(CLI::App* app, BenchFlags* flags) {
  const std::string group = "Load";
  CLI::Option* cameras = app->add_option("--cameras", flags->cameras, "concurrent camera streams")
                             ->type_name("N")
                             ->check(io::Between(1, 4096))
                             ->group(group);
  app->add_option("--sweep", flags->sweep, "one run per camera count, e.g. 1,2,4,8,16")
      ->type_name("LIST")
      ->delimiter(',')
      ->check(io::Between(1, 4096))
      ->excludes(cameras)
      ->group(group);
  CLI::Option* window =
      app->add_option("--window,--inflight", flags->window,
                      "closed loop: at most K frames in flight per camera (the client's window)")
          ->type_name("K")
          ->check(io::Between(1, 4096))
          ->group(group);
  io::AddOptional(app, "--fps", &flags->fps,
                  "open loop instead: R frames/s per camera on an absolute schedule; "
                  "latency counts from the scheduled time")
      ->type_name("R")
      ->check(io::NonNegativeNumber())
      ->excludes(window)
      ->group(group);
  io::AddDuration(app, "--warmup", &flags->warmup, "discarded warm-up", "2s")->group(group);
  io::AddDuration(app, "--duration", &flags->duration, "measured time", "10s")->group(group);
  io::AddDuration(app, "--drain-timeout", &flags->drain_timeout,
                  "wait for the last answers this long", "10s")
      ->group(group);
  app->add_option("--max-reconnects", flags->max_reconnects,
                  "a camera stops reconnecting when the same status code comes back after N "
                  "reconnections in a row with no frame answered, as in "
                  "`stream`; the run ends early when every camera has stopped, and the exit "
                  "status is 1")
      ->type_name("N")
      ->check(io::Between(0, 1000000))
      ->group(group);
  io::AddDuration(app, "--timeline", &flags->timeline,
                  "also report each interval D of the measured time: answers, errors and "
                  "latency percentiles (for soaks)")
      ->group(group);
}

void AddFrameOptions(CLI::App* app, BenchFlags* flags) {
  const std::string group = "Frames";
  CLI::Option* synthetic =
      app->add_option("--synthetic", flags->synthetic, "render N synthetic frames (without INPUT)")
          ->type_name("N")
          ->check(io::Between(1, 100000))
          ->group(group);
  app->add_option("--jpeg-quality", flags->jpeg_quality, "JPEG quality of the synthetic frames")
      ->type_name("Q")
      ->check(io::Between(1, 100))
      ->group(group);
  app->add_flag("--raw", flags->raw, "send decoded BGR pixels instead of JPEG/PNG bytes")
      ->group(group);
  app->add_option("--max-frames", flags->max_frames, "frames read from INPUT at most")
      ->type_name("N")
      ->check(io::Between(1, 1000000))
      ->group(group);
  app->add_option("INPUT", flags->inputs, "image files, directories, list files or videos")
      ->excludes(synthetic);
}

void AddTargetOptions(CLI::App* app, BenchFlags* flags) {
  const std::string group = "Targets and sessions";
  AddTargetOption(app, &flags->target,
                  "host:port, a comma list a:1,b:2 (cameras spread over them in turn) or "
                  "dns:///name (round_robin over its addresses)")
      ->group(group);
  io::AddOptional(app, "--connections", &flags->connections,
                  "gRPC channels (TCP connections) per target, shared by its cameras")
      ->type_name("C")
      ->check(io::Between(1, 64))
      ->default_str("one per camera")
      ->group(group);
  app->add_option("--camera-prefix", flags->camera_prefix, "camera id prefix")
      ->type_name("P")
      ->group(group);
  AddSessionConfigOptions(app, &flags->session);
  app->add_flag("--replace", flags->replace, "replace sessions with a different config")
      ->group(group);
  app->add_flag("--keep-sessions", flags->keep_sessions, "do not delete the sessions at the end")
      ->group(group);
}

void AddReportOptions(CLI::App* app, BenchFlags* flags) {
  const std::string group = "Reference and report";
  app->add_flag("--inprocess", flags->inprocess,
                "also run the same decode + detect (and tracking, if the session tracks) on the "
                "same frames without gRPC, on the server's number of workers, half of the "
                "duration before the service runs and half after, and report service / "
                "in-process throughput")
      ->group(group);
  io::AddOptional(app, "--workers", &flags->workers, "worker threads of the in-process run")
      ->type_name("W")
      ->check(io::Between(1, 1024))
      ->default_str("the server's, from GetServerInfo")
      ->group(group);
  CLI::Option* json =
      app->add_flag("--json", flags->json, "report as JSON instead of text")->group(group);
  app->add_flag("--csv", flags->csv, "report as CSV instead of text")->excludes(json)->group(group);
  io::AddOptional(app, "--output", &flags->output, "write the report to FILE instead of stdout")
      ->type_name("FILE")
      ->group(group);
  io::AddOptional(app, "--html", &flags->html,
                  "also write the report as one self-contained HTML page (latency over "
                  "time and histogram as inline SVG)")
      ->type_name("FILE")
      ->group(group);
  io::AddOptional(app, "--slo-p99-ms", &flags->slo_p99_ms,
                  "exit status 3 when a run's p99 latency exceeds X ms")
      ->type_name("X")
      ->check(io::NonNegativeNumber())
      ->group(group);
}

}  // namespace

Command AddBenchCommand(CLI::App& client) {
  auto flags = std::make_shared<BenchFlags>();
  CLI::App* app = io::AddCommand(client, "bench", "load test with per-frame latency",
                                 kBenchDescription, kBenchFooter);
  AddLoadOptions(app, flags.get());
  AddFrameOptions(app, flags.get());
  AddTargetOptions(app, flags.get());
  AddReportOptions(app, flags.get());
  return {app, [app, flags] { return RunBench(*app, *flags); }};
}

}  // namespace lane::client
